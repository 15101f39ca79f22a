// Internal: the torsion-only shooting map (Lock & Dupont 2011 §II.A): the twist angles and rates of the tubes and
// their sensitivities to the unknowns, integrated by RK4, and the backbone pose.
#pragma once

#include <Eigen/Core>
#include <array>
#include <vector>

#include "problem.hpp"

namespace ctr::detail {

/// Outputs of an evaluation: twist, tip pose, moments and contacts, the backbone when recorded, and the stability
/// (det of the twist-rate block of J) of the last evaluation with the Jacobian.
struct Outputs {
  Eigen::VectorXd twist;
  Eigen::Vector3d tip_position = Eigen::Vector3d::Zero();
  Eigen::Matrix3d tip_frame = Eigen::Matrix3d::Identity();
  std::vector<ConcentratedMoment> moments;
  std::vector<double> contacts_relative_twist, contacts_moment;
  std::vector<BackbonePoint> backbone;
  double stability = 0;
};

/// The torsion-only shooting map r(z) and its exact Jacobian (the sensitivities integrated with the state), with
/// its buffers.
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

}  // namespace ctr::detail
