/// @file context.hpp
/// @brief Everything a planning problem shares between threads: robot (with its friction), environment, collision
/// checker, planning mode and resolutions. Constant after construction.
#pragma once

#include <memory>
#include <string>

#include "ctr/environments/collision.hpp"
#include "ctr/environments/environment.hpp"
#include "ctr/model/friction.hpp"
#include "ctr/model/sampling.hpp"
#include "ctr/planner/uncertainty.hpp"

namespace ctr::planner {

/// @brief How friction (hysteresis) is treated by validity checking.
enum class Mode {
  Exact,         ///< States carry the hysteresis state; motions are propagated forward (ompl::control).
  Robust,        ///< Geometric planners; a configuration is valid when its whole friction band is (any history).
  Frictionless,  ///< Geometric planners on the frictionless model (the classic approach; for comparison).
};

/// @brief "exact" / "robust" / "frictionless".
const char* toString(Mode m);
/// @brief Parses a mode name; throws std::invalid_argument listing the valid names.
Mode parseMode(const std::string& s);

/// @brief Integration settings of every model solve while planning (validity, motion propagation, goal IK, replay):
/// RK4 steps of at most 40 mm and 0.3 rad of bending (the library default: 10 mm, 0.12 rad). Tip error against a
/// converged reference at most 1.4 um over 300 random configurations of each example robot (docs/planning.md),
/// far below the collision map's resolution, for about half the cost of a solve.
KinematicsOptions planningKinematicsOptions();

/// @brief Friction stepping options of planning: the library defaults with planningKinematicsOptions().
FrictionOptions planningFrictionOptions();

/// @brief Resolutions and model options of a planning problem.
struct ContextOptions {
  Mode mode = Mode::Exact;
  /// How motions are followed: the motion-checking resolution (0.5 deg, 0.5 mm; the same sub-steps as the replay, so
  /// that a motion checked valid is also valid when replayed: every replayed state is a checked state) and the snap
  /// rule (followMove, model/follow.hpp).
  FollowOptions motion{0.0087, 5e-4, 0.5, true};
  double min_protrusion = 1e-3;          ///< Innermost tube at least this far out of the actuation unit (m).
  /// Stepping options (sub-steps, paper / stick-slip); its `kinematics` are used by every solve of the planner.
  FrictionOptions friction = planningFrictionOptions();
  /// Robust mode: ranges of the robot's friction and drives to plan for (every value in them; uncertainty.hpp).
  RobotRanges ranges;
};

/// @brief Why frictionless mode cannot plan with this robot's drives, "" when it can. Its states carry no history and
/// keep rotations within one turn, so a drive must give the same joint for every history and for a command and the
/// same command a turn away: no play (its position is history) and no rotation ratio error (the joint then depends on
/// the unwrapped command). Robust mode covers a play's every position (robustCorners); exact mode carries it.
std::string geometricDriveLimit(const Robot& robot);

/// @brief The shared, constant part of a planning problem.
///
/// Configurations of the planner (states, paths, the query's start and goal) are **commands**: for a robot with
/// drives (an `actuation:` block) the tubes' joints are the commands through the drives. Exact mode steps the robot
/// with its drives (the plays' positions are in the states' HysteresisState, as the replay has them); a state
/// without history (a goal sample) is judged at jointsAt(), its plays centred.
class Context {
 public:
  /// @brief Builds the collision checker (FCL octree + distance field) for `robot` in `env`. Throws
  /// std::invalid_argument when frictionless mode is asked of a robot whose drives need a history
  /// (geometricDriveLimit), robust mode of one with a rotation ratio error, or another mode than robust to plan for
  /// ranges (ContextOptions::ranges, checked against the robot by checkRanges).
  Context(Robot robot, std::shared_ptr<const environments::Environment> env, ContextOptions options = {},
          environments::CollisionOptions collision = {});

  /// @brief The robot as described, with its drives (stepped and replayed with commands).
  const Robot& robot() const { return robot_; }
  /// @brief The robot without its drives (solved at joint values), with its friction.
  const Robot& tubes() const { return tubes_; }
  /// @brief The robot without its drives and without friction (frictionless mode and comparisons).
  const Robot& frictionlessRobot() const { return frictionless_; }
  /// @brief The robot (without drives: solved at jointsAt()) whose shapes the current mode judges.
  const Robot& modelRobot() const { return options_.mode == Mode::Frictionless ? frictionless_ : tubes_; }
  /// @brief The joints of a command without history (jointsOf with centred plays); the command itself for a robot
  /// without drives.
  Configuration jointsAt(const Configuration& command) const;
  /// @brief The command that puts the tubes at `joints` without history (commandsFor with centred plays; NaN where
  /// a transmission cannot be inverted); `joints` itself for a robot without drives.
  Configuration commandAt(const Configuration& joints) const;
  /// @brief True when the robot has drives (hasActuation).
  bool hasDrives() const { return drives_; }
  /// @brief Robust mode: the robots whose friction bands a robust-valid configuration holds (robustCorners of the
  /// robot and the ranges); empty in the other modes.
  const std::vector<RobustCorner>& robustCorners() const { return corners_; }
  const environments::Environment& environment() const { return *env_; }
  const std::shared_ptr<const environments::Environment>& environmentPtr() const { return env_; }
  const environments::CollisionChecker& checker() const { return *checker_; }
  const ContextOptions& options() const { return options_; }
  const TranslationSampler& translationSampler() const { return sampler_; }
  /// @brief Base frame -> world (the environment's base pose).
  const Eigen::Isometry3d& basePose() const { return env_->basePose(); }

 private:
  Robot robot_, tubes_, frictionless_;
  bool drives_ = false;
  std::vector<RobustCorner> corners_;
  std::shared_ptr<const environments::Environment> env_;
  ContextOptions options_;
  std::shared_ptr<environments::CollisionChecker> checker_;
  TranslationSampler sampler_;
};

/// @brief Per-thread mutable scratch of the planner (model workspace + collision query).
struct ThreadScratch {
  Workspace ws;
  environments::CollisionChecker::Query query;
};

/// @brief The calling thread's scratch (one per thread, created on first use).
ThreadScratch& scratch();

/// @brief Outcome of checking one equilibrium shape against the anatomy.
struct ShapeCheck {
  bool ok = false;                  ///< Converged, stable, collision-free.
  Failure failure = Failure::None;  ///< Why not (Inadmissible, NotConverged, Unstable, Collision).
  std::string message;  ///< Why not, in words ("not converged", "unstable", "collision (tube 2, s 0.031-0.035 m)").
};

/// @brief Checks a solved shape (needs a recorded backbone): converged, stable, collision-free.
ShapeCheck checkShape(const Context& ctx, const Solution& sol, ThreadScratch& t);

}  // namespace ctr::planner
