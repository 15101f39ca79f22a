/// @file configuration.hpp
/// @brief Actuator configuration (rotations alpha, translations beta) and its admissibility.
#pragma once

#include <Eigen/Core>
#include <string>

#include "ctr/model/robot.hpp"

namespace ctr {

/// @brief Actuator values of all tubes: rotations alpha_i (rad) and translations beta_i (m, <= 0).
struct Configuration {
  Eigen::VectorXd alpha;  ///< Rotation of each tube's proximal end about +z (rad).
  Eigen::VectorXd beta;   ///< Translation: tube i occupies s in [beta_i, beta_i + L_i] (m).

  Configuration() = default;
  Configuration(Eigen::VectorXd a, Eigen::VectorXd b) : alpha(std::move(a)), beta(std::move(b)) {}
  /// @brief All rotations zero and every tube's proximal end at its most retracted admissible position
  /// that keeps the straight parts in the actuation unit (beta_i = -straight_length_i when admissible).
  static Configuration zeros(int n);
  int size() const { return static_cast<int>(alpha.size()); }
};

/// @brief Result of an admissibility check: ok, or a message saying which constraint is violated.
struct Admissibility {
  bool ok = true;
  std::string message;
  explicit operator bool() const { return ok; }
};

/// @brief Checks sizes, finiteness, beta_n <= ... <= beta_1 <= 0, ordered distal ends
/// beta_1 + L_1 <= ... <= beta_n + L_n (formats.md), the innermost tube protruding (beta_n + L_n > 0),
/// and the per-tube limits of the robot description.
Admissibility checkAdmissible(const Robot& robot, const Configuration& q, double tolerance = 1e-12);

/// @brief Tolerance (m for translations, rad for rotations) within which a configuration read from a file may
/// violate the nesting/ordering constraints and the per-tube limits and still be taken as admissible: it is then
/// projected onto the admissible set (formats.md "admissibility tolerance"). 1 um / 1e-6 rad: logged values rounded
/// to 1 um (6 decimals in metres, 3 in millimetres) put a constraint between two of them up to 1 um off, while
/// moving a tube end by 1 um moves the tip by less than 1 um, far below any tracker's noise. Larger violations are
/// errors (docs/formats-io.md).
inline constexpr double kAdmissibilityTolerance = 1e-6;

/// @brief Projects q onto the admissible set when it violates the constraints by no more than `tolerance`:
/// beta_1 <= 0, then for i = 2..n beta_i = min(beta_i, beta_{i-1}) and max(beta_i, beta_{i-1} + L_{i-1} - L_i)
/// (coincident distal ends, ordered exactly in floating point), and rotations/translations clamped to the tube
/// limits. Returns ok (q projected, every value moved by at most `tolerance`, checkAdmissible(robot, q) holds) or
/// the violated constraint of the unprojected q (q unchanged). A q that checkAdmissible already accepts is left
/// unchanged bit for bit.
Admissibility projectAdmissible(const Robot& robot, Configuration& q, double tolerance = kAdmissibilityTolerance);

/// @brief The default configuration of the command line and the Python module: rotations 0, each tube's straight
/// part retracted (beta_i = -straight length), then made admissible (beta_{i+1} <= beta_i, ordered distal ends).
Configuration defaultConfiguration(const Robot& robot);

/// @brief Distal end s_i = beta_i + L_i of tube i (0-based).
inline double distalEnd(const Robot& robot, const Configuration& q, int i) {
  return q.beta[i] + robot.tube(i).length();
}

}  // namespace ctr
