// Internal: forward-mode dual numbers with N derivative directions, for the exact derivative of the discrete
// loaded-kinematics map (the integrator is templated on its scalar; with Dual<N> it carries N directional
// derivatives through every stage, so the result is the derivative of exactly what is computed).
#pragma once

#include <cmath>

namespace ctr::detail {

// The derivatives come first and the struct is 16-byte aligned, so that the loops over them read and write aligned
// pairs (SSE2 folds aligned loads into the arithmetic): 9 % fewer instructions in the loaded map's derivative pass
// than with the value first.
template <int N>
struct alignas(16) Dual {
  double d[N];  // left uninitialised by the default constructor: every operation below writes all of it
  double v;
  Dual() = default;
  Dual(double x) : v(x) {  // NOLINT: constants convert implicitly
    for (int k = 0; k < N; ++k) d[k] = 0.0;
  }
  Dual& operator+=(const Dual& o) {
    v += o.v;
    for (int k = 0; k < N; ++k) d[k] += o.d[k];
    return *this;
  }
  Dual& operator-=(const Dual& o) {
    v -= o.v;
    for (int k = 0; k < N; ++k) d[k] -= o.d[k];
    return *this;
  }
  Dual& operator*=(double c) {
    v *= c;
    for (int k = 0; k < N; ++k) d[k] *= c;
    return *this;
  }
};

template <int N>
inline Dual<N> operator-(const Dual<N>& a) {
  Dual<N> r;
  r.v = -a.v;
  for (int k = 0; k < N; ++k) r.d[k] = -a.d[k];
  return r;
}
template <int N>
inline Dual<N> operator+(const Dual<N>& a, const Dual<N>& b) {
  Dual<N> r;
  r.v = a.v + b.v;
  for (int k = 0; k < N; ++k) r.d[k] = a.d[k] + b.d[k];
  return r;
}
template <int N>
inline Dual<N> operator-(const Dual<N>& a, const Dual<N>& b) {
  Dual<N> r;
  r.v = a.v - b.v;
  for (int k = 0; k < N; ++k) r.d[k] = a.d[k] - b.d[k];
  return r;
}
template <int N>
inline Dual<N> operator*(const Dual<N>& a, const Dual<N>& b) {
  Dual<N> r;
  r.v = a.v * b.v;
  for (int k = 0; k < N; ++k) r.d[k] = a.d[k] * b.v + a.v * b.d[k];
  return r;
}
template <int N>
inline Dual<N> operator/(const Dual<N>& a, const Dual<N>& b) {
  Dual<N> r;
  const double ib = 1.0 / b.v;
  r.v = a.v * ib;
  for (int k = 0; k < N; ++k) r.d[k] = (a.d[k] - r.v * b.d[k]) * ib;
  return r;
}
template <int N>
inline Dual<N> operator+(const Dual<N>& a, double c) {
  Dual<N> r = a;
  r.v += c;
  return r;
}
template <int N>
inline Dual<N> operator+(double c, const Dual<N>& a) {
  return a + c;
}
template <int N>
inline Dual<N> operator-(const Dual<N>& a, double c) {
  Dual<N> r = a;
  r.v -= c;
  return r;
}
template <int N>
inline Dual<N> operator-(double c, const Dual<N>& a) {
  Dual<N> r = -a;
  r.v += c;
  return r;
}
template <int N>
inline Dual<N> operator*(const Dual<N>& a, double c) {
  Dual<N> r;
  r.v = a.v * c;
  for (int k = 0; k < N; ++k) r.d[k] = a.d[k] * c;
  return r;
}
template <int N>
inline Dual<N> operator*(double c, const Dual<N>& a) {
  return a * c;
}
template <int N>
inline Dual<N> operator/(const Dual<N>& a, double c) {
  return a * (1.0 / c);
}
template <int N>
inline Dual<N> operator/(double c, const Dual<N>& b) {
  Dual<N> r;
  const double ib = 1.0 / b.v;
  r.v = c * ib;
  const double f = -r.v * ib;
  for (int k = 0; k < N; ++k) r.d[k] = f * b.d[k];
  return r;
}
template <int N>
inline Dual<N> chain(const Dual<N>& a, double value, double slope) {
  Dual<N> r;
  r.v = value;
  for (int k = 0; k < N; ++k) r.d[k] = slope * a.d[k];
  return r;
}
template <int N>
inline Dual<N> sin(const Dual<N>& a) {
  return chain(a, std::sin(a.v), std::cos(a.v));
}
template <int N>
inline Dual<N> cos(const Dual<N>& a) {
  return chain(a, std::cos(a.v), -std::sin(a.v));
}
template <int N>
inline Dual<N> sqrt(const Dual<N>& a) {
  const double s = std::sqrt(a.v);
  return chain(a, s, s > 0.0 ? 0.5 / s : 0.0);
}
// Fused forms of frequent expressions: the same operations in the same order as the plain expressions (so the same
// results, bit for bit), without the temporaries.
/// a b + c d
template <int N>
inline Dual<N> mulAdd(const Dual<N>& a, const Dual<N>& b, const Dual<N>& c, const Dual<N>& d) {
  Dual<N> r;
  r.v = a.v * b.v + c.v * d.v;
  for (int k = 0; k < N; ++k) r.d[k] = (a.d[k] * b.v + a.v * b.d[k]) + (c.d[k] * d.v + c.v * d.d[k]);
  return r;
}
inline double mulAdd(double a, double b, double c, double d) {
  return a * b + c * d;
}
/// a b - c d
template <int N>
inline Dual<N> mulSub(const Dual<N>& a, const Dual<N>& b, const Dual<N>& c, const Dual<N>& d) {
  Dual<N> r;
  r.v = a.v * b.v - c.v * d.v;
  for (int k = 0; k < N; ++k) r.d[k] = (a.d[k] * b.v + a.v * b.d[k]) - (c.d[k] * d.v + c.v * d.d[k]);
  return r;
}
inline double mulSub(double a, double b, double c, double d) {
  return a * b - c * d;
}

/// Number of derivative directions of a scalar type (0 for double).
template <class T>
struct DerivativeCount {
  static constexpr int value = 0;
};
template <int N>
struct DerivativeCount<Dual<N>> {
  static constexpr int value = N;
};
template <class T>
constexpr int derivativeCount() {
  return DerivativeCount<T>::value;
}

/// The directions in which a has a nonzero derivative (at most N), for the sparse products below.
template <int N>
inline int nonzeroDirections(const Dual<N>& a, int* idx) {
  int cnt = 0;
  for (int k = 0; k < N; ++k)
    if (a.d[k] != 0.0) idx[cnt++] = k;
  return cnt;
}
inline int nonzeroDirections(double, int*) {
  return 0;
}
/// ys[d] = y[d] + c x[d] (d < dim) for a c whose derivative is nonzero only in the directions cidx[0 .. cnt) (e.g.
/// a step size that depends on a few translations): the dense part per entry, then those directions over all
/// entries (the same sums as the plain expression, in another order).
template <int N>
inline void axpySparse(Dual<N>* __restrict ys, const Dual<N>* __restrict y, const Dual<N>& c,
                       const Dual<N>* __restrict x, int dim, const int* cidx, int cnt) {
  for (int e = 0; e < dim; ++e) {
    ys[e].v = y[e].v + c.v * x[e].v;
    for (int k = 0; k < N; ++k) ys[e].d[k] = y[e].d[k] + c.v * x[e].d[k];
  }
  for (int q = 0; q < cnt; ++q) {
    const int k = cidx[q];
    const double ck = c.d[k];
    for (int e = 0; e < dim; ++e) ys[e].d[k] += ck * x[e].v;
  }
}
inline void axpySparse(double* __restrict ys, const double* __restrict y, double c, const double* __restrict x, int dim,
                       const int*, int) {
  for (int e = 0; e < dim; ++e) ys[e] = y[e] + c * x[e];
}
/// y[d] += h (k1 + 2 k2 + 2 k3 + k4)[d] (d < dim), the RK4 update, for such a sparse h.
template <int N>
inline void rk4SumSparse(Dual<N>* __restrict y, const Dual<N>& h, const Dual<N>* __restrict k1,
                         const Dual<N>* __restrict k2, const Dual<N>* __restrict k3, const Dual<N>* __restrict k4,
                         int dim, const int* hidx, int cnt) {
  for (int e = 0; e < dim; ++e) {
    y[e].v += h.v * (k1[e].v + 2.0 * k2[e].v + 2.0 * k3[e].v + k4[e].v);
    for (int k = 0; k < N; ++k) y[e].d[k] += h.v * (k1[e].d[k] + 2.0 * k2[e].d[k] + 2.0 * k3[e].d[k] + k4[e].d[k]);
  }
  for (int q = 0; q < cnt; ++q) {
    const int k = hidx[q];
    const double hk = h.d[k];
    for (int e = 0; e < dim; ++e) y[e].d[k] += hk * (k1[e].v + 2.0 * k2[e].v + 2.0 * k3[e].v + k4[e].v);
  }
}
inline void rk4SumSparse(double* __restrict y, double h, const double* __restrict k1, const double* __restrict k2,
                         const double* __restrict k3, const double* __restrict k4, int dim, const int*, int) {
  for (int e = 0; e < dim; ++e) y[e] += h * (k1[e] + 2.0 * k2[e] + 2.0 * k3[e] + k4[e]);
}

/// sin and cos of one argument (one sincos for the value).
template <int N>
inline void sinCos(const Dual<N>& a, Dual<N>& s, Dual<N>& c) {
  double sv, cv;
  ::sincos(a.v, &sv, &cv);
  s = chain(a, sv, cv);
  c = chain(a, cv, -sv);
}
inline void sinCos(double a, double& s, double& c) {
  ::sincos(a, &s, &c);
}

inline double value(double x) {
  return x;
}
template <int N>
inline double value(const Dual<N>& x) {
  return x.v;
}

}  // namespace ctr::detail
