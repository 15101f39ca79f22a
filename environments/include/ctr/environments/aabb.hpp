/// @file aabb.hpp
/// @brief Axis-aligned boxes in the world frame (metres).
#pragma once

#include <Eigen/Core>
#include <limits>

namespace ctr::environments {

/// @brief An axis-aligned box [min, max] (m). Default-constructed boxes are empty.
struct Aabb {
  Eigen::Vector3d min = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d max = Eigen::Vector3d::Constant(-std::numeric_limits<double>::infinity());

  Aabb() = default;
  Aabb(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi) : min(lo), max(hi) {}

  /// @brief True when the box contains no point (some min > max).
  bool empty() const { return (min.array() > max.array()).any(); }
  /// @brief Edge lengths (zero for an empty box).
  Eigen::Vector3d size() const { return empty() ? Eigen::Vector3d::Zero() : Eigen::Vector3d(max - min); }
  /// @brief Centre of the box.
  Eigen::Vector3d centre() const { return 0.5 * (min + max); }
  /// @brief Volume (m^3).
  double volume() const { return size().prod(); }
  /// @brief Whether p lies in the box grown by `tolerance` on every side.
  bool contains(const Eigen::Vector3d& p, double tolerance = 0.0) const {
    return (p.array() >= min.array() - tolerance).all() && (p.array() <= max.array() + tolerance).all();
  }
  /// @brief Whether the box b lies in this box grown by `tolerance`.
  bool contains(const Aabb& b, double tolerance = 0.0) const {
    return !b.empty() && contains(b.min, tolerance) && contains(b.max, tolerance);
  }
  /// @brief Whether the two boxes share a point.
  bool intersects(const Aabb& b) const {
    return !empty() && !b.empty() && (min.array() <= b.max.array()).all() && (b.min.array() <= max.array()).all();
  }
  /// @brief Grows the box to contain p.
  void extend(const Eigen::Vector3d& p) {
    min = min.cwiseMin(p);
    max = max.cwiseMax(p);
  }
  /// @brief Grows the box to contain b.
  void extend(const Aabb& b) {
    if (b.empty()) return;
    extend(b.min);
    extend(b.max);
  }
  /// @brief The box grown by d on every side.
  Aabb inflated(double d) const {
    if (empty()) return *this;
    return Aabb(min.array() - d, max.array() + d);
  }
  /// @brief Intersection of two boxes (possibly empty).
  Aabb intersection(const Aabb& b) const { return Aabb(min.cwiseMax(b.min), max.cwiseMin(b.max)); }
};

/// @brief Distance from p to the box (0 inside).
double distance(const Aabb& box, const Eigen::Vector3d& p);

}  // namespace ctr::environments
