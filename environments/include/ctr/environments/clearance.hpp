/// @file clearance.hpp
/// @brief Distance field over an octree region (Debian's dynamicEDT3D): distance from any point to the nearest
/// occupied cell, for clearance queries and as a conservative pre-filter of collision checks.
///
/// The transform works on cell centres: distance(p) is the Euclidean distance from the centre of p's cell to the
/// centre of the nearest occupied cell, capped at max_distance. Derived quantities:
/// - pointDistance(p): distance from p itself to the box of that nearest cell (an estimate of the distance to the
///   anatomy's voxel surface; exact when the transform's nearest cell is also p's nearest box, within
///   sqrt(3) * resolution otherwise);
/// - lowerBound(p): a conservative lower bound of the distance from p to every occupied voxel box.
/// Memory: about 25 bytes per cell of the region while building (dynamicEDT3D's grid), 5 bytes per cell afterwards
/// (the result is copied into compact arrays and dynamicEDT3D's grid is released).
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <memory>
#include <vector>

#include "ctr/environments/aabb.hpp"
#include "ctr/environments/environment.hpp"

namespace octomap {
class OcTree;
}

namespace ctr::environments {

/// @brief Options of a distance field.
struct DistanceFieldOptions {
  double max_distance = 0.005;                      ///< Distances saturate here (m); at most 126 cells.
  UnknownSpace unknown_space = UnknownSpace::Free;  ///< Unknown cells count as obstacles when Occupied.
  std::size_t max_cells = 60000000;                 ///< Refuse larger regions (memory guard).
};

/// @brief A Euclidean distance transform of the occupied cells of an octree within a region. Immutable after
/// construction; queries are const and thread-safe.
class DistanceField {
 public:
  /// @brief Builds the transform of `tree` over the cells intersecting `region`. Throws std::invalid_argument for an
  /// empty region, one with more than options.max_cells cells, or a max_distance beyond 126 cells.
  DistanceField(const octomap::OcTree& tree, const Aabb& region, const DistanceFieldOptions& options = {});
  ~DistanceField();
  DistanceField(const DistanceField&) = delete;
  DistanceField& operator=(const DistanceField&) = delete;

  double resolution() const { return res_; }
  /// @brief The cell-aligned region covered (m).
  const Aabb& region() const { return region_; }
  double maxDistance() const { return max_distance_; }
  std::size_t cells() const;
  /// @brief Seconds spent building.
  double buildSeconds() const { return build_seconds_; }
  /// @brief Number of occupied cells in the region.
  std::size_t occupiedCells() const { return occupied_; }

  /// @brief Whether p's cell is inside the field.
  bool contains(const Eigen::Vector3d& p) const;
  /// @brief Centre-to-centre distance (m) from p's cell to the nearest occupied cell, capped at maxDistance();
  /// negative if p is outside the field.
  double cellDistance(const Eigen::Vector3d& p) const;
  /// @brief Whether p's cell is occupied (false outside the field).
  bool occupied(const Eigen::Vector3d& p) const;
  /// @brief Nearest occupied cell centre of p's cell; false if p is outside or none lies within maxDistance().
  bool nearestObstacle(const Eigen::Vector3d& p, Eigen::Vector3d& obstacle_centre) const;
  /// @brief Estimated distance (m) from p to the occupied voxel surface (0 inside an occupied cell), capped at
  /// maxDistance(); negative if p is outside the field. See the file comment for the accuracy.
  double pointDistance(const Eigen::Vector3d& p, Eigen::Vector3d* obstacle_centre = nullptr) const;
  /// @brief Lower bound (m) of the distance from p to every occupied voxel box: the smallest distance from p's cell
  /// centre to the box of any cell at least cellDistance(p) away (a lattice bound, tighter than subtracting half a
  /// cell diagonal), minus |p - centre of p's cell|, minus a tenth of a cell of slack for the transform's
  /// propagation error. Negative if p is outside the field (no guarantee).
  double lowerBound(const Eigen::Vector3d& p) const;
  /// @brief lowerBound(p) and whether p's cell is occupied, with one lookup; false if p is outside the field.
  bool probe(const Eigen::Vector3d& p, double& lower_bound, bool& occupied) const;

 private:
  bool cellOf(const Eigen::Vector3d& p, int& x, int& y, int& z) const;
  Eigen::Vector3d centreOf(int x, int y, int z) const;
  std::size_t index(int x, int y, int z) const {
    return (static_cast<std::size_t>(z) * static_cast<std::size_t>(dims_.y()) + static_cast<std::size_t>(y)) *
               static_cast<std::size_t>(dims_.x()) +
           static_cast<std::size_t>(x);
  }

  std::vector<std::uint16_t> sq_;                 ///< Squared centre distance in cells (capped).
  std::vector<std::array<std::int8_t, 3>> near_;  ///< Offset to the nearest occupied cell (-128: none).
  double res_ = 0.0;
  double max_distance_ = 0.0;
  Aabb region_;
  Eigen::Vector3i origin_key_ = Eigen::Vector3i::Zero();
  Eigen::Vector3i dims_ = Eigen::Vector3i::Zero();
  std::size_t occupied_ = 0;
  double build_seconds_ = 0.0;
};

}  // namespace ctr::environments
