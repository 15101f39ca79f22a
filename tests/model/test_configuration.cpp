// Admissibility: projectAdmissible projects configurations read from files (rounded values) onto the admissible set
// when they violate it by at most kAdmissibilityTolerance, and refuses larger violations naming the constraint.
// Motion discretisation: subdivisions counts the sub-steps of a straight move, interpolate gives the configurations
// along it.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>

#include "ctr/model/configuration.hpp"
#include "tube_factory.hpp"

using namespace ctr;

namespace {

// Three tubes, 0.10 / 0.15 / 0.20 m long: at beta = (-0.03, -0.08, -0.13) the three distal ends coincide (0.07 m).
Robot threeTubes(bool limits = false) {
  Tube a = test::makeTube("outer", 0.05, 0.05, 5.0, 0.03, 0.3);
  Tube b = test::makeTube("middle", 0.10, 0.05, 8.0, 0.02, 0.3);
  Tube c = test::makeTube("inner", 0.15, 0.05, 12.0, 0.01, 0.3);
  if (limits) {
    b.rotation_limits = std::array<double, 2>{-1.0, 1.0};
    c.translation_limits = std::array<double, 2>{-0.20, -0.05};
  }
  return Robot("three_coincident", {a, b, c});
}

Configuration coincident() {
  return Configuration(Eigen::Vector3d(0.1, -0.2, 0.3), Eigen::Vector3d(-0.03, -0.08, -0.13));
}

bool sameBits(const Configuration& x, const Configuration& y) {
  return x.alpha.size() == y.alpha.size() && x.beta.size() == y.beta.size() &&
         std::memcmp(x.alpha.data(), y.alpha.data(), sizeof(double) * static_cast<std::size_t>(x.alpha.size())) == 0 &&
         std::memcmp(x.beta.data(), y.beta.data(), sizeof(double) * static_cast<std::size_t>(x.beta.size())) == 0;
}

double maxChange(const Configuration& x, const Configuration& y) {
  return std::max((x.alpha - y.alpha).cwiseAbs().maxCoeff(), (x.beta - y.beta).cwiseAbs().maxCoeff());
}

}  // namespace

TEST(Admissibility, ToleranceIsOneMicrometre) { EXPECT_EQ(kAdmissibilityTolerance, 1e-6); }

TEST(Admissibility, InnerEndBehindByRoundingIsProjectedToCoincidentEnds) {
  const Robot r = threeTubes();
  for (const double behind : {1e-10, 5e-7}) {
    for (int tube = 1; tube < 3; ++tube) {
      Configuration q = coincident();
      for (int i = tube; i < 3; ++i) q.beta[i] -= behind;  // inner end(s) behind the next outer end
      const Configuration raw = q;
      ASSERT_FALSE(checkAdmissible(r, q)) << behind;
      const Admissibility a = projectAdmissible(r, q);
      ASSERT_TRUE(a) << behind << ": " << a.message;
      EXPECT_TRUE(checkAdmissible(r, q)) << checkAdmissible(r, q).message;
      // Ends exactly ordered (no floating-point slack at all) and the robot as it was otherwise.
      EXPECT_TRUE(checkAdmissible(r, q, 0.0)) << checkAdmissible(r, q, 0.0).message;
      for (int i = 0; i + 1 < 3; ++i) EXPECT_GE(distalEnd(r, q, i + 1), distalEnd(r, q, i));
      EXPECT_NEAR(distalEnd(r, q, tube), distalEnd(r, q, tube - 1), 1e-15);
      EXPECT_LE(maxChange(q, raw), kAdmissibilityTolerance);
      EXPECT_TRUE(sameBits(Configuration(q.alpha, q.beta.head(tube)), Configuration(raw.alpha, raw.beta.head(tube))))
          << "outer tubes and rotations must not move";
    }
  }
}

TEST(Admissibility, EqualLengthsGiveEqualTranslations) {
  // Pair-B-like: two tubes of the same length; a rounded beta_2 behind beta_1 becomes beta_1 exactly.
  const Robot r("pair", {test::makeTube("outer", 0.018, 0.15, 6.5, 0.0334, 0.6),
                         test::makeTube("inner", 0.018, 0.15, 6.5, 0.0511, 0.6)});
  Configuration q(Eigen::Vector2d(0.0, 1.0), Eigen::Vector2d(-0.018, -0.0180000001));
  ASSERT_TRUE(projectAdmissible(r, q));
  EXPECT_EQ(q.beta[1], q.beta[0]);
  EXPECT_EQ(q.beta[0], -0.018);
}

TEST(Admissibility, TranslationAndRotationSlightlyOutsideAreClamped) {
  const Robot r = threeTubes(true);
  // beta_1 = +3e-7 > 0: projected to 0 (the other tubes stay where they are).
  Configuration q(Eigen::Vector3d(0.0, 0.0, 0.0), Eigen::Vector3d(3e-7, -0.04, -0.08));
  ASSERT_FALSE(checkAdmissible(r, q));
  const Configuration raw = q;
  ASSERT_TRUE(projectAdmissible(r, q));
  EXPECT_EQ(q.beta[0], 0.0);
  EXPECT_EQ(q.beta[1], raw.beta[1]);
  EXPECT_EQ(q.beta[2], raw.beta[2]);
  // beta_2 3e-7 in front of beta_1 (inner tube starting ahead of the outer one): beta_2 = beta_1.
  q = Configuration(Eigen::Vector3d(0.0, 0.0, 0.0), Eigen::Vector3d(-0.03, -0.03 + 3e-7, -0.06));
  ASSERT_TRUE(projectAdmissible(r, q));
  EXPECT_EQ(q.beta[1], -0.03);
  // Rotation 5e-7 rad outside rotation_limits [-1, 1] of tube 2: clamped to the limit.
  q = Configuration(Eigen::Vector3d(2.0, 1.0 + 5e-7, 0.0), Eigen::Vector3d(-0.03, -0.08, -0.13));
  ASSERT_FALSE(checkAdmissible(r, q));
  ASSERT_TRUE(projectAdmissible(r, q));
  EXPECT_EQ(q.alpha[1], 1.0);
  EXPECT_EQ(q.alpha[0], 2.0);
  q.alpha[1] = -1.0 - 5e-7;
  ASSERT_TRUE(projectAdmissible(r, q));
  EXPECT_EQ(q.alpha[1], -1.0);
  // Translation 5e-7 beyond translation_limits [-0.20, -0.05] of tube 3: clamped.
  q = Configuration(Eigen::Vector3d::Zero(), Eigen::Vector3d(-0.03, -0.04, -0.05 + 5e-7));
  ASSERT_FALSE(checkAdmissible(r, q));
  ASSERT_TRUE(projectAdmissible(r, q)) << checkAdmissible(r, q).message;
  EXPECT_EQ(q.beta[2], -0.05);
}

TEST(Admissibility, LargerViolationsAreRefusedNamingTheConstraintAndLeaveQUnchanged) {
  const Robot r = threeTubes(true);
  for (const double behind : {2e-6, 1e-3}) {
    Configuration q = coincident();
    q.beta[2] -= behind;
    const Configuration raw = q;
    const Admissibility a = projectAdmissible(r, q);
    ASSERT_FALSE(a) << behind;
    EXPECT_NE(a.message.find("distal end of tube 3"), std::string::npos) << a.message;
    EXPECT_NE(a.message.find("behind the end of tube 2"), std::string::npos) << a.message;
    EXPECT_TRUE(sameBits(q, raw));
  }
  Configuration q(Eigen::Vector3d::Zero(), Eigen::Vector3d(2e-6, -0.04, -0.08));
  const Configuration raw = q;
  Admissibility a = projectAdmissible(r, q);
  ASSERT_FALSE(a);
  EXPECT_NE(a.message.find("beta_1"), std::string::npos) << a.message;
  EXPECT_TRUE(sameBits(q, raw));
  q = Configuration(Eigen::Vector3d(0.0, 1.0 + 2e-6, 0.0), Eigen::Vector3d(-0.03, -0.08, -0.13));
  a = projectAdmissible(r, q);
  ASSERT_FALSE(a);
  EXPECT_NE(a.message.find("rotation_limits"), std::string::npos) << a.message;
  EXPECT_EQ(q.alpha[1], 1.0 + 2e-6);
  // A custom tolerance: 2e-6 is accepted with 1e-5.
  q = coincident();
  q.beta[2] -= 2e-6;
  EXPECT_TRUE(projectAdmissible(r, q, 1e-5));
  EXPECT_TRUE(checkAdmissible(r, q, 0.0));
}

TEST(Admissibility, ViolationsThatAddUpBeyondTheToleranceAreRefused) {
  // Each end 8e-7 behind the next outer one: every constraint alone is within 1e-6, but making the ends coincide
  // moves tube 3 by 1.6e-6.
  const Robot r = threeTubes();
  Configuration q = coincident();
  q.beta[1] -= 8e-7;
  q.beta[2] -= 1.6e-6;
  const Configuration raw = q;
  const Admissibility a = projectAdmissible(r, q);
  ASSERT_FALSE(a);
  EXPECT_NE(a.message.find("distal end of tube 2"), std::string::npos) << a.message;
  EXPECT_NE(a.message.find("admissibility tolerance"), std::string::npos) << a.message;
  EXPECT_TRUE(sameBits(q, raw));
}

TEST(Admissibility, AdmissibleConfigurationsAreUnchangedBitForBit) {
  const Robot r = threeTubes(true);
  for (const Configuration& q0 :
       {coincident(), Configuration(Eigen::Vector3d(0.5, -1.0, 7.0), Eigen::Vector3d(-0.01, -0.05, -0.09)),
        Configuration(Eigen::Vector3d(0.0, 1.0, 0.0), Eigen::Vector3d(0.0, 0.0, -0.05))}) {
    ASSERT_TRUE(checkAdmissible(r, q0)) << checkAdmissible(r, q0).message;
    Configuration q = q0;
    ASSERT_TRUE(projectAdmissible(r, q));
    EXPECT_TRUE(sameBits(q, q0));
  }
}

TEST(Admissibility, WhatCannotBeProjectedIsReportedAsBefore) {
  const Robot r = threeTubes();
  Configuration q(Eigen::Vector2d::Zero(), Eigen::Vector2d::Zero());
  Admissibility a = projectAdmissible(r, q);
  ASSERT_FALSE(a);
  EXPECT_NE(a.message.find("3 tubes"), std::string::npos) << a.message;
  q = coincident();
  q.beta[1] = std::numeric_limits<double>::quiet_NaN();
  a = projectAdmissible(r, q);
  ASSERT_FALSE(a);
  EXPECT_NE(a.message.find("beta_2 is not finite"), std::string::npos) << a.message;
  // The innermost tube inside the actuation unit: not a rounding matter, never projected.
  q = Configuration(Eigen::Vector3d::Zero(), Eigen::Vector3d(-0.2, -0.25, -0.25));
  ASSERT_FALSE(checkAdmissible(r, q));
  a = projectAdmissible(r, q);
  ASSERT_FALSE(a);
  EXPECT_NE(a.message.find("does not leave the actuation unit"), std::string::npos) << a.message;
}

namespace {

Configuration twoTubes(double a1, double a2, double b1, double b2) {
  return Configuration(Eigen::Vector2d(a1, a2), Eigen::Vector2d(b1, b2));
}

}  // namespace

TEST(Subdivisions, NoMoveIsOneStep) {
  const Configuration q = twoTubes(0.3, -1.0, -0.01, -0.02);
  EXPECT_EQ(subdivisions(q, q, 0.01, 1e-3), 1);
  EXPECT_EQ(subdivisions(Configuration(), Configuration(), 0.01, 1e-3), 1);
}

TEST(Subdivisions, ExactMultiplesTakeThatManySteps) {
  // Moves that are whole multiples of the step, also where the division rounds to just above the integer
  // (3 * 0.1 / 0.1 = 3.0000000000000004, 15 * 0.0087 / 0.0087 = 15.000000000000002) or below it
  // (0.7 / 0.1 = 6.999999999999999).
  const Configuration o = twoTubes(0.0, 0.0, 0.0, 0.0);
  EXPECT_EQ(subdivisions(o, twoTubes(3 * 0.1, 0.0, 0.0, 0.0), 0.1, 1.0), 3);
  EXPECT_EQ(subdivisions(o, twoTubes(0.0, 15 * 0.0087, 0.0, 0.0), 0.0087, 1.0), 15);
  EXPECT_EQ(subdivisions(o, twoTubes(0.0, 31 * 0.0175, 0.0, 0.0), 0.0175, 1e-3), 31);
  EXPECT_EQ(subdivisions(o, twoTubes(0.0, 0.7, 0.0, 0.0), 0.1, 1.0), 7);
  EXPECT_EQ(subdivisions(o, twoTubes(0.0, 0.0, -0.006, 0.0), 1.0, 1e-3), 6);
  EXPECT_EQ(subdivisions(o, twoTubes(0.0, 0.0, 0.0, -0.0087 * 3), 1.0, 0.0087), 3);
  // Commands that are sums of steps (as a propagation accumulates them) and the step itself.
  double a = 0.0;
  for (int k = 0; k < 10; ++k) a += 0.0087;
  EXPECT_EQ(subdivisions(o, twoTubes(a, 0.0, 0.0, 0.0), 0.0087, 1.0), 10);
  EXPECT_EQ(subdivisions(o, twoTubes(0.0175, 0.0, 0.0, 0.0), 0.0175, 1e-3), 1);
}

TEST(Subdivisions, RoundsUpBeyondTheSlack) {
  const Configuration o = twoTubes(0.0, 0.0, 0.0, 0.0);
  EXPECT_EQ(subdivisions(o, twoTubes(0.1000001, 0.0, 0.0, 0.0), 0.1, 1.0), 2);
  EXPECT_EQ(subdivisions(o, twoTubes(0.25, 0.0, 0.0, 0.0), 0.1, 1.0), 3);
  EXPECT_EQ(subdivisions(o, twoTubes(0.01, 0.0, 0.0, 0.0), 0.1, 1.0), 1);
  // Within the slack of a whole number of steps: that number.
  EXPECT_EQ(subdivisions(o, twoTubes(0.2 * (1 + 0.1 * kSubdivisionSlack), 0.0, 0.0, 0.0), 0.2, 1.0), 1);
}

TEST(Subdivisions, LargestChangeOfAnyTubeDecides) {
  const Configuration from = twoTubes(1.0, -2.0, -0.010, -0.020);
  // Rotation of tube 2 by -0.45 rad (5 steps of 0.1); translation of tube 1 by 3.5 mm (4 steps of 1 mm).
  EXPECT_EQ(subdivisions(from, twoTubes(1.05, -2.45, -0.0135, -0.020), 0.1, 1e-3), 5);
  EXPECT_EQ(subdivisions(from, twoTubes(1.05, -2.05, -0.0135, -0.020), 0.1, 1e-3), 4);
  // Direction does not matter.
  EXPECT_EQ(subdivisions(twoTubes(1.05, -2.45, -0.0135, -0.020), from, 0.1, 1e-3), 5);
}

TEST(Subdivisions, RotationsAreNotWrapped) {
  // Commands are unwrapped: 2 pi is a full turn (friction and twist depend on it), not no move.
  const Configuration o = twoTubes(0.0, 0.0, 0.0, 0.0);
  EXPECT_EQ(subdivisions(o, twoTubes(2 * M_PI, 0.0, 0.0, 0.0), 0.0175, 1e-3), 360);
  EXPECT_EQ(subdivisions(twoTubes(3.0, 0.0, 0.0, 0.0), twoTubes(-3.0, 0.0, 0.0, 0.0), 0.1, 1.0), 60);
}

TEST(Subdivisions, RejectsBadInput) {
  const Configuration o = twoTubes(0.0, 0.0, 0.0, 0.0);
  const double inf = std::numeric_limits<double>::infinity(), nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(subdivisions(o, Configuration(Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()), 0.1, 1e-3),
               std::invalid_argument);
  EXPECT_THROW(subdivisions(o, o, 0.0, 1e-3), std::invalid_argument);
  EXPECT_THROW(subdivisions(o, o, 0.1, -1e-3), std::invalid_argument);
  EXPECT_THROW(subdivisions(o, twoTubes(inf, 0.0, 0.0, 0.0), 0.1, 1e-3), std::invalid_argument);
  EXPECT_THROW(subdivisions(o, twoTubes(0.0, 0.0, nan, 0.0), 0.1, 1e-3), std::invalid_argument);
  EXPECT_THROW(subdivisions(o, twoTubes(1e300, 0.0, 0.0, 0.0), 1e-300, 1e-3), std::invalid_argument);
}

TEST(Interpolate, EndpointsAreExact) {
  // 0.1 + 1 * (0.7 - 0.1) is not 0.7 in floating point; interpolate returns the end itself.
  const Configuration a = twoTubes(0.1, -1.3, -0.0123, -0.0456), b = twoTubes(0.7, 2.9, -0.0311, -0.0789);
  EXPECT_TRUE(sameBits(interpolate(a, b, 0.0), a));
  EXPECT_TRUE(sameBits(interpolate(a, b, 1.0), b));
  const int n = subdivisions(a, b, 0.0175, 1e-3);
  EXPECT_TRUE(sameBits(interpolate(a, b, static_cast<double>(n) / n), b));
}

TEST(Interpolate, StraightLineInUnwrappedCommands) {
  const Configuration a = twoTubes(3.0, 0.0, -0.01, -0.02), b = twoTubes(-3.0, 1.0, -0.03, -0.02);
  const Configuration m = interpolate(a, b, 0.25);
  EXPECT_DOUBLE_EQ(m.alpha[0], 1.5);  // through 0, not the short way across pi
  EXPECT_DOUBLE_EQ(m.alpha[1], 0.25);
  EXPECT_DOUBLE_EQ(m.beta[0], -0.015);
  EXPECT_DOUBLE_EQ(m.beta[1], -0.02);
  // Consecutive sub-steps stay within the step sizes subdivisions was given.
  const int n = subdivisions(a, b, 0.1, 1e-3);
  for (int k = 1; k <= n; ++k) {
    const Configuration p = interpolate(a, b, static_cast<double>(k - 1) / n), q = interpolate(a, b, double(k) / n);
    EXPECT_LE((q.alpha - p.alpha).cwiseAbs().maxCoeff(), 0.1 * (1 + 1e-12));
    EXPECT_LE((q.beta - p.beta).cwiseAbs().maxCoeff(), 1e-3 * (1 + 1e-12));
  }
}

TEST(Configuration, ZerosIsAllZero) {
  const Configuration q = Configuration::zeros(3);
  EXPECT_EQ(q.size(), 3);
  EXPECT_TRUE(q.alpha.isZero(0.0));
  EXPECT_TRUE(q.beta.isZero(0.0));
}
