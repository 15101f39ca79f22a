/// @file environment_json.hpp
/// @brief The JSON description of an environment (`ctr env info --json`, the Python module's Environment.info()).
#pragma once

#include <string>

#include "ctr/environments/environment.hpp"

namespace ctr::environments {

/// @brief The environment as the JSON text of `ctr env info --json` (keys in docs/environments.md): name,
/// resolution, bounds {min, max, size}, octree statistics, build_seconds, base_pose {position, direction, matrix,
/// source, occupancy}, starts, targets {name, position, occupancy, distance_from_base, source}, sources and the
/// collision defaults. `indent` < 0 gives one line.
std::string infoJson(const Environment& environment, int indent = -1);

}  // namespace ctr::environments
