// Distributed-contact Coulomb friction (Lock & Dupont 2011 §II.B-C). The shooting problem is solved by the Newton core
// (newton.hpp) with its exact Jacobian (the integrator templated on its scalar, run on dual numbers); the implicit
// equation for u_z' is solved by fixed-point iteration (a contraction: the friction torque depends on u_z' only
// through the small term r K u'').
#include "ctr/model/distributed_friction.hpp"

#include <Eigen/Geometry>
#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <type_traits>
#include <vector>

#include "access.hpp"
#include "contact_events.hpp"
#include "distributed_map.hpp"
#include "dual.hpp"
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

using detail::value;

/// A 2-vector of scalars T (double, or dual numbers for the exact Jacobian).
template <class T>
struct V2 {
  T x, y;
};
template <class T>
inline V2<T> rotT(const T& c, const T& s, const V2<T>& a) {  // R_z(theta)^T a
  return {c * a.x + s * a.y, c * a.y - s * a.x};
}
template <class T>
inline V2<T> Jm(const V2<T>& a) {  // J = [[0,1],[-1,0]]
  return {a.y, -a.x};
}
template <class T>
inline void cross(const T& ax, const T& ay, const T& az, const T& bx, const T& by, const T& bz, T& cx, T& cy, T& cz) {
  cx = ay * bz - az * by;
  cy = az * bx - ax * bz;
  cz = ax * by - ay * bx;
}

/// What one stage of the integrator needs (the interface decomposition only for the recorded double pass).
template <class T>
struct StageOut {
  std::vector<T> uzp, nzp;  // u_z', n_z'
  V2<T> u0{T(0.0), T(0.0)};
  std::vector<double> iface_force, iface_torque;  // per interface j
};

// Distributed forces on every present tube (common frame F0) and their interface decomposition, for given u_z', at
// angles theta given by their cosines c and sines s.
template <class T>
void forces(const Model& M, const Segment& sg, const std::vector<T>& c, const std::vector<T>& s,
            const std::vector<T>& uz, const std::vector<T>& nz, const std::vector<T>& uzp, std::vector<T>& tau,
            std::vector<T>& nzp, std::vector<double>* iface_force, std::vector<double>* iface_torque, V2<T>& u0_out) {
  const Problem& P = *M.P;
  const int n = P.n;
  V2<T> u0{T(0.0), T(0.0)}, u0p{T(0.0), T(0.0)}, u0pp{T(0.0), T(0.0)};
  for (int j = 0; j < n; ++j) {
    if (sg.w[j] == 0.0) continue;
    const double w = sg.w[j];
    u0.x += w * (-s[j]);
    u0.y += w * c[j];
    u0p.x += (w * uz[j]) * (-c[j]);
    u0p.y += (w * uz[j]) * (-s[j]);
    u0pp.x += w * (-uzp[j] * c[j] - uz[j] * uz[j] * (-s[j]));
    u0pp.y += w * (-uzp[j] * s[j] - uz[j] * uz[j] * c[j]);
  }
  const double K = sg.K;
  u0 = {u0.x / K, u0.y / K};
  u0p = {u0p.x / K, u0p.y / K};
  u0pp = {u0pp.x / K, u0pp.y / K};
  u0_out = u0;
  std::vector<V2<T>> F(static_cast<std::size_t>(n), V2<T>{T(0.0), T(0.0)});
  for (int i = 0; i < n; ++i) nzp[i] = T(0.0);
  for (int i = 0; i < n; ++i) {
    if (!sg.present[static_cast<std::size_t>(i)]) continue;
    const double kb = P.kb[i], kt = P.kt[i];
    const double kap = sg.w[i] != 0.0 ? P.kappa[i] : 0.0;
    const V2<T> a0 = rotT(c[i], s[i], u0), a1 = rotT(c[i], s[i], u0p), a2 = rotT(c[i], s[i], u0pp);
    const V2<T> j0 = Jm(a0), j1 = Jm(a1);
    const T ux = a0.x, uy = a0.y, uzi = uz[i];
    const T upx = uzi * j0.x + a1.x, upy = uzi * j0.y + a1.y, upz = uzp[i];
    const T uppx = uzp[i] * j0.x - uzi * uzi * a0.x + 2.0 * uzi * j1.x + a2.x;
    const T uppy = uzp[i] * j0.y - uzi * uzi * a0.y + 2.0 * uzi * j1.y + a2.y;
    const T mx = kb * ux, my = kb * (uy - kap), mz = kt * uzi;
    const T mpx = kb * upx, mpy = kb * upy, mpz = kt * upz;
    const T mppx = kb * uppx, mppy = kb * uppy;
    // eq. 23: e_z x n = a := -m' - u x m (no distributed moment in x, y).
    T cx, cy, cz;
    cross(ux, uy, uzi, mx, my, mz, cx, cy, cz);
    const T ax = -mpx - cx, ay = -mpy - cy;
    const T nx = ay, ny = -ax;
    // eq. 26: derivative.
    T dx, dy, dz, ex, ey, ez;
    cross(upx, upy, upz, mx, my, mz, dx, dy, dz);
    cross(ux, uy, uzi, mpx, mpy, mpz, ex, ey, ez);
    const T apx = -mppx - (dx + ex), apy = -mppy - (dy + ey);
    const T npx = apy, npy = -apx;
    // eq. 22/27: f = n' + u x n.
    const T fx = npx + (uy * nz[i] - uzi * ny);
    const T fy = npy + (uzi * nx - ux * nz[i]);
    F[static_cast<std::size_t>(i)] = {c[i] * fx - s[i] * fy, s[i] * fx + c[i] * fy};  // to F0
    nzp[i] = ux * ny - uy * nx;                                                       // eq. 24
  }
  // Interface forces from the innermost present tube outwards: F_i = G_{i-1} - G_i.
  for (int i = 0; i < n; ++i) tau[i] = T(0.0);
  if (iface_force) iface_force->assign(static_cast<std::size_t>(std::max(0, n - 1)), 0.0);
  if (iface_torque) iface_torque->assign(static_cast<std::size_t>(std::max(0, n - 1)), 0.0);
  V2<T> G{T(0.0), T(0.0)};
  for (int i = n - 1; i > sg.outermost; --i) {
    G = {F[static_cast<std::size_t>(i)].x + G.x, F[static_cast<std::size_t>(i)].y + G.y};  // force on i from i-1
    const int j = i - 1;
    using std::sqrt;
    const T g = sqrt(G.x * G.x + G.y * G.y);
    const T Tq = (M.fric * M.radius[j]) * g;
    const double sg_dir = M.dir[static_cast<std::size_t>(j)];
    tau[i] += -sg_dir * Tq;  // applied torque on the inner tube, against its relative rotation
    tau[j] += sg_dir * Tq;   // and the reaction on the outer tube
    if (iface_force) (*iface_force)[static_cast<std::size_t>(j)] = value(g);
    if (iface_torque) (*iface_torque)[static_cast<std::size_t>(j)] = value(Tq);
  }
}

// u_z' solving u_z' = frictionless(theta) + tau(u_z')/k_t by fixed-point iteration. With dual numbers the derivatives
// iterate along with the values (the same contraction), so they converge to the derivatives of the fixed point.
template <class T>
bool stage(Model& M, const Segment& sg, const std::vector<T>& th, const std::vector<T>& uz, const std::vector<T>& nz,
           StageOut<T>& out, bool want_iface) {
  const Problem& P = *M.P;
  const int n = P.n;
  const std::size_t un = static_cast<std::size_t>(n);
  std::vector<T> base(un, T(0.0)), sn(un), cs(un);
  for (int j = 0; j < n; ++j) detail::sinCos(th[j], sn[j], cs[j]);
  // Frictionless part: (kb/kt) kappa u_ix.
  T A(0.0), B(0.0);
  for (int j = 0; j < n; ++j)
    if (sg.w[j] != 0.0) {
      A += sg.w[j] * cs[j];
      B += sg.w[j] * sn[j];
    }
  for (int i = 0; i < n; ++i)
    if (sg.a[i] != 0.0) base[i] = sg.a[i] * (sn[i] * A - cs[i] * B);
  std::vector<T>& uzp = out.uzp;
  uzp = base;
  std::vector<T> tau(un), next(un);
  out.nzp.resize(un);
  bool ok = false;
  int it = 0;
  for (; it < M.max_iter; ++it) {
    forces(M, sg, cs, sn, uz, nz, uzp, tau, out.nzp, nullptr, nullptr, out.u0);
    // tau is the applied distributed torque; the internal torque obeys m_z' = -tau + (elastic coupling).
    double change = 0.0, size = 0.0;
    for (int i = 0; i < n; ++i) {
      next[i] = base[i];
      if (sg.present[static_cast<std::size_t>(i)]) next[i] -= tau[i] / P.kt[i];
      change = std::max(change, std::abs(value(next[i]) - value(uzp[i])));
      size = std::max(size, std::abs(value(next[i])));
    }
    uzp.swap(next);
    if (change <= M.tol * (1.0 + size)) {
      ok = true;
      break;
    }
  }
  M.worst_iter = std::max(M.worst_iter, it + 1);
  if (!ok) M.root_failed = true;
  forces(M, sg, cs, sn, uz, nz, uzp, tau, out.nzp, want_iface ? &out.iface_force : nullptr,
         want_iface ? &out.iface_torque : nullptr, out.u0);
  return ok;
}

struct Pass {
  Eigen::VectorXd r;  // residuals: u_iz(end_i), n_iz(end_i), contact laws
  Eigen::VectorXd twist;
  Eigen::Vector3d p = Eigen::Vector3d::Zero();
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  std::vector<BackbonePoint> backbone;
  std::vector<DistributedForceSample> samples;
  std::vector<double> integrated;
  std::vector<double> contact_twist, contact_moment;  // per active contact (lumped friction)
};

// One integration from s = 0 to the tip for z = (u_z(0), n_z(0), contact torques): the residuals r (size 2n + nc).
// With T = double (and `out`) also the shape, twists, contact results and, when `record`, the backbone and force
// samples; with dual numbers only the residuals and their derivatives.
template <class T>
void integrate(Model& M, const std::vector<T>& z, std::vector<T>& r, bool record, Pass* out) {
  constexpr bool plain = std::is_same_v<T, double>;
  const Problem& P = *M.P;
  const int n = P.n;
  const std::size_t un = static_cast<std::size_t>(n);
  std::vector<T> th(un), uz(un), nz(un);
  for (int i = 0; i < n; ++i) {
    th[i] = P.alpha[i] - P.beta[i] * z[i];
    uz[i] = z[i];
    nz[i] = z[n + i];
  }
  const int nc = static_cast<int>(P.contacts.size());
  r.assign(static_cast<std::size_t>(2 * n + nc), T(0.0));
  if (out) {
    out->contact_twist.assign(static_cast<std::size_t>(nc), 0.0);
    out->contact_moment.assign(static_cast<std::size_t>(nc), 0.0);
    out->twist.setZero(std::max(0, n - 1));
    out->p.setZero();
    out->R.setIdentity();
    out->backbone.clear();
    out->samples.clear();
    out->integrated.assign(static_cast<std::size_t>(std::max(0, n - 1)), 0.0);
  }
  for (int i = 0; i < n; ++i)
    if (P.end[i] <= 1e-12) {
      r[i] = z[i];
      r[n + i] = z[n + i];
    }
  StageOut<T> k1, k2, k3, k4;
  auto recordNode = [&](double s, const Segment& sg, const auto& so) {
    if constexpr (plain) {  // discarded for dual numbers (clang checks a generic lambda's body eagerly)
      BackbonePoint bp;
      bp.s = s;
      bp.position = out->p;
      bp.frame = out->R;
      bp.theta = Eigen::Map<const Eigen::VectorXd>(th.data(), n);
      bp.uz = Eigen::Map<const Eigen::VectorXd>(uz.data(), n);
      bp.u0 = Eigen::Vector2d(so.u0.x, so.u0.y);
      bp.outermost = sg.outermost;
      out->backbone.push_back(bp);
      for (std::size_t j = 0; j < so.iface_force.size(); ++j) {
        if (static_cast<int>(j) < sg.outermost || !sg.present[j + 1]) continue;
        out->samples.push_back({s, static_cast<int>(j), so.iface_force[j],
                                so.iface_force[j] / std::sqrt(1 + M.mu * M.mu), so.iface_torque[j]});
      }
    }
  };
  std::vector<T> t2(un), u2(un), n2(un), dt[4], du[4], dn[4];
  for (int k = 0; k < 4; ++k) {
    dt[k].resize(un);
    du[k].resize(un);
    dn[k].resize(un);
  }
  StageOut<T>* ks[4] = {&k1, &k2, &k3, &k4};
  for (std::size_t si = 0; si < P.segments.size(); ++si) {
    const Segment& sg = P.segments[si];
    const double h = sg.h;
    auto on = [&](int i) { return sg.present[static_cast<std::size_t>(i)] != 0; };
    for (int st = 0; st < sg.steps; ++st) {
      // Classical RK4 on (theta, u_z, n_z): theta' = u_z, u_z' and n_z' from the stage (absent tubes frozen).
      for (int k = 0; k < 4; ++k) {
        const double f = k == 0 ? 0.0 : (k == 3 ? h : 0.5 * h);
        for (int i = 0; i < n; ++i) {
          t2[i] = k == 0 ? th[i] : th[i] + f * dt[k - 1][i];
          u2[i] = k == 0 ? uz[i] : uz[i] + f * du[k - 1][i];
          n2[i] = k == 0 ? nz[i] : nz[i] + f * dn[k - 1][i];
        }
        stage(M, sg, t2, u2, n2, *ks[k], plain && out);
        if constexpr (plain)
          if (k == 0 && record) recordNode(sg.s0 + st * h, sg, k1);
        for (int i = 0; i < n; ++i) {
          dt[k][i] = on(i) ? u2[i] : T(0.0);
          du[k][i] = on(i) ? ks[k]->uzp[i] : T(0.0);
          dn[k][i] = on(i) ? ks[k]->nzp[i] : T(0.0);
        }
      }
      if constexpr (plain)
        if (out)
          for (std::size_t j = 0; j < out->integrated.size(); ++j)
            out->integrated[j] +=
                h / 6 * (k1.iface_torque[j] + 2 * k2.iface_torque[j] + 2 * k3.iface_torque[j] + k4.iface_torque[j]);
      for (int i = 0; i < n; ++i) {
        th[i] += h / 6 * (dt[0][i] + 2.0 * dt[1][i] + 2.0 * dt[2][i] + dt[3][i]);
        uz[i] += h / 6 * (du[0][i] + 2.0 * du[1][i] + 2.0 * du[2][i] + du[3][i]);
        nz[i] += h / 6 * (dn[0][i] + 2.0 * dn[1][i] + 2.0 * dn[2][i] + dn[3][i]);
      }
      if constexpr (plain)
        if (out) {
          const Eigen::Vector2d a1(k1.u0.x, k1.u0.y), a2(k2.u0.x, k2.u0.y), a3(k3.u0.x, k3.u0.y), a4(k4.u0.x, k4.u0.y);
          detail::se3Step(out->R, out->p, h / 12 * (3 * a1 + 2 * a2 + 2 * a3 - a4), 0.5 * h);
          detail::se3Step(out->R, out->p, h / 12 * (-a1 + 2 * a2 + 2 * a3 + 3 * a4), 0.5 * h);
        }
    }
    const detail::Breakpoint& bp = P.breakpoints[si];
    if constexpr (plain)
      if (out && bp.twist_point)
        for (int k = 1; k < n; ++k) out->twist[k - 1] = th[k] - th[0];
    for (int i : bp.ending) {
      r[i] = uz[i];
      r[n + i] = nz[i];
    }
    // Lumped friction at concentrated moments (§II.D), as in the other integrators: unknown scaled torque tau_c, its
    // law's residual row, and its point torque.
    for (int c : bp.contacts) {
      const detail::ActiveContact& ac = P.contacts[static_cast<std::size_t>(c)];
      const T relative_twist = th[ac.site.inner] - th[ac.site.outer];
      const T mom = detail::siteMoment<T>(P, si, th.data(), ac.site, T(0.0), T(0.0));
      if (out) {
        out->contact_twist[static_cast<std::size_t>(c)] = value(relative_twist);
        out->contact_moment[static_cast<std::size_t>(c)] = value(mom);
      }
      r[2 * n + c] = detail::contactLawResidual(P, ac, z[2 * n + c], relative_twist, mom);
    }
    for (int c : bp.contacts)
      detail::applyContactJump(detail::contactJump(P, bp, P.contacts[static_cast<std::size_t>(c)]), z[2 * n + c],
                               r.data(), uz.data());
    if constexpr (plain)
      if (record && si + 1 == P.segments.size()) {
        StageOut<double> last;
        stage(M, sg, th, uz, nz, last, true);
        recordNode(bp.s, sg, last);
      }
  }
}

// The distributed-friction map as a system of the Newton core. Its Jacobian is exact: the integrator runs on dual
// numbers carrying the derivatives w.r.t. up to kChunk unknowns per pass (the implicit equation for u_z' at every
// stage is differentiated by iterating the derivatives with the values).
class DistributedSystem final : public detail::NewtonSystem {
 public:
  explicit DistributedSystem(Model& M) : M_(M) {}
  void evaluate(const Eigen::VectorXd& z, bool jacobian) override {
    const Eigen::Index m = z.size();
    zd_.assign(z.data(), z.data() + m);
    integrate<double>(M_, zd_, rd_, false, nullptr);
    r_ = Eigen::Map<const Eigen::VectorXd>(rd_.data(), m);
    if (!jacobian) return;
    J_.resize(m, m);
    for (Eigen::Index first = 0; first < m; first += kChunk) derivativeChunk(z, static_cast<int>(first));
  }
  const Eigen::VectorXd& residual() const override { return r_; }
  Eigen::MatrixXd& jacobian() override { return J_; }
  // The reported stability is the branch's without distributed friction: no Jacobian is needed at the solution.
  double stability() const override { return std::numeric_limits<double>::infinity(); }

 private:
  static constexpr int kChunk = 4;
  using D = detail::Dual<kChunk>;
  // Columns first .. first + kChunk - 1 of the Jacobian.
  void derivativeChunk(const Eigen::VectorXd& z, int first) {
    const int m = static_cast<int>(z.size());
    std::vector<D> zz(static_cast<std::size_t>(m)), rr;
    for (int c = 0; c < m; ++c) {
      zz[c] = D(z[c]);
      if (c >= first && c < first + kChunk) zz[c].d[c - first] = 1.0;
    }
    integrate<D>(M_, zz, rr, false, nullptr);
    for (int k = 0; k < kChunk && first + k < m; ++k)
      for (int row = 0; row < m; ++row) J_(row, first + k) = rr[row].d[k];
  }
  Model& M_;
  std::vector<double> zd_, rd_;
  Eigen::VectorXd r_;
  Eigen::MatrixXd J_;
};

// The problem (discretisation, contact sites) and the friction model of (robot, q, opt); returns the contact laws
// (nullptr: none).
const std::vector<ContactCondition>* setupModel(const Robot& robot, const Configuration& q,
                                                const DistributedFrictionOptions& opt, Problem& P, Model& M,
                                                bool& used_default_radius) {
  const int n = robot.size();
  if (!opt.contacts.empty() && opt.contacts.size() != contactSites(robot, q).size())
    throw std::invalid_argument("solveDistributedFriction: contacts needs one condition per contact site (" +
                                std::to_string(contactSites(robot, q).size()) + ")");
  const std::vector<ContactCondition>* conditions = opt.contacts.empty() ? nullptr : &opt.contacts;
  P.setup(robot, q, conditions, opt.kinematics);
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
      used_default_radius = true;
    }
    M.radius[j] = r;
  }
  M.dir = opt.direction;
  return conditions;
}

}  // namespace

namespace detail {

void distributedFrictionMap(const Robot& robot, const Configuration& q, const DistributedFrictionOptions& opt,
                            const Eigen::VectorXd& z, Eigen::VectorXd& r, Eigen::MatrixXd* J) {
  Problem P;
  Model M;
  bool used_default = false;
  setupModel(robot, q, opt, P, M, used_default);
  if (z.size() != 2 * P.n + static_cast<Eigen::Index>(P.contacts.size()))
    throw std::invalid_argument("distributedFrictionMap: z needs 2n + contacts entries");
  DistributedSystem S(M);
  S.evaluate(z, J != nullptr);
  r = S.residual();
  if (J) *J = S.jacobian();
}

}  // namespace detail

DistributedFrictionSolution solveDistributedFriction(const Robot& robot, const Configuration& q, Workspace& ws,
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
  Model M;
  const std::vector<ContactCondition>* conditions = setupModel(robot, q, opt, P, M, res.used_default_radius);
  const int nc = static_cast<int>(P.contacts.size());

  // Initial guess: the solution without distributed friction (with the same contact laws), n_z(0) = 0.
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
  {
    std::vector<double> zv(z.data(), z.data() + z.size()), rv;
    integrate<double>(M, zv, rv, opt.kinematics.record_backbone, &pass);
    pass.r = Eigen::Map<const Eigen::VectorXd>(rv.data(), static_cast<Eigen::Index>(rv.size()));
  }
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
