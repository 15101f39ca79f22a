/// @file collision.hpp
/// @brief Collision and clearance of a robot shape against an environment: FCL 0.7 (fcl::OcTree vs capsules, early
/// exit) for collision, a dynamicEDT3D distance field for clearance and as a conservative pre-filter.
///
/// Usage: build one CollisionChecker per (environment, robot) and share it; give every thread its own
/// CollisionChecker::Query (mutable buffers and FCL shapes).
/// @code
///   auto env = std::make_shared<const
///   ctr::environments::Environment>(ctr::environments::loadEnvironment("lung.yaml"));
///   ctr::environments::CollisionChecker checker(env, robot,
///   ctr::environments::CollisionOptions::fromEnvironment(*env)); auto q = checker.query();
///   ctr::environments::CollisionResult r = checker.check(solution, q);
///   ctr::environments::ClearanceResult c = checker.clearance(solution, q);
/// @endcode
///
/// Guarantees (verified against brute force in tests): a shape reported free has no capsule overlapping an occupied
/// voxel box (up to FCL's GJK tolerance); the distance-field pre-filter only ever skips FCL where a conservative
/// bound proves the answer.
#pragma once

#include <Eigen/Core>
#include <limits>
#include <memory>
#include <vector>

#include "ctr/environments/clearance.hpp"
#include "ctr/environments/environment.hpp"
#include "ctr/environments/robot_geometry.hpp"
#include "ctr/model/kinematics.hpp"
#include "ctr/model/robot.hpp"

namespace octomap {
class OcTree;
}

namespace ctr::environments {

/// @brief Options of collision checking and clearance.
struct CollisionOptions {
  RobotGeometryOptions geometry;                    ///< Safety margin, default diameter, capsule tolerance.
  UnknownSpace unknown_space = UnknownSpace::Free;  ///< Unknown space (and outside the map) as free or obstacle.
  bool distance_field = true;   ///< Build the distance field (needed for clearance and the pre-filter).
  bool prefilter = true;        ///< Let the distance field decide capsules it proves free / colliding.
  double max_distance = 0.005;  ///< Clearance saturates here (m); the field's build time grows with it.
  Aabb field_region;            ///< Region of the distance field; empty: the robot's reach around the base pose.
  std::size_t max_field_cells = 60000000;  ///< Memory guard of the distance field (about 25 bytes per cell).

  /// @brief Defaults with the environment description's `collision:` settings (safety margin, unknown space).
  static CollisionOptions fromEnvironment(const Environment& env);
};

/// @brief Result of a collision check.
struct CollisionResult {
  bool collision = false;
  int section = -1;  ///< First colliding section from the base (0-based), -1 if free.
  int tube = -1;     ///< Outermost tube of that section (0-based).
  double s0 = std::numeric_limits<double>::quiet_NaN();  ///< Arc-length range of the first colliding capsule (m).
  double s1 = std::numeric_limits<double>::quiet_NaN();
  bool outside_map = false;   ///< The collision is the shape leaving the map with unknown space = occupied.
  int capsules = 0;           ///< Capsules in the shape.
  int narrowphase_calls = 0;  ///< FCL collide() calls made (the rest were decided by the distance field).
};

/// @brief Result of a clearance query.
struct ClearanceResult {
  /// Smallest distance (m) between the robot's surface (capsules incl. margin) and the anatomy's occupied voxels;
  /// <= 0 in contact. Saturates at max_distance minus the radius. Accuracy: about one voxel (see clearance.hpp).
  double clearance = std::numeric_limits<double>::infinity();
  int section = -1, tube = -1;
  double s = std::numeric_limits<double>::quiet_NaN();       ///< Arc length of the closest robot point (m).
  Eigen::Vector3d robot_point = Eigen::Vector3d::Zero();     ///< Closest point on the robot axis (world, m).
  Eigen::Vector3d obstacle_point = Eigen::Vector3d::Zero();  ///< Centre of the nearest occupied voxel (world, m).
  bool saturated = false;                                    ///< No obstacle within max_distance of the shape.
  bool complete = true;  ///< False if part of the shape lies outside the distance field (ignored there).
};

/// @brief Collision checker of one robot in one environment. Constant after construction; thread-safe queries.
class CollisionChecker {
 public:
  /// @brief Per-thread mutable state (capsule buffer, FCL shapes and request/result). Never share between threads.
  class Query {
   public:
    Query();
    ~Query();
    Query(Query&&) noexcept;
    Query& operator=(Query&&) noexcept;
    Query(const Query&) = delete;
    Query& operator=(const Query&) = delete;
    /// @brief Capsules of the last shape checked.
    const std::vector<Capsule>& capsules() const { return capsules_; }
    struct Impl;

   private:
    friend class CollisionChecker;
    std::vector<Capsule> capsules_;
    std::unique_ptr<Impl> impl_;
  };

  /// @brief Builds the FCL octree (and, with options.distance_field, the distance field). With unknown space
  /// occupied, the collision octree is a copy with every unknown cell inside the map bounds occupied.
  /// Throws std::invalid_argument for a null environment or a distance field region over the memory guard.
  CollisionChecker(std::shared_ptr<const Environment> env, Robot robot, CollisionOptions options = {});
  ~CollisionChecker();

  /// @brief A fresh per-thread query object.
  Query query() const { return Query(); }

  /// @brief Collision of a solved shape (needs a recorded backbone), checked capsule by capsule from the base, with
  /// early exit at the first colliding capsule.
  CollisionResult check(const Solution& solution, Query& query) const;
  /// @brief Collision of given world-frame capsules, in order.
  CollisionResult checkCapsules(const std::vector<Capsule>& capsules, Query& query) const;
  /// @brief Whether one capsule collides (FCL only, no pre-filter).
  bool capsuleCollidesFcl(const Capsule& c, Query& query) const;

  /// @brief Clearance of a solved shape (needs the distance field).
  ClearanceResult clearance(const Solution& solution, Query& query) const;
  /// @brief Clearance of given capsules (needs the distance field); throws std::logic_error without one.
  ClearanceResult clearanceCapsules(const std::vector<Capsule>& capsules) const;

  const Environment& environment() const { return *env_; }
  const Robot& robot() const { return robot_; }
  const CollisionOptions& options() const { return options_; }
  /// @brief The octree FCL checks against (the environment's, or the unknown-filled copy).
  const octomap::OcTree& collisionTree() const { return *tree_; }
  /// @brief The distance field, or nullptr.
  const DistanceField* distanceField() const { return field_.get(); }
  /// @brief Longest possible shape outside the actuation unit (m): max over tubes of the length plus the largest
  /// admissible translation (0, or the upper translation limit).
  double reach() const { return reach_; }

 private:
  struct Fcl;
  std::shared_ptr<const Environment> env_;
  Robot robot_;
  CollisionOptions options_;
  std::shared_ptr<const octomap::OcTree> tree_;
  std::unique_ptr<Fcl> fcl_;
  std::shared_ptr<const DistanceField> field_;  ///< Shared by checkers of the same octree, region and options.
  double reach_ = 0.0;
};

}  // namespace ctr::environments
