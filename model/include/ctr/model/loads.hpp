/// @file loads.hpp
/// @brief External loads on a robot: gravity (distributed over the tubes' linear densities) and a tip wrench.
#pragma once

#include <Eigen/Core>

namespace ctr {

/// @brief Dead external loads in the base frame (docs/formats.md `loads:`): they keep their direction in the base
/// frame whatever the robot's shape. All zero (the default) means no external load: the torsion-only model.
struct Loads {
  Eigen::Vector3d gravity = Eigen::Vector3d::Zero();     ///< Gravitational acceleration (m/s^2), acts on s >= 0.
  Eigen::Vector3d tip_force = Eigen::Vector3d::Zero();   ///< Force applied at the tip (N).
  Eigen::Vector3d tip_moment = Eigen::Vector3d::Zero();  ///< Moment applied at the tip (N m).

  /// @brief True when every component is zero (the load-free model is used).
  bool empty() const {
    return (gravity.array() == 0.0).all() && (tip_force.array() == 0.0).all() && (tip_moment.array() == 0.0).all();
  }
  /// @brief True when every component is finite.
  bool finite() const { return gravity.allFinite() && tip_force.allFinite() && tip_moment.allFinite(); }
};

}  // namespace ctr
