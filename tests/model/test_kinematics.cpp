// Correctness evidence for the frictionless torsionally compliant model: analytic solutions, an independent BVP
// solve, invariants, convergence under refinement and the snapping bifurcation.
#include <gtest/gtest.h>

#include "tube_factory.hpp"

#include <Eigen/Geometry>
#include <cmath>
#include <functional>

#include "ctr/model/backbone.hpp"
#include "ctr/model/kinematics.hpp"
#include "workspace_impl.hpp"  // internal: the shooting map and its analytic Jacobian

using namespace ctr;

namespace {

using test::makeTube;

// Independent solution of alpha'' = c sin(alpha), alpha(0) = a0, alpha'(L) = 0 by scalar shooting (secant on
// alpha'(0), fine RK4 of the scalar second-order ODE).
double relativeTwistBvp(double c, double L, double a0, double guess, double* slope0 = nullptr) {
  auto shoot = [&](double v0, double* aL) {
    const int N = 40000;
    const double h = L / N;
    double a = a0, v = v0;
    for (int i = 0; i < N; ++i) {
      auto f = [&](double x) { return c * std::sin(x); };
      const double k1a = v, k1v = f(a);
      const double k2a = v + 0.5 * h * k1v, k2v = f(a + 0.5 * h * k1a);
      const double k3a = v + 0.5 * h * k2v, k3v = f(a + 0.5 * h * k2a);
      const double k4a = v + h * k3v, k4v = f(a + h * k3a);
      a += h / 6 * (k1a + 2 * k2a + 2 * k3a + k4a);
      v += h / 6 * (k1v + 2 * k2v + 2 * k3v + k4v);
    }
    if (aL) *aL = a;
    return v;  // alpha'(L)
  };
  double x0 = guess, x1 = guess + 0.1;
  double f0 = shoot(x0, nullptr), f1 = shoot(x1, nullptr);
  for (int it = 0; it < 100 && std::abs(f1) > 1e-14; ++it) {
    const double x2 = x1 - f1 * (x1 - x0) / (f1 - f0);
    x0 = x1;
    f0 = f1;
    x1 = x2;
    f1 = shoot(x1, nullptr);
  }
  double aL = 0;
  shoot(x1, &aL);
  if (slope0) *slope0 = x1;
  return aL;
}

}  // namespace

TEST(Kinematics, TwoFullyCurvedTubesMatchIndependentBvp) {
  const double nu = 0.6, k1 = 1 / 0.154, k2 = 1 / 0.2, L = 0.15;
  // Different bending stiffnesses: the relative-twist equation does not depend on them (same nu).
  const Robot robot("pair", {makeTube("outer", 0, L, k1, 0.0334, nu), makeTube("inner", 0, L, k2, 0.0511, nu)});
  Workspace ws;
  KinematicsOptions opt;
  opt.max_step = 5e-4;
  opt.tolerance = 1e-13;
  const double c = (1 + nu) * k1 * k2;
  for (double a0 : {0.3, 1.0, M_PI / 2, 2.5, 3.0}) {
    const Configuration q(Eigen::Vector2d(0.2, 0.2 + a0), Eigen::Vector2d(0, 0));
    const Solution s = solve(robot, q, ws, opt);
    ASSERT_TRUE(s.converged()) << s.summary.message;
    EXPECT_TRUE(s.summary.stable);
    double slope = 0;
    const double aL = relativeTwistBvp(c, L, a0, 0.0, &slope);
    EXPECT_NEAR(s.twist[0], aL, 1e-8) << "a0 = " << a0;
    EXPECT_NEAR(s.base_twist_rate[1] - s.base_twist_rate[0], slope, 1e-7);
  }
}

TEST(Kinematics, SingleTubeIsACircularArc) {
  const double kappa = 8.0, ls = 0.03, lc = 0.12, beta = -0.01;
  const Robot robot("one", {makeTube("t", ls, lc, kappa, 0.02, 0.3)});
  Workspace ws;
  for (double alpha : {0.0, 0.7, -2.0}) {
    const Configuration q(Eigen::VectorXd::Constant(1, alpha), Eigen::VectorXd::Constant(1, beta));
    const Solution s = solve(robot, q, ws);
    ASSERT_TRUE(s.converged());
    const double straight = ls + beta, th = kappa * lc;
    const Eigen::Vector3d expect((1 - std::cos(th)) / kappa * std::cos(alpha), (1 - std::cos(th)) / kappa * std::sin(alpha),
                                 straight + std::sin(th) / kappa);
    EXPECT_LT((s.tip_position - expect).norm(), 1e-9) << s.tip_position.transpose();
    EXPECT_NEAR(s.tipTangent().z(), std::cos(th), 1e-9);
    EXPECT_NEAR(s.base_twist_rate[0], 0.0, 1e-12);
  }
}

TEST(Kinematics, TorsionallyRigidLimit) {
  // k_t -> infinity: theta_i = alpha_i and the shape is the torsionally rigid model: piecewise-constant
  // curvature u0 = sum k_i kappa_i d(alpha_i) / sum k_i, integrated here with exact arcs.
  auto robotWith = [](double ratio) {
    std::vector<Tube> t{makeTube("a", 0.02, 0.10, 5.0, 0.04, 0.3), makeTube("b", 0.05, 0.09, 9.0, 0.02, 0.3),
                        makeTube("c", 0.12, 0.05, 15.0, 0.006, 0.3)};
    for (auto& x : t) x.torsional_stiffness = x.bending_stiffness * ratio;
    return Robot("rigid", t);
  };
  const Configuration q(Eigen::Vector3d(0.3, 2.0, -1.2), Eigen::Vector3d(-0.01, -0.02, -0.05));
  // Exact rigid model.
  const Robot r0 = robotWith(1.0);
  std::vector<double> pts{0.0};
  for (int i = 0; i < 3; ++i) {
    pts.push_back(q.beta[i] + r0.tube(i).length());
    const double d = q.beta[i] + r0.tube(i).straight_length;
    if (d > 0) pts.push_back(d);
  }
  std::sort(pts.begin(), pts.end());
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  for (std::size_t k = 0; k + 1 < pts.size(); ++k) {
    const double mid = 0.5 * (pts[k] + pts[k + 1]), len = pts[k + 1] - pts[k];
    if (len <= 0) continue;
    double K = 0;
    Eigen::Vector3d u = Eigen::Vector3d::Zero();
    for (int i = 0; i < 3; ++i) {
      const Tube& t = r0.tube(i);
      if (q.beta[i] + t.length() <= mid) continue;
      K += t.bending_stiffness;
      if (mid > q.beta[i] + t.straight_length)
        u += t.bending_stiffness * t.curvature * Eigen::Vector3d(-std::sin(q.alpha[i]), std::cos(q.alpha[i]), 0);
    }
    u /= K;
    // Exact motion with constant body twist (omega = u, v = e_z): closed form via the arc.
    const double w = u.norm();
    Eigen::Isometry3d step = Eigen::Isometry3d::Identity();
    if (w < 1e-14) {
      step.translation() = Eigen::Vector3d(0, 0, len);
    } else {
      const Eigen::Vector3d ax = u / w;
      step.linear() = Eigen::AngleAxisd(w * len, ax).toRotationMatrix();
      // p = integral_0^len R(s) e_z ds; e_z is perpendicular to ax.
      const Eigen::Vector3d ez(0, 0, 1), b = ax.cross(ez);
      step.translation() = ez * std::sin(w * len) / w + b * (1 - std::cos(w * len)) / w;
    }
    T = T * step;
  }
  Workspace ws;
  double prev_err = 1e9;
  for (double ratio : {1e2, 1e4, 1e6}) {
    const Solution s = solve(robotWith(ratio), q, ws);
    ASSERT_TRUE(s.converged());
    const double err = (s.tip_position - T.translation()).norm();
    EXPECT_LT(err, prev_err);
    prev_err = err;
  }
  EXPECT_LT(prev_err, 1e-6);
}

TEST(Kinematics, TotalTorsionalMomentIsZeroAlongTheRobot) {
  const Robot robot("three", {makeTube("a", 0.02, 0.10, 5.0, 0.04, 0.3), makeTube("b", 0.05, 0.09, 9.0, 0.02, 0.35),
                              makeTube("c", 0.12, 0.05, 15.0, 0.006, 0.4)});
  Workspace ws;
  KinematicsOptions opt;
  opt.max_step = 2e-3;  // check the invariant at many nodes
  for (int trial = 0; trial < 5; ++trial) {
    const Configuration q(Eigen::Vector3d(0.5 * trial, -1.0 + trial, 2.0 - trial), Eigen::Vector3d(-0.01, -0.02, -0.05));
    const Solution s = solve(robot, q, ws, opt);
    ASSERT_TRUE(s.converged());
    ASSERT_GT(s.backbone.size(), 20u);
    double scale = 0;
    for (int i = 0; i < 3; ++i) scale = std::max(scale, std::abs(robot.tube(i).torsional_stiffness * s.base_twist_rate[i]));
    for (const BackbonePoint& p : s.backbone) {
      double sum = 0;
      for (int i = 0; i < 3; ++i)
        if (q.beta[i] + robot.tube(i).length() > p.s + 1e-12) sum += robot.tube(i).torsional_stiffness * p.uz[i];
      EXPECT_LT(std::abs(sum), 1e-9 * std::max(scale, 1e-6)) << "s = " << p.s;
    }
  }
}

// The bending limit of a step per segment (KinematicsOptions::bending_limit_per_segment): where only the less curved
// tube bends, steps of max_step instead of max_bending_per_step over the robot's largest precurvature; where the more
// curved tube bends, the same steps; the tip as accurate as with the whole robot's limit.
TEST(Kinematics, BendingLimitPerSegmentLengthensOnlyTheLessCurvedSegments) {
  // Outer and middle: curved (4 1/m) over 0.15 m, rotated apart (they twist against each other). Inner: straight for
  // 0.17 m, then curved (20 1/m) over 0.05 m.
  const Robot robot("three",
                    {makeTube("outer", 0.0, 0.15, 4.0, 0.05, 0.3), makeTube("middle", 0.0, 0.15, 4.0, 0.04, 0.3),
                     makeTube("inner", 0.17, 0.05, 20.0, 0.01, 0.3)});
  // The inner tube curved on s in [0.15, 0.2].
  const Configuration q(Eigen::Vector3d(0.0, 2.0, 0.5), Eigen::Vector3d(0.0, 0.0, -0.02));
  KinematicsOptions per_segment, whole;
  whole.bending_limit_per_segment = false;
  KinematicsOptions fine;
  fine.max_step = 2.5e-4;
  fine.tolerance = 1e-12;
  Workspace ws;
  const Solution a = solve(robot, q, ws, per_segment), b = solve(robot, q, ws, whole), ref = solve(robot, q, ws, fine);
  ASSERT_TRUE(a.converged() && b.converged() && ref.converged());
  auto largestStep = [](const Solution& s, double s0, double s1) {
    double h = 0.0;
    for (std::size_t k = 0; k + 1 < s.backbone.size(); ++k)
      if (s.backbone[k].s >= s0 - 1e-12 && s.backbone[k + 1].s <= s1 + 1e-12)
        h = std::max(h, s.backbone[k + 1].s - s.backbone[k].s);
    return h;
  };
  // Only the 4 1/m tubes bend on [0, 0.15]: 10 mm steps (max_step; 0.12 / 4 = 30 mm) per segment, 6 mm (0.12 / 20)
  // with the whole robot's limit. The inner tube's curved part: 6 mm either way.
  EXPECT_NEAR(largestStep(a, 0.0, 0.15), 0.01, 1e-3);
  EXPECT_LE(largestStep(b, 0.0, 0.15), 0.12 / 20.0 + 1e-12);
  EXPECT_LE(largestStep(a, 0.15, 0.2), 0.12 / 20.0 + 1e-12);
  EXPECT_LT(a.backbone.size(), b.backbone.size());
  const double ea = (a.tip_position - ref.tip_position).norm(), eb = (b.tip_position - ref.tip_position).norm();
  std::printf("[ measured ] tip error per segment %.2e m (%zu nodes), whole robot %.2e m (%zu nodes)\n", ea,
              a.backbone.size(), eb, b.backbone.size());
  EXPECT_LT(ea, 1e-8);
  EXPECT_LT(eb, 1e-8);
}

TEST(Kinematics, ConvergesAtFourthOrderUnderStepRefinement) {
  // Every segment length is a multiple of 8 mm so that the step sizes halve exactly.
  const Robot robot("three", {makeTube("a", 0.032, 0.096, 5.0, 0.04, 0.3), makeTube("b", 0.064, 0.088, 9.0, 0.02, 0.35),
                              makeTube("c", 0.12, 0.064, 25.0, 0.006, 0.4)});
  const Configuration q(Eigen::Vector3d(0.2, 2.5, -1.0), Eigen::Vector3d(-0.016, -0.024, -0.04));
  Workspace ws;
  KinematicsOptions opt;
  opt.tolerance = 1e-12;
  opt.max_bending_per_step = 0.0;  // steps set by max_step alone, so that they halve exactly
  opt.max_step = 1e-4;
  const Solution ref = solve(robot, q, ws, opt);
  ASSERT_TRUE(ref.converged());
  std::vector<double> err;
  for (double h : {16e-3, 8e-3, 4e-3}) {
    opt.max_step = h;
    const Solution s = solve(robot, q, ws, opt);
    ASSERT_TRUE(s.converged());
    err.push_back((s.tip_position - ref.tip_position).norm() + std::abs(s.twist[1] - ref.twist[1]) * 0.1);
  }
  for (std::size_t k = 0; k + 1 < err.size(); ++k) {
    const double order = std::log2(err[k] / err[k + 1]);
    EXPECT_GT(order, 3.5) << "errors " << err[k] << " -> " << err[k + 1];
    EXPECT_LT(order, 4.6);
  }
  EXPECT_LT(err.back(), 1e-7);
}

TEST(Kinematics, CoincidentEventsAreContinuous) {
  // Two tubes ending at the same s vs 1e-9 m apart: results must agree to the perturbation size.
  auto robotWith = [](double extra) {
    return Robot("ev", {makeTube("a", 0.05, 0.10, 6.0, 0.03, 0.3), makeTube("b", 0.05 + extra, 0.10, 7.0, 0.03, 0.3)});
  };
  Workspace ws;
  const Configuration q(Eigen::Vector2d(0.0, 1.2), Eigen::Vector2d(-0.02, -0.02));
  const Solution a = solve(robotWith(0.0), q, ws);
  const Solution b = solve(robotWith(1e-9), q, ws);
  ASSERT_TRUE(a.converged() && b.converged());
  EXPECT_LT((a.tip_position - b.tip_position).norm(), 1e-8);
  EXPECT_NEAR(a.twist[0], b.twist[0], 1e-7);
}

TEST(Kinematics, ConcentratedMomentsAreReported) {
  const Robot robot("pair", {makeTube("outer", 0.05, 0.1, 6.0, 0.03, 0.3), makeTube("inner", 0.08, 0.1, 6.0, 0.03, 0.3)});
  Workspace ws;
  const Configuration q(Eigen::Vector2d(0.0, M_PI), Eigen::Vector2d(-0.01, -0.02));
  const Solution s = solve(robot, q, ws);
  ASSERT_TRUE(s.converged());
  // Outer end, inner end, and two discontinuities (at 0.04 and 0.06).
  int ends = 0, discs = 0;
  for (const auto& m : s.moments) {
    if (m.kind == MomentKind::TubeEnd) ++ends;
    if (m.kind == MomentKind::CurvatureDiscontinuity) {
      ++discs;
      EXPECT_NEAR(m.magnitude, 0.03 * 6.0 * 0.5, 1e-12);  // k kappa (K - k)/K
    }
  }
  EXPECT_EQ(ends, 2);
  EXPECT_EQ(discs, 2);
  // Opposed curvatures: at the outer end the outer tube's bending moment is large.
  EXPECT_GT(s.moments.back().magnitude + s.moments.front().magnitude, 0.0);
}

TEST(Kinematics, InadmissibleConfigurationIsReportedNotSolved) {
  const Robot robot("pair", {makeTube("outer", 0.05, 0.1, 6.0, 0.03, 0.3), makeTube("inner", 0.08, 0.1, 6.0, 0.03, 0.3)});
  Workspace ws;
  const Solution s = solve(robot, Configuration(Eigen::Vector2d(0, 0), Eigen::Vector2d(-0.02, -0.01)), ws);
  EXPECT_EQ(s.summary.status, SolveStatus::Inadmissible);
  EXPECT_NE(s.summary.message.find("beta_2"), std::string::npos) << s.summary.message;
  const Solution s2 = solve(robot, Configuration(Eigen::Vector2d(0, 0), Eigen::Vector2d(0.01, 0.0)), ws);
  EXPECT_EQ(s2.summary.status, SolveStatus::Inadmissible);
  const Solution s3 = solve(robot, Configuration(Eigen::Vector2d(0, 0), Eigen::Vector2d(-0.0, -0.04)), ws);
  EXPECT_EQ(s3.summary.status, SolveStatus::Inadmissible);
  EXPECT_NE(s3.summary.message.find("distal end"), std::string::npos) << s3.summary.message;
  const Solution s4 = solve(robot, Configuration(Eigen::Vector2d(NAN, 0), Eigen::Vector2d(0, 0)), ws);
  EXPECT_EQ(s4.summary.status, SolveStatus::Inadmissible);
}

namespace {

// Fully curved equal-stiffness pair with lambda L^2 = factor (pi/2)^2, no transmission.
Robot snapPair(double factor, double L = 0.1) {
  const double nu = 0.3;
  const double kappa = std::sqrt(factor * (M_PI / 2) * (M_PI / 2) / ((1 + nu) * L * L));
  return Robot("snap", {makeTube("outer", 0, L, kappa, 0.03, nu), makeTube("inner", 0, L, kappa, 0.03, nu)});
}

struct Sweep {
  std::vector<double> angle, twist, stability;
  std::vector<bool> snapped, stable;
};

Sweep sweep(const Robot& r, double from, double to, int steps, Solution* last = nullptr) {
  Workspace ws;
  Sweep sw;
  Solution s = last && last->converged() ? *last
                                         : solve(r, Configuration(Eigen::Vector2d(0, from), Eigen::Vector2d(0, 0)), ws);
  for (int k = 0; k <= steps; ++k) {
    const double a = from + (to - from) * k / steps;
    if (k > 0 || (last && last->converged()))
      s = continueTo(r, s, Configuration(Eigen::Vector2d(0, a), Eigen::Vector2d(0, 0)), ws);
    EXPECT_TRUE(s.converged()) << s.summary.message;
    sw.angle.push_back(a);
    sw.twist.push_back(s.twist[0]);
    sw.stability.push_back(s.summary.stability);
    sw.snapped.push_back(s.summary.snapped);
    sw.stable.push_back(s.summary.stable);
  }
  if (last) *last = s;
  return sw;
}

}  // namespace

TEST(Kinematics, SnapAboveThresholdTwoStableBranchesNearPi) {
  const Robot r = snapPair(2.0);
  Solution end;
  const Sweep up = sweep(r, 0.0, 2 * M_PI, 360, &end);
  const Sweep down = sweep(r, 2 * M_PI, 0.0, 360, &end);
  // Exactly one snap each way, and every returned solution is stable.
  int snaps_up = 0, snaps_down = 0;
  for (std::size_t k = 0; k < up.angle.size(); ++k) {
    snaps_up += up.snapped[k];
    snaps_down += down.snapped[k];
    EXPECT_TRUE(up.stable[k]);
    EXPECT_TRUE(down.stable[k]);
  }
  EXPECT_EQ(snaps_up, 1);
  EXPECT_EQ(snaps_down, 1);
  // At base angle pi (index 180 in both sweeps) the two branches differ: two stable equilibria.
  EXPECT_GT(std::abs(up.twist[180] - down.twist[180]), 1.0);
  // The stability measure goes to ~0 just before the snap (the fold), relative to its value at 0.
  std::size_t snap_at = 0;
  for (std::size_t k = 0; k < up.angle.size(); ++k)
    if (up.snapped[k]) snap_at = k;
  ASSERT_GT(snap_at, 180u);  // the branch continues past pi
  EXPECT_LT(up.stability[snap_at - 1], 0.1 * up.stability[0]);
  EXPECT_GT(up.stability[snap_at - 1], 0.0);
  // An unstable equilibrium exists at pi: the symmetric one (twist = pi) with negative stability.
  Workspace ws;
  Solution sym;
  sym.base_twist_rate = Eigen::Vector2d(0, 0);
  sym.summary.status = SolveStatus::Converged;
  KinematicsOptions opt;
  const Solution mid = solve(r, Configuration(Eigen::Vector2d(0, M_PI), Eigen::Vector2d(0, 0)), ws, opt, &sym);
  ASSERT_TRUE(mid.converged());
  EXPECT_NEAR(mid.twist[0], M_PI, 1e-9);
  EXPECT_LT(mid.summary.stability, 0.0);
  EXPECT_FALSE(mid.summary.stable);
}

TEST(Kinematics, NoSnapBelowThresholdOneBranch) {
  const Robot r = snapPair(0.8);
  Solution end;
  const Sweep up = sweep(r, 0.0, 2 * M_PI, 120, &end);
  const Sweep down = sweep(r, 2 * M_PI, 0.0, 120, &end);
  for (std::size_t k = 0; k < up.angle.size(); ++k) {
    EXPECT_FALSE(up.snapped[k]);
    EXPECT_TRUE(up.stable[k]);
    EXPECT_NEAR(up.twist[k], down.twist[up.angle.size() - 1 - k], 1e-8);
  }
  // The symmetric solution at pi is stable below the threshold.
  Workspace ws;
  const Solution mid = solve(r, Configuration(Eigen::Vector2d(0, M_PI), Eigen::Vector2d(0, 0)), ws);
  EXPECT_NEAR(mid.twist[0], M_PI, 1e-9);
  EXPECT_GT(mid.summary.stability, 0.0);
}

TEST(Kinematics, SecantPredictorFollowsTheSameBranchWithFewerIterations) {
  // Warm-started solves along a sweep, each from the previous solution, with and without the secant predictor
  // (KinematicsOptions::extrapolate_warm_start): the same equilibria at every step -- also through the fold and the
  // snap of the two-branch pair, and over a 3-tube sweep with translations -- in fewer Newton iterations.
  auto follow = [](const Robot& r, const std::function<Configuration(int)>& q, int steps, bool predictor,
                   std::vector<Eigen::VectorXd>& twists, std::vector<Eigen::Vector3d>& tips) {
    Workspace ws;
    KinematicsOptions o;
    o.extrapolate_warm_start = predictor;
    o.refine_below_stability = 0.0;  // the same discretisation everywhere
    o.tolerance = 1e-8;              // the planner's setting
    int iterations = 0;
    Solution prev = solve(r, q(0), ws, o);
    for (int k = 1; k <= steps; ++k) {
      Solution s = solve(r, q(k), ws, o, &prev);
      EXPECT_TRUE(s.converged()) << k << ": " << s.summary.message;
      iterations += s.summary.iterations;
      twists.push_back(s.twist);
      tips.push_back(s.tip_position);
      prev = std::move(s);
    }
    return iterations;
  };
  const Robot pair = snapPair(2.0);
  const auto pair_q = [](int k) { return Configuration(Eigen::Vector2d(0, 2 * M_PI * k / 360), Eigen::Vector2d(0, 0)); };
  const Tube t1 = makeTube("t1", 0.0, 0.10, 5.0, 0.05, 0.3), t2 = makeTube("t2", 0.0, 0.15, 8.0, 0.03, 0.3),
             t3 = makeTube("t3", 0.0, 0.22, 15.0, 0.012, 0.3);
  const Robot three("three", {t1, t2, t3});
  const auto three_q = [](int k) {
    const double a = 0.01 * k;
    return Configuration(Eigen::Vector3d(0.2, 1.0 + a, -2.0 + 1.3 * a),
                         Eigen::Vector3d(-0.05 + 1e-4 * k, -0.08 + 1.2e-4 * k, -0.11 + 1.5e-4 * k));
  };
  for (int c = 0; c < 2; ++c) {
    const Robot& r = c == 0 ? pair : three;
    const auto& q = c == 0 ? std::function<Configuration(int)>(pair_q) : std::function<Configuration(int)>(three_q);
    std::vector<Eigen::VectorXd> tw_plain, tw_pred;
    std::vector<Eigen::Vector3d> tip_plain, tip_pred;
    const int it_plain = follow(r, q, 300, false, tw_plain, tip_plain);
    const int it_pred = follow(r, q, 300, true, tw_pred, tip_pred);
    ASSERT_EQ(tw_plain.size(), tw_pred.size());
    double worst_twist = 0.0, worst_tip = 0.0;
    for (std::size_t k = 0; k < tw_plain.size(); ++k) {
      worst_twist = std::max(worst_twist, (tw_plain[k] - tw_pred[k]).cwiseAbs().maxCoeff());
      worst_tip = std::max(worst_tip, (tip_plain[k] - tip_pred[k]).norm());
    }
    std::printf("[ measured ] %s: Newton iterations %d plain, %d with the predictor; worst twist diff %.1e rad, tip "
                "diff %.1e m\n", c == 0 ? "snap pair" : "3 tubes", it_plain, it_pred, worst_twist, worst_tip);
    EXPECT_LT(worst_twist, 1e-8);
    EXPECT_LT(worst_tip, 1e-9);
    EXPECT_LT(it_pred, 0.8 * it_plain);
  }
}

TEST(Kinematics, ShootingJacobianWithContactsMatchesCentralDifferences) {
  // The analytic Jacobian of the shooting residuals (sensitivity ODE; a contact's column is only carried from its
  // site on) against central differences of the residuals, on a 3-tube robot with a contact at every site under
  // each law (Stick, Torque, Free).
  const Robot robot = Robot("three", {makeTube("t1", 0.08, 0.10, 5.0, 0.05, 0.3), makeTube("t2", 0.12, 0.15, 8.0, 0.03, 0.3),
                                      makeTube("t3", 0.16, 0.22, 15.0, 0.012, 0.3)})
                          .withFriction({0.1, 0.0});
  const Configuration q(Eigen::Vector3d(0.2, 1.3, -2.4), Eigen::Vector3d(-0.05, -0.08, -0.11));
  const std::vector<ContactSite> sites = contactSites(robot, q);
  ASSERT_GE(sites.size(), 3u);
  std::vector<ContactCondition> cond(sites.size(), ContactCondition{ContactCondition::Law::Torque, -1.0});
  cond[0] = {ContactCondition::Law::Stick, 0.03};
  cond[sites.size() - 1] = {ContactCondition::Law::Free, 0.0};
  detail::Problem P;
  const KinematicsOptions o;
  P.setup(robot, q, &cond, o);
  ASSERT_EQ(P.m, 3 + static_cast<int>(sites.size()));
  Eigen::VectorXd z(P.m);
  for (int i = 0; i < P.m; ++i) z[i] = 0.3 * std::sin(1.7 * i + 0.4);  // twist rates (1/m), scaled torques
  detail::Evaluator E;
  detail::Outputs out;
  E.evaluate(P, z, true, false, out);
  const Eigen::MatrixXd J = E.J;
  ASSERT_GT(J.rightCols(P.m - 3).cwiseAbs().maxCoeff(), 0.0);
  double worst = 0.0;
  for (int c = 0; c < P.m; ++c) {
    const double h = 1e-6;
    Eigen::VectorXd zp = z, zm = z;
    zp[c] += h;
    zm[c] -= h;
    E.evaluate(P, zp, false, false, out);
    const Eigen::VectorXd rp = E.r;
    E.evaluate(P, zm, false, false, out);
    const Eigen::VectorXd fd = (rp - E.r) / (2 * h);
    worst = std::max(worst, (fd - J.col(c)).cwiseAbs().maxCoeff() / std::max(1.0, J.col(c).cwiseAbs().maxCoeff()));
  }
  std::printf("[ measured ] shooting Jacobian with %zu contacts: worst column error %.1e\n", sites.size(), worst);
  EXPECT_LT(worst, 1e-7);
}

TEST(Kinematics, BackboneResamplingHitsRequestedResolution) {
  const Robot robot("pair", {makeTube("outer", 0.05, 0.1, 6.0, 0.03, 0.3), makeTube("inner", 0.08, 0.1, 6.0, 0.03, 0.3)});
  Workspace ws;
  const Solution s = solve(robot, Configuration(Eigen::Vector2d(0.0, 1.0), Eigen::Vector2d(-0.01, -0.02)), ws);
  const auto pts = resampleBackbone(s, 1e-3);
  ASSERT_GE(pts.size(), 2u);
  EXPECT_NEAR(pts.front().s, 0.0, 1e-15);
  EXPECT_NEAR(pts.back().s, s.tipArcLength(), 1e-15);
  EXPECT_LT((pts.back().position - s.tip_position).norm(), 1e-12);
  for (std::size_t k = 1; k < pts.size(); ++k) {
    EXPECT_LE(pts[k].s - pts[k - 1].s, 1e-3 + 1e-12);
    // Arc length ~ chord for a 1 mm step.
    EXPECT_NEAR((pts[k].position - pts[k - 1].position).norm(), pts[k].s - pts[k - 1].s, 1e-6);
  }
}

TEST(Kinematics, RobotValidationNamesTubeAndKey) {
  Tube bad = makeTube("inner", 0.05, 0.1, 6.0, 0.0, 0.3);
  try {
    Robot("r", {makeTube("outer", 0.05, 0.1, 6.0, 0.03, 0.3), bad});
    FAIL() << "expected an exception";
  } catch (const std::invalid_argument& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("inner"), std::string::npos) << m;
    EXPECT_NE(m.find("bending_stiffness"), std::string::npos) << m;
  }
}

TEST(Kinematics, TubeBendingMomentsBalance) {
  // Paper eq. 6: without external load the tubes' bending moments sum to zero at every cross section.
  const Robot robot("three", {makeTube("a", 0.02, 0.10, 5.0, 0.04, 0.3), makeTube("b", 0.05, 0.09, 9.0, 0.02, 0.35),
                              makeTube("c", 0.12, 0.05, 15.0, 0.006, 0.4)});
  const Configuration q(Eigen::Vector3d(0.3, 2.0, -1.0), Eigen::Vector3d(-0.01, -0.02, -0.05));
  Workspace ws;
  KinematicsOptions opt;
  opt.max_step = 2e-3;
  const Solution s = solve(robot, q, ws, opt);
  ASSERT_TRUE(s.converged());
  double largest = 0;
  for (const BackbonePoint& p : s.backbone) {  // integration nodes (both sides of every segment boundary)
    if (p.s >= s.tipArcLength() - 1e-9) continue;
    const Eigen::Matrix2Xd m = tubeBendingMoments(robot, q, p);
    largest = std::max(largest, m.colwise().norm().maxCoeff());
    EXPECT_LT(m.rowwise().sum().norm(), 1e-9) << "s = " << p.s;
  }
  EXPECT_GT(largest, 1e-3);  // the tubes do bend each other
  // The concentrated moment at the end of tube 1 is tube 1's bending moment just before it.
  for (const auto& cm : s.moments) {
    if (cm.kind != MomentKind::TubeEnd || cm.tube != 0) continue;
    for (const BackbonePoint& p : s.backbone) {
      if (std::abs(p.s - cm.s) < 1e-12 && !p.segment_start) {  // the s- side of the end
        EXPECT_NEAR(tubeBendingMoments(robot, q, p).col(0).norm(), cm.magnitude, 1e-12);
      }
    }
  }
}
