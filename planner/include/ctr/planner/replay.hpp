/// @file replay.hpp
/// @brief Replays a planned path from the start state at fine resolution through the stateful friction model
/// (the robot's true friction, whatever the planning mode) and reports collisions, snaps, clearance and goal error.
/// The replay is ctr::replay (model/replay.hpp, as `ctr simulate`) of the start history and the path's sub-steps,
/// every command reached by continuation (replayOptions()); the planner's checks come on top of it.
#pragma once

#include <functional>

#include "ctr/planner/propagator.hpp"

namespace ctr::planner {

/// @brief One replayed point.
struct ReplayPoint {
  Configuration q;             ///< Unwrapped command.
  Solution solution;           ///< Equilibrium reached (base frame, without backbone to save memory; its q: joints).
  HysteresisState hysteresis;  ///< Memory after the step (with drives: the command and the plays' positions).
  bool valid = true;           ///< Converged, stable, no snap, collision-free.
  double clearance = 0.0;      ///< Distance-field clearance (m).
};

/// @brief Replay outcome.
struct ReplayReport {
  bool completed = false;  ///< Every step converged.
  bool collision_free = true;
  bool stable = true;  ///< No unstable equilibrium and no snap along the path.
  bool goal_reached = false;
  double tip_error = 0.0;        ///< At the end (m).
  double direction_error = 0.0;  ///< At the end (rad).
  double min_clearance = 0.0;    ///< Along the path (m).
  int steps = 0;
  int collisions = 0, snaps = 0, unstable = 0;
  Failure failure = Failure::None;  ///< What went wrong first (None: nothing).
  std::string message;              ///< The same in words, with the step.
  std::vector<ReplayPoint> points;  ///< At every replay step.
  bool ok() const { return completed && collision_free && stable && goal_reached; }
};

/// @brief A plan replayed with the robot at points of its ranges (uncertainty.hpp): every corner, then samples.
struct RangeReplay {
  std::vector<std::string> names;  ///< The ranges (RangeDimension::name), in the order of each point's values.
  struct Point {
    std::vector<double> values;  ///< The robot's value for each range.
    bool corner = false;         ///< A corner of the box (else a random sample).
    bool ok = false;             ///< The replay is complete, collision-free, stable and reaches the goal.
    double min_clearance = 0.0;  ///< Along the path (m).
    double tip_error = 0.0;      ///< At the end (m).
    Failure failure = Failure::None;
    std::string message;
  };
  std::vector<Point> points;
  int corners = 0, samples = 0, clean = 0;
  double worst_clearance = 0.0;  ///< The least clearance of a completed replay (m).
  std::size_t worst = 0;         ///< Its point.
  bool ok() const { return clean == static_cast<int>(points.size()); }
  /// @brief "friction.boundary 0.12, tube 2 rotation play 0.2" for a point.
  std::string describe(const Point& p) const;
};

/// @brief Goal test at the end of a replay, of the last equilibrium and its command: (tip error m, direction error
/// rad, reached).
using GoalTest = std::function<std::tuple<double, double, bool>(const Solution&, const Configuration& command)>;

/// @brief The commands of a replay of `waypoints`: the first, then every motion between consecutive waypoints in its
/// subdivisions() at the given steps (interpolate(); each motion ends exactly at its waypoint).
std::vector<Configuration> replayCommands(const std::vector<Configuration>& waypoints, double rotation_step,
                                          double translation_step);

/// @brief Replays `waypoints` (unwrapped configurations, first = start) from the start history: ctr::replay of
/// startCommands() and then replayCommands() with replayOptions(). Every state from the start on is checked
/// (converged, stable, no snap, collision-free; ReplayPoint::valid); the replay ends at the first move that does not
/// converge (completed false). The goal is tested at the last state.
ReplayReport replayPath(const Context& ctx, const std::vector<Configuration>& waypoints, const StartHistory& history,
                        const GoalTest& goal, double rotation_step, double translation_step);
/// @brief The same with another robot than the context's (the same tubes: e.g. other friction or drives, as at the
/// points of RangeReplay); the context's collision checker and options.
ReplayReport replayPath(const Context& ctx, const Robot& robot, const std::vector<Configuration>& waypoints,
                        const StartHistory& history, const GoalTest& goal, double rotation_step,
                        double translation_step);

/// @brief CSV of a replay (docs/formats.md "Planned path"): the recording columns plus clearance, validity and
/// per-contact hysteresis (mode, torque, relative twist).
std::string replayCsv(const Robot& robot, const ReplayReport& r);

}  // namespace ctr::planner
