/// @file medmpd.hpp
/// @brief Med-MPD (Fried, Akulian, Alterovitz 2022) start and target files.
///
/// Start files: a 4x4 homogeneous matrix (text, 4 rows of 4 numbers) in RAS millimetres whose rotation's
/// z column is the insertion direction (the robot base +z axis). Target files: a RAS point in millimetres
/// (3 numbers, one per line or on one line). Both are returned in metres.
#pragma once

#include <Eigen/Geometry>
#include <string>

namespace ctr::environments {

/// @brief Reads a Med-MPD start pose as world_T_base (m). The rotation is orthonormalised; throws
/// ctr::io::InputError (with the line) for a missing file, a wrong number of values, non-numbers, a last row
/// other than [0 0 0 1] or a rotation block that is not a rotation.
Eigen::Isometry3d readMedMpdStart(const std::string& path);

/// @brief Reads a Med-MPD target point (m). Throws ctr::io::InputError for a missing file or not exactly 3 numbers.
Eigen::Vector3d readMedMpdTarget(const std::string& path);

}  // namespace ctr::environments
