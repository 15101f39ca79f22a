/// @file propagator.hpp
/// @brief Exact mode: OMPL control-based planning whose states carry the hysteresis state. Controls are actuator
/// rates; every motion is propagated forward from its source through the stick-slip model, so the target state's
/// memory is the result of that propagation. steer() drives toward a sampled configuration (SteeredControlSampler).
#pragma once

#include <ompl/control/SpaceInformation.h>
#include <ompl/control/StatePropagator.h>

#include "ctr/model/replay.hpp"
#include "ctr/planner/state_space.hpp"

namespace ctr::planner {

/// @brief How the robot arrived at the start configuration.
struct StartHistory {
  enum class Kind {
    Rest,      ///< At rest (ctr::restAt: the branch reached from the aligned tubes, contacts torque-free).
    Positive,  ///< Arrived by rotating every tube positively (by `approach` rad).
    Negative,  ///< Arrived by rotating every tube negatively.
    Path,      ///< Arrived along the given configurations (in order), ending at the start.
  };
  Kind kind = Kind::Rest;
  double approach = 0.5;            ///< Rotation of the approach for Positive / Negative (rad).
  std::vector<Configuration> path;  ///< For Path.
};

/// @brief "rest" / "positive" / "negative" / "path" (the query file's `history`).
const char* toString(StartHistory::Kind kind);

/// @brief The commands of a start history, ending with the start q: Rest: q alone; Positive / Negative: q with every
/// rotation reduced / increased by `approach`, then q; Path: the path, then q.
std::vector<Configuration> startCommands(const Configuration& q, const StartHistory& history);

/// @brief Options of every replay of the planner (ctr::replay): the context's friction stepping with backbones (for
/// the shape checks), every command reached by continuation from the one before (BranchRule::Path: the path is
/// known), no coarse sub-steps.
ReplayOptions replayOptions(const Context& ctx);

/// @brief Why row `index` of the replay of a start history leaves the start unknown (inadmissible, not converged, or
/// reached from rest again), "" when it does not.
std::string historyFailure(std::size_t index, const ReplayRow& row);

/// @brief The physics of the start state given its history: the last row of ctr::replay of startCommands() with
/// replayOptions() (the robot at rest at the history's first command, then moved along it). A history row that
/// fails (historyFailure) gives a start without a solution, saying why.
std::shared_ptr<const StateCache> startCache(const Context& ctx, const Configuration& q, const StartHistory& history);

/// @brief Propagates a motion from a state's cached memory to `to`: step() to each of the subdivisions() of the
/// motion at the context's resolutions (interpolate()), every intermediate state checked (converged, stable, no snap,
/// collision-free); the result gets a new cache.
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

}  // namespace ctr::planner
