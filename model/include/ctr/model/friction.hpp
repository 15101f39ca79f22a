/// @file friction.hpp
/// @brief Lumped Coulomb friction at concentrated moments (Lock & Dupont 2011 §II.D) with stick-slip memory:
/// an explicit hysteresis state carried along a path, a quasi-static stepping function and the friction band.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "ctr/model/distributed_friction.hpp"
#include "ctr/model/follow.hpp"
#include "ctr/model/kinematics.hpp"

namespace ctr {

/// @brief How the friction torque at a contact is determined.
enum class FrictionMode {
  StickSlip,  ///< Coulomb friction with memory: each contact sticks or slips (default).
  Paper,      ///< Always slipping, sign from the commanded direction of relative rotation (paper eq. 34-35).
};

/// @brief "stick-slip" / "paper".
const char* toString(FrictionMode mode);

/// @brief State of one contact: stuck, or slipping with the torque at the bound.
enum class ContactMode { Stick, SlipPositive, SlipNegative };

/// @brief "stick" / "slip_positive" / "slip_negative".
const char* toString(ContactMode mode);

/// @brief Memory of one contact site.
struct ContactMemory {
  ContactSite site;
  ContactMode mode = ContactMode::Stick;
  double relative_twist = 0.0;  ///< theta_inner - theta_outer at the site at the last step (rad).
  double torque = 0.0;          ///< Friction torque on the inner tube at the last step (N m).
  double bound = 0.0;           ///< mu' |m| at the last step (N m).
};

/// @brief Everything the friction model remembers of the path so far. A plain value: copy it to branch a path.
struct HysteresisState {
  /// The tubes' configuration at the last step (the joints: the command through the robot's drives; the command
  /// itself for a robot without actuation).
  Configuration q;
  /// The last command, for a robot with drives; empty otherwise (it is then q): read it with lastCommand().
  Configuration command;
  DriveState drives;                ///< The plays' positions (actuation.hpp); empty for a robot without actuation.
  Eigen::VectorXd base_twist_rate;  ///< Equilibrium branch: u_iz(0) at the last step (warm start).
  Eigen::Vector3d base_moment = Eigen::Vector3d::Zero();  ///< With external loads: m(0) at the last step (warm start).
  std::vector<ContactMemory> contacts;                    ///< One per contact site at the last step.
  Eigen::VectorXd direction;                              ///< Last commanded rotation direction per tube (-1, 0, +1).
  Eigen::VectorXd twist;                                  ///< Tip twist at the last step (snap detection).
  Eigen::VectorXd interface_direction;  ///< Distributed friction: last commanded relative rotation sign per interface.
  bool valid = false;                   ///< False until initialised by initialState / a step.
  /// Warm-start memory of the solver (not physics): the state one sub-step back (command, branch, base moment and
  /// contact torques in the order of `contacts`), kept while the contact sites and modes stay the same. With
  /// KinematicsOptions::extrapolate_warm_start a step that continues the same line in actuation space starts Newton
  /// from the extrapolation of the two. Empty (previous_q.size() == 0) otherwise.
  Configuration previous_q;
  Eigen::VectorXd previous_base_twist_rate;
  Eigen::Vector3d previous_base_moment = Eigen::Vector3d::Zero();
  Eigen::VectorXd previous_torques;

  /// @brief The last command: `command` for a robot with drives, else q (the command itself).
  const Configuration& lastCommand() const { return command.size() > 0 ? command : q; }
};

/// @brief Options of the friction stepping.
struct FrictionOptions {
  FrictionMode mode = FrictionMode::StickSlip;
  /// Sub-steps (1 deg, 1 mm) and snap rule of a step; snaps are judged by the tip twist alone (the stability
  /// measure is not a stability test under stick/slip contact conditions).
  FollowOptions follow{0.0175, 1e-3, 0.5, false};
  int max_active_set_iterations = 16;  ///< Return-mapping iterations before enumerating contact modes.
  KinematicsOptions kinematics;        ///< Options of the underlying equilibrium solves.
};

/// @brief Summary of one quasi-static step.
struct StepSummary {
  bool converged = false;
  int substeps = 0;
  int active_set_iterations = 0;
  bool snapped = false;
  bool enumerated = false;          ///< The active set cycled and contact modes were enumerated.
  Failure failure = Failure::None;  ///< Why the step failed (Inadmissible, NotConverged, NoContactSet).
  std::string message;
};

/// @brief Result of a step: the equilibrium at the target, the new memory, and how it went.
struct StepResult {
  Solution solution;
  HysteresisState state;
  StepSummary summary;
};

/// @brief Memory of a robot at rest at the command q without friction torques (all contacts stuck at zero torque).
/// A robot with actuation (hasActuation) is put at the joints of q (jointsOf; its plays centred on q).
/// Uses the robot's coefficients from robot.friction(): boundary mu' (stick-slip or paper mode) or distributed mu
/// (distributed_friction.hpp; sign from the commanded relative rotation), or both at once (the lumped torques then act
/// on the distributed-friction equilibrium; stick-slip and paper modes as without distributed friction).
/// `branch` (optional): a frictionless equilibrium at q that picks the branch (Newton starts from it; replay.hpp's
/// restAt passes the one reached from the aligned tubes); without it, the cold solve's.
StepResult initialState(const Robot& robot, const Configuration& q, Workspace& ws, const FrictionOptions& options = {},
                        const Solution* branch = nullptr);

/// @brief Memory of a robot at rest in the equilibrium `shape` with every contact stuck at the torque it carries there.
/// A shape of the friction band (frictionBand) is where some history left the robot; this is that history's memory,
/// from which step() continues (e.g. the end of a final approach move from every vertex of a band). `robot` is solved
/// at joints (no drives: use Robot::withoutActuation) and `shape` is one of its converged equilibria at shape.q.
/// Throws std::invalid_argument otherwise.
HysteresisState stuckStateAt(const Robot& robot, const Solution& shape);

/// @brief Quasi-static move from the state `from` to the command q, sub-stepped so that the result does not depend
/// on how the caller slices a path (see docs/friction.md for the tolerance rule at stick/slip changes). A robot with
/// actuation moves from the state's joints to the joints of q (jointsOf with the state's plays, which the new state
/// carries); the straight move is then in joint space.
StepResult step(const Robot& robot, const HysteresisState& from, const Configuration& q, Workspace& ws,
                const FrictionOptions& options = {});

struct FrictionBand;

/// @brief Options of the friction band query.
struct FrictionBandOptions {
  int interior_samples = 1;  ///< Extra samples per contact between the extremes (0 = vertices only).
  KinematicsOptions kinematics;
  /// A band at a configuration just before q on a path to it: each shape is continued from the shape of `follow` with
  /// the same torque fractions at the same sites (matched by identity, FrictionBand::sites), the frictionless one
  /// from follow's frictionless one; shapes without such a counterpart start from the frictionless shape at q.
  /// Null: every shape starts from the frictionless one, solved cold.
  const FrictionBand* follow = nullptr;
  /// Called after each converged shape is added (band.shapes.back()): an empty string goes on, any other ends the
  /// band there with that message (converged false). With a check the band also ends at the first shape that does not
  /// converge.
  std::function<std::string(const FrictionBand& band)> check;
};

/// @brief The set of equilibria at one configuration reachable under some history: every combination of contact
/// torques within their bounds. Extreme shapes are the vertices of the torque box.
/// Order: shapes[0] is frictionless; then every combination of the levels -1, +1 and the interior samples
/// -1 + 2 i / (interior_samples + 1) per contact (all zero skipped), the level of contact c being digit c of the
/// combination's index in base (number of levels). Vertices only (interior_samples = 0): shapes[1 + v] is vertex v,
/// with torque fraction +1 at sites[c] when bit c of v is set and -1 otherwise.
struct FrictionBand {
  bool converged = false;
  std::vector<ContactSite> sites;                     ///< The contact sites at q (order of the torque fractions).
  std::vector<Solution> shapes;                       ///< Vertex (and interior) shapes; [0] = frictionless.
  std::vector<std::vector<double>> torque_fractions;  ///< Per shape, torque / bound per contact.
  Eigen::VectorXd twist_min, twist_max;               ///< Extremes of each twist over the shapes (rad).
  double tip_spread = 0.0;                            ///< Largest tip distance from the frictionless tip (m).
  std::string message;
};

/// @brief Index in `band` of the shape with torque fraction fractions[c] at sites[c] for every c (sites matched by
/// identity, in any order), or -1 when `band` has other sites or no such shape.
long bandShapeWith(const FrictionBand& band, const std::vector<ContactSite>& sites,
                   const std::vector<double>& fractions);

/// @brief Computes the friction band at q.
FrictionBand frictionBand(const Robot& robot, const Configuration& q, Workspace& ws,
                          const FrictionBandOptions& options = {});

}  // namespace ctr
