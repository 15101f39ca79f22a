// The paper's numerical findings on distributed-contact friction (§II.C, Figs. 4-6), tube pair B at pi/2.
#include <gtest/gtest.h>

#include <cmath>

#include "ctr/model/distributed_friction.hpp"
#include "ctr/model/friction.hpp"

using namespace ctr;

namespace {

Tube makeTube(const std::string& name, double kb, double od, double id) {
  Tube t;
  t.name = name;
  t.straight_length = 0.018;
  t.curved_length = 0.150;
  t.curvature = 1 / 0.154;
  t.bending_stiffness = kb;
  t.torsional_stiffness = kb / 1.6;
  t.outer_diameter = od;
  t.inner_diameter = id;
  return t;
}

Robot pairB() { return Robot("B", {makeTube("outer", 0.0334, 2.77e-3, 2.55e-3), makeTube("inner", 0.0511, 2.41e-3, 1.97e-3)}); }

const Configuration kHalfPi(Eigen::Vector2d(0, M_PI / 2), Eigen::Vector2d(-0.018, -0.018));

DistributedFrictionSolution solveMu(double mu) {
  DistributedFrictionOptions o;
  o.mu = mu;
  o.direction = {1};
  return solveDistributedFriction(pairB(), kHalfPi, o);
}

}  // namespace

TEST(DistributedFriction, ZeroMuIsTheFrictionlessModel) {
  Workspace ws;
  const Solution ref = solve(pairB(), kHalfPi, ws);
  const DistributedFrictionSolution d = solveMu(0.0);
  ASSERT_TRUE(d.solution.converged()) << d.solution.summary.message;
  EXPECT_NEAR(d.solution.twist[0], ref.twist[0], 1e-9);
  EXPECT_LT((d.solution.tip_position - ref.tip_position).norm(), 1e-9);
  EXPECT_FALSE(d.used_default_radius);
}

TEST(DistributedFriction, TotalForceConstantNormalVanishesTorqueSaturates) {
  // Fig. 4-5: as mu grows |f| stays (nearly) constant, |f_n| -> 0 and the friction torque -> a finite asymptote.
  std::vector<double> mus{0.01, 0.1, 1.0, 10.0, 100.0, 1e5};
  std::vector<double> f, fn, tq;
  for (double mu : mus) {
    const DistributedFrictionSolution d = solveMu(mu);
    ASSERT_TRUE(d.solution.converged()) << d.solution.summary.message;
    ASSERT_FALSE(d.samples.empty());
    const DistributedForceSample& tip = d.samples.back();  // s = L
    EXPECT_NEAR(tip.s, d.solution.tipArcLength(), 1e-12);
    f.push_back(tip.force);
    fn.push_back(tip.normal_force);
    tq.push_back(tip.friction_torque);
  }
  for (std::size_t k = 0; k < mus.size(); ++k) EXPECT_NEAR(f[k], f[0], 0.02 * f[0]) << "mu = " << mus[k];
  for (std::size_t k = 1; k < mus.size(); ++k) {
    EXPECT_LT(fn[k], fn[k - 1]);
    EXPECT_GT(tq[k], tq[k - 1]);
  }
  EXPECT_LT(fn.back(), 1e-4 * fn.front());
  // The asymptote: r |f| at the contact radius.
  EXPECT_NEAR(tq.back(), 0.5 * 2.41e-3 * f.back(), 1e-6 * f.back());
  EXPECT_NEAR(tq[mus.size() - 2], tq.back(), 1e-4 * tq.back());
}

TEST(DistributedFriction, IntegratedTorqueTwoOrdersBelowBaseTorque) {
  const DistributedFrictionSolution d = solveMu(1e5);
  ASSERT_TRUE(d.solution.converged());
  const double base_torque = std::abs(pairB().tube(1).torsional_stiffness * d.solution.base_twist_rate[1]);
  EXPECT_GT(base_torque, 0.05);
  EXPECT_LT(d.integrated_friction_torque, 0.03 * base_torque);  // ~1.5 % here
  EXPECT_GT(d.integrated_friction_torque, 1e-4 * base_torque);  // but not zero: the model is active
}

TEST(DistributedFriction, EvenHugeMuChangesShapeNegligibly) {
  // Fig. 6: mu = 1e5 barely changes the twist rate and the tip.
  const DistributedFrictionSolution a = solveMu(0.0), b = solveMu(1e5);
  ASSERT_TRUE(a.solution.converged() && b.solution.converged());
  EXPECT_LT(std::abs(a.solution.twist[0] - b.solution.twist[0]), 0.02);  // rad (~1 deg)
  EXPECT_LT((a.solution.tip_position - b.solution.tip_position).norm(), 2e-4);  // m
  // Twist rate profile: relative difference along s small.
  ASSERT_EQ(a.solution.backbone.size(), b.solution.backbone.size());
  for (std::size_t k = 0; k < a.solution.backbone.size(); ++k) {
    const auto& pa = a.solution.backbone[k];
    const auto& pb = b.solution.backbone[k];
    const double ra = pa.uz[1] - pa.uz[0], rb = pb.uz[1] - pb.uz[0];
    EXPECT_LT(std::abs(ra - rb), 0.05 * std::abs(a.solution.base_twist_rate[1] - a.solution.base_twist_rate[0]) + 1e-9);
  }
}

TEST(DistributedFriction, OpposesTheRelativeRotationAndKeepsTorqueBalance) {
  const DistributedFrictionSolution d0 = solveMu(0.0);
  DistributedFrictionOptions o;
  o.mu = 1.0;
  o.direction = {1};
  const DistributedFrictionSolution up = solveDistributedFriction(pairB(), kHalfPi, o);
  o.direction = {-1};
  const DistributedFrictionSolution down = solveDistributedFriction(pairB(), kHalfPi, o);
  ASSERT_TRUE(up.solution.converged() && down.solution.converged());
  EXPECT_LT(up.solution.twist[0], d0.solution.twist[0]);    // lags when rotating positively
  EXPECT_GT(down.solution.twist[0], d0.solution.twist[0]);  // leads when rotating back
  for (const BackbonePoint& p : up.solution.backbone) {
    const double sum = pairB().tube(0).torsional_stiffness * p.uz[0] + pairB().tube(1).torsional_stiffness * p.uz[1];
    EXPECT_LT(std::abs(sum), 1e-9);
  }
}

TEST(DistributedFriction, SelectedThroughTheRobotFrictionBlockInReplay) {
  const Robot r = pairB().withFriction({0.0, 0.5});
  Workspace ws;
  FrictionOptions fo;
  fo.kinematics.record_backbone = false;
  std::vector<Configuration> path;
  for (int k = 0; k <= 9; ++k) path.emplace_back(Eigen::Vector2d(0, k * 0.1), Eigen::Vector2d(-0.018, -0.018));
  for (int k = 8; k >= 0; --k) path.emplace_back(Eigen::Vector2d(0, k * 0.1), Eigen::Vector2d(-0.018, -0.018));
  const std::vector<StepResult> res = replay(r, path, ws, fo);
  ASSERT_EQ(res.size(), path.size());
  for (const auto& s : res) ASSERT_TRUE(s.summary.converged) << s.summary.message;
  // Tiny but present envelope at 0.5 rad (rows 5 and 13): down branch above the up branch.
  EXPECT_GT(res[13].solution.twist[0] - res[5].solution.twist[0], 1e-5);
  EXPECT_LT(res[13].solution.twist[0] - res[5].solution.twist[0], 0.02);
  EXPECT_THROW(initialState(pairB().withFriction({0.1, 0.5}), path[0], ws, fo), std::invalid_argument);
}
