/// @file propagator.hpp
/// @brief Exact mode: OMPL control-based planning whose states carry the hysteresis state. Controls are actuator
/// rates; every motion is propagated forward from its source through the stick-slip model, so the target state's
/// memory is the result of that propagation. steer() drives toward a sampled configuration (SteeredControlSampler).
#pragma once

#include <ompl/control/SpaceInformation.h>
#include <ompl/control/StatePropagator.h>

#include "ctr/planner/state_space.hpp"

namespace ctr::plan {

/// @brief How the robot arrived at the start configuration.
struct StartHistory {
  enum class Kind {
    Rest,      ///< Torque-free contacts (e.g. just assembled / relaxed): frictionless start.
    Positive,  ///< Arrived by rotating every tube positively (by `approach` rad).
    Negative,  ///< Arrived by rotating every tube negatively.
    Path,      ///< Arrived along the given configurations (in order), ending at the start.
  };
  Kind kind = Kind::Rest;
  double approach = 0.5;                 ///< Rotation of the approach for Positive / Negative (rad).
  std::vector<Configuration> path;       ///< For Path.
};

/// @brief The physics of the start state given its history.
std::shared_ptr<const StateCache> startCache(const Context& ctx, const Configuration& q, const StartHistory& history);

/// @brief Propagates one stick-slip step (sub-stepped) from a state's cached memory; result gets a new cache.
std::shared_ptr<const StateCache> propagateCache(const Context& ctx, const StateCache& from, const Configuration& to);

/// @brief OMPL state propagator through the friction model.
class FrictionPropagator : public ompl::control::StatePropagator {
public:
  /// @param rotation_rate, translation_rate: control bounds (rad / s, m / s); the propagation step size sets the
  /// length of one step.
  FrictionPropagator(ompl::control::SpaceInformation* si, std::shared_ptr<const Context> ctx, double rotation_rate,
                     double translation_rate);
  void propagate(const ompl::base::State* state, const ompl::control::Control* control, double duration,
                 ompl::base::State* result) const override;
  bool canPropagateBackward() const override { return false; }
  bool canSteer() const override { return true; }
  bool steer(const ompl::base::State* from, const ompl::base::State* to, ompl::control::Control* result,
             double& duration) const override;

private:
  std::shared_ptr<const Context> ctx_;
  const CtrStateSpace* space_;
  double rot_rate_, trans_rate_;
};

}  // namespace ctr::plan
