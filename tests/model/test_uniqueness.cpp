// The certificate of one equilibrium per torque vector (model/uniqueness.hpp): against the classic two-tube bound,
// under refinement, and against the model's own equilibria (continuations from both sides of a rotation, solves with
// friction torques at the band's vertices).
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "ctr/model/friction.hpp"
#include "ctr/model/kinematics.hpp"
#include "ctr/model/uniqueness.hpp"
#include "tube_factory.hpp"

namespace ctr {
namespace {

constexpr double kL = 0.08;  // overlap of the curved parts (m)

// Two tubes curved over their whole length, both proximal ends at s = 0 (no transmission length), the inner one
// 10 mm longer: they couple over [0, kL] only, with b = kb1 kb2 k1 k2 / (kb1 + kb2). `scale` scales both
// precurvatures.
Robot overlappingPair(double scale) {
  Tube outer = test::makeTube("outer", 0.0, kL, 12.0 * scale, 0.02, 0.3);
  Tube inner = test::makeTube("inner", 0.0, kL + 0.01, 10.0 * scale, 0.012, 0.3);
  outer.outer_diameter = 2e-3;
  outer.inner_diameter = 1.6e-3;
  inner.outer_diameter = 1.4e-3;
  inner.inner_diameter = 1.0e-3;
  return Robot("overlapping_pair", {outer, inner}, {0.1, 0.0});
}

// The classic bound: the energy's lower bound Q is positive definite iff lambda = b L^2 (1/kt1 + 1/kt2) < pi^2 / 4
// (fixed rotations at s = 0, free ends at s = L). Returns lambda / (pi^2 / 4).
double analyticInteraction(const Robot& r) {
  const Tube &a = r.tube(0), &b = r.tube(1);
  const double coupling = a.bending_stiffness * b.bending_stiffness * a.curvature * b.curvature /
                          (a.bending_stiffness + b.bending_stiffness);
  return coupling * kL * kL * (1.0 / a.torsional_stiffness + 1.0 / b.torsional_stiffness) / (M_PI * M_PI / 4.0);
}

// The curvature scale that gives the pair an analytic interaction `target`.
double scaleFor(double target) {
  return std::sqrt(target / analyticInteraction(overlappingPair(1.0)));
}

Configuration atRotation(double alpha2) {
  return Configuration(Eigen::Vector2d(0.0, alpha2), Eigen::Vector2d(0.0, 0.0));
}

TEST(Uniqueness, TwoTubesGiveTheClassicBoundPiSquaredOverFour) {
  for (double target : {0.5, 0.9, 1.05, 1.6}) {
    const Robot r = overlappingPair(scaleFor(target));
    ASSERT_NEAR(analyticInteraction(r), target, 1e-12);
    UniquenessOptions o;
    o.measure = true;
    o.max_element = kL / 400;
    const UniquenessCertificate c = uniquenessCertificate(r, atRotation(0.7), o);
    // Rayleigh-Ritz: the discrete quotient is a lower bound of the continuous one, close at this resolution.
    EXPECT_LE(c.interaction, target * (1 + 1e-12)) << target;
    EXPECT_NEAR(c.interaction, target, 1e-4 * target) << target;
    // Certified exactly below 1 - margin (the rotations do not enter).
    EXPECT_EQ(c.certified(), target < 1.0 - o.margin) << target;
    EXPECT_EQ(uniquenessCertificate(r, atRotation(3.0), o).certified(), c.certified());
  }
}

TEST(Uniqueness, TheDiscreteBoundConvergesAtSecondOrder) {
  const Robot r = overlappingPair(scaleFor(0.9));
  std::vector<double> error;
  for (int elements : {5, 10, 20, 40}) {
    UniquenessOptions o;
    o.measure = true;
    o.min_elements = 1;
    o.max_element = kL / elements;
    error.push_back(0.9 - uniquenessCertificate(r, atRotation(0.0), o).interaction);
  }
  for (std::size_t k = 1; k < error.size(); ++k) {
    EXPECT_GT(error[k], 0.0);
    EXPECT_NEAR(error[k - 1] / error[k], 4.0, 0.3) << "elements " << (5 << k);
  }
  // The default resolution's error is far inside the margin.
  UniquenessOptions d;
  d.measure = true;
  EXPECT_LT(0.9 - uniquenessCertificate(r, atRotation(0.0), d).interaction, 0.1 * d.margin);
}

// The model's frictionless equilibria at relative rotations around pi, continued from 0 upwards and from 2 pi
// (the tubes aligned again) downwards: one equilibrium when certified, two stable ones somewhere when the
// interaction is above the bound. With friction torques at the vertices of the band, Newton started from either
// branch converges to the same equilibrium when certified.
TEST(Uniqueness, CertifiedMeansOneEquilibriumInTheModel) {
  Workspace ws;
  for (double target : {0.8, 1.8}) {
    const Robot r = overlappingPair(scaleFor(target));
    const bool certified = uniquenessCertificate(r, atRotation(0.0)).certified();
    EXPECT_EQ(certified, target < 1.0);
    Solution up = solve(r, atRotation(0.0), ws), down = solve(r, atRotation(2 * M_PI), ws);
    ASSERT_TRUE(up.converged() && down.converged());
    double widest = 0.0;
    for (int k = 1; k <= 12; ++k) {
      const double a = M_PI - 0.6 + 0.1 * k;  // 2.64 .. 3.74 rad
      up = continueTo(r, up, atRotation(a), ws);
      ASSERT_TRUE(up.converged()) << a;
      const Solution from_above = continueTo(r, down, atRotation(a), ws);
      ASSERT_TRUE(from_above.converged()) << a;
      if (up.summary.stable && from_above.summary.stable)
        widest = std::max(widest, (up.tip_position - from_above.tip_position).norm());
      if (certified) {
        EXPECT_TRUE(up.summary.stable) << a;
        // Vertex torques (slipping at the bound, both signs) from either branch: the same equilibrium.
        for (double f : {-1.0, 1.0}) {
          const std::vector<ContactCondition> c(contactSites(r, atRotation(a)).size(),
                                                ContactCondition{ContactCondition::Law::Torque, f});
          const Solution x = solveWithContacts(r, atRotation(a), c, ws, {}, &up);
          const Solution y = solveWithContacts(r, atRotation(a), c, ws, {}, &from_above);
          ASSERT_TRUE(x.converged() && y.converged()) << a;
          EXPECT_LT((x.tip_position - y.tip_position).norm(), 1e-6) << a << " " << f;
        }
      }
    }
    if (certified)
      EXPECT_LT(widest, 1e-6);
    else
      EXPECT_GT(widest, 1e-3) << "the uncertified pair must hold two stable equilibria somewhere near pi";
  }
}

// Around a friction band only the relative angles the band spans enter. The uncertified pair, its inner tube turned
// from the aligned tubes: the band followed along the turn stays converged and stable, and is certified while its
// relative angles stay away from pi; at 3.4 rad they reach it where the tubes couple and the band is not certified --
// the branch ends 0.2 rad further on (the followed band snaps to the other branch). The cold band at 3.4 rad, on
// that other branch, is certified.
TEST(Uniqueness, AroundABandTheBandsRelativeAnglesDecide) {
  const Robot r = overlappingPair(scaleFor(1.8));
  ASSERT_FALSE(uniquenessCertificate(r, atRotation(0.0)).certified());
  Workspace ws;
  FrictionBandOptions o;
  o.kinematics.record_tube_states = true;
  FrictionBand followed = frictionBand(r, atRotation(0.0), ws, o);
  for (int k = 1; k <= 34; ++k) {
    FrictionBandOptions f = o;
    f.follow = &followed;
    FrictionBand next = frictionBand(r, atRotation(0.1 * k), ws, f);
    ASSERT_TRUE(next.converged) << next.message;
    for (const Solution& s : next.shapes) ASSERT_TRUE(s.summary.stable) << 0.1 * k;
    ASSERT_LT((next.shapes[0].twist - followed.shapes[0].twist).cwiseAbs().maxCoeff(), 0.5) << "no snap";
    followed = std::move(next);
    EXPECT_EQ(uniquenessCertificate(r, followed).certified(), k <= 33) << 0.1 * k;
  }
  const FrictionBand cold = frictionBand(r, atRotation(3.4), ws, o);
  ASSERT_TRUE(cold.converged) << cold.message;
  EXPECT_GT((cold.shapes[0].twist - followed.shapes[0].twist).cwiseAbs().maxCoeff(), 2.0) << "another branch";
  EXPECT_TRUE(uniquenessCertificate(r, cold).certified());
  // ... and the followed branch ends: 0.2 rad further on it snaps to the cold band's branch.
  FrictionBandOptions f = o;
  f.follow = &followed;
  const FrictionBand beyond = frictionBand(r, atRotation(3.6), ws, f);
  ASSERT_TRUE(beyond.converged);
  EXPECT_GT((beyond.shapes[0].twist - followed.shapes[0].twist).cwiseAbs().maxCoeff(), 2.0);
  // Misuse: shapes without the tubes' angles.
  FrictionBandOptions bare;
  bare.kinematics.record_tube_states = false;
  EXPECT_THROW(uniquenessCertificate(r, frictionBand(r, atRotation(0.4), ws, bare)), std::invalid_argument);
}

}  // namespace
}  // namespace ctr
