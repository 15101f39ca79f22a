/// @file ik.hpp
/// @brief Inverse kinematics of the equilibrium model: actuator values (alpha, beta) that put the tip on a target
/// position, optionally with a tip direction. Damped least squares on the exact tip Jacobian (jacobian.hpp) with a
/// backtracking line search, restarts from random admissible configurations, and the admissible set (nesting,
/// ordered distal ends, joint limits) as constraints of every step (docs/ik.md).
///
/// The frictionless map here (with the robot's external loads, if any); the friction-aware inverse of the stateful
/// stick-slip step is in friction_ik.hpp.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "ctr/model/kinematics.hpp"

namespace ctr {

/// @brief What the tip should do: a position, optionally a direction of the tip tangent with a weight.
struct IkTarget {
  Eigen::Vector3d position = Eigen::Vector3d::Zero();  ///< Tip position (base frame, m).
  std::optional<Eigen::Vector3d> direction;            ///< Desired tip tangent (base frame; normalised when used).
  /// Weight of the direction in the least-squares cost |p - p*|^2 + w^2 |t - d|^2 (m per unit of tangent difference,
  /// about m per rad for small angles): 0.01 makes 1 rad of direction error cost as much as 10 mm of position.
  double direction_weight = 0.01;

  IkTarget() = default;
  explicit IkTarget(const Eigen::Vector3d& p) : position(p) {}
  IkTarget(const Eigen::Vector3d& p, const Eigen::Vector3d& d, double weight = 0.01)
      : position(p), direction(d), direction_weight(weight) {}
};

/// @brief Options of the inverse kinematics.
struct IkOptions {
  double tolerance = 1e-5;            ///< Reached when the tip is within this distance of the target (m).
  double direction_tolerance = 0.01;  ///< With a direction: and the tangent within this angle of it (rad).
  int max_iterations = 50;            ///< Damped least-squares iterations per start.
  /// Further starts when a start does not reach the target: random admissible configurations (from `seed`), tried in
  /// the order of their tip's distance to the target (the cold solve draws `cold_candidates` of them).
  int restarts = 8;
  /// Random configurations solved for a cold start or for restarts: this many that converge to a stable equilibrium
  /// from a cold start without continuation (at most twice as many are drawn).
  int cold_candidates = 32;
  /// When none of the cold_candidates lies within this distance of the target in the (radius, height) half-plane (m),
  /// more are drawn, until one does or `max_cold_candidates` converged (a start far from the target needs many
  /// iterations, and the nearest of a few more random configurations is often far nearer). 0: never more.
  double near_start = 0.02;
  int max_cold_candidates = 96;  ///< See near_start.
  /// Cold start and restarts: a descent that is slow — at the rate its error fell over its last two iterations, it
  /// would need more than this many further iterations — is set aside for the next start; the set-aside descents are
  /// resumed (the smallest error first) only when no start reaches the target with a cold-solve-consistent
  /// equilibrium. A slow descent that stalls where another already stalled (the same local minimum) is stopped.
  /// 0: every descent runs to its end before the next start.
  double slow_start_horizon = 5.0;
  std::uint64_t seed = 1;  ///< Of the random configurations (the result is deterministic for a given seed).
  /// Initial Levenberg-Marquardt damping, relative to the mean diagonal of J J^T (divided by 10 after a successful
  /// step, multiplied by 10 when the line search finds no decrease).
  double damping = 1e-4;
  /// Translation scale of a step (m per unit): the step treats 1 rad of rotation like this many metres of translation.
  double translation_scale = 0.02;
  /// Largest change of one actuator in one iteration, in step units (rad, or translation_scale m).
  double max_step = 0.3;
  double min_protrusion = 1e-3;  ///< The innermost tube stays at least this far out of the actuation unit (m).
  /// Accept only stable equilibria (SolveSummary::stable) along the way and as the answer: a step that lands on an
  /// unstable equilibrium or jumps branch (does not converge from the previous shape) is refused.
  bool require_stable = true;
  /// Cold and warm (from a configuration) IK: check a reached answer by a cold solve of its configuration
  /// (IkSummary::branch_dependent; cold IK then prefers another start). False skips that solve (a caller that solves
  /// the answer cold anyway, as the planner's goal pool).
  bool check_branch = true;
  /// Discretisation of every solve (and of the differentiated map). The backbone is not recorded by default.
  KinematicsOptions kinematics = [] {
    KinematicsOptions k;
    k.record_backbone = false;
    return k;
  }();
};

/// @brief Outcome of an inverse kinematics.
enum class IkStatus {
  Reached,     ///< Tip within the tolerance (and the direction within its tolerance, if given).
  NotReached,  ///< Not within the tolerance from any start: the result is the closest configuration found.
  Failed,      ///< The model did not converge at any start: nothing to report.
};

/// @brief "reached" / "not reached" / "failed".
const char* toString(IkStatus s);

/// @brief Summary of an inverse kinematics (Ceres-style).
struct IkSummary {
  IkStatus status = IkStatus::Failed;
  double tip_error = std::numeric_limits<double>::infinity();  ///< |p - p*| at the returned configuration (m).
  double direction_error = 0.0;  ///< Angle between the tip tangent and the direction (rad); 0 without direction.
  /// Tip position at the returned configuration: on the target when reached, the closest point found otherwise.
  Eigen::Vector3d closest = Eigen::Vector3d::Zero();
  int iterations = 0;   ///< Least-squares iterations over all starts.
  int evaluations = 0;  ///< Equilibrium solves (stateful steps for the friction-aware inverse).
  int jacobians = 0;    ///< Exact tip Jacobians computed.
  int starts = 0;       ///< Starts tried (the given or first one, then restarts).
  bool stable = false;  ///< The returned equilibrium is stable (SolveSummary::stable).
  double stability = 0.0;
  /// Reached on an equilibrium that a cold solve of q (forward kinematics without history, `ctr fk`) does not give:
  /// several stable equilibria coexist at q and the robot is in this one only when it gets to q continuously from
  /// the start along the descent. Cold IK prefers answers without it (next start); checked by the cold and the warm
  /// IK from a configuration (one more solve), not by warm updates (always false there).
  bool branch_dependent = false;
  std::string message;  ///< Why it was not reached or failed.
  bool reached() const { return status == IkStatus::Reached; }
};

/// @brief Result: the configuration, its equilibrium and how it went; plus the last tip Jacobian for a warm update.
struct IkResult {
  Configuration q;    ///< Admissible (checkAdmissible holds) whenever a start converged.
  Solution solution;  ///< Equilibrium at q (without backbone unless IkOptions::kinematics records it).
  IkSummary summary;
  /// The last exact tip Jacobian computed (TipJacobian::actuation, 6 x 2n) and where: a warm update from this result
  /// takes its first step with it (empty when none was computed).
  Eigen::MatrixXd jacobian;
  Configuration jacobian_q;
};

/// @brief Cold inverse kinematics: starts from the best of `cold_candidates` random admissible configurations (each
/// turned about the base axis toward the target's azimuth; the nearest in radius and height first), then from the
/// next ones up to `restarts` more times, until a start reaches the target with an equilibrium that a cold solve of
/// its configuration also gives (IkSummary::branch_dependent); a slow descent is set aside for the next start and
/// continued only if none reaches (IkOptions::slow_start_horizon). Throws std::invalid_argument for a non-finite
/// target, options out of range or an empty admissible set.
IkResult inverseKinematics(const Robot& robot, const IkTarget& target, Workspace& ws, const IkOptions& options = {});

/// @brief Warm inverse kinematics from `start` (projected onto the admissible set if it is not admissible; throws
/// std::invalid_argument for a wrong size or non-finite values): follows the equilibrium branch of the start's cold
/// solve (each solve warm-started from the last accepted one), then, only if that does not reach, up to `restarts`
/// starts as the cold inverse kinematics.
IkResult inverseKinematics(const Robot& robot, const IkTarget& target, const Configuration& start, Workspace& ws,
                           const IkOptions& options = {});

/// @brief Warm update from a previous result (a servo loop: the next target one period away): starts at
/// `previous.q` with its equilibrium (no solve) and takes the first step with `previous.jacobian`; a new Jacobian is
/// computed only when that step does not reach the target. No restarts (a servo loop must not jump elsewhere): a
/// target out of reach gives NotReached with the closest point on the way. Falls back to the warm inverse kinematics
/// from `previous.q` (without restarts) when `previous` has no converged equilibrium.
IkResult inverseKinematics(const Robot& robot, const IkTarget& target, const IkResult& previous, Workspace& ws,
                           const IkOptions& options = {});

/// @brief A path of targets (a servo loop): the first by the warm inverse kinematics from `*start`, or the cold one
/// when `start` is null; each next by a warm update from the previous result (no restarts: the commands do not jump).
/// One result per target.
std::vector<IkResult> inverseKinematicsPath(const Robot& robot, const std::vector<IkTarget>& targets,
                                            const Configuration* start, Workspace& ws, const IkOptions& options = {});

}  // namespace ctr
