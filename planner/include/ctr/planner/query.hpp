/// @file query.hpp
/// @brief Planning query file (YAML; docs/planning.md): robot, environment, start configuration and its history,
/// goal (tip position with tolerance and optional direction cone, or a goal configuration), mode, planner, time
/// limit, seed, objective.
#pragma once

#include <map>
#include <optional>
#include <string>

#include "ctr/model/loads.hpp"
#include "ctr/planner/context.hpp"
#include "ctr/planner/goal.hpp"
#include "ctr/planner/propagator.hpp"

namespace ctr::planner {

/// @brief A parsed query (paths resolved relative to the query file's folder).
struct Query {
  std::string file;                              ///< The query file (for messages).
  std::string name;                              ///< Query name (default: file stem).
  std::string robot;                             ///< Robot YAML path.
  std::string environment;                       ///< Environment YAML path.
  std::string base_start;                        ///< Optional: environment start pose to use as the base pose.
  std::optional<FrictionCoefficients> friction;  ///< Overrides the robot's friction block (a range: its middle).
  /// Ranges (and single values, lo == hi) of the robot's friction and drives: `friction:` intervals, `actuation:`,
  /// `robot_uncertainty:` (a diagnosis's 95 % intervals). The robot is planned and replayed at the middle of each;
  /// robust mode plans for every value in them and the plan is replayed at their corners and random samples.
  RobotRanges ranges;
  std::string robot_uncertainty;                 ///< The diagnosis JSON the ranges came from ("" if none).
  std::vector<std::string> uncertainty_skipped;  ///< Its named effects that a range cannot hold (kept as described).
  /// Overrides the robot's `loads:` block (same keys and units as the robot YAML). In `loads_frame` Base (the robot
  /// YAML's convention) or Environment (world frame of the environment: turned into the base frame by the base pose
  /// the query uses, e.g. gravity as it points in the patient's scan).
  std::optional<Loads> loads;
  enum class LoadsFrame { Base, Environment };
  LoadsFrame loads_frame = LoadsFrame::Base;
  Configuration start;
  StartHistory history;
  std::optional<TipGoalSpec> tip_goal;
  std::string target_name;  ///< Environment target used for tip_goal (if named).
  std::optional<Configuration> goal_configuration;
  double goal_configuration_tolerance = 0.05;  ///< In the state-space metric.
  Mode mode = Mode::Exact;
  std::string planner = "default";
  double time_limit = 10.0;  ///< Seconds (> 0).
  /// Clock of time_limit and planning_time: wall-clock (default), or CPU time of the process (reproducible on a
  /// loaded machine; the planners are single-threaded, so on an idle machine the two agree).
  bool cpu_time_limit = false;
  std::uint64_t seed = 1;
  std::string objective = "path_length";                               ///< path_length | clearance
  double replay_rotation_step = 0.0087;                                ///< Replay resolution (rad, 0.5 deg).
  double replay_translation_step = 5e-4;                               ///< Replay resolution (m).
  double resolution_rotation = 0.0087, resolution_translation = 5e-4;  ///< Motion checking (default: the replay's).
  double env_resolution = 0.0;           ///< Overrides the environment's octree resolution when > 0 (m).
  std::map<std::string, int> key_lines;  ///< 1-based line of each key ("start", "start.alpha", ...) in the file.

  /// @brief Line of `key` in the query file (of its closest parent key if absent; 0 if unknown), for messages
  /// about problems found after parsing (start in collision, target outside the map, ...).
  int lineOf(const std::string& key) const;
};

/// @brief Parses a query file; throws ctr::io::InputError naming file, line and key on any problem.
Query loadQuery(const std::string& path);
/// @brief Parses query text; relative paths resolve against base_dir.
/// With check_files = false the robot / environment paths need not exist (robot and environment given directly).
Query parseQuery(const std::string& text, const std::string& source, const std::string& base_dir,
                 bool check_files = true);

/// @brief Known planner names per mode.
std::vector<std::string> plannerNames(Mode mode);

}  // namespace ctr::planner
