/// @file environment.hpp
/// @brief An anatomy environment: one occupancy octree (OctoMap) in the world frame, the robot's base pose,
/// named start poses and named targets. Built once (see environment_yaml.hpp), then shared read-only.
///
/// World frame: metres. For environments built from NIfTI segmentations it is the image's RAS frame
/// (right, anterior, superior) converted from millimetres to metres.
#pragma once

#include <Eigen/Geometry>
#include <memory>
#include <string>
#include <vector>

#include "ctr/environments/aabb.hpp"

namespace octomap {
class OcTree;
}

namespace ctr::environments {

/// @brief How space the map knows nothing about (no octree node) is treated by collision and clearance.
enum class UnknownSpace {
  Free,      ///< Unknown space is free (default).
  Occupied,  ///< Unknown space, including everything outside the map bounds, is an obstacle.
};

/// @brief "free" / "occupied".
const char* toString(UnknownSpace u);
/// @brief Parses "free" / "occupied"; throws std::invalid_argument otherwise.
UnknownSpace parseUnknownSpace(const std::string& text);

/// @brief Occupancy of one point of the map.
enum class Occupancy { Free, Occupied, Unknown };

/// @brief "free" / "occupied" / "unknown".
const char* toString(Occupancy o);

/// @brief A named rigid pose world_T_base (the robot base frame: origin where the tubes leave the actuation
/// unit, +z the insertion direction; docs/formats.md "Conventions").
struct NamedPose {
  std::string name;
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  std::string source;  ///< Where it came from (file or "procedural"), for reports.
};

/// @brief A named target point in the world frame (m).
struct NamedTarget {
  std::string name;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  std::string source;
};

/// @brief Collision settings an environment description may carry (defaults of CollisionOptions).
struct CollisionDefaults {
  double safety_margin = 0.0;                       ///< Added to every tube radius (m).
  UnknownSpace unknown_space = UnknownSpace::Free;  ///< Treatment of unknown space.
  double exclude_proximal = 0.0;                    ///< Arc length excluded after s = 0 (m), see RobotGeometryOptions.
};

/// @brief Summary of the map's content.
struct OccupancyStats {
  std::size_t nodes = 0;            ///< Octree nodes (inner + leaves).
  std::size_t occupied_leaves = 0;  ///< Occupied leaves (any depth).
  std::size_t free_leaves = 0;      ///< Free leaves (any depth).
  double occupied_volume = 0.0;     ///< Volume of the occupied leaves (m^3).
  double free_volume = 0.0;         ///< Volume of the known-free leaves (m^3).
  double memory_bytes = 0.0;        ///< OctoMap's memory estimate.
};

/// @brief An anatomy environment. A value type that shares its (immutable) octree; build it once, then share
/// `std::shared_ptr<const Environment>` between threads.
class Environment {
 public:
  /// @brief Wraps a finished octree. `bounds` is the mapped region (the part of the world the map describes); it is
  /// extended to contain every leaf of the tree, so nothing of the map lies outside bounds(). The tree's inner
  /// occupancy must be up to date.
  Environment(std::string name, std::shared_ptr<const octomap::OcTree> tree, Aabb bounds = {});

  /// @brief Name of the environment.
  const std::string& name() const { return name_; }
  /// @brief The occupancy octree (world frame, m).
  const octomap::OcTree& tree() const { return *tree_; }
  /// @brief The occupancy octree, shared.
  const std::shared_ptr<const octomap::OcTree>& treePtr() const { return tree_; }
  /// @brief Leaf size of the octree (m).
  double resolution() const;
  /// @brief The mapped region (m). Points outside it are unknown.
  const Aabb& bounds() const { return bounds_; }

  /// @brief Base pose world_T_base of the robot (identity unless set).
  const Eigen::Isometry3d& basePose() const { return base_pose_; }
  /// @brief Sets the base pose.
  void setBasePose(const Eigen::Isometry3d& world_T_base, std::string source = {});
  /// @brief Where the base pose came from ("start1", a file, "matrix", ...).
  const std::string& basePoseSource() const { return base_pose_source_; }

  /// @brief Named start poses (alternative base poses).
  const std::vector<NamedPose>& starts() const { return starts_; }
  /// @brief Adds or replaces a named start pose.
  void addStart(NamedPose p);
  /// @brief The start pose called `name`; throws std::invalid_argument listing the known names otherwise.
  const NamedPose& start(const std::string& name) const;
  /// @brief Makes the start pose `name` the base pose.
  void useStart(const std::string& name);

  /// @brief Named targets.
  const std::vector<NamedTarget>& targets() const { return targets_; }
  /// @brief Adds or replaces a named target.
  void addTarget(NamedTarget t);
  /// @brief The target called `name`; throws std::invalid_argument listing the known names otherwise.
  const NamedTarget& target(const std::string& name) const;

  /// @brief Collision defaults from the description.
  const CollisionDefaults& collisionDefaults() const { return collision_; }
  void setCollisionDefaults(const CollisionDefaults& c) { collision_ = c; }

  /// @brief Occupancy of the leaf containing the world point p (respects the tree's occupancy threshold).
  Occupancy occupancy(const Eigen::Vector3d& p) const;
  /// @brief Whether p is an obstacle, with unknown space treated as `unknown`.
  bool isObstacle(const Eigen::Vector3d& p, UnknownSpace unknown = UnknownSpace::Free) const;

  /// @brief Node counts and volumes of the map.
  OccupancyStats stats() const;

  /// @brief Seconds it took to build the map (0 if not built here).
  double buildSeconds() const { return build_seconds_; }
  void setBuildSeconds(double s) { build_seconds_ = s; }
  /// @brief Human-readable description of each source that went into the map.
  const std::vector<std::string>& sources() const { return sources_; }
  void addSourceNote(std::string s) { sources_.push_back(std::move(s)); }

  /// @brief Writes the octree to `path`: `.bt` (OctoMap binary: occupied / free, for octovis) or `.ot`
  /// (full occupancy). Atomic: writes `path.tmp` and renames; no partial file on failure (throws InputError).
  void write(const std::string& path) const;

 private:
  std::string name_;
  std::shared_ptr<const octomap::OcTree> tree_;
  Aabb bounds_;
  Eigen::Isometry3d base_pose_ = Eigen::Isometry3d::Identity();
  std::string base_pose_source_ = "identity";
  std::vector<NamedPose> starts_;
  std::vector<NamedTarget> targets_;
  CollisionDefaults collision_;
  double build_seconds_ = 0.0;
  std::vector<std::string> sources_;
};

/// @brief Writes an octree atomically (`.bt` binary or `.ot` full); throws ctr::io::InputError on failure.
void writeOcTree(const octomap::OcTree& tree, const std::string& path);

/// @brief Base pose from a position and an insertion direction (+z of the base frame). The base x axis is
/// `x_hint` made orthogonal to the direction; without a hint (or a hint parallel to the direction) it is the
/// world axis least aligned with the direction, made orthogonal. Throws std::invalid_argument for a zero direction.
Eigen::Isometry3d poseFromDirection(const Eigen::Vector3d& position, const Eigen::Vector3d& direction,
                                    const Eigen::Vector3d* x_hint = nullptr);

/// @brief A rigid pose from a 4x4 matrix whose rotation block is orthonormalised (polar decomposition).
/// Throws std::invalid_argument if the block is far from a rotation (|R^T R - I| > tolerance) or the last
/// row is not [0 0 0 1].
Eigen::Isometry3d poseFromMatrix(const Eigen::Matrix4d& m, double tolerance = 1e-3);

}  // namespace ctr::environments
