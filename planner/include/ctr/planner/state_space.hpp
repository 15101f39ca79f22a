/// @file state_space.hpp
/// @brief OMPL state space over tube rotations (one SO2 per tube, or a bounded interval with rotation limits) and
/// translations (one bounded R^n with the nesting constraints), an admissible-only sampler, and a tip-position
/// projection. States may carry the friction model's memory (exact mode).
#pragma once

#include <ompl/base/ProjectionEvaluator.h>
#include <ompl/base/StateSampler.h>
#include <ompl/base/StateSpace.h>
#include <memory>

#include "ctr/planner/context.hpp"

namespace ctr::planner {

/// @brief The physics of a state reached along a path (exact mode): hysteresis memory and the equilibrium shape.
struct StateCache {
  HysteresisState hysteresis;
  Solution solution;        ///< With the backbone (for collision checking).
  bool physics_ok = false;  ///< Converged, stable, no snap on the way here.
  Failure failure = Failure::None;  ///< Why not.
  std::string message;              ///< Why not, in words.
};

/// @brief Compound space: n rotations then one R^n of translations.
class CtrStateSpace : public ompl::base::CompoundStateSpace {
 public:
  /// @brief A state with an optional cached physics (shared, immutable; copied by pointer).
  class StateType : public ompl::base::CompoundStateSpace::StateType {
   public:
    std::shared_ptr<const StateCache> cache;
  };

  /// @param translation_weight Distance weight of translations (m) relative to rotations (rad).
  CtrStateSpace(const Robot& robot, const TranslationSampler& sampler, double translation_weight = 50.0);

  int tubes() const { return n_; }
  /// @brief The configuration of a state (rotations as stored: SO2 in (-pi, pi]).
  Configuration configuration(const ompl::base::State* s) const;
  /// @brief Sets a state's configuration (rotations wrapped into the SO2 range) and drops its cache.
  void setConfiguration(ompl::base::State* s, const Configuration& q) const;
  /// @brief Shortest signed rotation differences and translation differences `to - from`.
  Configuration difference(const ompl::base::State* from, const ompl::base::State* to) const;

  ompl::base::State* allocState() const override;
  void freeState(ompl::base::State* state) const override;
  void copyState(ompl::base::State* destination, const ompl::base::State* source) const override;
  void interpolate(const ompl::base::State* from, const ompl::base::State* to, double t,
                   ompl::base::State* state) const override;
  ompl::base::StateSamplerPtr allocDefaultStateSampler() const override;

  const TranslationSampler& translationSampler() const { return sampler_; }
  const Robot& robot() const { return robot_; }

 private:
  Robot robot_;
  const TranslationSampler& sampler_;
  int n_;
  std::vector<bool> so2_;  // rotation i is SO2 (else a bounded interval)
};

/// @brief Samples only admissible configurations (uniform rotations, TranslationSampler for translations).
class CtrStateSampler : public ompl::base::StateSampler {
 public:
  explicit CtrStateSampler(const CtrStateSpace* space);
  void sampleUniform(ompl::base::State* state) override;
  void sampleUniformNear(ompl::base::State* state, const ompl::base::State* near, double distance) override;
  void sampleGaussian(ompl::base::State* state, const ompl::base::State* mean, double stdDev) override;

 private:
  const CtrStateSpace* ctr_;
  std::mt19937_64 gen_;
  void nearImpl(ompl::base::State* state, const ompl::base::State* near, double distance, bool gaussian);
};

/// @brief Projection onto the tip position (world frame), from the cached shape or the frictionless model.
class TipProjection : public ompl::base::ProjectionEvaluator {
 public:
  TipProjection(const CtrStateSpace* space, std::shared_ptr<const Context> ctx, double cell_size = 5e-3);
  unsigned int getDimension() const override { return 3; }
  void defaultCellSizes() override;
  void project(const ompl::base::State* state, Eigen::Ref<Eigen::VectorXd> projection) const override;

 private:
  const CtrStateSpace* ctr_;
  std::shared_ptr<const Context> ctx_;
  double cell_;
};

/// @brief Tip position (world frame) of a state: cached shape if present, else a frictionless solve.
/// Returns false if the model does not converge.
bool tipOf(const Context& ctx, const CtrStateSpace& space, const ompl::base::State* s, Eigen::Vector3d& tip,
           Eigen::Vector3d* tangent = nullptr);

}  // namespace ctr::planner
