// Evidence for the lumped stick-slip friction model (paper §II.D) and its hysteresis state.
#include <gtest/gtest.h>

#include "tube_factory.hpp"

#include <cmath>
#include <random>

#include "ctr/model/friction.hpp"

using namespace ctr;

namespace {

using test::makeTube;

// Tube pair B of Lock & Dupont 2011 (150 mm curved length assumed), beta = -18 mm.
Robot pairB(double mu) {
  return Robot("B", {makeTube("outer", 0.018, 0.150, 1 / 0.154, 0.0334, 0.6),
                     makeTube("inner", 0.018, 0.150, 1 / 0.154, 0.0511, 0.6)},
               {mu, 0.0});
}

Configuration cfgB(double a2) { return Configuration(Eigen::Vector2d(0, a2), Eigen::Vector2d(-0.018, -0.018)); }

FrictionOptions fastOptions(FrictionMode mode = FrictionMode::StickSlip) {
  FrictionOptions fo;
  fo.mode = mode;
  fo.kinematics.record_backbone = false;
  return fo;
}

// Twist after each command of a path of inner-tube angles (deg) starting from rest at the first one.
std::vector<double> twists(const Robot& r, const std::vector<double>& deg, FrictionOptions fo = fastOptions(),
                           std::vector<StepResult>* all = nullptr) {
  Workspace ws;
  StepResult cur = initialState(r, cfgB(deg[0] * M_PI / 180), ws, fo);
  std::vector<double> out{cur.solution.twist[0]};
  if (all) all->push_back(cur);
  for (std::size_t k = 1; k < deg.size(); ++k) {
    cur = step(r, cur.state, cfgB(deg[k] * M_PI / 180), ws, fo);
    EXPECT_TRUE(cur.summary.converged) << cur.summary.message;
    out.push_back(cur.solution.twist[0]);
    if (all) all->push_back(cur);
  }
  return out;
}

std::vector<double> range(double from, double to, double stepv) {
  std::vector<double> v;
  const int n = static_cast<int>(std::round(std::abs(to - from) / stepv));
  for (int k = 0; k <= n; ++k) v.push_back(from + (to > from ? 1 : -1) * stepv * k);
  return v;
}

std::vector<double> concat(std::vector<double> a, const std::vector<double>& b) {
  a.insert(a.end(), b.begin() + 1, b.end());
  return a;
}

}  // namespace

TEST(Friction, ZeroCoefficientReproducesFrictionlessModelExactly) {
  const Robot r = pairB(0.0);
  Workspace ws;
  const std::vector<double> path = concat(range(0, 250, 10), range(250, 40, 10));
  const std::vector<double> tw = twists(r, path);
  Solution s = solve(r, cfgB(0), ws);
  for (std::size_t k = 1; k < path.size(); ++k) {
    s = continueTo(r, s, cfgB(path[k] * M_PI / 180), ws);
    EXPECT_NEAR(tw[k], s.twist[0], 1e-9) << path[k];  // same equations; differs only by Newton tolerance
  }
}

TEST(Friction, SameCommandDifferentHistoryGivesDifferentShape) {
  const Robot r = pairB(0.12);
  const std::vector<double> up = twists(r, range(0, 180, 5));
  const std::vector<double> down = twists(r, concat(range(0, 360, 5), range(360, 180, 5)));
  EXPECT_GT(down.back() - up.back(), 0.5);  // envelope width at pi, rad
}

TEST(Friction, OneStepEqualsHundredSubstepsAfterSlipOnlyMove) {
  const Robot r = pairB(0.12);
  Workspace ws;
  const FrictionOptions fo = fastOptions();
  StepResult cur = initialState(r, cfgB(0), ws, fo);
  cur = step(r, cur.state, cfgB(60 * M_PI / 180), ws, fo);  // now slipping positively
  const StepResult one = step(r, cur.state, cfgB(120 * M_PI / 180), ws, fo);
  StepResult many = cur;
  for (int k = 1; k <= 100; ++k) many = step(r, many.state, cfgB((60 + 0.6 * k) * M_PI / 180), ws, fo);
  ASSERT_TRUE(one.summary.converged && many.summary.converged);
  EXPECT_NEAR(one.solution.twist[0], many.solution.twist[0], 1e-6);
  EXPECT_NEAR(one.state.contacts[0].relative_twist, many.state.contacts[0].relative_twist, 1e-6);
}

TEST(Friction, HysteresisLoopClosesAndRepeats) {
  const Robot r = pairB(0.12);
  const std::vector<double> loop = concat(range(0, 360, 10), range(360, 0, 10));
  const std::vector<double> path = concat(loop, loop);
  const std::vector<double> tw = twists(r, path);
  const std::size_t L = loop.size() - 1;
  // After one loop the state is back where it started (curvatures aligned: no moment, no friction).
  EXPECT_NEAR(tw[L], tw[0], 1e-9);
  for (std::size_t k = 0; k <= L; ++k) EXPECT_NEAR(tw[k], tw[k + L], 1e-8) << "angle " << path[k];
}

TEST(Friction, StickAfterReversalExistsAndLengthensWithMu) {
  std::vector<int> stick_steps;
  for (double mu : {0.03, 0.08, 0.16}) {
    const Robot r = pairB(mu);
    std::vector<StepResult> all;
    const std::vector<double> path = concat(range(0, 180, 2), range(180, 90, 1));
    twists(r, path, fastOptions(), &all);
    const std::size_t rev = range(0, 180, 2).size() - 1;
    int count = 0;
    const double tip_at_reversal = all[rev].solution.twist[0];
    for (std::size_t k = rev + 1; k < all.size(); ++k) {
      if (all[k].state.contacts[0].mode != ContactMode::Stick) break;
      // Stuck: the relative twist at the contact does not move.
      EXPECT_NEAR(all[k].state.contacts[0].relative_twist, all[rev].state.contacts[0].relative_twist, 1e-9);
      ++count;
    }
    EXPECT_GT(count, 0) << "mu' = " << mu;
    // While stuck the tip twist changes much less than the base (it "stays put").
    if (count > 0) {
      EXPECT_LT(std::abs(all[rev + count].solution.twist[0] - tip_at_reversal), 0.5 * count * M_PI / 180);
    }
    stick_steps.push_back(count);
  }
  EXPECT_LT(stick_steps[0], stick_steps[1]);
  EXPECT_LT(stick_steps[1], stick_steps[2]);
}

TEST(Friction, EnvelopeWidthAtPiGrowsMonotonicallyWithMu) {
  double prev = 0.0;
  for (double mu : {0.0, 0.02, 0.05, 0.1, 0.15}) {
    const Robot r = pairB(mu);
    const double up = twists(r, range(0, 180, 10)).back();
    const double down = twists(r, concat(range(0, 360, 10), range(360, 180, 10))).back();
    const double width = down - up;
    if (mu == 0.0) {
      EXPECT_NEAR(width, 0.0, 1e-9);
    } else {
      EXPECT_GT(width, prev);
    }
    prev = width;
  }
}

TEST(Friction, PaperModeAndStickSlipAgreeOnMonotoneSweeps) {
  const Robot r = pairB(0.12);
  const std::vector<double> path = range(0, 330, 5);
  const std::vector<double> a = twists(r, path, fastOptions(FrictionMode::StickSlip));
  const std::vector<double> b = twists(r, path, fastOptions(FrictionMode::Paper));
  for (std::size_t k = 2; k < path.size(); ++k) EXPECT_NEAR(a[k], b[k], 1e-8) << path[k];
}

TEST(Friction, BandVerticesAreTheEnvelopeBranches) {
  const Robot r = pairB(0.12);
  Workspace ws;
  const std::vector<double> up = twists(r, range(0, 150, 5));
  const std::vector<double> down = twists(r, concat(range(0, 360, 5), range(360, 150, 5)));
  FrictionBandOptions bo;
  bo.kinematics.record_backbone = false;
  const FrictionBand band = frictionBand(r, cfgB(150 * M_PI / 180), ws, bo);
  ASSERT_TRUE(band.converged) << band.message;
  EXPECT_NEAR(band.twist_min[0], up.back(), 1e-8);
  EXPECT_NEAR(band.twist_max[0], down.back(), 1e-8);
  EXPECT_GT(band.tip_spread, 1e-3);
  // Interior samples lie between the extremes.
  for (const Solution& s : band.shapes) {
    EXPECT_GE(s.twist[0], band.twist_min[0] - 1e-12);
    EXPECT_LE(s.twist[0], band.twist_max[0] + 1e-12);
  }
}

TEST(Friction, ALongEnoughMoveFromEveryBandShapeForgetsTheHistory) {
  // From every shape of the band at 150 deg (each contact stuck at its torque there: stuckStateAt), turning the inner
  // tube on to 270 deg slips every contact positively and ends on the branch reached from rest at 0 deg: the band
  // collapses to one equilibrium. A 5 deg move does not (the contacts stick through it).
  const Robot r = pairB(0.12);
  Workspace ws;
  const FrictionOptions fo = fastOptions();
  FrictionBandOptions bo;
  bo.kinematics.record_backbone = false;
  const FrictionBand band = frictionBand(r, cfgB(150 * M_PI / 180), ws, bo);
  ASSERT_TRUE(band.converged) << band.message;
  ASSERT_GE(band.shapes.size(), 3u);
  const double from_rest = twists(r, range(0, 270, 5)).back();
  double short_lo = 1e9, short_hi = -1e9;
  for (const Solution& shape : band.shapes) {
    const HysteresisState st = stuckStateAt(r, shape);
    ASSERT_TRUE(st.valid);
    ASSERT_EQ(st.contacts.size(), shape.contacts.size());
    const StepResult longer = step(r, st, cfgB(270 * M_PI / 180), ws, fo);
    ASSERT_TRUE(longer.summary.converged) << longer.summary.message;
    EXPECT_NEAR(longer.solution.twist[0], from_rest, 1e-6);
    for (const ContactMemory& m : longer.state.contacts) EXPECT_EQ(m.mode, ContactMode::SlipPositive);
    const StepResult shorter = step(r, st, cfgB(155 * M_PI / 180), ws, fo);
    ASSERT_TRUE(shorter.summary.converged) << shorter.summary.message;
    short_lo = std::min(short_lo, shorter.solution.twist[0]);
    short_hi = std::max(short_hi, shorter.solution.twist[0]);
  }
  EXPECT_GT(short_hi - short_lo, 0.5 * (band.twist_max[0] - band.twist_min[0]));
  // Misuse: a shape of another robot.
  const Robot three("three",
                    {makeTube("a", 0.05, 0.10, 4.0, 0.04, 0.3), makeTube("b", 0.08, 0.10, 6.0, 0.02, 0.3),
                     makeTube("c", 0.15, 0.06, 12.0, 0.006, 0.3)},
                    {0.1, 0.0});
  EXPECT_THROW(stuckStateAt(three, band.shapes[0]), std::invalid_argument);
}

TEST(Friction, TorqueBalanceHoldsWithFrictionTorques) {
  const Robot r = pairB(0.12);
  Workspace ws;
  FrictionOptions fo;  // record the backbone
  StepResult cur = initialState(r, cfgB(0), ws, fo);
  cur = step(r, cur.state, cfgB(2.0), ws, fo);
  ASSERT_TRUE(cur.summary.converged);
  ASSERT_FALSE(cur.solution.contacts.empty());
  EXPECT_GT(std::abs(cur.solution.contacts[0].torque), 1e-4);
  for (const BackbonePoint& p : cur.solution.backbone) {
    double sum = 0;
    for (int i = 0; i < 2; ++i)
      if (cur.solution.q.beta[i] + r.tube(i).length() > p.s + 1e-12) sum += r.tube(i).torsional_stiffness * p.uz[i];
    EXPECT_LT(std::abs(sum), 1e-10) << "s = " << p.s;
  }
}

TEST(Friction, RandomWalksOnThreeTubesKeepBoundsAndTerminate) {
  // Three tubes with translations: tube ends and curvature discontinuities outside the actuation unit.
  const Robot r("three",
                {makeTube("a", 0.05, 0.10, 4.0, 0.04, 0.3), makeTube("b", 0.08, 0.10, 6.0, 0.02, 0.3),
                 makeTube("c", 0.15, 0.06, 12.0, 0.006, 0.3)},
                {0.1, 0.0});
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> da(-0.15, 0.15), db(-0.003, 0.003);
  Workspace ws;
  FrictionOptions fo = fastOptions();
  for (int walk = 0; walk < 5; ++walk) {
    Configuration q(Eigen::Vector3d(0.1 * walk, 1.0, -0.5), Eigen::Vector3d(-0.02, -0.04, -0.07));
    StepResult cur = initialState(r, q, ws, fo);
    ASSERT_TRUE(cur.summary.converged);
    for (int k = 0; k < 40; ++k) {
      Configuration next = q;
      for (int i = 0; i < 3; ++i) next.alpha[i] += da(rng);
      for (int i = 0; i < 3; ++i) next.beta[i] += db(rng);
      if (!checkAdmissible(r, next)) continue;
      q = next;
      cur = step(r, cur.state, q, ws, fo);
      ASSERT_TRUE(cur.summary.converged) << cur.summary.message;
      EXPECT_GE(cur.solution.contacts.size(), 2u);
      for (const ContactResult& c : cur.solution.contacts) {
        EXPECT_LE(std::abs(c.torque), 0.1 * c.moment * (1 + 1e-8) + 1e-14);
        EXPECT_TRUE(std::isfinite(c.relative_twist));
      }
      EXPECT_TRUE(cur.state.base_twist_rate.allFinite());
    }
  }
}

TEST(Friction, StepRejectsUninitialisedState) {
  const Robot r = pairB(0.1);
  Workspace ws;
  HysteresisState s;
  EXPECT_THROW(step(r, s, cfgB(0), ws), std::invalid_argument);
}

TEST(Friction, BoundsAreContinuousWhenCoincidentEndsSeparate) {
  // Three tubes whose ends coincide (all retracted to 2 mm out, as the Med-MPD start poses) vs the inner ones
  // protruding by 1e-7 m. The friction bound mu'|m| at a tube end takes coincident ends in their nesting order, so
  // every friction-band vertex must agree to the perturbation size. (Before: the middle tube's end moment was taken
  // in the segment that still held the outer tube; the vertex twists jumped by up to 6 mrad here, and from 2.8 to
  // 0.5 rad on a 0.04 mm move of the Med-MPD lung robot.)
  const Robot r("three",
                {makeTube("outer", 0.07, 0.05, 25.0, 0.02, 0.3), makeTube("middle", 0.16, 0.06, 15.0, 0.01, 0.3),
                 makeTube("needle", 0.32, 0.0, 0.0, 0.004, 0.3)},
                {0.1, 0.0});
  const double out = 0.002;
  auto cfg = [&](double eps) {
    return Configuration(Eigen::Vector3d(0.0, 0.4, -0.3),
                         Eigen::Vector3d(out - 0.12, out + eps - 0.22, out + 2 * eps - 0.32));
  };
  Workspace ws;
  const Configuration a = cfg(0.0), b = cfg(1e-7);
  const std::vector<ContactSite> sa = contactSites(r, a), sb = contactSites(r, b);
  ASSERT_EQ(sa.size(), 2u);
  ASSERT_EQ(sb.size(), 2u);
  for (std::size_t code = 0; code < 4; ++code) {
    // The same torque signs at the same sites (the sites' order along the backbone may differ).
    std::vector<ContactCondition> ca(2), cb(2);
    for (std::size_t c = 0; c < 2; ++c) {
      const double sign = (code >> c) & 1u ? 1.0 : -1.0;
      ca[c] = {ContactCondition::Law::Torque, sign};
      const std::size_t j = sb[0] == sa[c] ? 0 : 1;
      cb[j] = {ContactCondition::Law::Torque, sign};
    }
    const Solution x = solveWithContacts(r, a, ca, ws), y = solveWithContacts(r, b, cb, ws);
    ASSERT_TRUE(x.converged() && y.converged());
    for (int k = 0; k < 2; ++k) EXPECT_NEAR(x.twist[k], y.twist[k], 1e-4) << "vertex " << code;
    for (const ContactResult& cx : x.contacts)
      for (const ContactResult& cy : y.contacts)
        if (cx.site == cy.site) {
          EXPECT_NEAR(cx.moment, cy.moment, 1e-6) << "vertex " << code;
          EXPECT_NEAR(cx.torque, cy.torque, 1e-7) << "vertex " << code;
        }
    EXPECT_LT((x.tip_position - y.tip_position).norm(), 1e-6);
  }
  // The needle (straight, innermost) carries no bending moment at the common tip.
  const Solution f = solve(r, a, ws);
  for (const ConcentratedMoment& m : f.moments)
    if (m.kind == MomentKind::TubeEnd && m.tube == 2) {
      EXPECT_LT(m.magnitude, 1e-12);
    }
}

TEST(Friction, StepDependsOnlyOnTheStateAndTheCommand) {
  // The hysteresis state is everything the model remembers: a step from a state to a command gives bit-identical
  // results whatever the workspace solved before (here: the same walk step by step, once in sequence and once from
  // the stored states with a workspace that has just followed another path, frictionless and with friction), with
  // the planner's solver settings (path predictor and Jacobian reuse on), without and with external loads. A
  // planner's checked states are then exactly what the replay of its path computes.
  Tube ta = makeTube("a", 0.05, 0.10, 4.0, 0.04, 0.3), tb = makeTube("b", 0.08, 0.10, 6.0, 0.02, 0.3),
       tc = makeTube("c", 0.15, 0.06, 12.0, 0.006, 0.3);
  ta.linear_density = 0.02;
  tb.linear_density = 0.012;
  tc.linear_density = 0.006;
  Loads loads;
  loads.gravity = Eigen::Vector3d(2.0, -9.81, 0.0);
  loads.tip_force = Eigen::Vector3d(0.03, 0.0, -0.02);
  for (bool loaded : {false, true}) {
    SCOPED_TRACE(loaded ? "with loads" : "without loads");
    const Robot r = Robot("three", {ta, tb, tc}, {0.1, 0.0}).withLoads(loaded ? loads : Loads{});
    FrictionOptions fo = fastOptions();
    fo.kinematics.tolerance = 1e-8;
    fo.kinematics.extrapolate_warm_start = true;
    std::uniform_real_distribution<double> da(-0.04, 0.04), db(-0.001, 0.001);
    Workspace ws, other;
    Configuration q(Eigen::Vector3d(0.3, 1.0, -0.5), Eigen::Vector3d(-0.02, -0.04, -0.07));
    StepResult cur = initialState(r, q, ws, fo);
    ASSERT_TRUE(cur.summary.converged);
    EXPECT_EQ(cur.solution.loaded, loaded);
    int compared = 0, slipping = 0;
    for (int k = 0; k < (loaded ? 150 : 300); ++k) {
      Configuration next = q;
      std::mt19937 dir(static_cast<unsigned>(1000 + k / 10));  // runs of 10 steps in one direction
      for (int i = 0; i < 3; ++i) next.alpha[i] += da(dir);
      for (int i = 0; i < 3; ++i) next.beta[i] += db(dir);
      if (!checkAdmissible(r, next)) continue;
      const HysteresisState before = cur.state;
      q = next;
      cur = step(r, before, q, ws, fo);
      if (!cur.summary.converged) break;
      // Another path in the other workspace (a frictionless chain and a stick-slip step), then the same step.
      Configuration p = q;
      for (int j = 0; j < 3; ++j) {
        p.alpha[1] += 0.01;
        solve(r.withFriction({0.0, 0.0}), p, other, fo.kinematics);
      }
      initialState(r, p, other, fo);
      const StepResult again = step(r, before, q, other, fo);
      ASSERT_TRUE(again.summary.converged);
      EXPECT_EQ(again.solution.tip_position, cur.solution.tip_position) << "step " << k;
      EXPECT_EQ(again.solution.twist, cur.solution.twist) << "step " << k;
      EXPECT_EQ(again.state.base_twist_rate, cur.state.base_twist_rate) << "step " << k;
      EXPECT_EQ(again.state.base_moment, cur.state.base_moment) << "step " << k;
      ASSERT_EQ(again.state.contacts.size(), cur.state.contacts.size());
      for (std::size_t c = 0; c < cur.state.contacts.size(); ++c) {
        EXPECT_EQ(again.state.contacts[c].mode, cur.state.contacts[c].mode) << "step " << k;
        EXPECT_EQ(again.state.contacts[c].torque, cur.state.contacts[c].torque) << "step " << k;
        slipping += cur.state.contacts[c].mode != ContactMode::Stick;
      }
      ++compared;
    }
    EXPECT_GE(compared, loaded ? 75 : 150);
    EXPECT_GT(slipping, loaded ? 15 : 30);
  }
}

TEST(Friction, PredictedStepsGiveTheSameStickSlipPath) {
  // With KinematicsOptions::extrapolate_warm_start a sub-step continuing the line of the previous one starts Newton
  // from the extrapolation of the two states (the state's warm-start memory). The same random walk with and without
  // it: the same contact modes at every step, the same shapes to the solver tolerance, fewer iterations.
  const Robot r("three",
                {makeTube("a", 0.05, 0.10, 4.0, 0.04, 0.3), makeTube("b", 0.08, 0.10, 6.0, 0.02, 0.3),
                 makeTube("c", 0.15, 0.06, 12.0, 0.006, 0.3)},
                {0.1, 0.0});
  auto walk = [&](bool predictor, std::vector<StepResult>& out) {
    FrictionOptions fo = fastOptions();
    fo.kinematics.tolerance = 1e-8;
    fo.kinematics.extrapolate_warm_start = predictor;
    std::uniform_real_distribution<double> da(-0.04, 0.04), db(-0.001, 0.001);
    Workspace ws;
    Configuration q(Eigen::Vector3d(0.3, 1.0, -0.5), Eigen::Vector3d(-0.02, -0.04, -0.07));
    StepResult cur = initialState(r, q, ws, fo);
    int iterations = 0;
    for (int k = 0; k < 300; ++k) {
      Configuration next = q;
      std::mt19937 dir(static_cast<unsigned>(1000 + k / 10));  // runs of 10 steps in one direction
      for (int i = 0; i < 3; ++i) next.alpha[i] += da(dir);
      for (int i = 0; i < 3; ++i) next.beta[i] += db(dir);
      if (!checkAdmissible(r, next)) continue;
      q = next;
      cur = step(r, cur.state, q, ws, fo);
      if (!cur.summary.converged) break;
      iterations += cur.solution.summary.iterations;
      out.push_back(cur);
    }
    return iterations;
  };
  std::vector<StepResult> plain, predicted;
  const int it_plain = walk(false, plain), it_pred = walk(true, predicted);
  ASSERT_EQ(plain.size(), predicted.size());
  ASSERT_GE(plain.size(), 150u);
  double worst_twist = 0.0, worst_tip = 0.0;
  int with_memory = 0;
  for (std::size_t k = 0; k < plain.size(); ++k) {
    ASSERT_EQ(plain[k].state.contacts.size(), predicted[k].state.contacts.size()) << "step " << k;
    for (std::size_t c = 0; c < plain[k].state.contacts.size(); ++c)
      ASSERT_EQ(plain[k].state.contacts[c].mode, predicted[k].state.contacts[c].mode) << "step " << k;
    worst_twist = std::max(worst_twist, (plain[k].solution.twist - predicted[k].solution.twist).cwiseAbs().maxCoeff());
    worst_tip = std::max(worst_tip, (plain[k].solution.tip_position - predicted[k].solution.tip_position).norm());
    with_memory += predicted[k].state.previous_q.size() > 0;
  }
  std::printf("[ measured ] %zu stick-slip steps (%d with warm-start memory): worst twist diff %.1e rad, tip diff %.1e "
              "m; Newton iterations %d plain, %d predicted\n",
              plain.size(), with_memory, worst_twist, worst_tip, it_plain, it_pred);
  EXPECT_LT(worst_twist, 1e-7);
  EXPECT_LT(worst_tip, 1e-9);
  EXPECT_GT(with_memory, 100);
  EXPECT_LT(it_pred, it_plain);
}

