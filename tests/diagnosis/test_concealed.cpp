// Concealed cases built with the injection path: random order, noise comparable to the effect, position-only
// recordings in an unknown frame, 3-tube robots with translations, two effects at once, sensor latency, null.
#include <gtest/gtest.h>

#include <algorithm>

#include "actuation_cases.hpp"
#include "ctr/diagnosis/diagnose.hpp"
#include "ctr/diagnosis/simulate.hpp"
#include "ctr/io/robot_yaml.hpp"

using namespace ctr;
using namespace ctr::diagnosis;

namespace {

Robot robot(const std::string& name) {
  return io::loadRobot(std::string(CTR_SOURCE_DIR) + "/examples/robots/" + name + ".yaml");
}

struct Result {
  DiagnosisReport rep;
  io::Recording rec;
};

Result run(const Robot& truth_nominal, const Robot& believed, const std::vector<Effect>& effects, ActuationOptions a,
           SimulationOptions s, FrameMode frame = FrameMode::Base) {
  std::vector<Configuration> cmd;
  Eigen::VectorXd time;
  makeActuation(truth_nominal, a, cmd, time);
  Result r;
  r.rec = simulateRecording(truth_nominal, cmd, time, effects, s);
  DiagnoseOptions o;
  o.frame = frame;
  r.rep = diagnose(believed, r.rec, o);
  return r;
}

const Effect* find(const DiagnosisReport& rep, EffectKind k) {
  for (const Effect& e : rep.final_effects)
    if (e.kind == k) return &e;
  return nullptr;
}

/// A continuous random walk logged coarsely: up to 6 rad/s per tube at 10 Hz, 160 rows (10-35 deg per tube between
/// rows, like set 2 of the public recordings).
ActuationOptions coarseWalk(std::uint64_t seed) {
  ActuationOptions a;
  a.pattern = ActuationPattern::RandomWalk;
  a.rows = 160;
  a.dt = 0.1;
  a.max_speed = 6.0;
  a.seed = seed;
  return a;
}

/// The noise of set 2 of the public recordings: twist 2 deg, tip position 0.5 mm, tangent 1 deg.
SimulationOptions coarseNoise(std::uint64_t seed) {
  SimulationOptions s;
  s.twist_sd = 2 * M_PI / 180;
  s.position_sd = 5e-4;
  s.tangent_sd = 1 * M_PI / 180;
  s.seed = seed;
  return s;
}

void expectHeldOutDown(const DiagnosisReport& rep) {
  for (const auto& kv : rep.baseline.heldout_rmse)
    EXPECT_LT(rep.final.heldout_rmse.at(kv.first), kv.second) << kv.first;
}

}  // namespace

TEST(Concealed, FrictionRandomOrderNoisy) {
  // Random actuation order (no sweeps), twist noise 3 deg.
  const Robot r = robot("tube_pair_B");
  ActuationOptions a;
  a.pattern = ActuationPattern::Random;
  a.rows = 32;  // random jumps make every friction replay sub-step a full revolution: keep it small
  a.dt = 0;
  a.seed = 11;
  SimulationOptions s;
  s.twist_sd = 3 * M_PI / 180;
  s.position_sd = 1e-3;
  s.tangent_sd = 2 * M_PI / 180;
  s.seed = 12;
  const Result res = run(r, r, {{EffectKind::BoundaryFriction, 0, 0.08}}, a, s);
  EXPECT_EQ(res.rep.verdict, std::vector<std::string>{"boundary_friction"}) << res.rep.summary;
  if (const Effect* e = find(res.rep, EffectKind::BoundaryFriction)) {
    EXPECT_NEAR(e->value, 0.08, 0.016);
  }
  expectHeldOutDown(res.rep);
}

TEST(Concealed, FrictionMaskedByPoissonRatio) {
  // The description says nu = 0.3; the robot has nu = 0.6 and boundary friction (the paper's situation).
  const Robot truth = robot("tube_pair_B");
  const Robot believed = applyToRobot(truth, {{EffectKind::TorsionalStiffness, 0, 0.3}});
  ActuationOptions a;
  a.dt = 0;
  SimulationOptions s;
  s.seed = 3;
  const Result res = run(truth, believed, {{EffectKind::BoundaryFriction, 0, 0.06}}, a, s);
  auto v = res.rep.verdict;
  std::sort(v.begin(), v.end());
  EXPECT_EQ(v, (std::vector<std::string>{"boundary_friction", "torsional_stiffness"})) << res.rep.summary;
  if (const Effect* e = find(res.rep, EffectKind::TorsionalStiffness)) {
    EXPECT_NEAR(e->value, 0.6, 0.12);
  }
  if (const Effect* e = find(res.rep, EffectKind::BoundaryFriction)) {
    EXPECT_NEAR(e->value, 0.06, 0.012);
  }
  expectHeldOutDown(res.rep);
}

TEST(Concealed, OffsetPositionOnlyUnknownFrameThreeTubes) {
  // 3 tubes with translations, random walk, only tip positions, in an unknown sensor frame.
  const Robot r = robot("three_tube_generic");
  ActuationOptions a = test::randomWalk(120, true, 0, 5);
  SimulationOptions s;
  s.twist = s.tip_tangent = false;
  s.position_sd = 3e-4;
  Registration reg;
  reg.rotation = Eigen::AngleAxisd(1.0, Eigen::Vector3d(0.3, -1, 0.2).normalized()).toRotationMatrix();
  reg.translation = Eigen::Vector3d(0.05, 0.1, -0.02);
  reg.tip_offset = 0.004;
  s.sensor_frame = reg;
  s.seed = 6;
  const Result res = run(r, r, {{EffectKind::ActuatorOffset, 3, 0.25}}, a, s, FrameMode::Unknown);
  EXPECT_EQ(res.rep.verdict, std::vector<std::string>{"actuator_offset"}) << res.rep.summary;
  if (const Effect* e = find(res.rep, EffectKind::ActuatorOffset)) {
    EXPECT_EQ(e->tube, 3);
    EXPECT_NEAR(e->value, 0.25, 0.05);
  }
  expectHeldOutDown(res.rep);
}

TEST(Concealed, LatencyIsNotFriction) {
  // Timed random walk: the measurement lags by 0.3 s; direction-dependent residuals that scale with speed.
  const Robot r = robot("tube_pair_A");
  ActuationOptions a = test::randomWalk(120, false, 0.1, 9);
  a.max_speed = 1.0;
  SimulationOptions s;
  s.seed = 10;
  const Result res = run(r, r, {{EffectKind::SensorLatency, 0, 0.3}}, a, s);
  EXPECT_EQ(res.rep.verdict, std::vector<std::string>{"sensor_latency"}) << res.rep.summary;
  if (const Effect* e = find(res.rep, EffectKind::SensorLatency)) {
    EXPECT_NEAR(e->value, 0.3, 0.06);
  }
  expectHeldOutDown(res.rep);
}

TEST(Concealed, NullThreeTubeTimedWalk) {
  const Robot r = robot("three_tube_generic");
  ActuationOptions a = test::randomWalk(100, true, 0.1, 21);
  SimulationOptions s;
  s.seed = 22;
  const Result res = run(r, r, {}, a, s);
  EXPECT_TRUE(res.rep.verdict.empty()) << res.rep.summary;
}

TEST(Concealed, TwoWeakEffectsTogether) {
  // Friction and a torsional stiffness on a sweep, each absorbing part of the other's signature: alone neither
  // predicts the held-out rows significantly better, so no single candidate passes its round; the joint pair does,
  // and both must be named at their values.
  const Robot r = robot("tube_pair_B");
  ActuationOptions a;
  a.rows = 73;
  a.dt = 0;
  a.seed = 42;
  SimulationOptions s;
  s.seed = 43;
  const Result res =
      run(r, r, {{EffectKind::BoundaryFriction, 0, 0.06}, {EffectKind::TorsionalStiffness, 0, 0.3}}, a, s);
  auto v = res.rep.verdict;
  std::sort(v.begin(), v.end());
  EXPECT_EQ(v, (std::vector<std::string>{"boundary_friction", "torsional_stiffness"})) << res.rep.summary;
  if (const Effect* e = find(res.rep, EffectKind::BoundaryFriction)) {
    EXPECT_NEAR(e->value, 0.06, 0.012);
  }
  if (const Effect* e = find(res.rep, EffectKind::TorsionalStiffness)) {
    EXPECT_NEAR(e->value, 0.3, 0.06);
  }
  expectHeldOutDown(res.rep);
}

TEST(Concealed, StageOffsetDoesNotStandInForATipLoad) {
  // A drive offset and a tip force on a random walk of the Dupont-lab design with translations, 2x the public noise.
  // Other offsets and the Poisson ratio add on top of the drive offset in-sample (they take up part of the force,
  // which does not pass alone) but not on top of the drive offset and the tip load: they must not be accepted with
  // the drive offset, and the next round must name the load.
  const Robot r = robot("dupont_lab_3tube");
  ActuationOptions a = test::randomWalk(120, true, 0, 47);
  SimulationOptions s;
  s.twist_sd *= 2;  // 2x the public noise
  s.position_sd *= 2;
  s.tangent_sd *= 2;
  s.seed = 48;
  const Result res =
      run(r, r, {parseEffect("tip_load:force=-0.02,0.02,0"), {EffectKind::ActuatorOffset, 2, 0.1}}, a, s);
  auto v = res.rep.verdict;
  std::sort(v.begin(), v.end());
  EXPECT_EQ(v, (std::vector<std::string>{"actuator_offset", "tip_load"})) << res.rep.summary;
  if (const Effect* e = find(res.rep, EffectKind::ActuatorOffset)) {
    EXPECT_NEAR(e->value, 0.1, 0.02);
  }
  if (const Effect* e = find(res.rep, EffectKind::TipLoad)) {
    EXPECT_NEAR(e->vec.x(), -0.02, 0.006);
    EXPECT_NEAR(e->vec.y(), 0.02, 0.006);
  }
  expectHeldOutDown(res.rep);
}

// A continuous motion logged coarsely (a random walk at up to 6 rad/s sampled at 10 Hz: 10-35 deg per tube between
// rows, the noise of the public set 2) with friction and 8 of 160 tip samples off by 6-15 mm (tracker glitches).
// Rows are in the order taken, so the replay follows the motion; the glitches are listed and left out, friction is
// named within 10 %, and nothing is called physics outside the library. Fails when rows after large moves are reached
// from rest (friction then fitted at a fraction of its value) or when the glitches stay in the fit.
TEST(CoarseWalk, FrictionWithTrackerGlitches) {
  const Robot r = robot("tube_pair_B");
  std::vector<Configuration> cmd;
  Eigen::VectorXd time;
  makeActuation(r, coarseWalk(25), cmd, time);
  io::Recording rec = simulateRecording(r, cmd, time, {{EffectKind::BoundaryFriction, 0, 0.12}}, coarseNoise(26));
  const std::vector<int> glitched = {7, 23, 41, 60, 88, 102, 131, 150};
  for (std::size_t j = 0; j < glitched.size(); ++j) {
    const Eigen::Vector3d d = Eigen::Vector3d(std::cos(1.7 * j), std::sin(1.7 * j), 0.5 - 0.13 * j).normalized();
    rec.tip_position.row(glitched[j]) += (0.006 + 0.0012 * static_cast<double>(j)) * d.transpose();
  }
  const DiagnosisReport rep = diagnose(r, rec);
  EXPECT_EQ(rep.verdict, std::vector<std::string>{"boundary_friction"}) << rep.summary;
  if (const Effect* e = find(rep, EffectKind::BoundaryFriction)) {
    EXPECT_NEAR(e->value, 0.12, 0.012);
  }
  std::vector<int> listed;
  for (const OutlierRow& o : rep.outlier_rows) listed.push_back(o.row - 1);
  EXPECT_EQ(listed, glitched);
  EXPECT_FALSE(rep.unexplained.present) << rep.summary;
  EXPECT_EQ(rep.branch, "path");
  expectHeldOutDown(rep);
}

// The same motion with friction and a sensor latency: both named with their values (latency + friction is not
// latency + play, as reaching coarse rows from rest makes it), and no glitch in a clean recording.
TEST(CoarseWalk, FrictionAndLatency) {
  const Robot r = robot("tube_pair_A");
  const Result res = run(r, r, {{EffectKind::BoundaryFriction, 0, 0.07}, {EffectKind::SensorLatency, 0, 0.18}},
                         coarseWalk(22), coarseNoise(23));
  std::vector<std::string> v = res.rep.verdict;
  std::sort(v.begin(), v.end());
  EXPECT_EQ(v, (std::vector<std::string>{"boundary_friction", "sensor_latency"})) << res.rep.summary;
  if (const Effect* e = find(res.rep, EffectKind::BoundaryFriction)) {
    EXPECT_NEAR(e->value, 0.07, 0.0105);
  }
  if (const Effect* e = find(res.rep, EffectKind::SensorLatency)) {
    EXPECT_NEAR(e->value, 0.18, 0.027);
  }
  EXPECT_TRUE(res.rep.outlier_rows.empty());
  expectHeldOutDown(res.rep);
}
