/// @file voxel_grid.hpp
/// @brief Dense voxel grid aligned with the OctoMap key space of a resolution; the common target every source
/// rasterises into before one hierarchical conversion to an octree.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <vector>

#include "ctr/environments/aabb.hpp"

namespace octomap {
class OcTree;
}

namespace ctr::environments {

/// @brief OctoMap key (per axis) of a coordinate at a resolution: floor(c / res) + 32768, as octomap computes it.
int coordToKey(double c, double resolution);
/// @brief Centre coordinate of a key: (key - 32768 + 0.5) * res.
double keyToCoord(int key, double resolution);

/// @brief A dense grid of cells (free / occupied / unknown) aligned with the OctoMap keys of `resolution`.
/// Cell (i, j, k) has key origin + (i, j, k). Values: kFree, kOccupied, kUnknown.
class VoxelGrid {
 public:
  static constexpr std::uint8_t kFree = 0;
  static constexpr std::uint8_t kOccupied = 1;
  static constexpr std::uint8_t kUnknown = 2;

  VoxelGrid() = default;
  /// @brief Grid of every cell whose box intersects `region`, all set to `fill`. Throws std::invalid_argument for
  /// an empty region, a non-positive resolution, a region beyond OctoMap's key range, or more than `max_cells`.
  VoxelGrid(double resolution, const Aabb& region, std::uint8_t fill = kFree, std::size_t max_cells = 600000000);

  double resolution() const { return res_; }
  const Eigen::Vector3i& dims() const { return dims_; }
  /// @brief Key of cell (0, 0, 0).
  const Eigen::Vector3i& originKey() const { return origin_; }
  std::size_t cells() const { return data_.size(); }
  /// @brief Metric extent of the grid (union of its cell boxes).
  Aabb bounds() const;

  std::size_t index(int i, int j, int k) const {
    return (static_cast<std::size_t>(k) * static_cast<std::size_t>(dims_.y()) + static_cast<std::size_t>(j)) *
               static_cast<std::size_t>(dims_.x()) +
           static_cast<std::size_t>(i);
  }
  bool inside(int i, int j, int k) const {
    return i >= 0 && j >= 0 && k >= 0 && i < dims_.x() && j < dims_.y() && k < dims_.z();
  }
  std::uint8_t at(int i, int j, int k) const { return data_[index(i, j, k)]; }
  void set(int i, int j, int k, std::uint8_t v) { data_[index(i, j, k)] = v; }
  std::vector<std::uint8_t>& data() { return data_; }
  const std::vector<std::uint8_t>& data() const { return data_; }

  /// @brief Cell index (possibly outside the grid) of the cell containing p.
  Eigen::Vector3i cellOf(const Eigen::Vector3d& p) const;
  /// @brief Centre of cell (i, j, k).
  Eigen::Vector3d centre(int i, int j, int k) const;
  /// @brief Range [lo, hi] of cell indices (clipped to the grid) whose boxes overlap `box` by more than `eps`
  /// (m) on every axis; returns false if there is none.
  bool cellRange(const Aabb& box, Eigen::Vector3i& lo, Eigen::Vector3i& hi, double eps = 1e-9) const;
  /// @brief Sets every cell overlapping `box` (see cellRange) to v.
  void fillBox(const Aabb& box, std::uint8_t v, double eps = 1e-9);
  /// @brief Number of cells with value v.
  std::size_t count(std::uint8_t v) const;
  /// @brief Sets every cell of this grid to `v` where `other` (same resolution, any extent) has `where`.
  void paint(const VoxelGrid& other, std::uint8_t where, std::uint8_t v);

 private:
  double res_ = 0.0;
  Eigen::Vector3i dims_ = Eigen::Vector3i::Zero();
  Eigen::Vector3i origin_ = Eigen::Vector3i::Zero();
  std::vector<std::uint8_t> data_;
};

/// @brief Converts a grid into an octree without inserting cell by cell: blocks of the key space that are uniform
/// in the grid become single (pruned) nodes. Occupied cells get the clamping maximum, free cells the clamping
/// minimum (or stay unknown when `free_as_known` is false); cells outside the grid stay unknown. Inner occupancy
/// is up to date (max of the children).
std::shared_ptr<octomap::OcTree> gridToOcTree(const VoxelGrid& grid, bool free_as_known = true);

/// @brief Marks in `grid` every cell covered by an occupied leaf of `tree` (which must have the grid's resolution,
/// or a coarser one that is a power-of-two multiple; finer trees are resampled conservatively); free leaves set
/// kFree when `mark_free`.
void rasterizeOcTree(const octomap::OcTree& tree, VoxelGrid& grid, bool mark_free = false);

/// @brief A copy of `tree` in which every unknown cell inside `bounds` is occupied (for UnknownSpace::Occupied).
std::shared_ptr<octomap::OcTree> fillUnknown(const octomap::OcTree& tree, const Aabb& bounds);

}  // namespace ctr::environments
