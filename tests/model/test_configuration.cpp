// Admissibility: projectAdmissible projects configurations read from files (rounded values) onto the admissible set
// when they violate it by at most kAdmissibilityTolerance, and refuses larger violations naming the constraint.
#include <gtest/gtest.h>

#include <cstring>
#include <limits>

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
