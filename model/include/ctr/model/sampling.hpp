/// @file sampling.hpp
/// @brief Uniform sampling of admissible configurations (nested translations + rotation limits) without rejection.
#pragma once

#include <random>
#include <vector>

#include "ctr/model/configuration.hpp"
#include "ctr/model/robot.hpp"

namespace ctr {

/// @brief The smallest box around the admissible translations: for each tube the lowest and highest beta_i of a
/// configuration with beta_n <= ... <= beta_1 <= 0, beta_i + L_i <= beta_{i+1} + L_{i+1}, per-tube translation limits
/// (default [-L_i, 0]) and beta_n + L_n >= min_protrusion. The bounds are consistent along the chain: for any beta_i
/// within its bounds there are admissible neighbours within theirs, so clamping tube by tube from the outermost (each
/// beta_i to its bounds and to the interval its outer neighbour allows) always ends in an admissible configuration.
struct TranslationBounds {
  Eigen::VectorXd lower, upper;  ///< Per tube (m).
  /// @brief Whether some admissible translation exists.
  bool feasible() const { return (lower.array() <= upper.array()).all(); }
};

/// @brief Computes the TranslationBounds of `robot` (O(n^2), no allocation beyond the two vectors).
TranslationBounds translationBounds(const Robot& robot, double min_protrusion = 1e-3);

/// @brief Samples translations uniformly over the admissible polytope beta_n <= ... <= beta_1 <= 0,
/// beta_i + L_i <= beta_{i+1} + L_{i+1}, per-tube translation limits (default [-L_i, 0]) and beta_n + L_n >= min_protrusion.
///
/// The set is a chain: given beta_i, beta_{i+1} lies in an interval. The sampler tabulates the volume of the
/// remaining chain as a function of each beta_i on a fine grid (exact up to the grid's piecewise-linear
/// interpolation) and draws each beta_i from its conditional marginal, so samples are uniform over the set and no
/// sample is rejected. Construct once per robot (constant, shareable); sampling is thread-safe with per-thread RNGs.
class TranslationSampler {
public:
  /// @param grid Grid points per tube for the volume tables.
  explicit TranslationSampler(const Robot& robot, double min_protrusion = 1e-3, int grid = 2048);
  /// @brief A uniform sample of admissible translations.
  Eigen::VectorXd sample(std::mt19937_64& rng) const;
  /// @brief Whether the admissible set is non-empty.
  bool feasible() const { return feasible_; }
  /// @brief Lower and upper bounds of each translation over the admissible set.
  const Eigen::VectorXd& lower() const { return lo_; }
  const Eigen::VectorXd& upper() const { return hi_; }

private:
  int n_ = 0;
  bool feasible_ = false;
  Eigen::VectorXd len_, lo_, hi_;
  // For tube i: grid over [lo_i, hi_i] of V_i(b) = volume of admissible (beta_{i+1}..beta_n) given beta_i = b.
  std::vector<std::vector<double>> vol_;
  double cell(int i) const;
  double volumeAt(int i, double b) const;
  double drawFromConditional(int i, double a, double b, std::mt19937_64& rng) const;
};

/// @brief A uniform admissible configuration: rotations uniform in the rotation limits (default [-pi, pi]),
/// translations from the sampler.
Configuration sampleConfiguration(const Robot& robot, const TranslationSampler& sampler, std::mt19937_64& rng);

}  // namespace ctr
