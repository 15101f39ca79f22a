// Torsionally compliant CTR kinematics (Lock & Dupont 2011 §II.A, Dupont et al. TRO 2010, Rucker et al. IJRR 2010)
// solved by shooting on the base twist rates u_iz(0) with an exact Jacobian: the variational equations are
// integrated with the same RK4 scheme as the state, which makes the Jacobian the exact derivative of the
// discrete shooting map (so Newton converges quadratically). Optional contact unknowns (concentrated friction
// torques of §II.D) enter as point torques at contact sites.
#include "ctr/model/kinematics.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Geometry>
#include <Eigen/LU>
#include <algorithm>
#include <functional>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>

#include "loaded_impl.hpp"
#include "se3_step.hpp"
#include "sincos_shift.hpp"
#include "workspace_impl.hpp"

namespace ctr {

const char* toString(SolveStatus s) {
  switch (s) {
    case SolveStatus::Converged: return "converged";
    case SolveStatus::NotConverged: return "not_converged";
    case SolveStatus::Inadmissible: return "inadmissible";
  }
  return "unknown";
}

Workspace::Workspace() : impl_(std::make_unique<Impl>()) {}
Workspace::~Workspace() = default;
Workspace::Workspace(Workspace&&) noexcept = default;
Workspace& Workspace::operator=(Workspace&&) noexcept = default;

namespace {

constexpr double kSameS = 1e-12;

double disconStart(const Robot& r, const Configuration& q, int i) {
  return q.beta[i] + r.tube(i).straight_length;
}

bool hasDiscontinuity(const Robot& r, const Configuration& q, int i) {
  const Tube& t = r.tube(i);
  const double sd = disconStart(r, q, i);
  return t.curvature != 0.0 && t.curved_length > 0.0 && t.straight_length > 0.0 && sd > kSameS &&
         sd < distalEnd(r, q, i) - kSameS;
}

}  // namespace

std::vector<ContactSite> contactSites(const Robot& robot, const Configuration& q) {
  std::vector<ContactSite> sites;
  const int n = robot.size();
  if (n < 2) return sites;
  sites.reserve(static_cast<std::size_t>(2 * n));
  for (int i = 0; i + 1 < n; ++i) {
    const double e = distalEnd(robot, q, i);
    if (e > kSameS) sites.push_back({MomentKind::TubeEnd, i, i, i + 1, e});
  }
  for (int j = 0; j < n; ++j) {
    if (!hasDiscontinuity(robot, q, j)) continue;
    const double sd = disconStart(robot, q, j);
    int outer = -1, inner = -1;
    if (j > 0 && distalEnd(robot, q, j - 1) > sd + kSameS) {
      outer = j - 1;
      inner = j;
    } else if (j + 1 < n) {
      outer = j;
      inner = j + 1;
    }
    if (outer >= 0) sites.push_back({MomentKind::CurvatureDiscontinuity, j, outer, inner, sd});
  }
  // Stable insertion sort by s (a handful of sites; std::stable_sort would allocate a buffer per call).
  for (std::size_t k = 1; k < sites.size(); ++k)
    for (std::size_t j = k; j > 0 && sites[j].s < sites[j - 1].s; --j) std::swap(sites[j], sites[j - 1]);
  return sites;
}

namespace detail {

// ---------------------------------------------------------------------------------------------------------------
// Problem set-up: segments between discontinuities, breakpoints with their events, active contacts.
// ---------------------------------------------------------------------------------------------------------------
void Problem::setup(const Robot& robot, const Configuration& q, const std::vector<ContactCondition>* conditions,
                    const KinematicsOptions& opt, double kappa_scale, double step_factor) {
  const double max_step = step_factor * opt.max_step;
  const double max_bending_per_step = step_factor * opt.max_bending_per_step;
  const bool per_segment = opt.bending_limit_per_segment;
  n = robot.size();
  mu_boundary = robot.friction().boundary;
  kb.resize(n);
  kt.resize(n);
  kappa.resize(n);
  alpha = q.alpha;
  beta = q.beta;
  end.resize(n);
  disc.resize(n);
  for (int i = 0; i < n; ++i) {
    const Tube& t = robot.tube(i);
    kb[i] = t.bending_stiffness;
    kt[i] = t.torsional_stiffness;
    kappa[i] = t.curvature * kappa_scale;
    end[i] = distalEnd(robot, q, i);
    disc[i] = disconStart(robot, q, i);
  }
  s_tip = end.maxCoeff();
  s_twist = end[0];
  const double kmax = kappa.cwiseAbs().maxCoeff();  // the whole robot's (bending limit not per segment)

  // Active contacts (those with an unknown torque).
  contacts.clear();
  if (conditions) {
    const std::vector<ContactSite> sites = contactSites(robot, q);
    for (std::size_t c = 0; c < sites.size() && c < conditions->size(); ++c) {
      // Every site gets an unknown (Free ones a trivial one, tau = 0) so that all report their relative twist.
      ContactCondition cc = (*conditions)[c];
      if (cc.law == ContactCondition::Law::Torque && (cc.value == 0.0 || mu_boundary == 0.0))
        cc = ContactCondition{ContactCondition::Law::Free, 0.0};
      ActiveContact ac;
      ac.site = sites[c];
      ac.condition = cc;
      ac.site_index = static_cast<int>(c);
      contacts.push_back(ac);
    }
  }
  m = n + static_cast<int>(contacts.size());

  // Breakpoints.
  std::vector<double> pts;
  pts.reserve(static_cast<std::size_t>(2 * n + 1));
  pts.push_back(0.0);
  for (int i = 0; i < n; ++i) {
    if (end[i] > kSameS) pts.push_back(end[i]);
    if (hasDiscontinuity(robot, q, i)) pts.push_back(disc[i]);
  }
  std::sort(pts.begin(), pts.end());
  std::size_t kept = 0;  // merge breakpoints closer than kSameS (in place)
  for (double p : pts)
    if (kept == 0 || p > pts[kept - 1] + kSameS) pts[kept++] = p;
  pts.resize(kept);
  const std::vector<double>& uniq = pts;

  // Segments and breakpoints are rebuilt in place: their vectors keep their storage from the previous solve.
  const std::size_t count = uniq.size() > 1 ? uniq.size() - 1 : 0;
  segments.resize(count);
  breakpoints.resize(count);
  for (std::size_t b = 0; b < count; ++b) {
    Segment& sg = segments[b];
    sg.s0 = uniq[b];
    sg.s1 = uniq[b + 1];
    const double mid = 0.5 * (sg.s0 + sg.s1);
    // Step: at most max_step, and at most max_bending_per_step over the largest precurvature of the tubes curved on
    // this segment (the backbone curvature is a weighted mean of theirs; where no tube is curved nothing bends), or
    // of the whole robot when not per segment.
    double kseg = per_segment ? 0.0 : kmax;
    if (per_segment)
      for (int i = 0; i < n; ++i)
        if (end[i] > mid && mid > disc[i]) kseg = std::max(kseg, std::abs(kappa[i]));
    const double h_max =
        kseg > 0.0 && max_bending_per_step > 0.0 ? std::min(max_step, max_bending_per_step / kseg) : max_step;
    sg.steps = std::max(1, static_cast<int>(std::ceil((sg.s1 - sg.s0) / h_max - 1e-9)));
    sg.h = (sg.s1 - sg.s0) / sg.steps;
    sg.present.assign(static_cast<std::size_t>(n), 0);
    sg.a.setZero(n);
    sg.w.setZero(n);
    sg.K = 0.0;
    sg.outermost = n - 1;
    for (int i = n - 1; i >= 0; --i) {
      if (end[i] > mid) {
        sg.present[static_cast<std::size_t>(i)] = 1;
        sg.K += kb[i];
        sg.outermost = i;
      }
    }
    for (int i = 0; i < n; ++i) {
      if (!sg.present[static_cast<std::size_t>(i)]) continue;
      const bool curved = mid > disc[i] && kappa[i] != 0.0;
      if (curved) {
        sg.w[i] = kb[i] * kappa[i];
        sg.a[i] = kb[i] / kt[i] * kappa[i] / sg.K;
      }
    }
    Breakpoint& bp = breakpoints[b];
    bp.s = sg.s1;
    bp.ending.clear();
    bp.discontinuities.clear();
    bp.contacts.clear();
    for (int i = 0; i < n; ++i)
      if (std::abs(end[i] - sg.s1) <= kSameS) bp.ending.push_back(i);
    for (int i = 0; i < n; ++i)
      if (hasDiscontinuity(robot, q, i) && std::abs(disc[i] - sg.s1) <= kSameS) bp.discontinuities.push_back(i);
    for (std::size_t c = 0; c < contacts.size(); ++c)
      if (std::abs(contacts[c].site.s - sg.s1) <= kSameS) bp.contacts.push_back(static_cast<int>(c));
    bp.twist_point = std::abs(sg.s1 - s_twist) <= kSameS;
  }
}

// ---------------------------------------------------------------------------------------------------------------
// Integration of the state, its sensitivities and the backbone frame.
// ---------------------------------------------------------------------------------------------------------------
namespace {

struct Trig {
  double A = 0, B = 0;  // sum w_j cos(theta_j), sum w_j sin(theta_j)
};

}  // namespace

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

// Bending moment magnitude of tube i just before the end of segment sg, with its gradient w.r.t. theta.
// Tubes that end at the same s are taken in their nesting order (the limit of inner tubes protruding by an
// infinitesimal length): the moment of tube i is that of the segment without the outer tubes ending with it.
// Without this rule the moment, hence the friction bound, jumps when coincident ends separate.
double endMoment(const Problem& P, const Segment& sg, const double* th, int i, Eigen::VectorXd* grad,
                 const std::vector<int>* ending) {
  const int n = P.n;
  auto excluded = [&](int j) {
    return ending && j < i && std::find(ending->begin(), ending->end(), j) != ending->end();
  };
  double A = 0.0, B = 0.0, K = sg.K;
  double si = 0.0, ci = 0.0;  // sin, cos of th[i]
  bool have_i = false;
  for (int j = 0; j < n; ++j) {
    if (excluded(j)) {
      if (sg.present[static_cast<std::size_t>(j)]) K -= P.kb[j];
      continue;
    }
    if (sg.w[j] != 0.0) {
      double sj, cj;
      ::sincos(th[j], &sj, &cj);
      A += sg.w[j] * cj;
      B += sg.w[j] * sj;
      if (j == i) {
        si = sj;
        ci = cj;
        have_i = true;
      }
    }
  }
  const double chi_kappa = sg.w[i] != 0.0 ? P.kappa[i] : 0.0;
  if (!have_i) ::sincos(th[i], &si, &ci);
  // v = u0 - chi kappa_i d(theta_i), d = (-sin, cos).
  const Eigen::Vector2d v(-B / K + chi_kappa * si, A / K - chi_kappa * ci);
  const double nv = v.norm();
  if (grad) {
    grad->setZero(n);
    if (nv > 0.0) {
      for (int j = 0; j < n; ++j) {
        if (sg.w[j] == 0.0 || excluded(j)) continue;
        const Eigen::Vector2d dd(-std::cos(th[j]), -std::sin(th[j]));  // d'(theta_j)
        Eigen::Vector2d dv = sg.w[j] / K * dd;
        if (j == i) dv -= chi_kappa * dd;
        (*grad)[j] = P.kb[i] * v.dot(dv) / nv;
      }
    }
  }
  return P.kb[i] * nv;
}

double discontinuityMoment(const Problem& P, const Segment& next, int j) {
  return std::abs(P.kb[j] * P.kappa[j] * (next.K - P.kb[j]) / next.K);
}

double siteMoment(const Problem& P, std::size_t si, const double* th, const ContactSite& site, Eigen::VectorXd* grad) {
  if (site.kind == MomentKind::TubeEnd)
    return endMoment(P, P.segments[si], th, site.tube, grad, &P.breakpoints[si].ending);
  if (grad) grad->setZero(P.n);
  return discontinuityMoment(P, P.segments[si + 1], site.tube);
}

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

    // Point torques (per unit torsional stiffness) from contact unknowns, applied to tubes at this s.
    // Contact c with scaled unknown tau_c: torque T = kt_inner * tau_c on the inner tube, -T on the outer.
    // Contact residual rows (computed before the jumps; theta is continuous).
    for (int c : bp.contacts) {
      const ActiveContact& ac = P.contacts[static_cast<std::size_t>(c)];
      const int row = n + c, col = n + c;
      const int a = ac.site.outer, b = ac.site.inner;
      out.contacts_relative_twist[static_cast<std::size_t>(c)] = Y[b] - Y[a];
      const double mom = siteMoment(P, si, Y.data(), ac.site, jac ? &grad : nullptr);
      out.contacts_moment[static_cast<std::size_t>(c)] = mom;
      if (ac.condition.law == ContactCondition::Law::Free) {
        r[row] = z[col];
        if (jac) J(row, col) = 1.0;
      } else if (ac.condition.law == ContactCondition::Law::Stick) {
        r[row] = Y[b] - Y[a] - ac.condition.value;
        if (jac)
          for (int col2 = 0; col2 < m; ++col2)
            J(row, col2) = Y[2 * n + col2 * ld + b] - Y[2 * n + col2 * ld + a];
      } else {  // Torque law: tau = lambda mu' |m| / kt_inner
        const double f = ac.condition.value * P.mu_boundary / P.kt[b];
        r[row] = z[col] - f * mom;
        if (jac) {
          for (int col2 = 0; col2 < m; ++col2) {
            double d = 0.0;
            for (int k = 0; k < n; ++k) d += grad[k] * Y[2 * n + col2 * ld + k];
            J(row, col2) = -f * d;
          }
          J(row, col) += 1.0;
        }
      }
    }
    // Distal boundary conditions of tubes ending here: k_i u_iz(s-) = point torque on tube i.
    for (int i : bp.ending) {
      r[i] = Y[n + i];
      if (jac)
        for (int col2 = 0; col2 < m; ++col2) J(i, col2) = Y[2 * n + col2 * ld + n + i];
    }
    for (int c : bp.contacts) {
      const ActiveContact& ac = P.contacts[static_cast<std::size_t>(c)];
      const int col = n + c;
      const int a = ac.site.outer, b = ac.site.inner;
      const double pa = -P.kt[b] / P.kt[a];  // point torque on a per unit tau, scaled by 1/kt_a
      const bool a_ends = std::find(bp.ending.begin(), bp.ending.end(), a) != bp.ending.end();
      const bool b_ends = std::find(bp.ending.begin(), bp.ending.end(), b) != bp.ending.end();
      // Tube a: residual u_a - P_a (if it ends) or jump u_a(s+) = u_a(s-) - P_a.
      if (a_ends) {
        r[a] -= pa * z[col];
        if (jac) J(a, col) -= pa;
      } else {
        Y[n + a] -= pa * z[col];
        if (jac) Y[2 * n + col * ld + n + a] -= pa;
      }
      if (b_ends) {
        r[b] -= z[col];
        if (jac) J(b, col) -= 1.0;
      } else {
        Y[n + b] -= z[col];
        if (jac) Y[2 * n + col * ld + n + b] -= 1.0;
      }
      if (jac && col >= active) {
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
    cm.magnitude = endMoment(P, P.segments[pm.segment], &end_theta_[pm.theta], cm.tube, nullptr,
                             &P.breakpoints[pm.segment].ending);
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

// Actuation as one vector for the warm-start history: alpha, then beta in units of 2 cm (~1 rad).
Eigen::VectorXd historyKey(const Configuration& q) {
  Eigen::VectorXd v;
  historyKey(q, v);
  return v;
}

void historyKey(const Configuration& q, Eigen::VectorXd& v) {
  v.resize(2 * q.size());
  v << q.alpha, kHistoryBetaScale * q.beta;
}

// Continuation predictor: when q continues the straight line through the last solves of the chain (each step
// within 2.6 deg of the line's direction, q at most two steps ahead), the base twist rates extrapolated along it by
// the polynomial through up to four of them (Lagrange, in the arc length along the line). A higher-order term larger
// than a quarter of the secant's step (a fold ahead) falls back to the secant.
bool continuationPredictor(const WarmHistory& H, const Eigen::VectorXd& q, Eigen::VectorXd& z) {
  if (H.count < 2 || H.q[0].size() != q.size() || z.size() < H.z[0].size()) return false;
  // Scalar loops throughout: no temporaries (this runs once per solve along a path).
  const Eigen::Index dim = q.size(), nz = H.z[0].size();
  double ahead2 = 0.0;
  for (Eigen::Index c = 0; c < dim; ++c) ahead2 += (q[c] - H.q[0][c]) * (q[c] - H.q[0][c]);
  const double ahead = std::sqrt(ahead2);
  if (!(ahead > 0.0)) return false;
  double s[WarmHistory::kDepth] = {0.0};
  int points = 1;
  for (int k = 1; k < H.count; ++k) {
    if (H.q[k].size() != dim || H.z[k].size() != nz) break;
    double len2 = 0.0, dot = 0.0;  // step = q[k-1] - q[k]; along = step . (q - q[0]) / ahead
    for (Eigen::Index c = 0; c < dim; ++c) {
      const double st = H.q[k - 1][c] - H.q[k][c];
      len2 += st * st;
      dot += st * (q[c] - H.q[0][c]);
    }
    const double len = std::sqrt(len2), along = dot / ahead;
    if (!(len > 0.0) || along < 0.999 * len) break;  // not (nearly) the same direction
    s[k] = s[k - 1] - along;
    ++points;
  }
  if (points < 2 || ahead > 2.0 * -s[1]) return false;
  // Lagrange weights of the polynomial through the chain's points, at `ahead`; the secant's factor.
  double w[WarmHistory::kDepth];
  for (int i = 0; i < points; ++i) {
    w[i] = 1.0;
    for (int j = 0; j < points; ++j)
      if (j != i) w[i] *= (ahead - s[j]) / (s[i] - s[j]);
  }
  const double f = ahead / -s[1];
  auto secantAt = [&](Eigen::Index c) { return H.z[0][c] + f * (H.z[0][c] - H.z[1][c]); };
  auto polyAt = [&](Eigen::Index c) {
    double v = 0.0;
    for (int i = 0; i < points; ++i) v += w[i] * H.z[i][c];
    return v;
  };
  double secant_step = 0.0, gap = 0.0;
  bool finite = true;
  for (Eigen::Index c = 0; c < nz; ++c) {
    const double sc = secantAt(c), pc = polyAt(c);
    finite = finite && std::isfinite(pc);
    secant_step = std::max(secant_step, std::abs(sc - H.z[0][c]));
    gap = std::max(gap, std::abs(pc - sc));
  }
  const bool smooth = finite && gap <= 0.25 * secant_step;
  for (Eigen::Index c = 0; c < nz; ++c) z[c] = smooth ? polyAt(c) : secantAt(c);
  return z.allFinite();
}

void recordInChain(WarmHistory& H, bool chained, const Eigen::VectorXd& qv, const Eigen::VectorXd& z) {
  if (!chained) H.count = 0;
  for (int k = std::min(H.count, WarmHistory::kDepth - 1); k > 0; --k) {
    std::swap(H.q[k], H.q[k - 1]);
    std::swap(H.z[k], H.z[k - 1]);
  }
  H.q[0] = qv;
  H.z[0] = z;
  H.count = std::min(H.count + 1, WarmHistory::kDepth);
}

// (The loaded solver's base moments pass through a Solution in N m: the unknowns are compared to rounding.)
bool continuesChain(const WarmHistory& H, const Configuration& warm_q, const Eigen::VectorXd& q_key,
                    const Eigen::VectorXd& z) {
  if (!(H.count > 0 && warm_q.size() * 2 == q_key.size() && H.q[0].size() == q_key.size() && z.size() == H.z[0].size()))
    return false;
  const int n = warm_q.size();
  for (int i = 0; i < n; ++i)  // historyKey(warm_q) == H.q[0], without forming the key
    if (!(warm_q.alpha[i] == H.q[0][i] && kHistoryBetaScale * warm_q.beta[i] == H.q[0][n + i])) return false;
  return (z - H.z[0]).cwiseAbs().maxCoeff() <= 1e-13 * (1.0 + H.z[0].cwiseAbs().maxCoeff());
}

}  // namespace detail

// ---------------------------------------------------------------------------------------------------------------
// Newton iteration with backtracking, homotopy fallback, public entry points.
// ---------------------------------------------------------------------------------------------------------------
namespace {

using detail::Evaluator;
using detail::Outputs;
using detail::Problem;

double maxAbs(const Eigen::VectorXd& v) { return v.size() ? v.cwiseAbs().maxCoeff() : 0.0; }

bool allFinite(const Eigen::VectorXd& v) { return v.allFinite(); }

// Newton from z; returns true on convergence. z, ws outputs updated to the last evaluated point (with `record`, every
// evaluation records the backbone, so that it is at hand for the returned point without another pass).
// Below this |stability|, a solution reached by a value-only evaluation is evaluated once more with the Jacobian
// (the stability's sign and the refinement test then use the exact Jacobian at the solution, as near a fold).
constexpr double kExactStabilityBelow = 0.25;

bool newton(const Problem& P, Evaluator& E, Outputs& out, Eigen::VectorXd& z, const KinematicsOptions& opt,
            int& iterations, double& res_norm, std::string& why, bool record) {
  E.evaluate(P, z, true, record, out);
  bool jac_at_z = true;  // E.J (and out.stability) belong to z
  bool chord = false;    // the last value-only step contracted the residual 10x: the next reuses its factorisation
  Eigen::PartialPivLU<Eigen::MatrixXd>& lu = E.lu;  // the evaluator's scratch (no allocation per solve)
  Eigen::VectorXd& dz = E.dz;
  Eigen::VectorXd& zt = E.zt;
  double nr = maxAbs(E.r);
  double merit = E.r.squaredNorm();  // Newton directions descend on the 2-norm (not on the max-norm)
  const double step_cap = 4.0 * M_PI / std::max(P.s_tip, 1e-3);  // limit on a base twist rate change (1/m)
  for (int it = 0; it < opt.max_iterations; ++it) {
    if (!allFinite(E.r)) {
      why = "non-finite residual";
      res_norm = nr;
      return false;
    }
    if (nr < opt.tolerance) {
      // Converged on a value-only evaluation: the Jacobian (stability) of the previous iterate, within ~|dz| of the
      // exact one, is kept unless the stability is small enough for its sign or the refinement test to depend on it.
      const double limit = std::max(kExactStabilityBelow, 2.0 * opt.refine_below_stability);
      if (!jac_at_z && !(std::abs(out.stability) > limit)) E.evaluate(P, z, true, record, out);
      res_norm = nr;
      return true;
    }
    if (!jac_at_z && !chord) {  // the value-only evaluation did not converge after all: the Jacobian at z
      E.evaluate(P, z, true, record, out);
      jac_at_z = true;
    }
    ++iterations;
    // A chord step (the previous iterate's factorised Jacobian) when the last value-only step contracted well: near
    // the solution the Jacobian changes by ~|dz|, so a chord step converges nearly as fast, for one value-only
    // evaluation instead of a Jacobian and a value.
    if (jac_at_z) lu.compute(E.J);
    dz.noalias() = lu.solve(-E.r);
    if (jac_at_z && (!allFinite(dz) || std::abs(lu.determinant()) < 1e-300)) {
      // Singular Jacobian (at a fold): regularised step.
      const Eigen::MatrixXd JtJ = E.J.transpose() * E.J + 1e-8 * Eigen::MatrixXd::Identity(P.m, P.m);
      dz = JtJ.ldlt().solve(-E.J.transpose() * E.r);
      if (!allFinite(dz)) {
        why = "singular Jacobian";
        res_norm = nr;
        return false;
      }
    }
    const double big = maxAbs(dz.head(P.n));
    if (big > step_cap) dz *= step_cap / big;
    // Newton's quadratic convergence (residual ~ K nr^2 after the step, K 0.002-0.03 median on the example robots)
    // predicts the step converges: evaluate the trial points without the Jacobian (its sensitivities are most of an
    // evaluation's cost). Measured over 26 k Newton steps of the example robots (cold, warm, stick-slip; tolerance
    // 1e-10 and 1e-8): 90 % of such trials converge; the others cost one evaluation more (the Jacobian at z next).
    const bool value_only = chord || nr * nr < 1000.0 * opt.tolerance;
    const double nr_before = nr;
    double t = 1.0;
    bool accepted = false;
    for (int ls = 0; ls < 12; ++ls) {
      zt = z + t * dz;
      E.evaluate(P, zt, !value_only, record, out);
      const double mt = E.r.squaredNorm();
      if (allFinite(E.r) && mt < (1.0 - 1e-4 * t) * merit) {
        accepted = true;
        nr = maxAbs(E.r);
        merit = mt;
        break;
      }
      t *= 0.5;
    }
    if (!accepted && !jac_at_z && allFinite(dz)) {
      // A chord step that found no descent: retry from z with the Jacobian at z.
      chord = false;
      E.evaluate(P, z, true, record, out);
      jac_at_z = true;
      nr = maxAbs(E.r);
      merit = E.r.squaredNorm();
      continue;
    }
    z = zt;
    jac_at_z = !value_only;
    chord = value_only && accepted && nr < 0.1 * nr_before;
    if (!accepted) {
      nr = maxAbs(E.r);
      merit = E.r.squaredNorm();
      if (!(nr < opt.tolerance)) {
        why = "line search failed (no descent direction)";
        res_norm = nr;
        return false;
      }
    }
  }
  res_norm = nr;
  if (nr < opt.tolerance) {
    if (!jac_at_z) E.evaluate(P, z, true, record, out);
    return true;
  }
  std::ostringstream os;
  os << "no convergence in " << opt.max_iterations << " Newton iterations (residual " << nr << ")";
  why = os.str();
  return false;
}

Solution package(const Robot& robot, const Configuration& q, const Problem& P, const Outputs& out,
                 const Eigen::VectorXd& z, bool ok, int iterations, double res_norm, const std::string& why,
                 const KinematicsOptions& opt) {
  Solution sol;
  sol.q = q;
  sol.summary.status = ok ? SolveStatus::Converged : SolveStatus::NotConverged;
  sol.summary.iterations = iterations;
  sol.summary.residual_norm = res_norm;
  sol.summary.message = ok ? "" : why;
  sol.summary.stability = out.stability;
  sol.summary.stable = ok && out.stability > 0.0;
  const int n = P.n;
  sol.base_twist_rate = z.head(n);
  sol.theta0.resize(n);
  for (int i = 0; i < n; ++i) sol.theta0[i] = P.alpha[i] - P.beta[i] * z[i];
  sol.contact_unknowns = z.tail(P.m - n);
  sol.twist = out.twist;
  if (sol.twist.size() != n - 1) sol.twist = Eigen::VectorXd::Zero(n - 1);
  sol.tip_position = out.tip_position;
  sol.tip_frame = out.tip_frame;
  sol.moments = out.moments;
  if (opt.record_backbone) {
    // The last evaluation was at (P, z) with recording on (see solveImpl).
    if (opt.record_tube_states) {
      sol.backbone = out.backbone;
    } else {
      sol.backbone.resize(out.backbone.size());
      for (std::size_t k = 0; k < out.backbone.size(); ++k) {
        const BackbonePoint& a = out.backbone[k];
        BackbonePoint& b = sol.backbone[k];
        b.s = a.s;
        b.position = a.position;
        b.frame = a.frame;
        b.u0 = a.u0;
        b.outermost = a.outermost;
        b.segment_start = a.segment_start;
      }
    }
  }
  sol.contacts.reserve(P.contacts.size());
  for (std::size_t c = 0; c < P.contacts.size(); ++c) {
    const detail::ActiveContact& ac = P.contacts[c];
    ContactResult cr;
    cr.site = ac.site;
    cr.condition = ac.condition;
    cr.relative_twist = out.contacts_relative_twist[c];
    cr.moment = out.contacts_moment[c];
    cr.torque = z[n + static_cast<int>(c)] * P.kt[ac.site.inner];
    sol.contacts.push_back(cr);
  }
  (void)robot;
  return sol;
}

Solution inadmissible(const Configuration& q, const std::string& why, int n) {
  Solution s;
  s.q = q;
  s.summary.status = SolveStatus::Inadmissible;
  s.summary.message = why;
  s.base_twist_rate = Eigen::VectorXd::Zero(n);
  s.theta0 = Eigen::VectorXd::Zero(n);
  s.twist = Eigen::VectorXd::Zero(std::max(0, n - 1));
  return s;
}

Eigen::VectorXd initialGuess(const Problem& P, const Solution* warm) {
  Eigen::VectorXd z = Eigen::VectorXd::Zero(P.m);
  if (warm && warm->base_twist_rate.size() == P.n && warm->base_twist_rate.allFinite()) {
    z.head(P.n) = warm->base_twist_rate;
    // Contact unknowns: match by site.
    for (std::size_t c = 0; c < P.contacts.size(); ++c)
      for (std::size_t w = 0; w < warm->contacts.size(); ++w)
        if (warm->contacts[w].site == P.contacts[c].site)
          z[P.n + static_cast<int>(c)] = warm->contacts[w].torque / P.kt[P.contacts[c].site.inner];
  }
  return z;
}

// Adaptive continuation in a parameter t from 0 (where z is a solution) to 1. `setAt(t)` sets the problem up.
bool continuation(const std::function<void(double)>& setAt, const Problem& P, Evaluator& E, Outputs& out,
                  Eigen::VectorXd& z, const KinematicsOptions& opt, int& iterations, int& steps, std::string& why) {
  double t = 0.0, dt = 1.0 / std::max(1, opt.homotopy_steps);
  KinematicsOptions o = opt;
  o.max_iterations = std::min(opt.max_iterations, 12);  // short Newton runs; shrink the step instead
  while (t < 1.0) {
    const double tn = std::min(1.0, t + dt);
    setAt(tn);
    Eigen::VectorXd zt = z;
    double rn = 0;
    std::string w;
    ++steps;
    const bool ok = newton(P, E, out, zt, o, iterations, rn, w, false);
    if (ok) {
      z = zt;
      t = tn;
      dt = std::min(0.5, 1.5 * dt);
    } else {
      dt *= 0.5;
      if (dt < 1e-4) {
        why = w;
        return false;
      }
    }
    if (steps > 400) {
      why = "continuation took too many steps";
      return false;
    }
  }
  return true;
}

// The robot's kb, kt, kappa as one vector (the chord cache's robot key).
void robotKey(const Problem& P, Eigen::VectorXd& k) {
  k.resize(3 * P.n);
  k << P.kb, P.kt, P.kappa;
}

bool sameRobot(const Eigen::VectorXd& k, const Problem& P) {
  const int n = P.n;
  return k.size() == 3 * n && k.head(n) == P.kb && k.segment(n, n) == P.kt && k.tail(n) == P.kappa;
}

// The cached Jacobian serves quasi-Newton steps when it is of this robot and problem size and was taken within 0.1
// (rad, or 2 mm of translation in history-key units) of q.
bool chordUsable(const detail::ChordCache& C, const Problem& P, const Eigen::VectorXd& qv) {
  return C.valid && C.J.rows() == P.m && C.q.size() == qv.size() && (C.q - qv).cwiseAbs().maxCoeff() <= 0.1 &&
         sameRobot(C.robot, P);
}

void storeChord(detail::ChordCache& C, const Problem& P, const Evaluator& E, double stability,
                const Eigen::VectorXd& qv) {
  C.J = E.J;
  C.q = qv;
  robotKey(P, C.robot);
  C.stability = stability;
  C.valid = true;
}

// Quasi-Newton iteration from a good start (a predicted z, or the previous state of a stick-slip step): value-only
// evaluations, the first step with a cached exact Jacobian taken a few solves back, Broyden updates after it.
// Succeeds when z converges within `max_steps` steps, each cutting the residual by at least 4; otherwise the caller
// runs Newton from the start. The stability is the cached one unless it is small enough for its sign to matter (then
// the Jacobian is evaluated at the solution, as newton() does).
bool chordSolve(const Problem& P, Evaluator& E, Outputs& out, Eigen::VectorXd& z, const KinematicsOptions& opt,
                const detail::ChordCache& C, int max_steps, int& iterations, double& res_norm, bool record) {
  E.evaluate(P, z, false, record, out);
  if (!allFinite(E.r)) return false;
  double nr = maxAbs(E.r);
  // The evaluator's scratch (kept between solves: no allocation per solve).
  Eigen::MatrixXd& J = E.J_quasi;
  Eigen::VectorXd& step = E.dz;
  Eigen::VectorXd& r_old = E.r_prev;
  J = C.J;
  for (int it = 0; it < max_steps && !(nr < opt.tolerance); ++it) {
    ++iterations;
    E.lu.compute(J);
    step.noalias() = E.lu.solve(-E.r);
    r_old = E.r;
    z += step;
    E.evaluate(P, z, false, record, out);
    const double nn = maxAbs(E.r);
    if (!allFinite(E.r) || !(nn < 0.25 * nr)) return false;
    nr = nn;
    // Broyden update along the step (superlinear convergence instead of the chord's linear rate).
    const double ss = step.squaredNorm();
    if (ss > 0.0) {
      r_old -= E.r;  // r_old <- -(change of r); J += (dr - J step) step^T / ss
      r_old.noalias() += J * step;
      J.noalias() -= r_old * (step.transpose() / ss);
    }
  }
  if (!(nr < opt.tolerance)) return false;
  res_norm = nr;
  out.stability = C.stability;
  if (!(std::abs(out.stability) > std::max(kExactStabilityBelow, 2.0 * opt.refine_below_stability)))
    E.evaluate(P, z, true, record, out);
  return true;
}

Solution solveImpl(const Robot& robot, const Configuration& q, const std::vector<ContactCondition>* conditions,
                   Workspace& ws, const KinematicsOptions& opt, const Solution* warm) {
  const Admissibility adm = checkAdmissible(robot, q);
  if (!adm) return inadmissible(q, adm.message, robot.size());
  auto& W = ws.impl();
  Problem& P = W.problem;
  P.setup(robot, q, conditions, opt);
  Eigen::VectorXd z = initialGuess(P, warm);
  int iters = 0;
  double rn = 0.0;
  std::string why;
  // Every path below ends with an evaluation at the returned (P, z) with recording on: the backbone (and the
  // stability) package() returns are that evaluation's.
  const bool rec = opt.record_backbone;
  const bool frictionless = conditions == nullptr;
  // Following a path: a frictionless solve warm-started from this workspace's last frictionless solve. (Solves under
  // contact laws never use the workspace's history: a stick-slip step is a function of its state and command, so
  // that a planner's checked states are what a replay of its path computes.)
  detail::WarmHistory& H = W.history;
  detail::ChordCache& CC = W.chain_chord;
  Eigen::VectorXd& qv = W.key;  // the workspace's scratch vectors: no allocation per solve
  detail::historyKey(q, qv);
  const bool chained = frictionless && warm && detail::continuesChain(H, warm->q, qv, z);
  bool ok = false;
  const long jacobians_before = W.eval.jacobian_evaluations;
  if (opt.extrapolate_warm_start && chained && H.count >= 2) {
    Eigen::VectorXd& zp = W.z_predicted;
    zp = z;
    if (detail::continuationPredictor(H, qv, zp)) {
      int it_p = 0;
      if (chordUsable(CC, P, qv)) {
        Eigen::VectorXd& zc = W.z_chord;
        zc = zp;
        ok = chordSolve(P, W.eval, W.out, zc, opt, CC, 2, it_p, rn, rec);
        if (ok) z = zc;
      }
      if (!ok) {
        ok = newton(P, W.eval, W.out, zp, opt, it_p, rn, why, rec);
        if (ok) z = zp;
      }
      iters += it_p;
    }
  }
  if (!ok && opt.extrapolate_warm_start && chained && chordUsable(CC, P, qv)) {
    // A path-following solve without a usable prediction: quasi-Newton steps from the warm start.
    Eigen::VectorXd& zc = W.z_chord;
    zc = z;
    ok = chordSolve(P, W.eval, W.out, zc, opt, CC, 4, iters, rn, rec);
    if (ok) z = zc;
  }
  if (!ok) ok = newton(P, W.eval, W.out, z, opt, iters, rn, why, rec);
  bool plain = ok;  // converged on the first attempt at the actual problem (no fallback, no refinement)
  const bool cold = (warm == nullptr);
  int cont_steps = 0;
  if ((!ok || (cold && W.out.stability <= 0.0)) && opt.homotopy) {
    plain = false;
    const Eigen::VectorXd z_first = z;
    const bool ok_first = ok;
    auto finish = [&](Eigen::VectorXd& zc) {
      P.setup(robot, q, conditions, opt);
      return newton(P, W.eval, W.out, zc, opt, iters, rn, why, rec) && W.out.stability > 0.0;
    };
    // Fallback 1: continuation in the precurvatures from the interaction-free robot (unique, stable solution).
    Eigen::VectorXd zh = Eigen::VectorXd::Zero(P.m);
    std::string hwhy;
    bool found = continuation([&](double lam) { P.setup(robot, q, conditions, opt, lam); }, P, W.eval, W.out, zh, opt,
                              iters, cont_steps, hwhy) &&
                 finish(zh);
    // Fallback 2: continuation in rotation from the aligned configuration (relative angles zero: untwisted
    // solution exact), along the shortest relative rotations (the model is 2 pi periodic in them).
    if (!found) {
      Configuration qa = q;
      Eigen::VectorXd rel(q.size());
      for (int i = 0; i < q.size(); ++i) {
        rel[i] = std::remainder(q.alpha[i] - q.alpha[0], 2.0 * M_PI);
        qa.alpha[i] = q.alpha[0];
      }
      zh.setZero(P.m);
      std::string rwhy;
      found = continuation(
                  [&](double t) {
                    Configuration qt = qa;
                    qt.alpha = qa.alpha + t * rel;
                    P.setup(robot, qt, conditions, opt);
                  },
                  P, W.eval, W.out, zh, opt, iters, cont_steps, rwhy) &&
              finish(zh);
      if (!found) hwhy += "; rotation continuation from the aligned configuration: " + rwhy;
    }
    if (found) {
      z = zh;
      ok = true;
    } else {
      z = z_first;
      ok = ok_first;
      P.setup(robot, q, conditions, opt);
      if (!ok) why += "; homotopy from zero precurvature: " + hwhy;
      W.eval.evaluate(P, z, true, rec, W.out);  // outputs of the returned point
      rn = maxAbs(W.eval.r);
    }
  }
  if (ok && opt.refine_below_stability > 0.0 && std::abs(W.out.stability) < opt.refine_below_stability) {
    plain = false;
    // Ill-conditioned twist near a fold: refine the discretisation (warm start, same branch).
    Eigen::VectorXd zr = z;
    int it2 = 0;
    double rn2 = 0;
    std::string w2;
    P.setup(robot, q, conditions, opt, 1.0, 0.25);
    if (newton(P, W.eval, W.out, zr, opt, it2, rn2, w2, rec)) {
      z = zr;
      rn = rn2;
    } else {
      P.setup(robot, q, conditions, opt);
      W.eval.evaluate(P, z, true, rec, W.out);
    }
    iters += it2;
  }
  W.eval.finish(P, W.out);
  Solution sol = package(robot, q, P, W.out, z, ok, iters, rn, why, opt);
  sol.summary.continuation_steps = cont_steps;
  if (frictionless && ok)
    detail::recordInChain(H, chained, qv, z);
  else if (frictionless)
    H.count = 0;
  if (frictionless && plain && W.eval.jacobian_evaluations > jacobians_before && W.eval.J.rows() == P.m) {
    // An exact Jacobian of this solve (at its last Newton iterate): the chord matrix of the next nearby solves.
    storeChord(CC, P, W.eval, W.out.stability, qv);
  }
  return sol;
}

}  // namespace

Solution detail::solveTorsionOnly(const Robot& robot, const Configuration& q,
                                  const std::vector<ContactCondition>* conditions, Workspace& ws,
                                  const KinematicsOptions& opt, const Solution* warm) {
  return solveImpl(robot, q, conditions, ws, opt, warm);
}

Solution solve(const Robot& robot, const Configuration& q, Workspace& ws, const KinematicsOptions& options,
               const Solution* warm) {
  if (detail::useLoadedModel(robot, options)) return detail::solveLoaded(robot, q, nullptr, ws, options, warm);
  return solveImpl(robot, q, nullptr, ws, options, warm);
}

Solution solveWithContacts(const Robot& robot, const Configuration& q,
                           const std::vector<ContactCondition>& conditions, Workspace& ws,
                           const KinematicsOptions& options, const Solution* warm) {
  const std::size_t k = contactSites(robot, q).size();
  if (conditions.size() != k && checkAdmissible(robot, q))
    throw std::invalid_argument("solveWithContacts: " + std::to_string(conditions.size()) + " conditions for " +
                                std::to_string(k) + " contact sites");
  if (detail::useLoadedModel(robot, options))
    return detail::solveLoaded(robot, q, &conditions, ws, options, warm);
  return solveImpl(robot, q, &conditions, ws, options, warm);
}

Solution continueTo(const Robot& robot, const Solution& from, const Configuration& q, Workspace& ws,
                    const KinematicsOptions& options) {
  const Admissibility adm = checkAdmissible(robot, q);
  if (!adm) return inadmissible(q, adm.message, robot.size());
  if (!from.converged() || from.q.size() != q.size()) {
    Solution s = solve(robot, q, ws, options, nullptr);
    return s;
  }
  const int steps = subdivisions(from.q, q, options.max_rotation_step, options.max_translation_step);
  KinematicsOptions inner = options;
  inner.record_backbone = false;
  Solution cur = from;
  bool snapped = false;
  int iters = 0;
  for (int k = 1; k <= steps; ++k) {
    const Configuration qk = interpolate(from.q, q, static_cast<double>(k) / steps);
    if (k == steps) inner.record_backbone = options.record_backbone;
    Solution next = solve(robot, qk, ws, inner, &cur);
    iters += next.summary.iterations;
    if (!next.converged() || (cur.summary.stable && !next.summary.stable)) {
      // The branch we followed ended (fold) or was lost: find a stable equilibrium from scratch.
      Solution cold = solve(robot, qk, ws, inner, nullptr);
      iters += cold.summary.iterations;
      if (cold.converged()) {
        snapped = snapped || cur.summary.stable;
        next = cold;
      } else if (!next.converged()) {
        next.summary.message = "continuation lost the equilibrium: " + next.summary.message;
        next.summary.iterations = iters;
        next.summary.continuation_steps = k;
        return next;
      }
    } else if (next.twist.size() && cur.twist.size() == next.twist.size() &&
               (next.twist - cur.twist).cwiseAbs().maxCoeff() > options.snap_threshold) {
      snapped = true;
    }
    cur = std::move(next);
  }
  cur.summary.snapped = snapped;
  cur.summary.iterations = iters;
  cur.summary.continuation_steps = steps;
  return cur;
}

}  // namespace ctr
