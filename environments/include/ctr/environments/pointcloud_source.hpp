/// @file pointcloud_source.hpp
/// @brief Point clouds (`.xyz` text, `.ply` ASCII or binary) as obstacles: each point occupies its cell, or every
/// cell within `radius` of it.
#pragma once

#include <Eigen/Geometry>
#include <string>
#include <vector>

#include "ctr/environments/aabb.hpp"
#include "ctr/environments/voxel_grid.hpp"

namespace ctr::environments {

/// @brief Reads points (m after `scale` and `transform`). `.xyz`/`.txt`/`.csv`: one point per line, the first three
/// numbers (separated by spaces, tabs or commas; `#` starts a comment). `.ply`: the x, y, z properties of the
/// vertex element (ascii, binary_little_endian or binary_big_endian). Throws ctr::io::InputError with the line for
/// malformed input, and for a cloud without points.
std::vector<Eigen::Vector3d> loadPointCloud(const std::string& path, double scale = 1.0,
                                            const Eigen::Isometry3d& transform = Eigen::Isometry3d::Identity());

/// @brief AABB of the points.
Aabb pointsExtent(const std::vector<Eigen::Vector3d>& points);

/// @brief Sets to `value` the cell of every point (radius 0), or every cell whose box is within `radius` of a point.
void rasterizePoints(const std::vector<Eigen::Vector3d>& points, VoxelGrid& grid, double radius = 0.0,
                     std::uint8_t value = VoxelGrid::kOccupied);

/// @brief Writes an ASCII `.xyz` file (for tests and tools).
void writeXyz(const std::string& path, const std::vector<Eigen::Vector3d>& points);

}  // namespace ctr::environments
