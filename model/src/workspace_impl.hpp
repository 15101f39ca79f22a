// Internal: the solver's problem description and buffers (one per Workspace, i.e. per thread).
#pragma once

#include <Eigen/Core>
#include <Eigen/LU>
#include <array>
#include <vector>

#include "ctr/model/kinematics.hpp"

namespace ctr {
namespace detail {

/// A piece of [0, s_tip] on which the set of present tubes and their precurvatures are constant.
struct Segment {
  double s0 = 0, s1 = 0, h = 0;
  int steps = 1;
  std::vector<char> present;  // tube i present on the segment
  Eigen::VectorXd a;          // (kb_i / kt_i) kappa_i / K for present curved tubes, else 0
  Eigen::VectorXd w;          // kb_i kappa_i for present curved tubes, else 0
  double K = 0;               // sum of kb over present tubes
  int outermost = 0;
};

/// Events at the distal end of a segment.
struct Breakpoint {
  double s = 0;
  std::vector<int> ending;           // tubes whose distal end is here
  std::vector<int> discontinuities;  // tubes whose curved part starts here
  std::vector<int> contacts;         // active contacts here (indices into Problem::contacts)
  bool twist_point = false;          // s = distal end of tube 1 (where twist is measured)
};

struct ActiveContact {
  ContactSite site;
  ContactCondition condition;
  int site_index = 0;
};

struct Problem {
  int n = 0, m = 0;
  double mu_boundary = 0, s_tip = 0, s_twist = 0;
  Eigen::VectorXd kb, kt, kappa, alpha, beta, end, disc;
  std::vector<Segment> segments;
  std::vector<Breakpoint> breakpoints;
  std::vector<ActiveContact> contacts;
  /// Steps from opt (max_step, max_bending_per_step, bending_limit_per_segment), both lengths scaled by step_factor;
  /// precurvatures scaled by kappa_scale (the homotopy).
  void setup(const Robot& robot, const Configuration& q, const std::vector<ContactCondition>* conditions,
             const KinematicsOptions& opt, double kappa_scale = 1.0, double step_factor = 1.0);
};

struct Outputs {
  Eigen::VectorXd twist;
  Eigen::Vector3d tip_position = Eigen::Vector3d::Zero();
  Eigen::Matrix3d tip_frame = Eigen::Matrix3d::Identity();
  std::vector<ConcentratedMoment> moments;
  std::vector<double> contacts_relative_twist, contacts_moment;
  std::vector<BackbonePoint> backbone;
  double stability = 0;
};

/// Bending moment magnitude of tube i at the distal end of segment sg for angles th; optional gradient w.r.t. th.
/// `ending`: the tubes ending at the same breakpoint; outer ones among them are left out (nesting-order limit).
double endMoment(const Problem& P, const Segment& sg, const double* th, int i, Eigen::VectorXd* grad,
                 const std::vector<int>* ending = nullptr);
/// |jump of m_j| = k_j kappa_j (K - k_j) / K at tube j's curvature discontinuity, K of the segment that follows it.
double discontinuityMoment(const Problem& P, const Segment& next, int j);
/// |m| of the concentrated moment at a contact site on the distal boundary of segment si (angles th there), with its
/// gradient w.r.t. th when asked (zero at a discontinuity, whose moment does not depend on the angles).
double siteMoment(const Problem& P, std::size_t si, const double* th, const ContactSite& site, Eigen::VectorXd* grad);

class Evaluator {
public:
  /// Integrates from s = 0 to the tip for unknowns z; fills r (and J when jac). Without `record` the backbone pose
  /// is left pending: only the pose steps are kept, and finish() integrates them (the residual does not depend
  /// on the pose, so Newton's other evaluations never pay for it).
  void evaluate(const Problem& P, const Eigen::VectorXd& z, bool jac, bool record, Outputs& out);
  /// Completes the outputs of the last evaluation: out.tip_position and out.tip_frame (no-op when it recorded them
  /// already) and the tube-end moments in out.moments (left pending by evaluate: they cost libm calls that Newton's
  /// other evaluations do not need). P: the problem of that evaluation.
  void finish(const Problem& P, Outputs& out);
  Eigen::MatrixXd J;
  Eigen::VectorXd r;
  long jacobian_evaluations = 0;  ///< Evaluations with the Jacobian so far (J belongs to the last of them).
  /// Scratch of Newton's and the quasi-Newton iterations (kinematics.cpp newton(), chordSolve()): storage reused
  /// between solves.
  Eigen::PartialPivLU<Eigen::MatrixXd> lu;
  Eigen::VectorXd dz, zt, r_prev;
  Eigen::MatrixXd J_quasi;

private:
  /// One step of the backbone pose: two SE(3) steps of length hh with the body curvatures w1, w2; `last`: the last
  /// step of a segment (re-orthonormalised after it).
  struct PoseStep {
    Eigen::Vector2d w1, w2;
    double hh;
    bool last;
  };
  std::vector<PoseStep> pose_steps_;
  bool pose_pending_ = false;
  /// A tube-end moment left pending: its entry in out.moments, its segment, and its angles (n values) in end_theta_.
  struct PendingMoment {
    std::size_t moment, segment, theta;
  };
  std::vector<PendingMoment> pending_moments_;
  std::vector<double> end_theta_;

  void resize(int n, int m);
  /// Derivative of the state and of its first `columns` sensitivity columns (0: the state only).
  /// `shift`: angles = the base's + shift (sines and cosines by angle addition); `base`: this is the new base.
  void deriv(const Segment& sg, const double* Y, double* dY, int columns, Eigen::Vector2d& u0, const double* shift,
             bool base);
  int n_ = -1, m_ = -1;
  Eigen::VectorXd Y, Ytmp;
  std::array<Eigen::VectorXd, 4> K;
  Eigen::VectorXd sn, cs, sn0, cs0, shift, step_shift, lin;
};

/// The last converged frictionless solves of a workspace (no contact laws) that form a chain, each warm-started from
/// the one before it (a path being followed): the continuation predictor of KinematicsOptions::extrapolate_warm_start.
/// Solves under contact laws (stick-slip steps) never use it: a step depends only on its HysteresisState and command.
struct WarmHistory {
  static constexpr int kDepth = 4;  ///< Solves kept: up to a cubic extrapolation.
  std::array<Eigen::VectorXd, kDepth> q;  ///< q[0] the last solve: its historyKey.
  std::array<Eigen::VectorXd, kDepth> z;  ///< Its unknowns.
  int count = 0;                          ///< Entries of the chain (0: none).
};

/// Translations count as this many radians per metre in the history key (2 cm ~ 1 rad).
constexpr double kHistoryBetaScale = 50.0;

/// Actuation as one vector for the warm-start history: alpha, then kHistoryBetaScale x beta.
Eigen::VectorXd historyKey(const Configuration& q);
/// The same into v (its storage reused).
void historyKey(const Configuration& q, Eigen::VectorXd& v);

/// Continuation predictor: when q continues the straight line through the chain's last solves, z <- the extrapolation
/// of their unknowns along it (kinematics.cpp); false when it does not apply.
bool continuationPredictor(const WarmHistory& H, const Eigen::VectorXd& q, Eigen::VectorXd& z);

/// Records a converged solve (q, z) in the chain: appended when it was warm-started from the chain's last solve
/// (`chained`), else the chain restarts with it.
void recordInChain(WarmHistory& H, bool chained, const Eigen::VectorXd& qv, const Eigen::VectorXd& z);

/// Whether a warm start (its configuration and unknowns) is the chain's last solve.
bool continuesChain(const WarmHistory& H, const Configuration& warm_q, const Eigen::VectorXd& q_key,
                    const Eigen::VectorXd& z);

/// The exact shooting Jacobian of a recent frictionless solve, kept as the matrix of quasi-Newton steps for the next
/// nearby solves of the chain: where it was taken (history key), the robot's kb, kt, kappa, and its stability.
struct ChordCache {
  bool valid = false;
  Eigen::MatrixXd J;
  Eigen::VectorXd q, robot;
  double stability = 0.0;
};

/// The loaded (Cosserat-rod) problem: the segments of a Problem plus the loads (loaded_kinematics.cpp).
struct LoadedProblem {
  Problem P;
  Eigen::VectorXd rho;                                 // linear density per tube (kg/m)
  Eigen::VectorXd length, straight;                    // tube lengths L_i and straight lengths (m)
  Eigen::Vector3d g = Eigen::Vector3d::Zero();         // gravity (scaled by the load parameter)
  Eigen::Vector3d F = Eigen::Vector3d::Zero();         // tip force (scaled)
  Eigen::Vector3d M = Eigen::Vector3d::Zero();         // tip moment (scaled)
  double K0 = 1.0;                                     // scale of the base-moment unknowns (N m^2)
  int m = 0;                                           // unknowns: n - 1 twist rates, 3 base moments, contacts
  std::vector<int> bp_tube, bp_kind;                   // source of each segment boundary: kind 0 s=0, 1 end, 2 disc
  std::vector<double> seg_rho;                         // sum of linear densities of the tubes on each segment
};

/// Recorded outputs of a loaded evaluation (double only).
struct LoadedOutputs {
  Eigen::VectorXd twist;
  std::vector<ConcentratedMoment> moments;
  std::vector<double> contacts_relative_twist, contacts_moment;
  std::vector<BackbonePoint> backbone;
  std::size_t nodes = 0;
};

struct LoadedWork {
  LoadedProblem L;
  LoadedOutputs out;
  Eigen::VectorXd r;       // residual at the last evaluation
  Eigen::MatrixXd J;       // its Jacobian w.r.t. the unknowns (when asked)
  Eigen::Vector3d tip_p = Eigen::Vector3d::Zero();
  Eigen::Matrix3d tip_R = Eigen::Matrix3d::Identity();
  Eigen::MatrixXd D;       // derivatives of (r, tip p, tip R, theta_n) w.r.t. chosen inputs
  // The exact Jacobian of the last converged solve and where it was taken (initial Jacobian of the next warm start).
  bool J_valid = false;
  int J_updates = 0;  // Broyden updates since J was last exact
  Eigen::VectorXd J_z, J_alpha, J_beta, J_robot;
  WarmHistory history;  ///< loaded solves following a path (KinematicsOptions::extrapolate_warm_start)
};

}  // namespace detail

struct Workspace::Impl {
  detail::WarmHistory history;     ///< frictionless solves following a path
  detail::ChordCache chain_chord;  ///< Jacobian of a recent frictionless solve of the chain
  detail::Problem problem;
  detail::Evaluator eval;
  detail::Outputs out;
  detail::LoadedWork loaded;
  Eigen::VectorXd key, z_predicted, z_chord;  ///< scratch of a frictionless solve (storage reused between solves)
};

}  // namespace ctr
