/// @file result_json.hpp
/// @brief The JSON object of a planning result (`ctr plan --json`, the Python module's PlanResult.to_dict()).
#pragma once

#include <string>

#include "ctr/planner/planner.hpp"

namespace ctr::planner {

/// @brief The result as the JSON text of `ctr plan --json` (keys in docs/planning.md): query, solved,
/// planner_solved, mode, planner, planning and replay times, time_limit_clock, path_length, waypoints, goal_pool,
/// replay (replayJson) and message (when not empty). Non-finite numbers are null. `indent` < 0 gives one line.
std::string resultJson(const Query& query, const PlanResult& result, int indent = 2);

/// @brief The replay of a result as a JSON object on one line (the `replay` of `ctr plan --json`, also in the
/// benchmark records): completed, collision_free, stable, goal_reached, tip_error, direction_error, min_clearance,
/// steps, collisions, snaps, failure, first_failure. Non-finite numbers are null.
std::string replayJson(const PlanResult& result);

}  // namespace ctr::planner
