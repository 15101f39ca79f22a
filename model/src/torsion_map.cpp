// The torsion-only shooting map (Lock & Dupont 2011 §II.A, Dupont et al. TRO 2010, Rucker et al. IJRR 2010): the
// variational equations are integrated with the same RK4 scheme as the state, which makes the Jacobian the exact
// derivative of the discrete shooting map (so Newton converges quadratically). Contact unknowns (concentrated friction
// torques of §II.D) enter as point torques at contact sites.
#include "torsion_map.hpp"

#include <Eigen/Geometry>
#include <Eigen/LU>
#include <algorithm>
#include <cmath>

#include "contact_events.hpp"
#include "se3_step.hpp"
#include "sincos_shift.hpp"

namespace ctr::detail {

void Evaluator::resize(int n, int m) {
  if (n_ == n && m_ == m) return;
  n_ = n;
  m_ = m;
  const int dim = 2 * n + 2 * n * m;
  Y.resize(dim);
  Ytmp.resize(dim);
  for (auto& k : K) k.resize(dim);
  sn.resize(n);
  cs.resize(n);
  sn0.resize(n);
  cs0.resize(n);
  shift.resize(n);
  step_shift.resize(n);
  lin.resize(5 * n);
  J.resize(m, m);
  r.resize(m);
}

// dY = F(Y) on one segment. Also returns the backbone bending curvature u0. With `shift`, the angles are those of the
// base (the last first-stage evaluation) plus shift[i]: their sines and cosines follow from the base's by angle
// addition; `base`: this evaluation is the new base (a step's first stage). A segment's first step calls libm, every
// other stage adds a small angle (one libm sincos per tube and segment instead of four per step).
void Evaluator::deriv(const Segment& sg, const double* Yin, double* dY, int columns, Eigen::Vector2d& u0,
                      const double* shift, bool base) {
  const int n = n_;
  const double* th = Yin;
  const double* u = Yin + n;
  double A = 0.0, B = 0.0;
  for (int i = 0; i < n; ++i) {
    if (sg.w[i] != 0.0) {
      if (shift)
        sinCosShifted(th[i], sn0[i], cs0[i], shift[i], sn[i], cs[i]);
      else
        ::sincos(th[i], &sn[i], &cs[i]);
      if (base) {
        sn0[i] = sn[i];
        cs0[i] = cs[i];
      }
      A += sg.w[i] * cs[i];
      B += sg.w[i] * sn[i];
    } else {
      sn[i] = 0.0;
      cs[i] = 0.0;
    }
  }
  u0 = Eigen::Vector2d(-B / sg.K, A / sg.K);
  for (int i = 0; i < n; ++i) {
    dY[i] = sg.present[static_cast<std::size_t>(i)] ? u[i] : 0.0;
    dY[n + i] = sg.a[i] != 0.0 ? sg.a[i] * (sn[i] * A - cs[i] * B) : 0.0;
  }
  if (columns == 0) return;
  // Sensitivities: d(u_i')/d(theta_k) = a_i [(c_i A + s_i B) delta_ik - w_k (c_i c_k + s_i s_k)].
  double* wc = lin.data();
  double* ws = wc + n;
  double* g = ws + n;
  double* ac = g + n;
  double* as = ac + n;
  for (int i = 0; i < n; ++i) {
    wc[i] = sg.w[i] * cs[i];
    ws[i] = sg.w[i] * sn[i];
    g[i] = sg.a[i] * (cs[i] * A + sn[i] * B);
    ac[i] = sg.a[i] * cs[i];
    as[i] = sg.a[i] * sn[i];
  }
  const double* S = Yin + 2 * n;
  double* dS = dY + 2 * n;
  const int ld = 2 * n;
  for (int c = 0; c < columns; ++c) {
    const double* Sc = S + c * ld;
    double* dSc = dS + c * ld;
    double Cc = 0.0, Sc_ = 0.0;
    for (int k = 0; k < n; ++k) {
      Cc += wc[k] * Sc[k];
      Sc_ += ws[k] * Sc[k];
    }
    for (int i = 0; i < n; ++i) {
      dSc[i] = sg.present[static_cast<std::size_t>(i)] ? Sc[n + i] : 0.0;
      dSc[n + i] = sg.a[i] != 0.0 ? g[i] * Sc[i] - ac[i] * Cc - as[i] * Sc_ : 0.0;
    }
  }
}

namespace {

void orthonormalize(Eigen::Matrix3d& R) {
  Eigen::Vector3d z = R.col(2).normalized();
  Eigen::Vector3d x = (R.col(0) - z * z.dot(R.col(0))).normalized();
  R.col(0) = x;
  R.col(1) = z.cross(x);
  R.col(2) = z;
}

}  // namespace

void Evaluator::evaluate(const Problem& P, const Eigen::VectorXd& z, bool jac, bool record, Outputs& out) {
  const int n = P.n, m = P.m;
  resize(n, m);
  const int ld = 2 * n;
  // Sensitivity columns carried: the twist-rate columns from s = 0, a contact's column from its site on (before it,
  // it is zero: its point torque is applied there). Columns below `active` that are still zero stay zero.
  int active = jac ? n : 0;
  int dim = 2 * n + 2 * n * active;
  Y.setZero();
  for (int i = 0; i < n; ++i) {
    Y[i] = P.alpha[i] - P.beta[i] * z[i];
    Y[n + i] = z[i];
    if (jac) {
      Y[2 * n + i * ld + i] = -P.beta[i];
      Y[2 * n + i * ld + n + i] = 1.0;
    }
  }
  r.setZero();
  if (jac) {
    J.setZero();
    ++jacobian_evaluations;
  }
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d p = Eigen::Vector3d::Zero();
  Eigen::Vector2d u0;
  out.moments.clear();
  out.contacts_relative_twist.assign(P.contacts.size(), 0.0);
  out.contacts_moment.assign(P.contacts.size(), 0.0);

  // Tubes that never leave the actuation unit: u_iz = 0 there.
  for (int i = 0; i < n; ++i) {
    if (P.end[i] <= kSameS) {
      r[i] = z[i];
      if (jac) J(i, i) = 1.0;
    }
  }
  // Twist when tube 1 ends inside the actuation unit: linear twist there.
  if (P.s_twist <= kSameS) {
    out.twist.resize(n - 1);
    for (int k = 1; k < n; ++k) {
      const double th_k = P.alpha[k] + (P.s_twist - P.beta[k]) * z[k];
      const double th_1 = P.alpha[0] + (P.s_twist - P.beta[0]) * z[0];
      out.twist[k - 1] = th_k - th_1;
    }
  }

  // Backbone nodes are written in place into out.backbone (its elements and their theta / u_z vectors are reused
  // from the previous evaluation: no allocation per node). u0 is the curvature at the node: the first RK4 stage's.
  std::size_t nodes = 0;
  auto pushNode = [&](double s, const Segment& sg, const Eigen::Vector2d& u0n, bool segment_start) {
    if (nodes == out.backbone.size()) out.backbone.emplace_back();
    BackbonePoint& bp = out.backbone[nodes++];
    bp.s = s;
    bp.segment_start = segment_start;
    bp.position = p;
    bp.frame = R;
    bp.theta = Y.head(n);
    bp.uz = Y.segment(n, n);
    bp.u0 = u0n;
    bp.outermost = sg.outermost;
  };

  pose_steps_.clear();
  pose_pending_ = false;
  pending_moments_.clear();
  end_theta_.clear();
  Eigen::VectorXd grad;
  for (std::size_t si = 0; si < P.segments.size(); ++si) {
    const Segment& sg = P.segments[si];
    const double h = sg.h;
    for (int st = 0; st < sg.steps; ++st) {
      Eigen::Vector2d u01, u02, u03, u04;
      double* y = Y.data();
      double* yt = Ytmp.data();
      deriv(sg, y, K[0].data(), active, u01, st > 0 ? step_shift.data() : nullptr, true);
      // Node at the start of the step (the segment's first node is after the previous breakpoint's events: both
      // sides of a jump are kept).
      if (record) pushNode(sg.s0 + st * h, sg, u01, st == 0);
      // Stage angles: theta + c h K[.][0..n) (the theta rows of the previous stage's derivative).
      for (int i = 0; i < n; ++i) shift[i] = 0.5 * h * K[0][i];
      for (int d = 0; d < dim; ++d) yt[d] = y[d] + 0.5 * h * K[0][d];
      deriv(sg, yt, K[1].data(), active, u02, shift.data(), false);
      for (int i = 0; i < n; ++i) shift[i] = 0.5 * h * K[1][i];
      for (int d = 0; d < dim; ++d) yt[d] = y[d] + 0.5 * h * K[1][d];
      deriv(sg, yt, K[2].data(), active, u03, shift.data(), false);
      for (int i = 0; i < n; ++i) shift[i] = h * K[2][i];
      for (int d = 0; d < dim; ++d) yt[d] = y[d] + h * K[2][d];
      deriv(sg, yt, K[3].data(), active, u04, shift.data(), false);
      for (int d = 0; d < dim; ++d) y[d] += h / 6.0 * (K[0][d] + 2.0 * K[1][d] + 2.0 * K[2][d] + K[3][d]);
      for (int i = 0; i < n; ++i) step_shift[i] = h / 6.0 * (K[0][i] + 2.0 * K[1][i] + 2.0 * K[2][i] + K[3][i]);
      // Backbone pose: 4th-order commutator-free Lie group step on SE(3) with the RK4 stage curvatures
      // (exact for constant curvature, stays on SO(3)).
      const Eigen::Vector2d w1 = h / 12.0 * (3.0 * u01 + 2.0 * u02 + 2.0 * u03 - u04);
      const Eigen::Vector2d w2 = h / 12.0 * (-u01 + 2.0 * u02 + 2.0 * u03 + 3.0 * u04);
      if (record) {
        detail::se3Step(R, p, w1, 0.5 * h);
        detail::se3Step(R, p, w2, 0.5 * h);
      } else {
        pose_steps_.push_back({w1, w2, 0.5 * h, st + 1 == sg.steps});
      }
    }
    if (record) orthonormalize(R);

    // Events at the end of the segment.
    const Breakpoint& bp = P.breakpoints[si];
    if (record) {
      double A = 0, B = 0;
      for (int j = 0; j < n; ++j)
        if (sg.w[j] != 0.0) {
          A += sg.w[j] * std::cos(Y[j]);
          B += sg.w[j] * std::sin(Y[j]);
        }
      pushNode(bp.s, sg, Eigen::Vector2d(-B / sg.K, A / sg.K), false);
    }
    if (bp.twist_point) {
      out.twist.resize(n - 1);
      for (int k = 1; k < n; ++k) out.twist[k - 1] = Y[k] - Y[0];
    }
    // Concentrated moments: tube ends (moment of the tube just before its end; its value in finish()) ...
    for (int i : bp.ending) {
      pending_moments_.push_back({out.moments.size(), si, end_theta_.size()});
      end_theta_.insert(end_theta_.end(), Y.data(), Y.data() + n);
      out.moments.push_back({MomentKind::TubeEnd, i, bp.s, 0.0});
    }
    // ... and curvature discontinuities: |jump of m_j| = k_j kappa_j (K - k_j) / K.
    if (si + 1 < P.segments.size()) {
      const Segment& nx = P.segments[si + 1];
      for (int j : bp.discontinuities)
        out.moments.push_back({MomentKind::CurvatureDiscontinuity, j, bp.s, discontinuityMoment(P, nx, j)});
    }

    // Contact residual rows (before the point-torque jumps; theta is continuous) with their sensitivities.
    for (int c : bp.contacts) {
      const ActiveContact& ac = P.contacts[static_cast<std::size_t>(c)];
      const int row = n + c, col = n + c;
      const int a = ac.site.outer, b = ac.site.inner;
      const double relative_twist = Y[b] - Y[a];
      const double mom = siteMoment<double>(P, si, Y.data(), ac.site, 0.0, 0.0, jac ? &grad : nullptr);
      out.contacts_relative_twist[static_cast<std::size_t>(c)] = relative_twist;
      out.contacts_moment[static_cast<std::size_t>(c)] = mom;
      r[row] = contactLawResidual(P, ac, z[col], relative_twist, mom);
      if (!jac) continue;
      if (ac.condition.law == ContactCondition::Law::Free) {
        J(row, col) = 1.0;
      } else if (ac.condition.law == ContactCondition::Law::Stick) {
        for (int col2 = 0; col2 < m; ++col2) J(row, col2) = Y[2 * n + col2 * ld + b] - Y[2 * n + col2 * ld + a];
      } else {
        const double f = torqueLawFactor(P, ac);
        for (int col2 = 0; col2 < m; ++col2) {
          double d = 0.0;
          for (int k = 0; k < n; ++k) d += grad[k] * Y[2 * n + col2 * ld + k];
          J(row, col2) = -f * d;
        }
        J(row, col) += 1.0;
      }
    }
    // Distal boundary conditions of tubes ending here: k_i u_iz(s-) = point torque on tube i.
    for (int i : bp.ending) {
      r[i] = Y[n + i];
      if (jac)
        for (int col2 = 0; col2 < m; ++col2) J(i, col2) = Y[2 * n + col2 * ld + n + i];
    }
    // Point torques of the contact unknowns (their sensitivity: 1 in the contact's own column).
    for (int c : bp.contacts) {
      const ContactJump jump = contactJump(P, bp, P.contacts[static_cast<std::size_t>(c)]);
      const int col = n + c;
      applyContactJump(jump, z[col], r.data(), Y.data() + n);
      if (!jac) continue;
      if (jump.a_ends)
        J(jump.a, col) -= jump.pa;
      else
        Y[2 * n + col * ld + n + jump.a] -= jump.pa;
      if (jump.b_ends)
        J(jump.b, col) -= 1.0;
      else
        Y[2 * n + col * ld + n + jump.b] -= 1.0;
      if (col >= active) {
        active = col + 1;
        dim = 2 * n + 2 * n * active;
      }
    }
  }
  pose_pending_ = !record;
  if (record) {
    out.tip_position = p;
    out.tip_frame = R;
  }
  if (record) out.backbone.resize(nodes);
  if (record && !P.segments.empty()) {
    // Last node: values after the final events (frozen tubes).
    out.backbone.back().theta = Y.head(n);
    out.backbone.back().uz = Y.segment(n, n);
  }
  if (jac) {
    out.stability = J.topLeftCorner(n, n).determinant();
  }
}

void Evaluator::finish(const Problem& P, Outputs& out) {
  for (const PendingMoment& pm : pending_moments_) {
    ConcentratedMoment& cm = out.moments[pm.moment];
    cm.magnitude = endMoment<double>(P, P.segments[pm.segment], &end_theta_[pm.theta], cm.tube,
                                     &P.breakpoints[pm.segment].ending, 0.0, 0.0);
  }
  pending_moments_.clear();
  if (!pose_pending_) return;
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d p = Eigen::Vector3d::Zero();
  for (const PoseStep& ps : pose_steps_) {
    detail::se3Step(R, p, ps.w1, ps.hh);
    detail::se3Step(R, p, ps.w2, ps.hh);
    if (ps.last) orthonormalize(R);
  }
  out.tip_position = p;
  out.tip_frame = R;
  pose_pending_ = false;
}

}  // namespace ctr::detail
