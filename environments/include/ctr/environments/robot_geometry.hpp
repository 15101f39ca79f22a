/// @file robot_geometry.hpp
/// @brief Collision geometry of a solved robot shape: a chain of capsules along the backbone, one radius per tube
/// section (the outermost tube present), transformed into the world frame by the environment's base pose.
///
/// A *section* is a maximal arc-length interval [s0, s1] with s0 >= 0 over which the same tube is outermost;
/// section k (0-based, from the base) usually has tube k outermost. Everything at s < 0 (inside the actuation unit)
/// is excluded (and, optionally, the first `exclude_proximal` metres). Integration steps whose arc may leave the chord
/// by more than half of `chord_tolerance` are split at points of the cubic Hermite interpolant of their end positions
/// and tangents; consecutive points are merged into one capsule while the chord stays within `chord_tolerance` of the
/// curve, and the capsule radius is increased by the chord's deviation, so the capsule chain contains the swept tube
/// (docs/environments.md, "Collision geometry").
#pragma once

#include <Eigen/Geometry>
#include <vector>

#include "ctr/model/kinematics.hpp"
#include "ctr/model/robot.hpp"

namespace ctr::environments {

/// @brief Options of the collision geometry.
struct RobotGeometryOptions {
  double safety_margin = 0.0;            ///< Added to every radius (m).
  double default_outer_diameter = 2e-3;  ///< Used for tubes whose outer_diameter is 0 (unknown) (m).
  double chord_tolerance = 0.1e-3;       ///< Largest deviation of a capsule axis from the backbone (m).
  double max_capsule_length = 0.02;      ///< Longest capsule (m); keeps bounding boxes tight.
  /// Arc length (m) from s = 0 that is excluded as well: the part of the robot still inside a delivery instrument
  /// (bronchoscope, trocar) beyond the actuation unit, or crossing the access wall. 0 by default.
  double exclude_proximal = 0.0;
};

/// @brief One capsule: the segment a-b swept by a sphere of `radius` (world frame, m).
struct Capsule {
  Eigen::Vector3d a = Eigen::Vector3d::Zero();
  Eigen::Vector3d b = Eigen::Vector3d::Zero();
  double radius = 0.0;
  int section = 0;            ///< Section index (0-based from the base).
  int tube = 0;               ///< Outermost tube of the section (0-based).
  double s0 = 0.0, s1 = 0.0;  ///< Arc lengths of the ends (m).
};

/// @brief One section of the shape.
struct Section {
  int tube = 0;  ///< Outermost tube (0-based).
  double s0 = 0.0, s1 = 0.0;
  double radius = 0.0;  ///< Tube radius + safety margin (m), before chord inflation.
};

/// @brief Radius used for tube i: outer_diameter / 2 (or default_outer_diameter / 2 when unknown) + margin.
double tubeRadius(const Robot& robot, int tube, const RobotGeometryOptions& options);

/// @brief Builds the capsule chain of a solved shape (requires a recorded backbone, see KinematicsOptions).
/// `world_T_base` maps base-frame points into the world. Clears and fills `capsules` (reuse the vector across calls
/// to avoid allocations) and optionally `sections`. Throws std::invalid_argument if the backbone is empty.
void robotCapsules(const Robot& robot, const Solution& solution, const Eigen::Isometry3d& world_T_base,
                   const RobotGeometryOptions& options, std::vector<Capsule>& capsules,
                   std::vector<Section>* sections = nullptr);

/// @brief Convenience overload returning the capsules.
std::vector<Capsule> robotCapsules(const Robot& robot, const Solution& solution, const Eigen::Isometry3d& world_T_base,
                                   const RobotGeometryOptions& options = {});

/// @brief Closest point of segment [a, b] to p.
Eigen::Vector3d closestPointOnSegment(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& p);

}  // namespace ctr::environments
