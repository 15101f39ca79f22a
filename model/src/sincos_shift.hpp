// Internal: sines and cosines of RK4 stage angles from those of the step's first stage (angle addition).
#pragma once

#include <cmath>

namespace ctr::detail {

// sin and cos of theta0 + d from those of theta0 (s0, c0): the angle-addition formulas with sin d and cos d from
// their Taylor polynomials (truncation < 1e-19: degree 10 for |d| <= 0.1, the usual case, 16 up to 0.5), libm
// beyond.
inline void sinCosShifted(double theta, double s0, double c0, double d, double& s, double& c) {
  const double x = d * d;
  double sd, cd;
  if (x <= 0.01) {
    sd = d * (1.0 + x * (-1.0 / 6 + x * (1.0 / 120 + x * (-1.0 / 5040 + x * (1.0 / 362880)))));
    cd = 1.0 + x * (-0.5 + x * (1.0 / 24 + x * (-1.0 / 720 + x * (1.0 / 40320 + x * (-1.0 / 3628800)))));
  } else if (x <= 0.25) {
    sd = d * (1.0 + x * (-1.0 / 6 +
                         x * (1.0 / 120 +
                              x * (-1.0 / 5040 +
                                   x * (1.0 / 362880 + x * (-1.0 / 39916800 + x * (1.0 / 6227020800.0 +
                                                                                   x * (-1.0 / 1307674368000.0))))))));
    cd = 1.0 + x * (-0.5 + x * (1.0 / 24 +
                                x * (-1.0 / 720 +
                                     x * (1.0 / 40320 +
                                          x * (-1.0 / 3628800 + x * (1.0 / 479001600 + x * (-1.0 / 87178291200.0 +
                                                                                            x / 20922789888000.0)))))));
  } else {
    ::sincos(theta, &s, &c);
    return;
  }
  s = s0 * cd + c0 * sd;
  c = c0 * cd - s0 * sd;
}

}  // namespace ctr::detail
