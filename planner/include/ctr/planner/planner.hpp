/// @file planner.hpp
/// @brief A SimpleSetup-like facade: plan a query in a few lines.
/// @code
///   ctr::planner::Query q = ctr::planner::loadQuery("examples/queries/proc_intracardiac.yaml");
///   ctr::planner::PlanResult r = ctr::planner::plan(q);
///   if (r.solved) { /* r.path: waypoints; r.replay: collisions, clearance, tip error */ }
/// @endcode
#pragma once

#include <optional>

#include <ompl/control/SimpleSetup.h>
#include <ompl/geometric/SimpleSetup.h>

#include "ctr/planner/goal.hpp"
#include "ctr/planner/query.hpp"
#include "ctr/planner/replay.hpp"
#include "ctr/planner/validity.hpp"

namespace ctr::planner {

/// @brief Result of planning + replay.
struct PlanResult {
  bool solved = false;          ///< Planner found a path AND the replay succeeded (collision-free, stable, goal).
  bool planner_solved = false;  ///< The planner reported an (exact) solution.
  Mode mode = Mode::Exact;
  std::string planner;
  double planning_time = 0.0;       ///< Seconds in the planner (including goal sampling), on the query's clock.
  double planning_wall_time = 0.0;  ///< The same in wall-clock seconds.
  double replay_time = 0.0;
  double path_length = 0.0;         ///< Joint-space length of the path (state-space metric).
  std::size_t goal_pool = 0;        ///< Goal configurations found by IK (sampleable goal), at the end of planning.
  std::vector<Configuration> path;  ///< Waypoints, unwrapped, from the start.
  /// Robust mode: the path ends with this final approach move (the last waypoint minus the one before it) because its
  /// goal holds only after it: the move leaves every history's robot on the target (TipGoal::approachMove).
  std::optional<Configuration> final_approach;
  ReplayReport replay;              ///< At the robot as planned (each range at its middle).
  /// With ranges (robust mode): the path replayed at every corner of the ranges and at 20 random samples inside them
  /// (when the replay above is clean); solved needs every one clean.
  std::optional<RangeReplay> range_replay;
  std::string message;  ///< Why not solved.
};

/// @brief Planning problem built from a query: contexts, OMPL set-ups, planner selection.
class CtrPlanner {
 public:
  /// @brief Loads robot and environment (throws ctr::io::InputError for bad files) and sets everything up.
  explicit CtrPlanner(const Query& query);
  /// @brief With a robot and an environment already loaded (query.robot / query.environment are ignored).
  CtrPlanner(const Query& query, Robot robot, environments::Environment environment);
  /// @brief Checks the start before planning, as `ctr plan` does: throws ctr::io::InputError naming the query file,
  /// the line and key `start` when the model does not converge there or the start configuration is invalid
  /// (collision, elastic instability). solve() itself reports an invalid start in its result instead.
  void checkStart() const;
  /// @brief Plans within the query's time limit, then replays the path. Never reports an unreplayed path as solved.
  PlanResult solve();
  /// @brief Plans with another planner / time (for benchmarks); clears previous planner data.
  PlanResult solve(const std::string& planner, double time_limit);
  /// @brief Fills the tip goal's pool of goal configurations (solve() does it; call it before running planners
  /// directly, e.g. with ompl::tools::Benchmark). Uses at most a quarter of `time_limit` (5 s at most) on the
  /// query's clock, or up to half of it while no goal at all has been found; returns the pool size (0 for a goal
  /// configuration).
  std::size_t prepareGoal(double time_limit);

  /// @brief The query as planned: its start (and goal configuration) projected onto the admissible set when they
  /// were off by at most kAdmissibilityTolerance (rounded values; docs/formats.md "Admissibility tolerance").
  const Query& query() const { return query_; }
  const std::shared_ptr<const Context>& context() const { return ctx_; }
  /// @brief The OMPL set-up of geometric modes (null in exact mode).
  const ompl::geometric::SimpleSetupPtr& geometricSetup() const { return gss_; }
  /// @brief The OMPL set-up of exact mode (null otherwise).
  const ompl::control::SimpleSetupPtr& controlSetup() const { return css_; }
  /// @brief Creates a planner by name for the current mode; throws std::invalid_argument for unknown names.
  ompl::base::PlannerPtr makePlanner(const std::string& name) const;
  /// @brief Replays an OMPL solution path of the current set-up.
  PlanResult replaySolution(const std::string& planner, double planning_time, bool exact);

 private:
  void init(Robot robot, environments::Environment e);
  Query query_;
  std::shared_ptr<const environments::Environment> env_;
  std::shared_ptr<const Context> ctx_;
  std::shared_ptr<const CtrStateSpace> space_holder_;
  ompl::geometric::SimpleSetupPtr gss_;
  ompl::control::SimpleSetupPtr css_;
  std::shared_ptr<TipGoal> goal_;
  std::shared_ptr<const StateCache> start_cache_;
};

/// @brief loadQuery + CtrPlanner + solve.
PlanResult plan(const Query& query);

}  // namespace ctr::planner
