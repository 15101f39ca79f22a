// Inverse kinematics: every answer is checked by an independent forward kinematics solve (a fresh
// workspace, the library's default discretisation) and against the admissible set; the friction-aware commands are
// checked by stepping the stateful model again from the same state. No timing here (bench/bench_ik.cpp).
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "ctr/io/robot_yaml.hpp"
#include "ctr/model/friction_ik.hpp"
#include "ctr/model/ik.hpp"
#include "ctr/model/sampling.hpp"

using namespace ctr;

namespace {

Robot example(const std::string& name) {
  return io::loadRobot(std::string(CTR_SOURCE_DIR) + "/examples/robots/" + name);
}

// Forward kinematics of q in a fresh workspace at the library's defaults (not the IK's solver state).
Solution fk(const Robot& r, const Configuration& q) {
  Workspace ws;
  return solve(r, q, ws);
}

// The admissible set, written out: nesting, ordered ends, protrusion, limits.
void expectAdmissible(const Robot& r, const Configuration& q, double min_protrusion = 1e-3) {
  ASSERT_EQ(q.size(), r.size());
  EXPECT_TRUE(checkAdmissible(r, q)) << checkAdmissible(r, q).message;
  const int n = r.size();
  for (int i = 0; i < n; ++i) {
    EXPECT_LE(q.beta[i], 0.0);
    if (i + 1 < n) {
      EXPECT_LE(q.beta[i + 1], q.beta[i]);
      EXPECT_LE(q.beta[i] + r.tube(i).length(), q.beta[i + 1] + r.tube(i + 1).length() + 1e-15);
    }
    if (const auto& l = r.tube(i).rotation_limits) {
      EXPECT_GE(q.alpha[i], (*l)[0]);
      EXPECT_LE(q.alpha[i], (*l)[1]);
    }
    if (const auto& l = r.tube(i).translation_limits) {
      EXPECT_GE(q.beta[i], (*l)[0]);
      EXPECT_LE(q.beta[i], (*l)[1]);
    }
  }
  EXPECT_GE(q.beta[n - 1] + r.tube(n - 1).length(), min_protrusion - 1e-15);
}

// An IK answer checked by forward kinematics: the reported tip is the tip of the returned configuration (its cold
// solve; for an answer on a branch a cold solve does not give, the solve warm-started from the answer's branch).
void expectAnswerMatchesForwardKinematics(const Robot& r, const IkResult& res, const Eigen::Vector3d& target) {
  expectAdmissible(r, res.q);
  Workspace ws;
  const Solution s = res.summary.branch_dependent ? solve(r, res.q, ws, {}, &res.solution) : solve(r, res.q, ws);
  ASSERT_TRUE(s.converged()) << s.summary.message;
  EXPECT_NEAR((s.tip_position - res.summary.closest).norm(), 0.0, 1e-8);
  EXPECT_NEAR((s.tip_position - target).norm(), res.summary.tip_error, 1e-8);
  EXPECT_EQ(s.summary.stable, res.summary.stable);
  if (res.summary.reached()) {
    EXPECT_LE((s.tip_position - target).norm(), IkOptions{}.tolerance + 1e-8);
  }
}

// Targets made by forward kinematics of random admissible configurations (stable equilibria).
std::vector<Eigen::Vector3d> reachableTargets(const Robot& r, int count, std::uint64_t seed,
                                              std::vector<Solution>* shapes = nullptr) {
  const TranslationSampler sampler(r);
  std::mt19937_64 rng(seed);
  Workspace ws;
  std::vector<Eigen::Vector3d> out;
  while (static_cast<int>(out.size()) < count) {
    const Solution s = solve(r, sampleConfiguration(r, sampler, rng), ws);
    if (!s.converged() || !s.summary.stable) continue;
    out.push_back(s.tip_position);
    if (shapes) shapes->push_back(s);
  }
  return out;
}

// The 10 mm (diameter) circle of the teleoperation example around a 3-tube robot's tip.
std::vector<IkTarget> circle(const Eigen::Vector3d& start, int points, double radius = 0.005) {
  const Eigen::Vector3d centre = start - Eigen::Vector3d(radius, 0.0, 0.0);
  std::vector<IkTarget> t;
  for (int k = 0; k <= points; ++k) {
    const double a = 2.0 * M_PI * k / points;
    t.emplace_back(centre + radius * Eigen::Vector3d(std::cos(a), std::sin(a), 0.0));
  }
  return t;
}

const Configuration kDupontStart(Eigen::Vector3d(0.0, 0.5, -1.0), Eigen::Vector3d(0.0, -0.017, -0.09));

}  // namespace

TEST(Ik, ColdReachesTargetsMadeByForwardKinematics) {
  for (const char* name : {"dupont_lab_3tube.yaml", "three_tube_generic.yaml", "tube_pair_B.yaml",
                           "proc_intracardiac.yaml", "medmpd_lung.yaml"}) {
    SCOPED_TRACE(name);
    const Robot r = example(name);
    Workspace ws;
    int reached = 0, total = 0;
    for (const Eigen::Vector3d& target : reachableTargets(r, 12, 7)) {
      const IkResult res = inverseKinematics(r, IkTarget(target), ws);
      ASSERT_NE(res.summary.status, IkStatus::Failed) << res.summary.message;
      expectAnswerMatchesForwardKinematics(r, res, target);
      reached += res.summary.reached() && !res.summary.branch_dependent;
      ++total;
      if (res.summary.reached() && !res.summary.branch_dependent) {
        EXPECT_TRUE(res.summary.message.empty());
      }
    }
    EXPECT_GE(reached, total - 1);
  }
}

// The default options against `other` on the same reachable targets (bench_ik's) and seeds: every default answer
// checks out by forward kinematics, and every target `other` reaches is reached by the default too.
struct DefaultVersus {
  int reached = 0, reached_other = 0;        // reached with a cold-solve-consistent equilibrium
  int iterations = 0, iterations_other = 0;  // in all
  int most = 0, most_other = 0;              // for the target that needs the most
  int several_starts_other = 0;              // targets where `other` needed more than one start
  int more_solves = 0;                       // targets where the default solved more configurations
};
DefaultVersus compareWithDefault(const Robot& r, IkOptions other, int targets) {
  Workspace ws;
  DefaultVersus v;
  int k = 0;
  for (const Eigen::Vector3d& target : reachableTargets(r, targets, 2024)) {
    IkOptions o;
    o.seed = other.seed = static_cast<std::uint64_t>(++k);
    const IkResult res = inverseKinematics(r, IkTarget(target), ws, o);
    const IkResult ref = inverseKinematics(r, IkTarget(target), ws, other);
    expectAnswerMatchesForwardKinematics(r, res, target);
    const bool ok = res.summary.reached() && !res.summary.branch_dependent;
    const bool ok_other = ref.summary.reached() && !ref.summary.branch_dependent;
    EXPECT_TRUE(ok || !ok_other) << "target " << k;
    v.reached += ok;
    v.reached_other += ok_other;
    v.iterations += res.summary.iterations;
    v.iterations_other += ref.summary.iterations;
    v.most = std::max(v.most, res.summary.iterations);
    v.most_other = std::max(v.most_other, ref.summary.iterations);
    v.several_starts_other += ref.summary.starts > 1;
    v.more_solves += res.summary.evaluations > ref.summary.evaluations;
  }
  std::printf("iterations %d (most %d per target), other options %d (most %d)\n", v.iterations, v.most,
              v.iterations_other, v.most_other);
  return v;
}

TEST(Ik, SettingSlowStartsAsideLosesNoTarget) {
  // medmpd_lung and medmpd_liver (the example robots with the most starts per target and the slowest single cold IK):
  // with slow descents set aside, resumed only when no start reaches, and stopped where another start already stalled,
  // every target that running each start to its end reaches is reached too, the answers check out, and the descents
  // take fewer iterations, in all and for the target that needs the most.
  for (const char* name : {"medmpd_lung.yaml", "medmpd_liver.yaml"}) {
    SCOPED_TRACE(name);
    IkOptions sequential;
    sequential.slow_start_horizon = 0.0;
    const DefaultVersus v = compareWithDefault(example(name), sequential, 100);
    EXPECT_GE(v.reached, v.reached_other);
    EXPECT_GE(v.reached, 99);
    EXPECT_GT(v.several_starts_other, 0);  // the targets exercised the restarts
    EXPECT_LT(v.iterations, v.iterations_other);
    EXPECT_LT(v.most, v.most_other);
  }
}

// proc_airway and medmpd_liver (the slowest single cold IK): when none of the first random candidates lies near the
// target, drawing more until one does (IkOptions::near_start) loses no target the plain ranking reaches, and the target
// that needs the most iterations needs fewer.
TEST(Ik, DrawingANearerStartLosesNoTargetAndShortensTheWorst) {
  for (const char* name : {"proc_airway.yaml", "medmpd_liver.yaml"}) {
    SCOPED_TRACE(name);
    IkOptions plain;
    plain.near_start = 0.0;
    const DefaultVersus v = compareWithDefault(example(name), plain, 200);
    EXPECT_GE(v.reached, v.reached_other);
    EXPECT_GT(v.more_solves, 0);  // the targets exercised it
    EXPECT_LT(v.most, v.most_other);
  }
}

TEST(Ik, WarmStartReachesANearbyTargetOnItsBranch) {
  const Robot r = example("dupont_lab_3tube.yaml");
  Workspace ws;
  const Solution s0 = fk(r, kDupontStart);
  Configuration q1 = kDupontStart;
  q1.alpha += Eigen::Vector3d(0.05, -0.03, 0.04);
  q1.beta += Eigen::Vector3d(-0.002, -0.001, -0.003);
  ASSERT_TRUE(checkAdmissible(r, q1));
  const Eigen::Vector3d target = fk(r, q1).tip_position;
  ASSERT_GT((target - s0.tip_position).norm(), 1e-3);
  IkOptions o;
  o.restarts = 0;
  const IkResult res = inverseKinematics(r, IkTarget(target), kDupontStart, ws, o);
  ASSERT_TRUE(res.summary.reached()) << res.summary.message;
  EXPECT_EQ(res.summary.starts, 1);
  EXPECT_LE(res.summary.iterations, 6);
  expectAnswerMatchesForwardKinematics(r, res, target);
  // The answer is near the start (damped least squares moves little), not a configuration from elsewhere.
  EXPECT_LT((res.q.alpha - kDupontStart.alpha).cwiseAbs().maxCoeff(), 0.3);
  // The twist stays on the start's branch.
  EXPECT_LT((res.solution.twist - s0.twist).cwiseAbs().maxCoeff(), 0.5);
}

TEST(Ik, ServoUpdatesTrackACircleContinuously) {
  const Robot r = example("dupont_lab_3tube.yaml");
  Workspace ws;
  const std::vector<IkTarget> path = circle(fk(r, kDupontStart).tip_position, 400);
  IkResult cur = inverseKinematics(r, path[0], kDupontStart, ws);
  ASSERT_TRUE(cur.summary.reached()) << cur.summary.message;
  int evaluations = 0;
  for (std::size_t k = 1; k < path.size(); ++k) {
    const IkResult next = inverseKinematics(r, path[k], cur, ws);
    ASSERT_TRUE(next.summary.reached()) << k << ": " << next.summary.message;
    // Continuous: 79 um of target motion per update moves no actuator by more than 0.02 rad / 1 mm.
    EXPECT_LT((next.q.alpha - cur.q.alpha).cwiseAbs().maxCoeff(), 0.02) << k;
    EXPECT_LT((next.q.beta - cur.q.beta).cwiseAbs().maxCoeff(), 1e-3) << k;
    evaluations += next.summary.evaluations;
    if (k % 50 == 0) expectAnswerMatchesForwardKinematics(r, next, path[k].position);
    cur = next;
  }
  // Mostly one solve per update (the previous Jacobian's step lands within the tolerance).
  EXPECT_LT(evaluations, static_cast<int>(2 * path.size()));
}

TEST(Ik, UnreachableTargetIsRefusedWithTheClosestPoint) {
  const Robot r = example("dupont_lab_3tube.yaml");
  Workspace ws;
  // 1 m along the axis (the robot is 0.27 m long) and 5 cm behind the base.
  for (const Eigen::Vector3d& target : {Eigen::Vector3d(0.0, 0.0, 1.0), Eigen::Vector3d(0.02, 0.0, -0.05)}) {
    const IkResult res = inverseKinematics(r, IkTarget(target), ws);
    EXPECT_EQ(res.summary.status, IkStatus::NotReached);
    EXPECT_FALSE(res.summary.message.empty());
    expectAnswerMatchesForwardKinematics(r, res, target);
    // No random admissible configuration has its tip closer than the closest point found.
    std::vector<Solution> shapes;
    reachableTargets(r, 200, 3, &shapes);
    double best = std::numeric_limits<double>::infinity();
    for (const Solution& s : shapes) best = std::min(best, (s.tip_position - target).norm());
    EXPECT_LE(res.summary.tip_error, best + 1e-9);
  }
  // Along the axis the tip cannot be further out than the innermost tube's length, and the closest point found is
  // on the axis side of the workspace: near the axis, high up.
  const IkResult far = inverseKinematics(r, IkTarget(Eigen::Vector3d(0.0, 0.0, 1.0)), ws);
  EXPECT_GT(far.summary.tip_error, 1.0 - r.tube(2).length() - 1e-6);
  EXPECT_GT(far.summary.closest.z(), 0.2);
}

TEST(Ik, LimitsAreNeverViolated) {
  // three_tube_generic with narrow rotation and translation limits; targets from the unrestricted robot, many of them
  // out of reach of the restricted one: reached or not, every answer stays in the limits.
  const Robot wide = example("three_tube_generic.yaml");
  std::vector<Tube> tubes = wide.tubes();
  tubes[0].rotation_limits = std::array<double, 2>{-0.5, 0.5};
  tubes[1].rotation_limits = std::array<double, 2>{-1.0, 0.2};
  tubes[2].rotation_limits = std::array<double, 2>{0.0, 1.5};
  tubes[0].translation_limits = std::array<double, 2>{-0.06, -0.02};
  tubes[2].translation_limits = std::array<double, 2>{-0.19, -0.15};
  const Robot narrow("narrow", tubes);
  Workspace ws;
  int reached = 0, refused = 0;
  std::vector<Eigen::Vector3d> targets = reachableTargets(wide, 10, 5);
  for (const Eigen::Vector3d& t : reachableTargets(narrow, 6, 6)) targets.push_back(t);
  for (const Eigen::Vector3d& target : targets) {
    const IkResult cold = inverseKinematics(narrow, IkTarget(target), ws);
    ASSERT_NE(cold.summary.status, IkStatus::Failed);
    expectAnswerMatchesForwardKinematics(narrow, cold, target);
    // A warm start outside the limits is projected into them first.
    Configuration outside = defaultConfiguration(wide);
    outside.alpha << 2.0, -2.0, -1.0;
    const IkResult warm = inverseKinematics(narrow, IkTarget(target), outside, ws);
    ASSERT_NE(warm.summary.status, IkStatus::Failed);
    expectAnswerMatchesForwardKinematics(narrow, warm, target);
    reached += cold.summary.reached();
    refused += !cold.summary.reached();
  }
  // Both kinds occurred (the test exercised the limits).
  EXPECT_GT(reached, 0);
  EXPECT_GT(refused, 0);
}

TEST(Ik, TipDirectionIsReachedWithThePosition) {
  const Robot r = example("dupont_lab_3tube.yaml");
  Workspace ws;
  std::vector<Solution> shapes;
  reachableTargets(r, 6, 9, &shapes);
  int reached = 0;
  for (const Solution& s : shapes) {
    const IkTarget target(s.tip_position, s.tipTangent(), 0.02);
    const IkResult res = inverseKinematics(r, target, ws);
    expectAnswerMatchesForwardKinematics(r, res, target.position);
    if (!res.summary.reached()) continue;
    ++reached;
    const Solution check = fk(r, res.q);
    EXPECT_LE(std::acos(std::min(1.0, check.tipTangent().dot(s.tipTangent()))), IkOptions{}.direction_tolerance + 1e-6);
    EXPECT_NEAR(res.summary.direction_error, std::acos(std::min(1.0, check.tipTangent().dot(s.tipTangent()))), 1e-6);
  }
  EXPECT_GE(reached, 5);
  // Position alone does not fix the direction: the same position with another direction is also reached.
  const Solution& s = shapes.front();
  const Eigen::Vector3d tilted = (s.tipTangent() + 0.2 * s.tip_frame.col(0)).normalized();
  const IkResult other = inverseKinematics(r, IkTarget(s.tip_position, tilted, 0.02), ws);
  if (other.summary.reached()) {
    EXPECT_LE(other.summary.direction_error, 0.01);
  }
}

TEST(Ik, MisuseThrows) {
  const Robot r = example("dupont_lab_3tube.yaml");
  Workspace ws;
  const IkTarget t(Eigen::Vector3d(0.02, 0.0, 0.2));
  EXPECT_THROW(inverseKinematics(r, t, Configuration::zeros(2), ws), std::invalid_argument);
  Configuration nan = kDupontStart;
  nan.alpha[0] = std::nan("");
  EXPECT_THROW(inverseKinematics(r, t, nan, ws), std::invalid_argument);
  EXPECT_THROW(inverseKinematics(r, IkTarget(Eigen::Vector3d(0.0, std::nan(""), 0.1)), ws), std::invalid_argument);
  EXPECT_THROW(inverseKinematics(r, IkTarget(t.position, Eigen::Vector3d::Zero()), ws), std::invalid_argument);
  IkOptions negative;
  negative.slow_start_horizon = -1.0;
  EXPECT_THROW(inverseKinematics(r, t, ws, negative), std::invalid_argument);
  const Robot rf = r.withFriction({0.1, 0.0});
  EXPECT_THROW(frictionInverseKinematics(rf, HysteresisState{}, t, ws), std::invalid_argument);
}

TEST(FrictionIk, CommandPutsTheTipOnTheTargetThroughTheStatefulStep) {
  const Robot r = example("dupont_lab_3tube.yaml").withFriction({0.1, 0.0});
  Workspace ws;
  for (const Approach approach : {Approach::Rest, Approach::Positive, Approach::Negative}) {
    SCOPED_TRACE(static_cast<int>(approach));
    const StepResult start = approachState(r, kDupontStart, approach, 0.5, ws);
    ASSERT_TRUE(start.summary.converged) << start.summary.message;
    Configuration q1 = kDupontStart;
    q1.alpha += Eigen::Vector3d(0.1, -0.2, 0.3);
    const Eigen::Vector3d target = fk(r, q1).tip_position;  // a frictionless tip near the start
    const FrictionIkResult res = frictionInverseKinematics(r, start.state, IkTarget(target), ws);
    ASSERT_TRUE(res.summary.reached()) << res.summary.message;
    expectAdmissible(r, res.q);
    // The command, stepped again from the same state in a fresh workspace, puts the tip on the target.
    Workspace fresh;
    const StepResult check = step(r, start.state, res.q, fresh, FrictionIkOptions{}.friction);
    ASSERT_TRUE(check.summary.converged);
    EXPECT_LE((check.solution.tip_position - target).norm(), IkOptions{}.tolerance + 1e-9);
    EXPECT_NEAR((check.solution.tip_position - res.step.solution.tip_position).norm(), 0.0, 1e-12);
    // Friction matters here: the friction-blind command (frictionless IK, reached on the frictionless model) leaves
    // the tip well off the target when stepped through the same model, and the commands differ.
    EXPECT_TRUE(res.cost.blind_reached);
    EXPECT_GT(res.cost.blind_tip_error, 5 * IkOptions{}.tolerance);
    const StepResult blind = step(r, start.state, res.cost.blind_q, fresh, FrictionIkOptions{}.friction);
    EXPECT_NEAR((blind.solution.tip_position - target).norm(), res.cost.blind_tip_error, 1e-9);
    EXPECT_GT(res.cost.alpha_difference, 1e-3);
  }
}

TEST(FrictionIk, PathCommandsReplayThroughTheStatefulModel) {
  // The teleoperation example's circle (10 mm diameter) with mu' = 0.1, 120 targets: each command checked by stepping
  // the model from the state the previous command left; friction-blind commands leave a far larger error.
  const Robot r = example("dupont_lab_3tube.yaml").withFriction({0.1, 0.0});
  Workspace ws;
  const std::vector<IkTarget> path = circle(fk(r, kDupontStart).tip_position, 120);
  const IkResult first = inverseKinematics(r, path[0], kDupontStart, ws);
  ASSERT_TRUE(first.summary.reached());
  const FrictionIkOptions o;
  const StepResult start = initialState(r, first.q, ws, o.friction);
  const std::vector<FrictionIkResult> res = frictionInverseKinematicsPath(r, start.state, path, ws, o);
  ASSERT_EQ(res.size(), path.size());
  Workspace fresh;
  HysteresisState h = start.state, blind_h = start.state;
  double comp2 = 0.0, blind2 = 0.0;
  for (std::size_t k = 0; k < res.size(); ++k) {
    EXPECT_TRUE(res[k].summary.reached()) << k << ": " << res[k].summary.message;
    expectAdmissible(r, res[k].q);
    const StepResult s = step(r, h, res[k].q, fresh, o.friction);
    ASSERT_TRUE(s.summary.converged) << k;
    const double e = (s.solution.tip_position - path[k].position).norm();
    EXPECT_LE(e, IkOptions{}.tolerance + 1e-9) << k;
    comp2 += e * e;
    h = s.state;
    const StepResult b = step(r, blind_h, res[k].cost.blind_q, fresh, o.friction);
    ASSERT_TRUE(b.summary.converged) << k;
    const double eb = (b.solution.tip_position - path[k].position).norm();
    EXPECT_NEAR(eb, res[k].cost.blind_tip_error, 1e-9) << k;
    blind2 += eb * eb;
    blind_h = b.state;
  }
  const double comp_rms = std::sqrt(comp2 / res.size()), blind_rms = std::sqrt(blind2 / res.size());
  std::printf("[ measured ] circle, mu' 0.1: tip RMS friction-blind %.3f mm, friction-aware %.4f mm\n", blind_rms * 1e3,
              comp_rms * 1e3);
  EXPECT_GT(blind_rms, 5.0 * comp_rms);
  EXPECT_GT(blind_rms, 1e-3);  // the blind commands are off by more than a millimetre (RMS)
}

TEST(FrictionIk, ApproachDirectionSetsTheContactMemory) {
  const Robot r = example("dupont_lab_3tube.yaml").withFriction({0.1, 0.0});
  Workspace ws;
  const StepResult rest = approachState(r, kDupontStart, Approach::Rest, 0.5, ws);
  const StepResult pos = approachState(r, kDupontStart, Approach::Positive, 0.5, ws);
  const StepResult neg = approachState(r, kDupontStart, Approach::Negative, 0.5, ws);
  ASSERT_TRUE(rest.summary.converged && pos.summary.converged && neg.summary.converged);
  EXPECT_TRUE(pos.state.q.alpha.isApprox(kDupontStart.alpha) && neg.state.q.alpha.isApprox(kDupontStart.alpha));
  // Same command, different memory: the twist of the innermost tube lies on either side of the torque-free shape's,
  // and the tip moved.
  ASSERT_EQ(pos.solution.twist.size(), 2);
  EXPECT_GT(std::abs(pos.solution.twist[1] - neg.solution.twist[1]), 0.1);
  EXPECT_LT((pos.solution.twist[1] - rest.solution.twist[1]) * (neg.solution.twist[1] - rest.solution.twist[1]), 0.0);
  EXPECT_GT((pos.solution.tip_position - neg.solution.tip_position).norm(), 1e-3);
  // Contact torques of opposite signs (inner tubes turned positively: torques negative), none of them at rest.
  ASSERT_EQ(pos.state.contacts.size(), neg.state.contacts.size());
  int opposite = 0;
  for (std::size_t c = 0; c < pos.state.contacts.size(); ++c) {
    EXPECT_EQ(rest.state.contacts[c].torque, 0.0);
    opposite += pos.state.contacts[c].torque < 0.0 && neg.state.contacts[c].torque > 0.0;
  }
  EXPECT_GE(opposite, 2);
}

TEST(FrictionIk, PaperModeAndDistributedFrictionCommandsReachThroughTheirOwnStep) {
  // The inverse is of whatever stateful model the options and the robot describe: the paper's always-slipping mode
  // (eq. 34-35), and distributed friction (eq. 15-21) on top of the boundary friction. Each command, stepped again
  // from the same state in a fresh workspace with the same options, puts the tip on the target.
  struct Case {
    const char* name;
    FrictionCoefficients mu;
    FrictionMode mode;
  };
  for (const Case& c :
       {Case{"paper", {0.1, 0.0}, FrictionMode::Paper}, Case{"distributed", {0.05, 0.1}, FrictionMode::StickSlip}}) {
    SCOPED_TRACE(c.name);
    const Robot r = example("dupont_lab_3tube.yaml").withFriction(c.mu);
    Workspace ws;
    FrictionIkOptions o;
    o.friction.mode = c.mode;
    const StepResult start = approachState(r, kDupontStart, Approach::Positive, 0.5, ws, o.friction);
    ASSERT_TRUE(start.summary.converged) << start.summary.message;
    Configuration q1 = kDupontStart;
    q1.alpha += Eigen::Vector3d(0.1, -0.2, 0.3);
    const Eigen::Vector3d target = fk(r, q1).tip_position;
    const FrictionIkResult res = frictionInverseKinematics(r, start.state, IkTarget(target), ws, o);
    ASSERT_TRUE(res.summary.reached()) << res.summary.message;
    expectAdmissible(r, res.q);
    Workspace fresh;
    const StepResult check = step(r, start.state, res.q, fresh, o.friction);
    ASSERT_TRUE(check.summary.converged) << check.summary.message;
    EXPECT_LE((check.solution.tip_position - target).norm(), IkOptions{}.tolerance + 1e-9);
    // Friction acts: the friction-blind command, stepped through the same model, leaves the tip off the target.
    EXPECT_GT(res.cost.blind_tip_error, 5 * IkOptions{}.tolerance);
  }
}
