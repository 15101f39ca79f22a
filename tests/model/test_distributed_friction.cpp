// The paper's numerical findings on distributed-contact friction (§II.C, Figs. 4-6), tube pair B at pi/2.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "ctr/model/distributed_friction.hpp"
#include "ctr/model/friction.hpp"
#include "ctr/model/replay.hpp"
#include "distributed_map.hpp"  // internal
#include "tube_factory.hpp"

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

Robot pairB() {
  return Robot("B", {makeTube("outer", 0.0334, 2.77e-3, 2.55e-3), makeTube("inner", 0.0511, 2.41e-3, 1.97e-3)});
}

const Configuration kHalfPi(Eigen::Vector2d(0, M_PI / 2), Eigen::Vector2d(-0.018, -0.018));

DistributedFrictionSolution solveMu(double mu) {
  DistributedFrictionOptions o;
  o.mu = mu;
  o.direction = {1};
  Workspace ws;
  return solveDistributedFriction(pairB(), kHalfPi, ws, o);
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
  EXPECT_LT(std::abs(a.solution.twist[0] - b.solution.twist[0]), 0.02);         // rad (~1 deg)
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
  Workspace ws;
  const DistributedFrictionSolution up = solveDistributedFriction(pairB(), kHalfPi, ws, o);
  o.direction = {-1};
  const DistributedFrictionSolution down = solveDistributedFriction(pairB(), kHalfPi, ws, o);
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
  ReplayOptions ro;
  ro.friction = fo;
  const std::vector<ReplayRow> res = replay(r, path, ws, ro);
  ASSERT_EQ(res.size(), path.size());
  for (const auto& s : res) ASSERT_TRUE(s.ok) << s.message;
  // Tiny but present envelope at 0.5 rad (rows 5 and 13): down branch above the up branch.
  EXPECT_GT(res[13].result.solution.twist[0] - res[5].result.solution.twist[0], 1e-5);
  EXPECT_LT(res[13].result.solution.twist[0] - res[5].result.solution.twist[0], 0.02);
  EXPECT_TRUE(initialState(pairB().withFriction({0.1, 0.5}), path[0], ws, fo).summary.converged);
}

// ---- Boundary (lumped, §II.D) and distributed (§II.B) friction together ----

namespace {

Robot threeTubes(double mu_boundary) {
  auto tube = [](const std::string& n, double ls, double lc, double kappa, double kb, double od, double id) {
    Tube t = test::makeTube(n, ls, lc, kappa, kb, 0.3);
    t.outer_diameter = od;
    t.inner_diameter = id;
    return t;
  };
  return Robot("three",
               {tube("a", 0.05, 0.10, 4.0, 0.04, 2.4e-3, 2.0e-3), tube("b", 0.08, 0.10, 6.0, 0.02, 1.9e-3, 1.5e-3),
                tube("c", 0.15, 0.06, 12.0, 0.006, 1.4e-3, 1.0e-3)},
               {mu_boundary, 0.0});
}

}  // namespace

TEST(DistributedFriction, LumpedTorquesWithZeroMuMatchTheKinematicsSolver) {
  // With mu = 0 the distributed solver (its own integrator, finite-difference shooting Jacobian) under given contact
  // laws must reproduce solveWithContacts (analytic Jacobian): every law, a 3-tube robot with 4+ contact sites.
  const Robot r = threeTubes(0.1);
  const Configuration q(Eigen::Vector3d(0.3, 1.2, -0.7), Eigen::Vector3d(-0.02, -0.04, -0.07));
  const std::vector<ContactSite> sites = contactSites(r, q);
  ASSERT_GE(sites.size(), 3u);
  Workspace ws;
  KinematicsOptions ko;
  ko.record_backbone = false;
  using Law = ContactCondition::Law;
  const std::vector<std::vector<ContactCondition>> cases = {
      std::vector<ContactCondition>(sites.size(), {Law::Free, 0.0}),
      std::vector<ContactCondition>(sites.size(), {Law::Torque, 1.0}),
      std::vector<ContactCondition>(sites.size(), {Law::Torque, -1.0}),
      std::vector<ContactCondition>(sites.size(), {Law::Stick, 0.05}),
  };
  for (std::size_t k = 0; k < cases.size(); ++k) {
    const Solution ref = solveWithContacts(r, q, cases[k], ws, ko);
    ASSERT_TRUE(ref.converged()) << ref.summary.message;
    DistributedFrictionOptions o;
    o.mu = 0.0;
    o.direction = {1, 1};
    o.contacts = cases[k];
    o.kinematics = ko;
    const DistributedFrictionSolution d = solveDistributedFriction(r, q, ws, o);
    ASSERT_TRUE(d.solution.converged()) << d.solution.summary.message;
    EXPECT_LT((d.solution.twist - ref.twist).cwiseAbs().maxCoeff(), 1e-8) << "case " << k;
    EXPECT_LT((d.solution.tip_position - ref.tip_position).norm(), 1e-9) << "case " << k;
    ASSERT_EQ(d.solution.contacts.size(), ref.contacts.size());
    for (std::size_t c = 0; c < ref.contacts.size(); ++c) {
      EXPECT_TRUE(d.solution.contacts[c].site == ref.contacts[c].site);
      EXPECT_NEAR(d.solution.contacts[c].torque, ref.contacts[c].torque,
                  1e-8 + 1e-6 * std::abs(ref.contacts[c].torque));
      EXPECT_NEAR(d.solution.contacts[c].moment, ref.contacts[c].moment, 1e-9 + 1e-6 * ref.contacts[c].moment);
      EXPECT_NEAR(d.solution.contacts[c].relative_twist, ref.contacts[c].relative_twist, 1e-8);
    }
    if (k == 1) {
      EXPECT_GT(std::abs(ref.contacts[0].torque), 1e-5);  // the laws really act
    }
  }
  DistributedFrictionOptions bad;
  bad.direction = {1, 1};
  bad.contacts.assign(sites.size() + 1, {Law::Free, 0.0});
  EXPECT_THROW(solveDistributedFriction(r, q, ws, bad), std::invalid_argument);
}

TEST(DistributedFriction, TogetherWithBoundaryFrictionKeepsBoundsAndTorqueBalance) {
  // Stick-slip steps with both models: lumped torques within mu'|m|, and at every node the total torsional moment
  // of the tubes present vanishes (all friction torques, distributed and lumped, act in equal and opposite pairs).
  const Robot r = threeTubes(0.1).withFriction({0.1, 1.0});
  Workspace ws;
  FrictionOptions fo;
  fo.follow.max_rotation_step = 0.05;
  Configuration q(Eigen::Vector3d(0.0, 1.0, -0.5), Eigen::Vector3d(-0.02, -0.04, -0.07));
  StepResult cur = initialState(r, q, ws, fo);
  ASSERT_TRUE(cur.summary.converged) << cur.summary.message;
  bool some_slip = false;
  for (int k = 0; k < 4; ++k) {
    q.alpha[2] += 0.25;
    q.alpha[1] -= 0.1;
    cur = step(r, cur.state, q, ws, fo);
    ASSERT_TRUE(cur.summary.converged) << cur.summary.message;
    ASSERT_GE(cur.solution.contacts.size(), 3u);
    for (const ContactResult& c : cur.solution.contacts) {
      EXPECT_LE(std::abs(c.torque), 0.1 * c.moment * (1 + 1e-8) + 1e-14);
      some_slip = some_slip || std::abs(c.torque) > 0.1 * c.moment * (1 - 1e-6);
    }
    for (const BackbonePoint& p : cur.solution.backbone) {
      double sum = 0, scale = 0;
      for (int i = 0; i < 3; ++i)
        if (q.beta[i] + r.tube(i).length() > p.s + 1e-12) {
          sum += r.tube(i).torsional_stiffness * p.uz[i];
          scale += std::abs(r.tube(i).torsional_stiffness * p.uz[i]);
        }
      EXPECT_LT(std::abs(sum), 1e-9 + 1e-7 * scale) << "s = " << p.s;
    }
  }
  EXPECT_TRUE(some_slip);
}

TEST(DistributedFriction, TogetherWithBoundaryFrictionWidensTheEnvelope) {
  // Twist of pair B at 2 rad after rotating up from 0 vs after going on to 2 pi and back: the hysteresis width of
  // both mechanisms together exceeds that of either alone.
  Workspace ws;
  FrictionOptions fo;
  fo.kinematics.record_backbone = false;
  fo.follow.max_rotation_step = 0.05;
  auto width = [&](double mu_b, double mu_d) {
    const Robot r = pairB().withFriction({mu_b, mu_d});
    auto at = [](double a) { return Configuration(Eigen::Vector2d(0, a), Eigen::Vector2d(-0.018, -0.018)); };
    StepResult up = initialState(r, at(0), ws, fo);
    up = step(r, up.state, at(2.0), ws, fo);
    StepResult down = initialState(r, at(0), ws, fo);
    down = step(r, down.state, at(2 * M_PI), ws, fo);
    down = step(r, down.state, at(2.0), ws, fo);
    EXPECT_TRUE(up.summary.converged && down.summary.converged) << up.summary.message << down.summary.message;
    return down.solution.twist[0] - up.solution.twist[0];
  };
  const double wb = width(0.05, 0.0), wd = width(0.0, 2.0), wbd = width(0.05, 2.0);
  std::printf("width at 2 rad: boundary %.6f, distributed %.6f, both %.6f rad\n", wb, wd, wbd);
  EXPECT_GT(wd, 1e-4);
  EXPECT_GT(wb, wd);
  EXPECT_GT(wbd, wb + 0.5 * wd);
  EXPECT_NEAR(wbd, wb + wd, 0.2 * wd);  // two small perturbations of one branch: nearly additive
}

TEST(DistributedFriction, ExactJacobianMatchesCentralDifferences) {
  // The shooting map's Jacobian from the dual-number pass against central differences of its residual, on a pair
  // and on three tubes with lumped contact laws of every kind (stick, slip torque, free), near the solution (its
  // u_z(0) and contact torques, n_z(0) = 0) and away from it.
  struct Case {
    Robot robot;
    Configuration q;
    std::vector<ContactCondition> contacts;
  };
  const Robot three = threeTubes(0.1).withFriction({0.1, 1.0});
  const Configuration q3(Eigen::Vector3d(0.0, 1.0, -0.5), Eigen::Vector3d(-0.02, -0.04, -0.07));
  std::vector<ContactCondition> laws;
  const ContactCondition::Law kinds[] = {ContactCondition::Law::Stick, ContactCondition::Law::Torque,
                                         ContactCondition::Law::Free};
  for (std::size_t c = 0; c < contactSites(three, q3).size(); ++c)
    laws.push_back({kinds[c % 3], kinds[c % 3] == ContactCondition::Law::Stick ? 0.05 : 0.7});
  const std::vector<Case> cases = {{pairB(), kHalfPi, {}}, {three, q3, laws}};
  Workspace ws;
  for (const Case& c : cases) {
    DistributedFrictionOptions o;
    o.mu = 0.3;
    o.direction.assign(static_cast<std::size_t>(c.robot.size() - 1), 1);
    o.contacts = c.contacts;
    const DistributedFrictionSolution sol = solveDistributedFriction(c.robot, c.q, ws, o);
    ASSERT_TRUE(sol.solution.converged()) << sol.solution.summary.message;
    const int n = c.robot.size(), m = 2 * n + static_cast<int>(c.contacts.size());
    Eigen::VectorXd z = Eigen::VectorXd::Zero(m);
    z.head(n) = sol.solution.base_twist_rate;
    for (std::size_t k = 0; k < c.contacts.size(); ++k)
      z[2 * n + static_cast<Eigen::Index>(k)] =
          sol.solution.contacts[k].torque / c.robot.tube(sol.solution.contacts[k].site.inner).torsional_stiffness;
    for (double away : {0.0, 0.3}) {
      Eigen::VectorXd za = z;
      for (int k = 0; k < m; ++k) za[k] += away * (0.5 + 0.1 * k);
      Eigen::VectorXd r;
      Eigen::MatrixXd J;
      detail::distributedFrictionMap(c.robot, c.q, o, za, r, &J);
      ASSERT_EQ(J.rows(), m);
      for (int k = 0; k < m; ++k) {
        const double h = 1e-6 * (1.0 + std::abs(za[k]));
        Eigen::VectorXd zp = za, zm = za, rp, rm;
        zp[k] += h;
        zm[k] -= h;
        detail::distributedFrictionMap(c.robot, c.q, o, zp, rp, nullptr);
        detail::distributedFrictionMap(c.robot, c.q, o, zm, rm, nullptr);
        const Eigen::VectorXd fd = (rp - rm) / (2 * h);
        EXPECT_LT((J.col(k) - fd).norm(), 1e-6 * (1.0 + fd.norm())) << "column " << k << ", away " << away;
      }
    }
  }
}
