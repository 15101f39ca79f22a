/// @file kinematics.hpp
/// @brief Torsionally compliant kinematics (Lock & Dupont 2011 §II.A) solved by shooting with an exact
/// Jacobian, with optional concentrated friction torques at contact sites (§II.D).
#pragma once

#include <Eigen/Core>
#include <memory>
#include <string>
#include <vector>

#include "ctr/model/configuration.hpp"
#include "ctr/model/robot.hpp"

namespace ctr {

namespace detail {
struct SolutionAccess;   // model/src/access.hpp: the solver's internal fields
struct WorkspaceAccess;  // model/src/access.hpp: the solver's buffers
}  // namespace detail

/// @brief Kind of a place where a concentrated bending moment acts.
enum class MomentKind {
  TubeEnd,                 ///< Distal end of a tube.
  CurvatureDiscontinuity,  ///< Start of a tube's precurved part (outside the actuation unit).
};

/// @brief "tube_end" / "curvature_discontinuity".
inline const char* toString(MomentKind k) {
  return k == MomentKind::TubeEnd ? "tube_end" : "curvature_discontinuity";
}

/// @brief A place where a concentrated bending moment acts between two neighbouring tubes, and so where
/// the lumped friction torque of §II.D acts. Identified by (kind, tube) along a path.
struct ContactSite {
  MomentKind kind = MomentKind::TubeEnd;
  int tube = 0;   ///< Tube whose end / discontinuity it is (0-based).
  int outer = 0;  ///< Outer tube of the neighbouring pair carrying the friction torque (0-based).
  int inner = 1;  ///< Inner tube of the pair (0-based, = outer + 1).
  double s = 0;   ///< Arc length (m).
  bool operator==(const ContactSite& o) const { return kind == o.kind && tube == o.tube; }
};

/// @brief The law imposed at a contact site by the friction layer.
struct ContactCondition {
  enum class Law {
    Free,    ///< No torque (frictionless).
    Stick,   ///< Relative twist theta_inner - theta_outer at the site held at `value` (rad).
    Torque,  ///< Torque on the inner tube = value * mu' * |m| (value in [-1, 1]; +-1 = slipping).
  };
  Law law = Law::Free;
  double value = 0.0;
};

/// @brief "free" / "stick" / "torque".
inline const char* toString(ContactCondition::Law law) {
  switch (law) {
    case ContactCondition::Law::Free:
      return "free";
    case ContactCondition::Law::Stick:
      return "stick";
    case ContactCondition::Law::Torque:
      return "torque";
  }
  return "?";
}

/// @brief How an equilibrium is followed along a straight move in actuator space (followMove, follow.hpp): the
/// sub-step sizes and the snap rule. The one set of step sizes of every follower.
struct FollowOptions {
  double max_rotation_step = 0.035;    ///< Largest rotation change per sub-step (rad).
  double max_translation_step = 2e-3;  ///< Largest translation change per sub-step (m).
  /// A change of any tube's tip twist larger than this over one sub-step is a snap (rad): the equilibrium jumped to
  /// another branch (a real snap jumps by about pi; a sub-step of a degree or two turns the twist by about as much).
  double snap_threshold = 0.5;
  /// Whether a stable equilibrium followed onto an unstable one is a snap (the branch ended at a fold). The stability
  /// measure is that of the torsion problem; equilibria that hold stick/slip contact conditions are judged by their
  /// twist jumps only (the stick-slip step sets this false).
  bool judge_stability = true;
};

/// @brief Options of the kinematics solver.
struct KinematicsOptions {
  double max_step = 1e-2;  ///< Largest RK4 step along s (m); segments are split evenly (see docs/model.md).
  /// Also limit the step to this angle over the largest precurvature of the tubes curved on the segment (rad).
  double max_bending_per_step = 0.12;
  /// The bending limit per segment (above); false: over the largest precurvature of the whole robot on every segment
  /// (shorter steps where only less curved tubes bend). The planner uses the per-segment limit too (its collision
  /// capsules follow each step's arc, docs/planning.md).
  bool bending_limit_per_segment = true;
  int max_iterations = 40;         ///< Newton iterations per solve.
  /// Trial points of Newton's backtracking line search in one iteration (the full step, then halved each time) before
  /// a solve gives up at a point without descent. Fewer make a solve that has no solution near its start (past a
  /// fold) fail sooner: the inverse kinematics' trial solves use 4 (docs/ik.md).
  int line_search_steps = 12;
  double tolerance = 1e-10;        ///< Converged when every scaled residual (1/m or rad) is below this.
  bool record_backbone = true;     ///< Store the backbone (theta, u_z, position, frame) at integration nodes.
  /// With record_backbone: also store each tube's theta and u_z at the nodes. False keeps the geometry only (s,
  /// position, frame, u0, outermost tube), which is all collision checking needs, and saves two allocations per node.
  bool record_tube_states = true;
  bool homotopy = true;                ///< On failure of a cold start, continue from zero precurvature.
  int homotopy_steps = 8;              ///< Steps of that continuation.
  FollowOptions follow;                ///< Sub-steps and snap rule of continueTo (2 deg, 2 mm, 0.5 rad).
  /// Near a fold the twist is ill-conditioned (error ~ discretisation / stability): when |stability| is below this,
  /// the converged solution is re-solved with a quarter of the step (0 disables).
  double refine_below_stability = 0.1;
  /// Use the loaded (Cosserat-rod) solver even when the robot has no external load (docs/model.md "External
  /// loads"). It is used anyway whenever robot.loads() is not empty; without load it gives the torsion-only result.
  bool loaded_model = false;
  /// Continuation predictor for paths: when a frictionless solve is warm-started from the workspace's previous
  /// solve, and that one was itself warm-started from the solve before it along (nearly) the same straight line in
  /// actuation space, Newton starts from the extrapolation of the chain's unknowns along the line (the polynomial
  /// through up to the last four solves; the secant when the higher-order term is large, e.g. before a fold) instead
  /// of the warm solution's, falling back to the warm solution if that fails. The torsion-only solver also reuses the
  /// chain's last exact shooting Jacobian (taken within 0.1 rad / 2 mm) for quasi-Newton steps with value-only
  /// evaluations, falling back to Newton when they do not converge fast; the reported stability is then that
  /// Jacobian's unless it is small (|stability| <= 0.25: evaluated exactly). Along a sweep a solve then costs about
  /// two evaluations without derivatives (docs/performance.md); the converged result is the same equilibrium to the
  /// tolerance, but depends (within it) on what the workspace solved before. Solves under contact laws never use the
  /// workspace's history: a stick-slip step extrapolates from its HysteresisState's own warm-start memory (the state
  /// one sub-step back) instead, so it stays a function of its state and command alone.
  bool extrapolate_warm_start = false;
};

/// @brief Outcome of a solve.
enum class SolveStatus {
  Converged,     ///< Boundary conditions met to tolerance.
  NotConverged,  ///< Newton (and the fallbacks) failed; the shape is not valid.
  Inadmissible,  ///< The configuration violates nesting or limits; nothing was solved.
};

/// @brief Human-readable name of a status.
const char* toString(SolveStatus s);

/// @brief Summary of a solve (Ceres-style): status, iterations, stability, snapping.
struct SolveSummary {
  SolveStatus status = SolveStatus::NotConverged;
  int iterations = 0;          ///< Newton iterations (all attempts).
  double residual_norm = 0.0;  ///< Max-norm of the scaled boundary residual at the returned point.
  double stability = 0.0;      ///< det of d(distal torsion conditions)/d(base twist rates); > 0 stable.
  bool stable = false;         ///< stability > 0 (and converged).
  bool snapped = false;        ///< A continuation jumped to another equilibrium branch.
  int continuation_steps = 0;  ///< Sub-steps taken by continueTo / homotopy.
  std::string message;         ///< Why it failed, when it failed.
  bool converged() const { return status == SolveStatus::Converged; }
};

/// @brief State of the backbone at one arc length.
struct BackbonePoint {
  double s = 0.0;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  Eigen::Matrix3d frame = Eigen::Matrix3d::Identity();  ///< Bishop frame F0(s); column 2 is the tangent.
  /// Twist angle of each tube relative to F0 (rad); frozen past the tube's end. Empty if recorded with
  /// KinematicsOptions::record_tube_states = false.
  Eigen::VectorXd theta;
  Eigen::VectorXd uz;                            ///< Torsional curvature of each tube (1/m); empty like theta.
  Eigen::Vector2d u0 = Eigen::Vector2d::Zero();  ///< Bending curvature of the backbone (x, y) (1/m).
  int outermost = 0;                             ///< Outermost tube present at s (0-based).
  bool segment_start = false;  ///< Recorded after the events of a segment boundary (s+ side), else s- side.
  /// Internal force n(s) and moment m(s) of the whole cross-section (base frame, N and N m): what the distal part
  /// exerts on the proximal part. Set by the loaded solver only (zero in load-free solutions, where they vanish).
  Eigen::Vector3d force = Eigen::Vector3d::Zero();
  Eigen::Vector3d moment = Eigen::Vector3d::Zero();
};

/// @brief A concentrated bending moment: jump of a tube's bending moment at its end or curvature discontinuity.
struct ConcentratedMoment {
  MomentKind kind = MomentKind::TubeEnd;
  int tube = 0;
  double s = 0.0;
  double magnitude = 0.0;  ///< N m
};

/// @brief Result at one contact site.
struct ContactResult {
  ContactSite site;
  ContactCondition condition;
  double relative_twist = 0.0;  ///< theta_inner - theta_outer at the site (rad).
  double torque = 0.0;          ///< Friction torque acting on the inner tube (N m); opposite on the outer tube.
  double moment = 0.0;          ///< |m| of the concentrated moment at the site (N m).
};

/// @brief A solved (or failed) equilibrium.
struct Solution {
  SolveSummary summary;
  Configuration q;
  Eigen::VectorXd base_twist_rate;  ///< u_iz(0): the shooting unknowns (1/m).
  Eigen::VectorXd theta0;           ///< theta_i(0) = alpha_i - beta_i u_iz(0) (rad).
  Eigen::VectorXd twist;            ///< twist_k = theta_k(s1) - theta_1(s1), k = 2..n (size n-1).
  Eigen::Vector3d tip_position = Eigen::Vector3d::Zero();
  Eigen::Matrix3d tip_frame = Eigen::Matrix3d::Identity();
  /// At integration nodes, if recorded. A segment boundary (tube end, curvature discontinuity) appears twice with the
  /// same s: before and after its events (u_z and the curvature may jump there).
  std::vector<BackbonePoint> backbone;
  std::vector<ConcentratedMoment> moments;  ///< Every tube end and curvature discontinuity at s > 0.
  std::vector<ContactResult> contacts;      ///< Contact sites with friction unknowns (empty if frictionless).
  bool loaded = false;  ///< Solved by the loaded (Cosserat-rod) solver (external loads, or loaded_model).
  /// Internal force and moment at s = 0 (base frame): the reaction the actuation unit must supply (with opposite
  /// sign). Zero for load-free solutions. base_moment.z() = sum_i k_it u_iz(0).
  Eigen::Vector3d base_force = Eigen::Vector3d::Zero();
  Eigen::Vector3d base_moment = Eigen::Vector3d::Zero();

  bool converged() const { return summary.converged(); }
  /// @brief Unit tangent at the tip.
  Eigen::Vector3d tipTangent() const { return tip_frame.col(2); }
  /// @brief Length of the robot outside the actuation unit (tip arc length, m).
  double tipArcLength() const { return backbone.empty() ? 0.0 : backbone.back().s; }

 private:
  friend struct detail::SolutionAccess;
  Eigen::VectorXd contact_unknowns_;  ///< The solver's scaled contact torques (warm start of later solves).
};

/// @brief Mutable per-thread buffers of the solver. Reuse one per thread; never share between threads.
class Workspace {
 public:
  Workspace();
  ~Workspace();
  Workspace(Workspace&&) noexcept;
  Workspace& operator=(Workspace&&) noexcept;
  Workspace(const Workspace&) = delete;
  Workspace& operator=(const Workspace&) = delete;

 private:
  friend struct detail::WorkspaceAccess;
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// @brief Contact sites (concentrated moments between neighbours at s > 0) of a configuration, ordered by s.
std::vector<ContactSite> contactSites(const Robot& robot, const Configuration& q);

/// @brief Frictionless forward kinematics. With `warm` (a nearby solution) Newton starts from it.
/// Never throws for a bad configuration: returns status Inadmissible with the reason in summary.message.
Solution solve(const Robot& robot, const Configuration& q, Workspace& ws, const KinematicsOptions& options = {},
               const Solution* warm = nullptr);

/// @brief Equilibrium with a law at each contact site (one per contactSites(robot, q), same order).
/// The friction layer (friction.hpp) uses this; mu' is robot.friction().boundary.
Solution solveWithContacts(const Robot& robot, const Configuration& q, const std::vector<ContactCondition>& conditions,
                           Workspace& ws, const KinematicsOptions& options = {}, const Solution* warm = nullptr);

/// @brief Frictionless quasi-static continuation from `from` to q in small steps, following the branch.
/// summary.snapped is set when the branch ended (fold) and the solution jumped to another branch.
Solution continueTo(const Robot& robot, const Solution& from, const Configuration& q, Workspace& ws,
                    const KinematicsOptions& options = {});

}  // namespace ctr
