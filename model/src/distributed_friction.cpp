// Distributed-contact Coulomb friction (Lock & Dupont 2011 §II.B-C). Not a hot path: the shooting problem is solved
// by the Newton core (newton.hpp) with a Jacobian by finite differences; the implicit equation for u_z' is solved by
// fixed-point iteration (a contraction: the friction torque depends on u_z' only through the small term r K u'').
#include "ctr/model/distributed_friction.hpp"

#include <Eigen/Geometry>
#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>

#include "access.hpp"
#include "contact_events.hpp"
#include "newton.hpp"
#include "se3_step.hpp"
#include "workspace_impl.hpp"

namespace ctr {
namespace {

using detail::Problem;
using detail::Segment;

struct Model {
  const Problem* P = nullptr;
  double mu = 0, fric = 0;  // mu, mu / sqrt(1 + mu^2)
  Eigen::VectorXd radius;   // contact radius of interface j
  std::vector<int> dir;     // sign of (theta_{j+1} - theta_j)' per interface
  int max_iter = 60;
  double tol = 1e-12;
  int worst_iter = 0;
  bool root_failed = false;
};

inline Eigen::Vector2d rotT(double c, double s, const Eigen::Vector2d& a) {  // R_z(theta)^T a
  return Eigen::Vector2d(c * a.x() + s * a.y(), -s * a.x() + c * a.y());
}
inline Eigen::Vector2d Jm(const Eigen::Vector2d& a) {
  return Eigen::Vector2d(a.y(), -a.x());
}  // J = [[0,1],[-1,0]]

struct StageOut {
  Eigen::VectorXd uzp, nzp;  // u_z', n_z'
  Eigen::Vector2d u0;
  std::vector<double> iface_force, iface_torque;  // per interface j
};

// Distributed forces on every present tube (common frame F0) and their interface decomposition, for given u_z'.
void forces(const Model& M, const Segment& sg, const Eigen::VectorXd& th, const Eigen::VectorXd& uz,
            const Eigen::VectorXd& nz, const Eigen::VectorXd& uzp, Eigen::VectorXd& tau, Eigen::VectorXd& nzp,
            std::vector<double>* iface_force, std::vector<double>* iface_torque, Eigen::Vector2d& u0_out) {
  const Problem& P = *M.P;
  const int n = P.n;
  Eigen::VectorXd c(n), s(n);
  for (int j = 0; j < n; ++j) {
    c[j] = std::cos(th[j]);
    s[j] = std::sin(th[j]);
  }
  Eigen::Vector2d u0 = Eigen::Vector2d::Zero(), u0p = Eigen::Vector2d::Zero(), u0pp = Eigen::Vector2d::Zero();
  for (int j = 0; j < n; ++j) {
    if (sg.w[j] == 0.0) continue;
    const Eigen::Vector2d e(c[j], s[j]), d(-s[j], c[j]);
    u0 += sg.w[j] * d;
    u0p += sg.w[j] * uz[j] * (-e);
    u0pp += sg.w[j] * (-uzp[j] * e - uz[j] * uz[j] * d);
  }
  u0 /= sg.K;
  u0p /= sg.K;
  u0pp /= sg.K;
  u0_out = u0;
  std::vector<Eigen::Vector2d> F(static_cast<std::size_t>(n), Eigen::Vector2d::Zero());
  nzp.setZero(n);
  for (int i = 0; i < n; ++i) {
    if (!sg.present[static_cast<std::size_t>(i)]) continue;
    const double kb = P.kb[i], kt = P.kt[i];
    const double kap = sg.w[i] != 0.0 ? P.kappa[i] : 0.0;
    const Eigen::Vector2d a0 = rotT(c[i], s[i], u0), a1 = rotT(c[i], s[i], u0p), a2 = rotT(c[i], s[i], u0pp);
    const Eigen::Vector2d uxy = a0;
    const Eigen::Vector2d upxy = uz[i] * Jm(a0) + a1;
    const Eigen::Vector2d uppxy = uzp[i] * Jm(a0) - uz[i] * uz[i] * a0 + 2.0 * uz[i] * Jm(a1) + a2;
    const Eigen::Vector3d u(uxy.x(), uxy.y(), uz[i]), up(upxy.x(), upxy.y(), uzp[i]);
    const Eigen::Vector3d m(kb * uxy.x(), kb * (uxy.y() - kap), kt * uz[i]);
    const Eigen::Vector3d mp(kb * upxy.x(), kb * upxy.y(), kt * uzp[i]);
    const Eigen::Vector2d mpp(kb * uppxy.x(), kb * uppxy.y());
    // eq. 23: e_z x n = a := -m' - u x m (no distributed moment in x, y).
    const Eigen::Vector3d a = -mp - u.cross(m);
    const double nx = a.y(), ny = -a.x();
    // eq. 26: derivative.
    const Eigen::Vector3d ucm_p = up.cross(m) + u.cross(mp);
    const Eigen::Vector2d ap(-mpp.x() - ucm_p.x(), -mpp.y() - ucm_p.y());
    const double npx = ap.y(), npy = -ap.x();
    // eq. 22/27: f = n' + u x n.
    const double fx = npx + (u.y() * nz[i] - u.z() * ny);
    const double fy = npy + (u.z() * nx - u.x() * nz[i]);
    F[static_cast<std::size_t>(i)] = Eigen::Vector2d(c[i] * fx - s[i] * fy, s[i] * fx + c[i] * fy);  // to F0
    nzp[i] = u.x() * ny - u.y() * nx;                                                                // eq. 24
  }
  // Interface forces from the innermost present tube outwards: F_i = G_{i-1} - G_i.
  tau.setZero(n);
  if (iface_force) iface_force->assign(static_cast<std::size_t>(std::max(0, n - 1)), 0.0);
  if (iface_torque) iface_torque->assign(static_cast<std::size_t>(std::max(0, n - 1)), 0.0);
  Eigen::Vector2d G = Eigen::Vector2d::Zero();
  for (int i = n - 1; i > sg.outermost; --i) {
    G = F[static_cast<std::size_t>(i)] + G;  // force on tube i from tube i-1
    const int j = i - 1;
    const double T = M.fric * M.radius[j] * G.norm();
    const double sg_dir = M.dir[static_cast<std::size_t>(j)];
    tau[i] += -sg_dir * T;  // applied torque on the inner tube, against its relative rotation
    tau[j] += sg_dir * T;   // and the reaction on the outer tube
    if (iface_force) (*iface_force)[static_cast<std::size_t>(j)] = G.norm();
    if (iface_torque) (*iface_torque)[static_cast<std::size_t>(j)] = T;
  }
}

// u_z' solving u_z' = frictionless(theta) + tau(u_z')/k_t by fixed-point iteration.
bool stage(Model& M, const Segment& sg, const Eigen::VectorXd& th, const Eigen::VectorXd& uz, const Eigen::VectorXd& nz,
           StageOut& out, bool want_iface) {
  const Problem& P = *M.P;
  const int n = P.n;
  Eigen::VectorXd base(n);
  // Frictionless part: (kb/kt) kappa u_ix.
  double A = 0, B = 0;
  for (int j = 0; j < n; ++j)
    if (sg.w[j] != 0.0) {
      A += sg.w[j] * std::cos(th[j]);
      B += sg.w[j] * std::sin(th[j]);
    }
  for (int i = 0; i < n; ++i) base[i] = sg.a[i] != 0.0 ? sg.a[i] * (std::sin(th[i]) * A - std::cos(th[i]) * B) : 0.0;
  Eigen::VectorXd uzp = base, tau(n), nzp(n);
  Eigen::Vector2d u0;
  bool ok = false;
  int it = 0;
  for (; it < M.max_iter; ++it) {
    forces(M, sg, th, uz, nz, uzp, tau, nzp, nullptr, nullptr, u0);
    // tau is the applied distributed torque; the internal torque obeys m_z' = -tau + (elastic coupling).
    Eigen::VectorXd next = base;
    for (int i = 0; i < n; ++i)
      if (sg.present[static_cast<std::size_t>(i)]) next[i] -= tau[i] / P.kt[i];
    const double change = (next - uzp).cwiseAbs().maxCoeff();
    uzp = next;
    if (change <= M.tol * (1.0 + uzp.cwiseAbs().maxCoeff())) {
      ok = true;
      break;
    }
  }
  M.worst_iter = std::max(M.worst_iter, it + 1);
  if (!ok) M.root_failed = true;
  out.uzp = uzp;
  if (want_iface) {
    forces(M, sg, th, uz, nz, uzp, tau, nzp, &out.iface_force, &out.iface_torque, u0);
  } else {
    forces(M, sg, th, uz, nz, uzp, tau, nzp, nullptr, nullptr, u0);
  }
  out.nzp = nzp;
  out.u0 = u0;
  return ok;
}

struct Pass {
  Eigen::VectorXd r;  // residuals: u_iz(end_i), n_iz(end_i)
  Eigen::VectorXd twist;
  Eigen::Vector3d p = Eigen::Vector3d::Zero();
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  std::vector<BackbonePoint> backbone;
  std::vector<DistributedForceSample> samples;
  std::vector<double> integrated;
  std::vector<double> contact_twist, contact_moment;  // per active contact (lumped friction)
};

// One integration from s = 0 to the tip for z = (u_z(0), n_z(0)).
void integrate(Model& M, const Eigen::VectorXd& z, bool record, Pass& out) {
  const Problem& P = *M.P;
  const int n = P.n;
  Eigen::VectorXd th(n), uz(n), nz(n);
  for (int i = 0; i < n; ++i) {
    th[i] = P.alpha[i] - P.beta[i] * z[i];
    uz[i] = z[i];
    nz[i] = z[n + i];
  }
  const int nc = static_cast<int>(P.contacts.size());
  out.r.setZero(2 * n + nc);
  out.contact_twist.assign(static_cast<std::size_t>(nc), 0.0);
  out.contact_moment.assign(static_cast<std::size_t>(nc), 0.0);
  out.twist.setZero(std::max(0, n - 1));
  out.p.setZero();
  out.R.setIdentity();
  out.backbone.clear();
  out.samples.clear();
  out.integrated.assign(static_cast<std::size_t>(std::max(0, n - 1)), 0.0);
  for (int i = 0; i < n; ++i)
    if (P.end[i] <= 1e-12) {
      out.r[i] = z[i];
      out.r[n + i] = z[n + i];
    }
  StageOut k1, k2, k3, k4;
  auto recordNode = [&](double s, const Segment& sg, const StageOut& so) {
    BackbonePoint bp;
    bp.s = s;
    bp.position = out.p;
    bp.frame = out.R;
    bp.theta = th;
    bp.uz = uz;
    bp.u0 = so.u0;
    bp.outermost = sg.outermost;
    out.backbone.push_back(bp);
    for (std::size_t j = 0; j < so.iface_force.size(); ++j) {
      if (static_cast<int>(j) < sg.outermost || !sg.present[j + 1]) continue;
      out.samples.push_back({s, static_cast<int>(j), so.iface_force[j], so.iface_force[j] / std::sqrt(1 + M.mu * M.mu),
                             so.iface_torque[j]});
    }
  };
  for (std::size_t si = 0; si < P.segments.size(); ++si) {
    const Segment& sg = P.segments[si];
    const double h = sg.h;
    for (int st = 0; st < sg.steps; ++st) {
      stage(M, sg, th, uz, nz, k1, true);
      if (record) recordNode(sg.s0 + st * h, sg, k1);
      auto dth = [&](const Eigen::VectorXd& u) {
        Eigen::VectorXd d = u;
        for (int i = 0; i < n; ++i)
          if (!sg.present[static_cast<std::size_t>(i)]) d[i] = 0;
        return d;
      };
      auto mask = [&](const Eigen::VectorXd& v) {
        Eigen::VectorXd d = v;
        for (int i = 0; i < n; ++i)
          if (!sg.present[static_cast<std::size_t>(i)]) d[i] = 0;
        return d;
      };
      const Eigen::VectorXd d1t = dth(uz), d1u = mask(k1.uzp), d1n = mask(k1.nzp);
      stage(M, sg, th + 0.5 * h * d1t, uz + 0.5 * h * d1u, nz + 0.5 * h * d1n, k2, true);
      const Eigen::VectorXd d2t = dth(uz + 0.5 * h * d1u), d2u = mask(k2.uzp), d2n = mask(k2.nzp);
      stage(M, sg, th + 0.5 * h * d2t, uz + 0.5 * h * d2u, nz + 0.5 * h * d2n, k3, true);
      const Eigen::VectorXd d3t = dth(uz + 0.5 * h * d2u), d3u = mask(k3.uzp), d3n = mask(k3.nzp);
      stage(M, sg, th + h * d3t, uz + h * d3u, nz + h * d3n, k4, true);
      const Eigen::VectorXd d4t = dth(uz + h * d3u), d4u = mask(k4.uzp), d4n = mask(k4.nzp);
      for (std::size_t j = 0; j < out.integrated.size(); ++j)
        out.integrated[j] +=
            h / 6 * (k1.iface_torque[j] + 2 * k2.iface_torque[j] + 2 * k3.iface_torque[j] + k4.iface_torque[j]);
      th += h / 6 * (d1t + 2 * d2t + 2 * d3t + d4t);
      uz += h / 6 * (d1u + 2 * d2u + 2 * d3u + d4u);
      nz += h / 6 * (d1n + 2 * d2n + 2 * d3n + d4n);
      detail::se3Step(out.R, out.p, h / 12 * (3 * k1.u0 + 2 * k2.u0 + 2 * k3.u0 - k4.u0), 0.5 * h);
      detail::se3Step(out.R, out.p, h / 12 * (-k1.u0 + 2 * k2.u0 + 2 * k3.u0 + 3 * k4.u0), 0.5 * h);
    }
    const detail::Breakpoint& bp = P.breakpoints[si];
    if (bp.twist_point)
      for (int k = 1; k < n; ++k) out.twist[k - 1] = th[k] - th[0];
    for (int i : bp.ending) {
      out.r[i] = uz[i];
      out.r[n + i] = nz[i];
    }
    // Lumped friction at concentrated moments (§II.D), as in the other integrators: unknown scaled torque tau_c, its
    // law's residual row, and its point torque.
    for (int c : bp.contacts) {
      const detail::ActiveContact& ac = P.contacts[static_cast<std::size_t>(c)];
      const double relative_twist = th[ac.site.inner] - th[ac.site.outer];
      const double mom = detail::siteMoment<double>(P, si, th.data(), ac.site, 0.0, 0.0);
      out.contact_twist[static_cast<std::size_t>(c)] = relative_twist;
      out.contact_moment[static_cast<std::size_t>(c)] = mom;
      out.r[2 * n + c] = detail::contactLawResidual(P, ac, z[2 * n + c], relative_twist, mom);
    }
    for (int c : bp.contacts)
      detail::applyContactJump(detail::contactJump(P, bp, P.contacts[static_cast<std::size_t>(c)]), z[2 * n + c],
                               out.r.data(), uz.data());
    if (record && si + 1 == P.segments.size()) {
      StageOut last;
      stage(M, sg, th, uz, nz, last, true);
      recordNode(bp.s, sg, last);
    }
  }
}

// The distributed-friction map as a system of the Newton core, its Jacobian by forward differences (the implicit
// equation for u_z' at every stage keeps it from the exact derivatives of the other maps).
class DistributedSystem final : public detail::NewtonSystem {
 public:
  explicit DistributedSystem(Model& M) : M_(M) {}
  void evaluate(const Eigen::VectorXd& z, bool jacobian) override {
    integrate(M_, z, false, pass_);
    if (!jacobian) return;
    const Eigen::Index m = z.size();
    J_.resize(m, m);
    for (Eigen::Index c = 0; c < m; ++c) {
      const double hstep = 1e-7 * (1.0 + std::abs(z[c]));
      probe_z_ = z;
      probe_z_[c] += hstep;
      integrate(M_, probe_z_, false, probe_);
      J_.col(c) = (probe_.r - pass_.r) / hstep;
    }
  }
  const Eigen::VectorXd& residual() const override { return pass_.r; }
  Eigen::MatrixXd& jacobian() override { return J_; }
  // The reported stability is the branch's without distributed friction: no Jacobian is needed at the solution.
  double stability() const override { return std::numeric_limits<double>::infinity(); }

 private:
  Model& M_;
  Pass pass_, probe_;
  Eigen::VectorXd probe_z_;
  Eigen::MatrixXd J_;
};

}  // namespace

DistributedFrictionSolution solveDistributedFriction(const Robot& robot, const Configuration& q,
                                                     const DistributedFrictionOptions& opt, const Solution* warm) {
  const int n = robot.size();
  if (static_cast<int>(opt.direction.size()) != std::max(0, n - 1))
    throw std::invalid_argument("solveDistributedFriction: direction needs " + std::to_string(std::max(0, n - 1)) +
                                " entries (one per interface)");
  if (!(opt.mu >= 0.0) || !std::isfinite(opt.mu))
    throw std::invalid_argument("solveDistributedFriction: mu must be finite and >= 0");
  DistributedFrictionSolution res;
  res.solution.q = q;
  const Admissibility adm = checkAdmissible(robot, q);
  if (!adm) {
    res.solution.summary.status = SolveStatus::Inadmissible;
    res.solution.summary.message = adm.message;
    return res;
  }
  if (!robot.loads().empty()) {
    // Not modelled: the distributed-contact forces of this solver come from the load-free rod equations.
    res.solution.summary.status = SolveStatus::NotConverged;
    res.solution.summary.message =
        "distributed friction with external loads (gravity, tip wrench) is not implemented; use boundary friction";
    res.solution.base_twist_rate = Eigen::VectorXd::Zero(n);
    res.solution.theta0 = Eigen::VectorXd::Zero(n);
    res.solution.twist = Eigen::VectorXd::Zero(std::max(0, n - 1));
    return res;
  }
  Problem P;
  if (!opt.contacts.empty() && opt.contacts.size() != contactSites(robot, q).size())
    throw std::invalid_argument("solveDistributedFriction: contacts needs one condition per contact site (" +
                                std::to_string(contactSites(robot, q).size()) + ")");
  const std::vector<ContactCondition>* conditions = opt.contacts.empty() ? nullptr : &opt.contacts;
  P.setup(robot, q, conditions, opt.kinematics);
  const int nc = static_cast<int>(P.contacts.size());
  Model M;
  M.P = &P;
  M.mu = opt.mu;
  M.fric = opt.mu / std::sqrt(1.0 + opt.mu * opt.mu);
  M.max_iter = opt.max_root_iterations;
  M.tol = opt.root_tolerance;
  M.radius.resize(std::max(0, n - 1));
  for (int j = 0; j + 1 < n; ++j) {
    double r = 0.5 * robot.tube(j + 1).outer_diameter;
    if (r <= 0) r = 0.5 * robot.tube(j).inner_diameter;
    if (r <= 0) {
      r = opt.default_contact_radius;
      res.used_default_radius = true;
    }
    M.radius[j] = r;
  }
  M.dir = opt.direction;

  // Initial guess: the solution without distributed friction (with the same contact laws), n_z(0) = 0.
  Workspace ws;
  KinematicsOptions ko = opt.kinematics;
  ko.record_backbone = false;
  const Solution base =
      conditions ? solveWithContacts(robot, q, *conditions, ws, ko, warm) : solve(robot, q, ws, ko, warm);
  Eigen::VectorXd z = Eigen::VectorXd::Zero(2 * n + nc);
  if (base.converged()) {
    z.head(n) = base.base_twist_rate;
    const Eigen::VectorXd& torques = detail::SolutionAccess::contactUnknowns(base);
    if (torques.size() == nc) z.tail(nc) = torques;
  }
  DistributedSystem S(M);
  detail::NewtonSettings settings =
      detail::newtonSettings(opt.kinematics, P.s_tip, n, detail::JacobianReuse::Chord);  // cap on u_z(0)
  detail::NewtonScratch scratch;
  detail::NewtonJacobian jac;
  int iters = 0;
  double nr = 0.0;
  std::string why;
  detail::newton(S, z, settings, scratch, jac, iters, nr, why);
  const double tol = opt.kinematics.tolerance;
  const bool ok = nr < std::max(tol, 1e-9) && !M.root_failed;
  Pass pass;
  integrate(M, z, opt.kinematics.record_backbone, pass);
  Solution& s = res.solution;
  s.summary.status = ok ? SolveStatus::Converged : SolveStatus::NotConverged;
  s.summary.iterations = iters;
  s.summary.residual_norm = nr;
  s.summary.stability = base.summary.stability;  // of the branch without distributed friction (a small perturbation)
  s.summary.stable = ok && base.summary.stable;
  if (!ok) {
    std::ostringstream os;
    os << "distributed-friction shooting did not converge";
    if (!why.empty()) os << ": " << why;
    if (M.root_failed) os << "; the implicit equation for u_z' did not converge at some stage";
    s.summary.message = os.str();
  } else if (res.used_default_radius) {
    s.summary.message = "tube diameters missing: default contact radius used";
  }
  s.base_twist_rate = z.head(n);
  s.theta0.resize(n);
  for (int i = 0; i < n; ++i) s.theta0[i] = P.alpha[i] - P.beta[i] * z[i];
  s.twist = pass.twist;
  s.tip_position = pass.p;
  s.tip_frame = pass.R;
  s.moments = base.moments;
  detail::SolutionAccess::contactUnknowns(s) = z.tail(nc);
  s.contacts = detail::contactResults(P, pass.contact_twist, pass.contact_moment, z, 2 * n);
  s.backbone = std::move(pass.backbone);
  res.samples = std::move(pass.samples);
  for (double v : pass.integrated) res.integrated_friction_torque = std::max(res.integrated_friction_torque, v);
  res.max_root_iterations = M.worst_iter;
  return res;
}

}  // namespace ctr
