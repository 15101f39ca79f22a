/// @file friction_ik.hpp
/// @brief Friction-aware inverse kinematics: the command that puts the tip on a target when the tubes are moved there
/// from a given HysteresisState with stick-slip friction — the stateful step (friction.hpp) inverted, not the
/// frictionless map — for one target or a path of targets (each from the state the previous one left), with what
/// friction costs: the command difference and the tip error a friction-blind command would leave (docs/ik.md).
#pragma once

#include <vector>

#include "ctr/model/friction.hpp"
#include "ctr/model/ik.hpp"

namespace ctr {

/// @brief Options of the friction-aware inverse kinematics.
struct FrictionIkOptions {
  /// Tolerances, iterations, damping and limits of both inverses (the friction-blind one also uses its restarts;
  /// `kinematics` is the discretisation of the friction-blind solves).
  IkOptions ik;
  /// Stepping of the stateful model (stick-slip or paper mode, sub-step sizes, discretisation). The backbone is not
  /// recorded by default.
  FrictionOptions friction = [] {
    FrictionOptions f;
    f.kinematics.record_backbone = false;
    return f;
  }();
  /// Along a path: also follow the friction-blind commands (FrictionCost after the first target). False saves a
  /// frictionless update and a stateful step per target (the cost fields of later targets stay NaN / empty).
  bool compare_blind = true;
};

/// @brief What friction costs at one target: the friction-blind command (frictionless inverse kinematics from the
/// same command) and where it leaves the tip when it is commanded through the stateful model.
struct FrictionCost {
  Configuration blind_q;       ///< Frictionless inverse kinematics of the target (the friction-blind command).
  bool blind_reached = false;  ///< It reached the target on the frictionless model.
  /// Tip after commanding blind_q through the stateful step (from the same state; along a path, from the state the
  /// previous blind commands left). NaN when that step did not converge.
  Eigen::Vector3d blind_tip = Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  double blind_tip_error = std::numeric_limits<double>::quiet_NaN();  ///< |blind_tip - target| (m).
  double alpha_difference = 0.0;  ///< max_i |alpha_i - blind alpha_i| of the friction-aware command (rad).
  double beta_difference = 0.0;   ///< max_i |beta_i - blind beta_i| (m).
  /// A robot with drives: max_i |command_i - joint_i| of the rotations (rad) and translations (m), i.e. what the
  /// compensation of the plays, transmission errors and offsets changes against the commands of the description
  /// without actuation (whose commands are the joints). 0 without drives.
  double drive_alpha_difference = 0.0;
  double drive_beta_difference = 0.0;
};

/// @brief Result at one target.
struct FrictionIkResult {
  Configuration q;    ///< The friction-aware command (admissible).
  StepResult step;    ///< step(robot, state, q): the equilibrium reached and the new HysteresisState.
  IkSummary summary;  ///< Reached / not reached, tip error (of step.solution), closest point, iterations, stability.
  FrictionCost cost;  ///< The friction-blind comparison.
  /// The last tip Jacobian of the stateful map (contact laws held) and where; the next target of a path starts with it.
  Eigen::MatrixXd jacobian;
  Configuration jacobian_q;
};

/// @brief Friction-aware inverse kinematics from `state` (a valid HysteresisState of `robot`: initialState, a step,
/// or approachState): the command q such that step(robot, state, q) puts the tip on the target. A robot with drives
/// (hasActuation): the tubes' joints are found on the tubes alone, then turned into the commands that put them there
/// from the state's plays (commandsFor: a play is taken up before the tube turns, a reversal costs its width), and
/// stepped through the drives (FrictionIkResult::step carries the plays on). Starts from the
/// friction-blind command, then iterates damped least-squares steps on the stateful map (each evaluation a step from
/// `state`, differentiated with the contact laws it ended in). A step that does not converge or snaps is refused.
/// Throws std::invalid_argument for an invalid state or target.
FrictionIkResult frictionInverseKinematics(const Robot& robot, const HysteresisState& state, const IkTarget& target,
                                           Workspace& ws, const FrictionIkOptions& options = {});

/// @brief A path of targets, each from the state the previous command left (the first from `state`, as
/// frictionInverseKinematics): a servo loop. Each later target starts at the previous command and equilibrium with the
/// previous Jacobian (usually one stateful step when the targets are close); no restarts after the first target (a
/// path must not jump). The friction-blind commands form their own chain from `state` (frictionless warm updates,
/// replayed through the stateful model) for FrictionCost. One result per target; a target not reached is reported
/// with its closest command, and the path goes on from there.
std::vector<FrictionIkResult> frictionInverseKinematicsPath(const Robot& robot, const HysteresisState& state,
                                                            const std::vector<IkTarget>& targets, Workspace& ws,
                                                            const FrictionIkOptions& options = {});

/// @brief How a robot arrived at its configuration (the memory of its contacts).
enum class Approach {
  Rest,      ///< At rest, contact torques zero (initialState).
  Positive,  ///< Every tube turned positively relative to its outer neighbour by `angle` to get there.
  Negative,  ///< Every tube turned negatively relative to its outer neighbour.
};

/// @brief "rest" / "positive" / "negative".
const char* toString(Approach approach);

/// @brief Where the approach to q starts: alpha_k - s (k - 1) angle for tube k = 1..n (s = +1 for Positive, -1 for
/// Negative; clamped to the rotation limits), the same translations; q itself for Rest. Throws std::invalid_argument
/// for a non-finite angle.
Configuration approachStart(const Robot& robot, const Configuration& q, Approach approach, double angle);

/// @brief The state at q after the approach: the robot at rest at approachStart(...) (restAt, as the first row of a
/// replay), then one step to q. Every neighbouring pair turned by `angle` relative to each other, so the contacts carry
/// the torques of that direction (slipping when `angle` exceeds their stick range). Rest: restAt(q). Replaying the
/// commands {approachStart(...), q} (`ctr simulate`, replay.hpp: every row after the first by continuation) gives the
/// same state.
StepResult approachState(const Robot& robot, const Configuration& q, Approach approach, double angle, Workspace& ws,
                         const FrictionOptions& options = {});

}  // namespace ctr
