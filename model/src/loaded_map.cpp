// Loaded equilibrium of concentric tubes (Rucker, Jones & Webster 2010 style Cosserat-rod model): internal force
// n(s) and moment m(s) of the whole cross-section in the base frame, dead loads (gravity over the tubes' linear
// densities, tip force and moment in the base frame), shooting on the base twist rates and the base moment.
//
// Equations as implemented (docs/model.md "External loads"), on each segment of constant tube set:
//   theta_i' = u_iz,   u_iz' = (k_ib / k_it) kappa_i u_ix        (curved present tubes; u_i,xy = R_z(theta_i)^T u0)
//   u0_xy    = K^-1 [ sum_j k_jb R_z(theta_j) (0, kappa_j) + (R^T m)_xy ]
//   R' = R [u0]x,  p' = R e3,  m' = -p' x n,  n(s) = F + g sum_i rho_i max(0, end_i - s)  (closed form: n' = -rho g)
// The Euclidean states (theta, u_z, m) are integrated by classical RK4 and the pose by the matching 4th-order
// commutator-free Lie-group method (CF4) whose stages are evaluated at the stage rotations; with m = 0 it reduces
// exactly to the load-free integrator of torsion_map.cpp (same stages, same pose update).
//
// Derivatives: the integrator is templated on its scalar. With Dual<N> it carries N directional derivatives through
// every stage and every segment boundary (the boundaries are functions of beta with a fixed number of steps per
// segment), so Jacobians are the exact derivatives of the discrete map (no finite differences).
#include "loaded_map.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <type_traits>

#include "contact_events.hpp"
#include "dual.hpp"
#include "loaded_frame.hpp"
#include "sincos_shift.hpp"

namespace ctr::detail {

void setLoadScale(LoadedProblem& L, const Robot& robot, double scale) {
  L.g = scale * robot.loads().gravity;
  L.F = scale * robot.loads().tip_force;
  L.M = scale * robot.loads().tip_moment;
}

void setupLoaded(LoadedProblem& L, const Robot& robot, const Configuration& q,
                 const std::vector<ContactCondition>* conditions, const KinematicsOptions& opt, double step_factor) {
  Problem& P = L.P;
  P.setup(robot, q, conditions, opt, 1.0, step_factor);
  const int n = P.n;
  L.rho.resize(n);
  L.length.resize(n);
  L.straight.resize(n);
  for (int i = 0; i < n; ++i) {
    const Tube& t = robot.tube(i);
    L.rho[i] = t.linear_density;
    L.length[i] = t.length();
    L.straight[i] = t.straight_length;
  }
  setLoadScale(L, robot, 1.0);
  L.m = n + 2 + static_cast<int>(P.contacts.size());
  L.K0 = P.kb.sum();
  const std::size_t count = P.segments.size();
  L.bp_tube.assign(count + 1, -1);
  L.bp_kind.assign(count + 1, 0);
  for (std::size_t b = 1; b <= count; ++b) {
    const double v = P.segments[b - 1].s1;
    int kind = 3, tube = -1;
    for (int i = 0; i < n && kind == 3; ++i)
      if (std::abs(P.end[i] - v) <= 2 * kSameS) kind = 1, tube = i;
    for (int i = 0; i < n && kind == 3; ++i)
      if (std::abs(P.disc[i] - v) <= 2 * kSameS) kind = 2, tube = i;
    L.bp_kind[b] = kind;
    L.bp_tube[b] = tube;
  }
  L.seg_rho.assign(count, 0.0);
  for (std::size_t si = 0; si < count; ++si)
    for (int i = 0; i < n; ++i)
      if (P.segments[si].present[static_cast<std::size_t>(i)]) L.seg_rho[si] += L.rho[i];
}

namespace {

// ys = y + c k over dim entries (c's derivative nonzero only in the directions cidx[0 .. cnt)); sh = the value of c k
// over the n angles (the stage's angle increments).
template <class T>
__attribute__((always_inline)) inline void stageState(T* __restrict ys, const T* __restrict y, const T& c,
                                                      const T* __restrict k, T* __restrict sh, int n, int dim,
                                                      const int* cidx, int cnt) {
  if constexpr (std::is_same_v<T, double>) {
    for (int d = 0; d < n; ++d) {
      sh[d] = c * k[d];
      ys[d] = y[d] + sh[d];
    }
    axpySparse(ys + n, y + n, c, k + n, dim - n, cidx, cnt);
  } else {
    for (int d = 0; d < n; ++d) sh[d].v = c.v * k[d].v;  // the value only (the angle increment of the stage)
    axpySparse(ys, y, c, k, dim, cidx, cnt);
  }
}

// y += h6 (k1 + 2 k2 + 2 k3 + k4) (h6's derivative nonzero only in hidx[0 .. cnt)); inc = the value of that increment
// over the n angles.
template <class T>
__attribute__((always_inline)) inline void rk4Update(T* __restrict y, const T& h6, const T* __restrict k1,
                                                     const T* __restrict k2, const T* __restrict k3,
                                                     const T* __restrict k4, T* __restrict inc, int n, int dim,
                                                     const int* hidx, int cnt) {
  if constexpr (std::is_same_v<T, double>) {
    for (int d = 0; d < n; ++d) {
      inc[d] = h6 * (k1[d] + 2.0 * k2[d] + 2.0 * k3[d] + k4[d]);
      y[d] += inc[d];
    }
    rk4SumSparse(y + n, h6, k1 + n, k2 + n, k3 + n, k4 + n, dim - n, hidx, cnt);
  } else {
    for (int d = 0; d < n; ++d)  // the value only
      inc[d].v = h6.v * (k1[d].v + 2.0 * k2[d].v + 2.0 * k3[d].v + k4[d].v);
    rk4SumSparse(y, h6, k1, k2, k3, k4, dim, hidx, cnt);
  }
}

// The contact residual rows at the distal boundary of segment si (before the point-torque jumps; theta is
// continuous), and the point torques of the contact unknowns after the distal conditions. Out of line: only solves
// under contact laws have them, and the integrator's loop stays small for the compiler.
template <class T>
__attribute__((noinline)) void contactRows(const LoadedProblem& L, std::size_t si, const T* z, const T* th,
                                           const T& mbx, const T& mby, T* r, LoadedOutputs* rec) {
  const Problem& P = L.P;
  const int n = P.n;
  for (int c : P.breakpoints[si].contacts) {
    const ActiveContact& ac = P.contacts[static_cast<std::size_t>(c)];
    const int row = n + 2 + c;
    const T relative_twist = th[ac.site.inner] - th[ac.site.outer];
    const T mom = siteMoment<T>(P, si, th, ac.site, mbx, mby);
    if (rec) {
      rec->contacts_relative_twist[static_cast<std::size_t>(c)] = value(relative_twist);
      rec->contacts_moment[static_cast<std::size_t>(c)] = value(mom);
    }
    r[row] = contactLawResidual(P, ac, z[row], relative_twist, mom);
  }
}

template <class T>
__attribute__((noinline)) void contactJumps(const LoadedProblem& L, const Breakpoint& bp, const T* z, T* r, T* uz) {
  const Problem& P = L.P;
  for (int c : bp.contacts)
    applyContactJump(contactJump(P, bp, P.contacts[static_cast<std::size_t>(c)]), z[P.n + 2 + c], r, uz);
}

/// The discrete loaded map. Inputs z (m unknowns), alpha, beta (n), F, M (3). Outputs the residual r (m), the tip
/// position p (3) and frame R (9, row-major). With `rec` (double only) also twist, moments, contacts, backbone.
/// NT > 0: the tube count as a compile-time constant (P.n must equal it), so that the loops over the state unroll.
template <class T, int NT = 0>
void runLoaded(const LoadedProblem& L, const T* z, const T* alpha, const T* beta, const T* F, const T* M, T* r, T* tipP,
               T* tipR, T* tipTheta, LoadedOutputs* rec, bool record_nodes, bool record_tubes,
               bool want_position = true) {
  const Problem& P = L.P;
  const int n = NT > 0 ? NT : P.n, m = L.m;
  const int dim = 2 * n + 3;        // theta, u_z, m
  thread_local std::vector<T> buf;  // scratch of this instantiation on this thread (no allocation per evaluation)
  buf.resize(static_cast<std::size_t>(7 * dim + 6 * n));
  T* y = buf.data();
  T* yt = y + dim;
  T* k[4] = {yt + dim, yt + 2 * dim, yt + 3 * dim, yt + 4 * dim};
  T* sn = yt + 5 * dim;
  T* cs = sn + n;
  T* sn0 = cs + n;  // the base of the angle additions (duals: values only; as torsion_map.cpp's Evaluator::deriv)
  T* cs0 = sn0 + n;
  T* shift = cs0 + n;
  T* step_shift = shift + n;
  thread_local std::vector<int> idx_store;
  thread_local std::vector<double> seg_store;
  idx_store.resize(static_cast<std::size_t>(2 * n));
  seg_store.resize(static_cast<std::size_t>(2 * n));
  int* idx_buf = idx_store.data();
  double* seg_buf = seg_store.data();
  T* th = y;
  T* uz = y + n;
  T* mm = y + 2 * n;

  // Base values from the unknowns: u_iz(0) for i < n-1, m(0) = K0 z[n-1..n+1], u_nz(0) from m_z(0).
  T msum = 0.0;
  for (int i = 0; i + 1 < n; ++i) {
    uz[i] = z[i];
    msum += P.kt[i] * z[i];
  }
  for (int c = 0; c < 3; ++c) mm[c] = L.K0 * z[n - 1 + c];
  uz[n - 1] = (mm[2] - msum) / P.kt[n - 1];
  for (int i = 0; i < n; ++i) th[i] = alpha[i] - beta[i] * uz[i];
  for (int i = 0; i < m; ++i) r[i] = 0.0;
  for (int i = 0; i + 1 < n; ++i)
    if (P.end[i] <= kSameS) r[i] = z[i];  // tubes that never leave the actuation unit: u_iz = 0 there
  if (rec) {
    rec->moments.clear();
    rec->contacts_relative_twist.assign(P.contacts.size(), 0.0);
    rec->contacts_moment.assign(P.contacts.size(), 0.0);
    rec->nodes = 0;
    rec->twist.setZero(std::max(0, n - 1));
    if (P.s_twist <= kSameS) {
      for (int kk = 1; kk < n; ++kk) {
        const double th_k = value(alpha[kk]) + (P.s_twist - value(beta[kk])) * value(uz[kk]);
        const double th_1 = value(alpha[0]) + (P.s_twist - value(beta[0])) * value(uz[0]);
        rec->twist[kk - 1] = th_k - th_1;
      }
    }
  }
  Frame<T> R;
  T p[3] = {0.0, 0.0, 0.0};

  // Segment boundaries as functions of beta (fixed number of steps per segment).
  auto boundary = [&](std::size_t b) -> T {
    switch (L.bp_kind[b]) {
      case 1:
        return beta[L.bp_tube[b]] + L.length[L.bp_tube[b]];
      case 2:
        return beta[L.bp_tube[b]] + L.straight[L.bp_tube[b]];
      case 3:
        return T(P.segments[b - 1].s1);
      default:
        return T(0.0);
    }
  };

  // The tubes of the current segment (set at its start): `curved` the present curved ones (index, w_j = k_bj kappa_j,
  // aK_j = (k_bj / k_tj) kappa_j), `straight_present` the present straight ones, and 1 / K. Rows of k[] that stay 0
  // on the segment (absent tubes' theta', straight tubes' u_z') are zeroed once at its start.
  int nc = 0, ns = 0;
  int* curved = idx_buf;
  int* straight_present = curved + n;
  double* wq = seg_buf;
  double* aq = wq + n;
  double invK = 1.0;
  auto startSegment = [&](const Segment& sg) {
    nc = ns = 0;
    for (int j = 0; j < n; ++j) {
      const bool present = sg.present[static_cast<std::size_t>(j)] != 0;
      if (sg.w[j] != 0.0) {
        curved[nc] = j;
        wq[nc] = sg.w[j];
        aq[nc] = sg.a[j] * sg.K;
        ++nc;
      } else if (present) {
        straight_present[ns++] = j;
      }
      for (int q = 0; q < 4; ++q) {
        if (!present) k[q][j] = 0.0;
        if (sg.w[j] == 0.0) k[q][n + j] = 0.0;
      }
    }
    invK = 1.0 / sg.K;
  };

  // Curvature and derivative of (theta, u_z, m) at arc length s, given the stage's (R^T m)_xy and tangent t = R e3;
  // force n(s) = F + g (C - rho s). (Curved tubes are present: their theta' is u_z too.)
  // The angles' values are the base's plus `sh` (when given), their sines and cosines by angle addition (for duals
  // the values so, the derivatives by the chain rule); `base`: this evaluation is the new base (a step's first
  // stage). A segment's first step calls libm (as torsion_map.cpp).
  auto derivCore = [&](double rho, const T& C, const T& s, const T* ys, const T* mb, const T* t, T* dy, T& u0x, T& u0y,
                       const T* sh, bool base) __attribute__((always_inline)) {
    const T* ths = ys;
    const T* uzs = ys + n;
    T A = 0.0, B = 0.0;
    for (int q = 0; q < nc; ++q) {
      const int j = curved[q];
      if constexpr (std::is_same_v<T, double>) {
        if (sh)
          sinCosShifted(ths[j], sn0[j], cs0[j], sh[j], sn[j], cs[j]);
        else
          sinCos(ths[j], sn[j], cs[j]);
        if (base) {
          sn0[j] = sn[j];
          cs0[j] = cs[j];
        }
      } else {  // the values as for double, the derivatives by the chain rule
        double sv, cv;
        if (sh)
          sinCosShifted(ths[j].v, sn0[j].v, cs0[j].v, sh[j].v, sv, cv);
        else
          ::sincos(ths[j].v, &sv, &cv);
        if (base) {
          sn0[j].v = sv;
          cs0[j].v = cv;
        }
        sn[j] = chain(ths[j], sv, cv);
        cs[j] = chain(ths[j], cv, -sv);
      }
      A += wq[q] * cs[j];
      B += wq[q] * sn[j];
    }
    u0x = (mb[0] - B) * invK;
    u0y = (A + mb[1]) * invK;
    for (int q = 0; q < nc; ++q) {
      const int j = curved[q];
      dy[j] = uzs[j];
      dy[n + j] = aq[q] * mulAdd(cs[j], u0x, sn[j], u0y);
    }
    for (int q = 0; q < ns; ++q) dy[straight_present[q]] = uzs[straight_present[q]];
    const T load = C - rho * s;
    T nv[3];
    for (int c = 0; c < 3; ++c) nv[c] = F[c] + L.g[c] * load;
    dy[2 * n] = mulSub(t[2], nv[1], t[1], nv[2]);  // -t x n (b a - a b is -(a b - b a) exactly)
    dy[2 * n + 1] = mulSub(t[0], nv[2], t[2], nv[0]);
    dy[2 * n + 2] = mulSub(t[1], nv[0], t[0], nv[1]);
  };
  // derivCore is inlined at the four stages for double (the value evaluations, the hot path); the duals call one
  // out-of-line copy (their code is large: inlining it four times per derivative size costs compile time, and the
  // exact Jacobians are few). The four stages spell the choice out: one `deriv` that forwards to either (a lambda,
  // even always_inline, or a reference to the chosen one) made GCC 12's code for double 8 % slower (352 k instead
  // of 327 k instructions per warm solve, callgrind).
  constexpr bool kInline = std::is_same_v<T, double>;
  auto derivOutOfLine = [&](double rho, const T& C, const T& s, const T* ys, const T* mb, const T* t, T* dy, T& u0x,
                            T& u0y, const T* sh, bool base) __attribute__((noinline)) {
    derivCore(rho, C, s, ys, mb, t, dy, u0x, u0y, sh, base);
  };

  auto pushNode = [&](double s, const Segment& sg, double u0x, double u0y, bool segment_start, const double* force) {
    if (!rec || !record_nodes) return;
    if (rec->nodes == rec->backbone.size()) rec->backbone.emplace_back();
    BackbonePoint& bp = rec->backbone[rec->nodes++];
    bp.s = s;
    bp.segment_start = segment_start;
    for (int a = 0; a < 3; ++a) {
      bp.position[a] = value(p[a]);
      bp.force[a] = force[a];
      bp.moment[a] = value(mm[a]);
      for (int b = 0; b < 3; ++b) bp.frame(a, b) = R.at(3 * a + b);
    }
    if (record_tubes) {
      bp.theta.resize(n);
      bp.uz.resize(n);
      for (int i = 0; i < n; ++i) {
        bp.theta[i] = value(th[i]);
        bp.uz[i] = value(uz[i]);
      }
    } else {
      bp.theta.resize(0);
      bp.uz.resize(0);
    }
    bp.u0 = Eigen::Vector2d(u0x, u0y);
    bp.outermost = sg.outermost;
  };

  T s_start = boundary(0);
  for (std::size_t si = 0; si < P.segments.size(); ++si) {
    const Segment& sg = P.segments[si];
    const T s_end = boundary(si + 1);
    const T h = (s_end - s_start) / static_cast<double>(sg.steps);
    const double rho = L.seg_rho[si];
    T C = 0.0;  // sum of rho_i end_i over the tubes present on the segment
    for (int i = 0; i < n; ++i)
      if (sg.present[static_cast<std::size_t>(i)] && L.rho[i] != 0.0) C += L.rho[i] * (beta[i] + L.length[i]);
    const T hh = 0.5 * h;
    // h depends on the translations of the tubes that bound the segment only: the directions where its derivative
    // is nonzero (none for double), for the products by h, h/2 and h/6 of the stage and RK4 updates.
    int hidx[std::max(1, derivativeCount<T>())];
    const int hcnt = nonzeroDirections(h, hidx);
    startSegment(sg);
    for (int st = 0; st < sg.steps; ++st) {
      const T s = s_start + static_cast<double>(st) * h;
      T u01x, u01y, u02x, u02y, u03x, u03y, u04x, u04y;
      T mb[3], t[3];
      // Stage 1 at (y, R).
      R.transposeTimes(y + 2 * n, mb);
      R.tangent(t);
      T* const sh1 = st > 0 ? step_shift : nullptr;
      if constexpr (kInline)
        derivCore(rho, C, s, y, mb, t, k[0], u01x, u01y, sh1, true);
      else
        derivOutOfLine(rho, C, s, y, mb, t, k[0], u01x, u01y, sh1, true);
      if (rec && record_nodes) {
        double f[3];
        for (int c = 0; c < 3; ++c) f[c] = value(F[c]) + L.g[c] * (value(C) - rho * value(s));
        pushNode(value(s), sg, value(u01x), value(u01y), st == 0, f);
      }
      // Stage 2: y + h/2 k1 at R E2, E2 = exp(h/2 u01).
      stageState(yt, y, hh, k[0], shift, n, dim, hidx, hcnt);
      const StageRotation<T> E2(hh * u01x, hh * u01y);
      R.stageKeep(E2, yt + 2 * n, mb, t);
      if constexpr (kInline)
        derivCore(rho, C, s + hh, yt, mb, t, k[1], u02x, u02y, shift, false);
      else
        derivOutOfLine(rho, C, s + hh, yt, mb, t, k[1], u02x, u02y, shift, false);
      // Stage 3: y + h/2 k2 at R exp(h/2 u02).
      stageState(yt, y, hh, k[1], shift, n, dim, hidx, hcnt);
      const StageRotation<T> E3(hh * u02x, hh * u02y);
      R.stage(E3, yt + 2 * n, mb, t);
      if constexpr (kInline)
        derivCore(rho, C, s + hh, yt, mb, t, k[2], u03x, u03y, shift, false);
      else
        derivOutOfLine(rho, C, s + hh, yt, mb, t, k[2], u03x, u03y, shift, false);
      // Stage 4: y + h k3 at R E2 E4, E4 = exp(h u03 - h/2 u01) (R E2 kept from stage 2).
      stageState(yt, y, h, k[2], shift, n, dim, hidx, hcnt);
      const StageRotation<T> E4(h * u03x - hh * u01x, h * u03y - hh * u01y);
      R.stageFromKept(E4, yt + 2 * n, mb, t);
      if constexpr (kInline)
        derivCore(rho, C, s + h, yt, mb, t, k[3], u04x, u04y, shift, false);
      else
        derivOutOfLine(rho, C, s + h, yt, mb, t, k[3], u04x, u04y, shift, false);
      const T h6 = h / 6.0;
      rk4Update(y, h6, k[0], k[1], k[2], k[3], step_shift, n, dim, hidx, hcnt);
      const T h12 = h / 12.0;
      const T w1x = h12 * (3.0 * u01x + 2.0 * u02x + 2.0 * u03x - u04x);
      const T w1y = h12 * (3.0 * u01y + 2.0 * u02y + 2.0 * u03y - u04y);
      const T w2x = h12 * (-u01x + 2.0 * u02x + 2.0 * u03x + 3.0 * u04x);
      const T w2y = h12 * (-u01y + 2.0 * u02y + 2.0 * u03y + 3.0 * u04y);
      R.step(w1x, w1y, want_position ? p : nullptr, hh);
      R.step(w2x, w2y, want_position ? p : nullptr, hh);
    }
    R.orthonormalize();
    s_start = s_end;

    // Events at the end of the segment.
    const Breakpoint& bp = P.breakpoints[si];
    T mloc[3];  // R^T m
    R.transposeTimes(mm, mloc);
    const T& mbx = mloc[0];
    const T& mby = mloc[1];
    if (rec) {
      if (record_nodes) {
        double A = 0, B = 0;
        for (int j = 0; j < n; ++j)
          if (sg.w[j] != 0.0) {
            A += sg.w[j] * std::cos(value(th[j]));
            B += sg.w[j] * std::sin(value(th[j]));
          }
        double f[3];
        for (int c = 0; c < 3; ++c) f[c] = value(F[c]) + L.g[c] * (value(C) - rho * value(s_end));
        pushNode(value(s_end), sg, (value(mbx) - B) / sg.K, (A + value(mby)) / sg.K, false, f);
      }
      if (bp.twist_point)
        for (int kk = 1; kk < n; ++kk) rec->twist[kk - 1] = value(th[kk]) - value(th[0]);
      for (int i : bp.ending)
        rec->moments.push_back({MomentKind::TubeEnd, i, bp.s, value(endMoment<T>(P, sg, th, i, &bp.ending, mbx, mby))});
      if (si + 1 < P.segments.size())
        for (int j : bp.discontinuities)
          rec->moments.push_back(
              {MomentKind::CurvatureDiscontinuity, j, bp.s, discontinuityMoment(P, P.segments[si + 1], j)});
    }
    if (!bp.contacts.empty()) contactRows<T>(L, si, z, th, mbx, mby, r, rec);
    // Distal conditions: k_i u_iz(s-) = point torque; the innermost tube carries the tip moment's tangent part.
    for (int i : bp.ending) {
      r[i] = uz[i];
      if (i == n - 1) {
        T Mloc[3];  // R^T M
        R.transposeTimes(M, Mloc);
        r[i] -= Mloc[2] / P.kt[n - 1];
      }
    }
    if (!bp.contacts.empty()) contactJumps<T>(L, bp, z, r, uz);
  }
  // Bending part of the tip moment condition (tip frame): (R^T (m - M))_xy = 0, scaled by the tip stiffness.
  const double Ktip = P.segments.empty() ? L.K0 : P.segments.back().K;
  const T d[3] = {mm[0] - M[0], mm[1] - M[1], mm[2] - M[2]};
  T dloc[3];  // R^T (m - M)
  R.transposeTimes(d, dloc);
  r[n] = dloc[0] / Ktip;
  r[n + 1] = dloc[1] / Ktip;
  for (int c = 0; c < 3; ++c) tipP[c] = p[c];
  R.matrix(tipR);
  *tipTheta = th[n - 1];
  if (rec && record_nodes) {
    rec->backbone.resize(rec->nodes);
    if (!rec->backbone.empty() && record_tubes) {
      for (int i = 0; i < n; ++i) {
        rec->backbone.back().theta[i] = value(th[i]);
        rec->backbone.back().uz[i] = value(uz[i]);
      }
    }
  }
}

// Inputs of the map as one vector: [z (m) | alpha (n) | beta (n) | F (3) | M (3)].
Eigen::VectorXd inputVector(const LoadedProblem& L, const Eigen::VectorXd& z) {
  const int n = L.P.n, m = L.m;
  Eigen::VectorXd x(m + 2 * n + 6);
  x << z, L.P.alpha, L.P.beta, L.F, L.M;
  return x;
}

}  // namespace

void evalValue(LoadedWork& W, const Eigen::VectorXd& z, LoadedOutputs* rec, bool nodes, bool tubes) {
  const LoadedProblem& L = W.L;
  const int m = L.m;
  W.r.resize(m);
  double p[3], R[9], th;
  // The value evaluations of Newton are the hot path: 2- and 3-tube robots have their own instantiation.
  auto run = [&](auto fn) {
    fn(L, z.data(), L.P.alpha.data(), L.P.beta.data(), L.F.data(), L.M.data(), W.r.data(), p, R, &th, rec, nodes, tubes,
       true);
  };
  if (L.P.n == 3)
    run(runLoaded<double, 3>);
  else if (L.P.n == 2)
    run(runLoaded<double, 2>);
  else
    run(runLoaded<double, 0>);
  W.tip_p = Eigen::Vector3d(p[0], p[1], p[2]);
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b) W.tip_R(a, b) = R[3 * a + b];
}

// Derivatives of (r, tip p, tip R) w.r.t. the inputs x[dirs[start .. start+cnt)] into columns of W.D.
namespace {

template <int N>
void evalDualChunk(LoadedWork& W, const Eigen::VectorXd& x, const std::vector<int>& dirs, int start, int cnt,
                   bool want_position) {
  const LoadedProblem& L = W.L;
  const int n = L.P.n, m = L.m;
  using D = Dual<N>;
  std::vector<D> xd(static_cast<std::size_t>(x.size()));
  for (int i = 0; i < x.size(); ++i) xd[static_cast<std::size_t>(i)] = D(x[i]);
  for (int k = 0; k < cnt; ++k) xd[static_cast<std::size_t>(dirs[static_cast<std::size_t>(start + k)])].d[k] = 1.0;
  std::vector<D> r(static_cast<std::size_t>(m));
  D p[3], R[9], th;
  const D* xs = xd.data();
  runLoaded<D>(L, xs, xs + m, xs + m + n, xs + m + 2 * n, xs + m + 2 * n + 3, r.data(), p, R, &th, nullptr, false,
               false, want_position);
  W.r.resize(m);
  for (int i = 0; i < m; ++i) {
    W.r[i] = r[static_cast<std::size_t>(i)].v;
    for (int k = 0; k < cnt; ++k) W.D(i, start + k) = r[static_cast<std::size_t>(i)].d[k];
  }
  for (int a = 0; a < 3 && want_position; ++a) {
    W.tip_p[a] = p[a].v;
    for (int k = 0; k < cnt; ++k) W.D(m + a, start + k) = p[a].d[k];
  }
  for (int c = 0; c < 9; ++c) {
    W.tip_R(c / 3, c % 3) = R[c].v;
    for (int k = 0; k < cnt; ++k) W.D(m + 3 + c, start + k) = R[c].d[k];
  }
  for (int k = 0; k < cnt; ++k) W.D(m + 12, start + k) = th.d[k];
}

}  // namespace

// Value and derivatives w.r.t. the listed inputs (W.D: (m + 13) x dirs.size(): r, tip p, tip R, theta_n(tip)).
void evalDerivatives(LoadedWork& W, const Eigen::VectorXd& z, const std::vector<int>& dirs, bool want_position) {
  const Eigen::VectorXd x = inputVector(W.L, z);
  const int total = static_cast<int>(dirs.size());
  W.D.resize(W.L.m + 13, total);
  for (int start = 0; start < total;) {
    const int left = total - start;
    int cnt = std::min(left, 24);
    // Directions per pass: the smallest instantiated size that holds them (the cost grows with the size; 13 and 15
    // are left out: GCC 12 generates markedly slower code for them than for 14 and 16, measured with callgrind).
    if (left <= 2) {
      evalDualChunk<2>(W, x, dirs, start, cnt, want_position);
    } else if (left <= 3) {
      evalDualChunk<3>(W, x, dirs, start, cnt, want_position);
    } else if (left <= 4) {
      evalDualChunk<4>(W, x, dirs, start, cnt, want_position);
    } else if (left <= 5) {
      evalDualChunk<5>(W, x, dirs, start, cnt, want_position);
    } else if (left <= 6) {
      evalDualChunk<6>(W, x, dirs, start, cnt, want_position);
    } else if (left <= 7) {
      evalDualChunk<7>(W, x, dirs, start, cnt, want_position);
    } else if (left <= 8) {
      evalDualChunk<8>(W, x, dirs, start, cnt, want_position);
    } else if (left <= 9) {
      evalDualChunk<9>(W, x, dirs, start, cnt, want_position);
    } else if (left <= 11) {
      evalDualChunk<11>(W, x, dirs, start, cnt, want_position);
    } else if (left <= 14) {
      evalDualChunk<14>(W, x, dirs, start, cnt, want_position);
    } else if (left <= 16) {
      evalDualChunk<16>(W, x, dirs, start, cnt, want_position);
    } else if (left <= 17) {
      evalDualChunk<17>(W, x, dirs, start, cnt, want_position);
    } else if (left <= 20) {
      evalDualChunk<20>(W, x, dirs, start, cnt, want_position);
    } else {
      evalDualChunk<24>(W, x, dirs, start, cnt, want_position);
    }
    start += cnt;
  }
}

// Residual and its Jacobian w.r.t. the unknowns.
void evalJacobian(LoadedWork& W, const Eigen::VectorXd& z) {
  const int m = W.L.m;
  std::vector<int> dirs(static_cast<std::size_t>(m));
  for (int i = 0; i < m; ++i) dirs[static_cast<std::size_t>(i)] = i;
  evalDerivatives(W, z, dirs, false);  // the residual does not depend on the tip position
  W.J = W.D.topRows(m);
}

Eigen::VectorXd unknownsFrom(const LoadedProblem& L, const Solution& s) {
  const Problem& P = L.P;
  const int n = P.n;
  Eigen::VectorXd z = Eigen::VectorXd::Zero(L.m);
  if (s.base_twist_rate.size() != n || !s.base_twist_rate.allFinite()) return z;
  for (int i = 0; i + 1 < n; ++i) z[i] = s.base_twist_rate[i];
  Eigen::Vector3d m0 = s.base_moment;
  if (!s.loaded || !m0.allFinite()) m0 = Eigen::Vector3d(0.0, 0.0, P.kt.dot(s.base_twist_rate));
  z.segment(n - 1, 3) = m0 / L.K0;
  contactUnknownsFrom(P, s.contacts, z, n + 2);
  return z;
}

// Stability of the loaded equilibrium: det(J) over the twist and moment rows/columns (no contacts), normalised by
// D0 = K0^3 / (k_nt K_tip^2), the determinant of the moment block at zero load with the other conditions held (the
// scalings of the moment unknowns m(0)/K0 and of the innermost torsion and bending rows). At zero load det(J) = D0 x
// the torsion-only measure exactly (the moment block is then a scaled rotation), so the two measures agree there; it
// is 1 without tube interaction and changes sign exactly where J is singular (folds). (A Schur complement over the
// moment block would divide by a determinant that itself crosses zero for strongly interacting tubes.)
double loadedStability(const LoadedProblem& L, const Eigen::MatrixXd& J) {
  const int n = L.P.n;
  const double Ktip = L.P.segments.empty() ? L.K0 : L.P.segments.back().K;
  return J.topLeftCorner(n + 2, n + 2).determinant() * L.P.kt[n - 1] * Ktip * Ktip / (L.K0 * L.K0 * L.K0);
}

}  // namespace ctr::detail
