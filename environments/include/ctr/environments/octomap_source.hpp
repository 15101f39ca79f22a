/// @file octomap_source.hpp
/// @brief Existing OctoMap files (`.bt` binary, `.ot` full) as obstacle sources, with validation.
#pragma once

#include <memory>
#include <string>

namespace octomap {
class OcTree;
}

namespace ctr::environments {

/// @brief Reads a `.bt` or `.ot` OcTree, checks it (header, node count, resolution, not empty) and brings its inner
/// occupancy up to date. Throws ctr::io::InputError naming the file for a missing, corrupt, truncated, empty or
/// non-OcTree file. OctoMap's own console messages are captured into the error text.
std::shared_ptr<octomap::OcTree> loadOcTreeFile(const std::string& path);

}  // namespace ctr::environments
