// Internal: one SE(3) exponential step of the backbone pose with a body twist (w = (wx, wy, 0), v = (0, 0, a)),
// used by the 4th-order commutator-free Lie-group integrator of the backbone.
#pragma once

#include <Eigen/Core>
#include <cmath>

namespace ctr::detail {

// sin(t)/t, (1-cos t)/t^2, (t - sin t)/t^3 of x = t^2, and dB/dx, dC/dx.
struct ExpCoefficients {
  double A, B, C, dB, dC;
};

// Power series in x up to x^6 for x <= 0.04 (truncation < 1e-20; the usual case, t = h |u0| per half step), the
// closed forms otherwise.
inline ExpCoefficients expCoefficientsOf(double x, bool withC, bool withDerivatives) {
  ExpCoefficients e{};
  if (x <= 0.04) {
    e.A =
        1.0 + x * (-1.0 / 6 +
                   x * (1.0 / 120 + x * (-1.0 / 5040 + x * (1.0 / 362880 + x * (-1.0 / 39916800 + x / 6227020800.0)))));
    e.B = 0.5 +
          x * (-1.0 / 24 +
               x * (1.0 / 720 + x * (-1.0 / 40320 + x * (1.0 / 3628800 + x * (-1.0 / 479001600 + x / 87178291200.0)))));
    if (withC)
      e.C = 1.0 / 6 +
            x * (-1.0 / 120 +
                 x * (1.0 / 5040 +
                      x * (-1.0 / 362880 + x * (1.0 / 39916800 + x * (-1.0 / 6227020800.0 + x / 1307674368000.0)))));
    if (withDerivatives) {
      e.dB =
          -1.0 / 24 +
          x * (2.0 / 720 + x * (-3.0 / 40320 + x * (4.0 / 3628800 + x * (-5.0 / 479001600 + x * 6.0 / 87178291200.0))));
      e.dC = -1.0 / 120 +
             x * (2.0 / 5040 +
                  x * (-3.0 / 362880 + x * (4.0 / 39916800 + x * (-5.0 / 6227020800.0 + x * 6.0 / 1307674368000.0))));
    }
  } else {
    const double th = std::sqrt(x);
    double sn, cs;
    ::sincos(th, &sn, &cs);
    e.A = sn / th;
    e.B = (1.0 - cs) / x;
    if (withC) e.C = (th - sn) / (x * th);
    if (withDerivatives) {
      e.dB = (0.5 * e.A - e.B) / x;
      e.dC = (0.5 * e.B - 1.5 * e.C) / x;
    }
  }
  return e;
}

/// (R, p) <- (R, p) * exp(xi), exact (Rodrigues + SE(3) left Jacobian), with series near zero rotation.
inline void se3Step(Eigen::Matrix3d& R, Eigen::Vector3d& p, const Eigen::Vector2d& w, double a) {
  const double wx = w.x(), wy = w.y(), x = wx * wx + wy * wy;
  const ExpCoefficients c = expCoefficientsOf(x, true, false);
  Eigen::Matrix3d E;
  E << 1.0 - c.B * wy * wy, c.B * wx * wy, c.A * wy,  //
      c.B * wx * wy, 1.0 - c.B * wx * wx, -c.A * wx,  //
      -c.A * wy, c.A * wx, 1.0 - c.B * x;
  p += R * Eigen::Vector3d(a * c.B * wy, -a * c.B * wx, a * (1.0 - c.C * x));  // R V(w) e_z a
  R = R * E;
}

}  // namespace ctr::detail
