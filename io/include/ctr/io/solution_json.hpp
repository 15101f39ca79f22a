/// @file solution_json.hpp
/// @brief The JSON object of a model solution (`ctr fk --json`, the Python module's solution dicts).
#pragma once

#include <string>

#include "ctr/model/kinematics.hpp"

namespace ctr::io {

/// @brief The solution as the JSON text of `ctr fk --json` (keys in docs/formats.md): converged, stable, status,
/// stability, iterations, tip_position, tip_tangent, twist, base_twist_rate, moments [{kind, tube (1-based), s,
/// magnitude}] and message (when not empty). Non-finite numbers are null. `indent` < 0 gives one line.
std::string solutionJson(const Solution& solution, int indent = -1);

}  // namespace ctr::io
