// The integrators' elementary functions (internal headers): the angle addition that replaces libm's sincos in the
// later RK4 stages, and the SO(3)/SE(3) exponential coefficients with their derivatives (series near zero).
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "se3_step.hpp"
#include "sincos_shift.hpp"

using namespace ctr::detail;

TEST(IntegratorNumerics, AngleAdditionMatchesLibmToRounding) {
  // The polynomial branches (|d| <= 0.1: degree 10; up to 0.5: degree 16) against sin and cos of the exact sum
  // t0 + d (long double: the rounding of t0 + d is not the method's); beyond 0.5 libm of the angle passed.
  std::mt19937_64 rng(1);
  std::uniform_real_distribution<double> th(-20.0, 20.0), dd(-0.7, 0.7);
  double worst = 0.0, worst_libm = 0.0;
  int polynomial = 0;
  for (int k = 0; k < 200000; ++k) {
    const double t0 = th(rng), d = k % 2 ? dd(rng) : 0.1 * dd(rng);
    double s0, c0, s, c;
    ::sincos(t0, &s0, &c0);
    const double t = t0 + d;
    sinCosShifted(t, s0, c0, d, s, c);
    if (std::abs(d) <= 0.5) {
      const long double ref = static_cast<long double>(t0) + static_cast<long double>(d);
      worst = std::max({worst, std::abs(s - static_cast<double>(std::sin(ref))),
                        std::abs(c - static_cast<double>(std::cos(ref)))});
      ++polynomial;
    } else {
      worst_libm = std::max({worst_libm, std::abs(s - std::sin(t)), std::abs(c - std::cos(t))});
    }
  }
  std::printf("[ measured ] angle addition (%d polynomial cases) vs sin/cos of the exact sum: worst %.1e; libm branch "
              "%.1e\n",
              polynomial, worst, worst_libm);
  EXPECT_GT(polynomial, 150000);
  EXPECT_LT(worst, 6e-16);  // a few roundings of numbers <= 1
  EXPECT_EQ(worst_libm, 0.0);
}

TEST(IntegratorNumerics, ExpCoefficientsAndDerivativesMatchTheirSeries) {
  // A = sin t / t, B = (1 - cos t) / t^2, C = (t - sin t) / t^3 of x = t^2, and dB/dx, dC/dx, as used (hand-written
  // series for x <= 0.04, closed forms beyond), against their full Taylor series summed in long double from the
  // general term (A = sum (-x)^k / (2k+1)!, B: (2k+2)!, C: (2k+3)!), on both sides of the switch.
  auto series = [](long double x, int offset, bool derivative) {
    long double sum = 0, fact = 1;
    for (int j = 1; j <= offset; ++j) fact *= j;
    for (int k = 0; k < 40; ++k) {
      if (k > 0) fact *= (2 * k + offset - 1) * (2 * k + offset);
      const long double sign = k % 2 ? -1 : 1;
      if (!derivative) sum += sign * std::pow(x, k) / fact;
      else if (k > 0) sum += sign * k * std::pow(x, k - 1) / fact;
    }
    return static_cast<double>(sum);
  };
  double worst_series = 0.0, worst_closed = 0.0, worst_d = 0.0;
  for (double x : {1e-6, 1e-4, 1e-3, 0.01, 0.03, 0.0399, 0.04, 0.0401, 0.1, 0.5, 2.0}) {
    const ExpCoefficients e = expCoefficientsOf(x, true, true);
    const double err = std::max({std::abs(e.A - series(x, 1, false)), std::abs(e.B - series(x, 2, false)),
                                 std::abs(e.C - series(x, 3, false))});
    (x <= 0.04 ? worst_series : worst_closed) = std::max(x <= 0.04 ? worst_series : worst_closed, err);
    worst_d = std::max({worst_d, std::abs(e.dB - series(x, 2, true)), std::abs(e.dC - series(x, 3, true))});
  }
  std::printf("[ measured ] exp coefficients: series branch %.1e, closed forms %.1e, derivatives %.1e\n", worst_series,
              worst_closed, worst_d);
  EXPECT_LT(worst_series, 2e-16);
  EXPECT_LT(worst_closed, 1e-14);  // cancellation in 1 - cos t and t - sin t just above the switch
  EXPECT_LT(worst_d, 1e-12);
}

TEST(IntegratorNumerics, Se3StepIsAnExactRotationAndComposesAlongAnArc) {
  // Constant curvature k along the x axis of the body: 10 steps of length h equal one step of length 10 h (a
  // circular arc), and R stays orthonormal.
  const double k = 7.0, h = 0.01;
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity(), R1 = R;
  Eigen::Vector3d p = Eigen::Vector3d::Zero(), p1 = p;
  for (int i = 0; i < 10; ++i) se3Step(R, p, Eigen::Vector2d(k * h, 0.0), h);
  se3Step(R1, p1, Eigen::Vector2d(k * 10 * h, 0.0), 10 * h);
  EXPECT_LT((R - R1).norm(), 1e-14);
  EXPECT_LT((p - p1).norm(), 1e-15);
  EXPECT_LT((R.transpose() * R - Eigen::Matrix3d::Identity()).norm(), 1e-14);
  // The arc: rotation about x by k s; the tip at (0, -(1 - cos ks)/k, sin(ks)/k).
  const double s = 10 * h;
  EXPECT_LT((p - Eigen::Vector3d(0.0, -(1 - std::cos(k * s)) / k, std::sin(k * s) / k)).norm(), 1e-15);
}
