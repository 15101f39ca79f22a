// Internal: the backbone frame of the loaded integrator (loaded_map.cpp) and its rotation steps, for a plain
// double and for forward-mode duals.
//
// Frame<double> is the rotation matrix R (row-major). Frame<Dual<N>> keeps the value R and, per derivative
// direction k, the body-frame tangent xi_k with dR_k = R [xi_k]x: the derivative of a rotation has 3 components,
// not 9, and a step R <- R exp([w]x) maps it by xi <- E^T xi + J_r(w) dw (E = exp([w]x), J_r the right Jacobian of
// SO(3)) instead of a 3x3 product of duals. Both give the derivative of the same discrete map (the rotation stays on
// SO(3) in both; they differ by rounding only).
#pragma once

#include <cmath>

#include "dual.hpp"
#include "se3_step.hpp"

namespace ctr::detail {

template <class T>
struct Exp {
  T A, B, C;  // sin(t)/t, (1-cos t)/t^2, (t - sin t)/t^3
};

// The coefficients of w = (wx, wy, 0). C only when asked (translation).
inline Exp<double> expCoefficients(double wx, double wy, bool withC) {
  const ExpCoefficients c = expCoefficientsOf(wx * wx + wy * wy, withC, false);
  return {c.A, c.B, c.C};
}

// E = exp([w]x) = I + A [w]x + B [w]x^2, w = (wx, wy, 0), row-major.
inline void rotationOf(double A, double B, double wx, double wy, double* E) {
  const double Bxy = B * wx * wy;
  E[0] = 1.0 - B * wy * wy;
  E[1] = Bxy;
  E[2] = A * wy;
  E[3] = Bxy;
  E[4] = 1.0 - B * wx * wx;
  E[5] = -(A * wx);
  E[6] = -(A * wy);
  E[7] = A * wx;
  E[8] = 1.0 - B * (wx * wx + wy * wy);
}

// R <- R exp([w]x) with w = (wx, wy, 0); R row-major. Optionally p <- p + R V(w) e3 a (SE(3) step).
inline void expStep(double* R, double* p, double wx, double wy, const double* a) {
  const Exp<double> c = expCoefficients(wx, wy, p != nullptr);
  double E[9];
  rotationOf(c.A, c.B, wx, wy, E);
  if (p) {
    const double tx = *a * c.B * wy, ty = -(*a * c.B * wx), tz = *a * (1.0 - c.C * (wx * wx + wy * wy));
    for (int r = 0; r < 3; ++r) p[r] += R[3 * r] * tx + R[3 * r + 1] * ty + R[3 * r + 2] * tz;
  }
  double out[9];
  for (int r = 0; r < 3; ++r)
    for (int col = 0; col < 3; ++col)
      out[3 * r + col] = R[3 * r] * E[col] + R[3 * r + 1] * E[3 + col] + R[3 * r + 2] * E[6 + col];
  for (int k = 0; k < 9; ++k) R[k] = out[k];
}

inline void transposeTimes(const double* R, const double* v, double* o) {
  for (int c = 0; c < 3; ++c) o[c] = R[c] * v[0] + R[3 + c] * v[1] + R[6 + c] * v[2];
}

inline void times(const double* R, const double* v, double* o) {
  for (int r = 0; r < 3; ++r) o[r] = R[3 * r] * v[0] + R[3 * r + 1] * v[1] + R[3 * r + 2] * v[2];
}

// Gram-Schmidt on the columns (z first): removes the rounding drift of R.
inline void orthonormalize(double* R) {
  double z[3] = {R[2], R[5], R[8]};
  const double nz = std::sqrt(z[0] * z[0] + z[1] * z[1] + z[2] * z[2]);
  for (auto& v : z) v = v / nz;
  const double d = R[0] * z[0] + R[3] * z[1] + R[6] * z[2];
  double x[3] = {R[0] - z[0] * d, R[3] - z[1] * d, R[6] - z[2] * d};
  const double nx = std::sqrt(x[0] * x[0] + x[1] * x[1] + x[2] * x[2]);
  for (auto& v : x) v = v / nx;
  const double y[3] = {z[1] * x[2] - z[2] * x[1], z[2] * x[0] - z[0] * x[2], z[0] * x[1] - z[1] * x[0]};
  for (int r = 0; r < 3; ++r) {
    R[3 * r] = x[r];
    R[3 * r + 1] = y[r];
    R[3 * r + 2] = z[r];
  }
}

/// A stage rotation E = exp([w]x), w = (wx, wy, 0), of the commutator-free integrator (applied to vectors without
/// forming it: a stage needs only R_s^T m and R_s e3).
template <class T>
struct StageRotation;

template <>
struct StageRotation<double> {
  double Bxx, Byy, Bxy, Awx, Awy;
  StageRotation(double wx, double wy) {
    const Exp<double> c = expCoefficients(wx, wy, false);
    Bxx = c.B * wx * wx;
    Byy = c.B * wy * wy;
    Bxy = c.B * wx * wy;
    Awx = c.A * wx;
    Awy = c.A * wy;
  }
  void transposeTimes(const double* v, double* o) const {  // o = E^T v
    o[0] = v[0] - Byy * v[0] + Bxy * v[1] - Awy * v[2];
    o[1] = Bxy * v[0] + v[1] - Bxx * v[1] + Awx * v[2];
    o[2] = Awy * v[0] - Awx * v[1] + v[2] - (Bxx + Byy) * v[2];
  }
  void thirdColumn(double* o) const {  // o = E e3
    o[0] = Awy;
    o[1] = -Awx;
    o[2] = 1.0 - (Bxx + Byy);
  }
  void times(const double* v, double* o) const {  // o = E v
    o[0] = v[0] - Byy * v[0] + Bxy * v[1] + Awy * v[2];
    o[1] = Bxy * v[0] + v[1] - Bxx * v[1] - Awx * v[2];
    o[2] = -(Awy * v[0]) + Awx * v[1] + v[2] - (Bxx + Byy) * v[2];
  }
};

/// The backbone frame (see the file comment).
template <class T>
struct Frame;

template <>
struct Frame<double> {
  double R[9] = {1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0};
  void transposeTimes(const double* v, double* o) const { detail::transposeTimes(R, v, o); }
  void tangent(double* t) const {
    t[0] = R[2];
    t[1] = R[5];
    t[2] = R[8];
  }
  /// (R E)^T m and (R E) e3 for a stage rotation E.
  void stage(const StageRotation<double>& E, const double* m, double* mb, double* t) const {
    double v[3], e[3];
    detail::transposeTimes(R, m, v);
    E.transposeTimes(v, mb);
    E.thirdColumn(e);
    detail::times(R, e, t);
  }
  /// As stage(), and keeps (a copy of) E for stageFromKept.
  void stageKeep(const StageRotation<double>& E, const double* m, double* mb, double* t) {
    kept_ = E;
    stage(E, m, mb, t);
  }
  /// (R E1 E)^T m and (R E1 E) e3, E1 the rotation last given to stageKeep. For double the product is not formed:
  /// the rotations are applied to the two vectors.
  void stageFromKept(const StageRotation<double>& E, const double* m, double* mb, double* t) const {
    double v[3], w[3], e[3];
    detail::transposeTimes(R, m, v);
    kept_.transposeTimes(v, w);
    E.transposeTimes(w, mb);
    E.thirdColumn(w);
    kept_.times(w, e);
    detail::times(R, e, t);
  }
  /// R <- R exp([w]x); with p: p <- p + R V(w) e3 a first (SE(3) step).
  void step(double wx, double wy, double* p, const double& a) { expStep(R, p, wx, wy, &a); }
  void orthonormalize() { detail::orthonormalize(R); }
  void matrix(double* out) const {
    for (int k = 0; k < 9; ++k) out[k] = R[k];
  }
  double at(int k) const { return R[k]; }

 private:
  StageRotation<double> kept_{0.0, 0.0};
};

/// Rows of N derivatives padded to an even length and 16-byte aligned (as Dual<N>::d), so that they are read and
/// written in aligned pairs.
template <int N>
constexpr int paddedDirections() {
  return (N + 1) / 2 * 2;
}

template <int N>
struct StageRotation<Dual<N>> {
  static constexpr int P = paddedDirections<N>();
  alignas(16) double dwx[P];
  alignas(16) double dwy[P];
  double E[9];          // row-major value
  double wx, wy, C, B;  // value of w and the coefficients of J_r(w)
  StageRotation(const Dual<N>& x, const Dual<N>& y) : wx(x.v), wy(y.v) {
    for (int k = 0; k < N; ++k) {
      dwx[k] = x.d[k];
      dwy[k] = y.d[k];
    }
    const ExpCoefficients c = expCoefficientsOf(wx * wx + wy * wy, true, false);
    B = c.B;
    C = c.C;
    rotationOf(c.A, c.B, wx, wy, E);
  }
  /// xo = E^T xi + J_r(w) dw: the tangent of R E from that of R (xi, the tangent of R).
  void mapTangent(const double (*__restrict xi)[P], double (*__restrict xo)[P]) const {
    const double x = wx * wx + wy * wy;
    const double f = 1.0 - C * x;
    for (int k = 0; k < N; ++k) {
      const double a = xi[0][k], b = xi[1][k], c = xi[2][k];
      const double dx = dwx[k], dy = dwy[k];
      const double wd = wx * dx + wy * dy;
      xo[0][k] = E[0] * a + E[3] * b + E[6] * c + f * dx + C * wx * wd;
      xo[1][k] = E[1] * a + E[4] * b + E[7] * c + f * dy + C * wy * wd;
      xo[2][k] = E[2] * a + E[5] * b + E[8] * c - B * (wx * dy - wy * dx);
    }
  }
};

template <int N>
struct Frame<Dual<N>> {
  using D = Dual<N>;
  static constexpr int P = paddedDirections<N>();
  alignas(16) double xi[3][P] = {};  // directions N .. P-1 unused
  double R[9] = {1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0};

  // o = R^T v; do_k = R^T dv_k - xi_k x (R^T v).
  static void transposeTimesOf(const double* R, const double (*xi)[P], const D* v, D* o) {
    double w[3];
    for (int c = 0; c < 3; ++c) w[c] = R[c] * v[0].v + R[3 + c] * v[1].v + R[6 + c] * v[2].v;
    for (int c = 0; c < 3; ++c) o[c].v = w[c];
    for (int k = 0; k < N; ++k) {
      const double a = v[0].d[k], b = v[1].d[k], e = v[2].d[k];
      const double x0 = xi[0][k], x1 = xi[1][k], x2 = xi[2][k];
      o[0].d[k] = R[0] * a + R[3] * b + R[6] * e - (x1 * w[2] - x2 * w[1]);
      o[1].d[k] = R[1] * a + R[4] * b + R[7] * e - (x2 * w[0] - x0 * w[2]);
      o[2].d[k] = R[2] * a + R[5] * b + R[8] * e - (x0 * w[1] - x1 * w[0]);
    }
  }
  // t = R e3; dt_k = R (xi_k x e3) = R (xi_y, -xi_x, 0).
  static void tangentOf(const double* R, const double (*xi)[P], D* t) {
    for (int r = 0; r < 3; ++r) t[r].v = R[3 * r + 2];
    for (int k = 0; k < N; ++k) {
      const double x0 = xi[0][k], x1 = xi[1][k];
      t[0].d[k] = R[0] * x1 - R[1] * x0;
      t[1].d[k] = R[3] * x1 - R[4] * x0;
      t[2].d[k] = R[6] * x1 - R[7] * x0;
    }
  }
  // Ro = R E.
  static void rotate(const double* __restrict R, const double* __restrict E, double* __restrict Ro) {
    for (int r = 0; r < 3; ++r)
      for (int col = 0; col < 3; ++col)
        Ro[3 * r + col] = R[3 * r] * E[col] + R[3 * r + 1] * E[3 + col] + R[3 * r + 2] * E[6 + col];
  }

  void transposeTimes(const D* v, D* o) const { transposeTimesOf(R, xi, v, o); }
  void tangent(D* t) const { tangentOf(R, xi, t); }
  // The frame R0 E (tangents xo) of the frame R0 (tangents x0) and (R0 E)^T m, (R0 E) e3.
  static void stageOf(const double* R0, const double (*x0)[P], const StageRotation<D>& E, const D* m, D* mb, D* t,
                      double* Ro, double (*xo)[P]) {
    E.mapTangent(x0, xo);
    rotate(R0, E.E, Ro);
    transposeTimesOf(Ro, xo, m, mb);
    tangentOf(Ro, xo, t);
  }
  /// (R E)^T m and (R E) e3 for a stage rotation E.
  void stage(const StageRotation<D>& E, const D* m, D* mb, D* t) const {
    double Rs[9];
    alignas(16) double xs[3][P];
    stageOf(R, xi, E, m, mb, t, Rs, xs);
  }
  /// As stage(), and keeps the frame R E (value and tangents) for stageFromKept.
  void stageKeep(const StageRotation<D>& E, const D* m, D* mb, D* t) { stageOf(R, xi, E, m, mb, t, Rk_, xk_); }
  /// (R E1 E)^T m and (R E1 E) e3, E1 the rotation last given to stageKeep: from the kept frame R E1.
  void stageFromKept(const StageRotation<D>& E, const D* m, D* mb, D* t) const {
    double Rs[9];
    alignas(16) double xs[3][P];
    stageOf(Rk_, xk_, E, m, mb, t, Rs, xs);
  }
  void step(const D& wx, const D& wy, D* p, const D& a) {
    const double vx = wx.v, vy = wy.v, xv = vx * vx + vy * vy;
    const ExpCoefficients c = expCoefficientsOf(xv, true, p != nullptr);
    if (p) {
      const D x = wx * wx + wy * wy;
      // p <- p + R tau, tau = a V(w) e3 = a (B wy, -B wx, 1 - C x); dp_k += R (dtau_k + xi_k x tau).
      const D Bd = chain(x, c.B, c.dB), Cd = chain(x, c.C, c.dC);
      const D tau[3] = {a * (Bd * wy), -(a * (Bd * wx)), a * (1.0 - Cd * x)};
      for (int r = 0; r < 3; ++r) p[r].v += R[3 * r] * tau[0].v + R[3 * r + 1] * tau[1].v + R[3 * r + 2] * tau[2].v;
      for (int k = 0; k < N; ++k) {
        const double g0 = tau[0].d[k] + xi[1][k] * tau[2].v - xi[2][k] * tau[1].v;
        const double g1 = tau[1].d[k] + xi[2][k] * tau[0].v - xi[0][k] * tau[2].v;
        const double g2 = tau[2].d[k] + xi[0][k] * tau[1].v - xi[1][k] * tau[0].v;
        for (int r = 0; r < 3; ++r) p[r].d[k] += R[3 * r] * g0 + R[3 * r + 1] * g1 + R[3 * r + 2] * g2;
      }
    }
    double E[9];
    rotationOf(c.A, c.B, vx, vy, E);
    const double f = 1.0 - c.C * xv;
    for (int k = 0; k < N; ++k) {
      const double a0 = xi[0][k], b0 = xi[1][k], c0 = xi[2][k];
      const double dx = wx.d[k], dy = wy.d[k];
      const double wd = vx * dx + vy * dy;
      xi[0][k] = E[0] * a0 + E[3] * b0 + E[6] * c0 + f * dx + c.C * vx * wd;
      xi[1][k] = E[1] * a0 + E[4] * b0 + E[7] * c0 + f * dy + c.C * vy * wd;
      xi[2][k] = E[2] * a0 + E[5] * b0 + E[8] * c0 - c.B * (vx * dy - vy * dx);
    }
    double Ro[9];
    rotate(R, E, Ro);
    for (int c = 0; c < 9; ++c) R[c] = Ro[c];
  }
  void orthonormalize() { detail::orthonormalize(R); }
  // The dual matrix: dR_k = R [xi_k]x.
  void matrix(D* out) const {
    for (int r = 0; r < 3; ++r) {
      const double* Rr = R + 3 * r;
      D& c0 = out[3 * r];
      D& c1 = out[3 * r + 1];
      D& c2 = out[3 * r + 2];
      c0.v = Rr[0];
      c1.v = Rr[1];
      c2.v = Rr[2];
      for (int k = 0; k < N; ++k) {
        c0.d[k] = Rr[1] * xi[2][k] - Rr[2] * xi[1][k];
        c1.d[k] = Rr[2] * xi[0][k] - Rr[0] * xi[2][k];
        c2.d[k] = Rr[0] * xi[1][k] - Rr[1] * xi[0][k];
      }
    }
  }
  double at(int k) const { return R[k]; }

 private:
  alignas(16) double xk_[3][P];  // the frame kept by stageKeep: tangents and value
  double Rk_[9];
};

}  // namespace ctr::detail
