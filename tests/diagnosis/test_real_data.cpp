// Diagnosis on recordings shaped like real lab data: pose sets reached by unknown paths (the branch rule and the other
// stable equilibria), repeated frames and returns to a pose (jitter and repeatability), a noise the user gives, an
// unbiased tangent-noise estimate, a null recording of a real design measured like the real log, and physics
// outside the library described by its structure instead of being given a library name.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <set>

#include "ctr/diagnosis/diagnose.hpp"
#include "ctr/diagnosis/import.hpp"
#include "ctr/diagnosis/simulate.hpp"
#include "ctr/io/robot_yaml.hpp"
#include "real_log.hpp"

using namespace ctr;
using namespace ctr::diagnosis;

namespace {

constexpr double kDeg = M_PI / 180;

Robot robot(const std::string& name) {
  return io::loadRobot(std::string(CTR_SOURCE_DIR) + "/examples/robots/" + name + ".yaml");
}

bool contains(const std::string& s, const std::string& part) {
  return s.find(part) != std::string::npos;
}

std::vector<Configuration> actuation(const Robot& r, ActuationOptions a, Eigen::VectorXd& time) {
  std::vector<Configuration> cmd;
  makeActuation(r, a, cmd, time);
  return cmd;
}

}  // namespace

// The noise estimate from a smooth model error (here none) is within 10 % of the truth at three levels, for the
// tangent (2 noisy directions per row, the unit-vector convention) and the position; the median-based estimate with
// the chi-square median of its degrees of freedom is unbiased.
TEST(Noise, TangentAndPositionEstimatesAreWithinTenPercentAtThreeLevels) {
  const Robot r = robot("three_tube_generic");
  ActuationOptions a;
  a.pattern = ActuationPattern::RandomWalk;
  a.rows = 1500;
  a.dt = 0.1;
  a.translate = true;
  a.seed = 31;
  Eigen::VectorXd time;
  const std::vector<Configuration> cmd = actuation(r, a, time);
  Workspace ws;
  const Prediction truth = predict(r, cmd, time, {}, ws);
  for (double level : {0.5, 1.0, 1.5}) {
    SimulationOptions s;
    s.tangent_sd = level * kDeg;
    s.position_sd = level * 4e-4;
    s.twist_sd = level * kDeg;
    s.seed = static_cast<std::uint64_t>(100 * level);
    const io::Recording rec = simulateRecording(r, cmd, time, {}, s);
    const Residuals res = computeResiduals(rec, truth);
    const NoiseReport n = estimateNoise(rec, res, truth, truth.ok);
    for (Quantity q : {Quantity::TipTangent, Quantity::TipPosition, Quantity::Twist}) {
      const double want = q == Quantity::TipPosition ? s.position_sd : s.tangent_sd;
      const NoiseEstimate& e = n.by_quantity.at(q);
      EXPECT_NEAR(e.sigma / want, 1.0, 0.10) << toString(q) << " at " << level << ": " << e.note;
      EXPECT_EQ(e.source, "neighbours");
      EXPECT_TRUE(e.supported) << e.note;
      EXPECT_LT(e.interval95[0], e.sigma);
      EXPECT_GT(e.interval95[1], e.sigma);
      std::printf("%s at %.1f: %.4f of the truth, 95 %% [%.4f, %.4f], %.0f dof\n", toString(q), level, e.sigma / want,
                  e.interval95[0] / want, e.interval95[1] / want, e.dof);
    }
  }
}

// A pose set measured like an optical tracker: 20 frames per visit (jitter 0.05 mm), poses revisited (the robot
// returns to 0.5 mm). The frames are averaged into visits; the jitter is measured from the frames, the noise the
// model must meet from the returns; the tool reports both and where they came from.
TEST(Noise, RepeatedFramesGiveTheJitterAndReturnsTheRepeatability) {
  const Robot r = robot("tube_pair_B");
  ActuationOptions a;
  a.pattern = ActuationPattern::Random;
  a.rows = 60;
  a.returns = 0.5;
  a.frames = 20;
  a.dt = 0;
  a.seed = 5;
  Eigen::VectorXd time;
  const std::vector<Configuration> cmd = actuation(r, a, time);
  SimulationOptions s;
  s.twist = false;
  s.position_sd = 5e-5;
  s.tangent_sd = 0.02 * kDeg;
  s.repeatability_position_sd = 5e-4;
  s.repeatability_tangent_sd = 0.3 * kDeg;
  s.seed = 6;
  const io::Recording rec = simulateRecording(r, cmd, time, {}, s);
  DiagnoseOptions o;
  o.max_effects = 0;
  const DiagnosisReport rep = diagnose(r, rec, o);
  int visits = 0;  // runs of one command (a return may follow its own pose)
  for (std::size_t k = 0; k < cmd.size(); ++k)
    visits += k == 0 || cmd[k].alpha != cmd[k - 1].alpha || cmd[k].beta != cmd[k - 1].beta;
  EXPECT_EQ(rep.recording_rows, 1200);
  EXPECT_EQ(rep.visits, visits);
  const NoiseEstimate& p = rep.noise.by_quantity.at(Quantity::TipPosition);
  EXPECT_EQ(p.source, "repeated") << p.note;
  EXPECT_NEAR(p.sigma / std::sqrt(5e-4 * 5e-4 + 5e-5 * 5e-5 / 20), 1.0, 0.35) << p.note;
  EXPECT_NEAR(p.jitter / 5e-5, 1.0, 0.1);
  EXPECT_EQ(p.frames, 20);
  EXPECT_TRUE(rep.verdict.empty()) << rep.summary;
  EXPECT_FALSE(rep.unexplained.present) << rep.summary;
  const std::string json = reportToJson(rep);
  EXPECT_TRUE(contains(json, "\"source\": \"repeated\"")) << json.substr(json.find("\"noise\""), 400);
  EXPECT_TRUE(contains(json, "\"jitter\""));
}

// With the tracker's noise given, a residual twice that noise is never called "at the noise"; given the true noise,
// the same null recording leaves nothing out.
TEST(Noise, GivenNoiseDecidesAndAResidualTwiceItIsNeverAtTheNoise) {
  const Robot r = robot("tube_pair_B");
  ActuationOptions a;
  a.pattern = ActuationPattern::RandomWalk;
  a.rows = 150;
  a.dt = 0.1;
  a.seed = 8;
  Eigen::VectorXd time;
  const std::vector<Configuration> cmd = actuation(r, a, time);
  SimulationOptions s;
  s.twist = false;
  s.position_sd = 4e-4;
  s.tangent_sd = 0.4 * kDeg;
  s.seed = 9;
  const io::Recording rec = simulateRecording(r, cmd, time, {}, s);
  DiagnoseOptions half, truth;
  half.noise = parseGivenNoise("tip_position=0.2mm,tip_tangent=0.2deg");
  truth.noise = parseGivenNoise("tip_position=0.4mm,tip_tangent=0.4deg");
  const DiagnosisReport low = diagnose(r, rec, half);
  EXPECT_TRUE(low.unexplained.present) << low.summary;
  EXPECT_GT(low.unexplained.heldout_ratio, 3.0);
  EXPECT_FALSE(contains(low.summary, "at the noise")) << low.summary;
  EXPECT_EQ(low.noise.by_quantity.at(Quantity::TipPosition).source, "given");
  const DiagnosisReport right = diagnose(r, rec, truth);
  EXPECT_TRUE(right.verdict.empty()) << right.summary;
  EXPECT_FALSE(right.unexplained.present) << right.summary;
  EXPECT_TRUE(contains(right.summary, "nothing was left out")) << right.summary;
}

namespace {

// A 50 Hz random walk of `sim` (twist not measured) seen by a tracker whose stream is filtered: white noise through a
// 10-sample moving average (sd `pos_sd` m and `tan_sd` rad after the filter), as a Kalman-filtered EM stream.
io::Recording filteredStream(const Robot& sim, double pos_sd, double tan_sd) {
  ActuationOptions a;
  a.pattern = ActuationPattern::RandomWalk;
  a.rows = 1200;
  a.dt = 0.02;
  a.max_speed = 1.0;
  a.seed = 41;
  Eigen::VectorXd time;
  const std::vector<Configuration> cmd = actuation(sim, a, time);
  SimulationOptions s;
  s.twist = false;
  s.position_sd = 1e-9;
  s.tangent_sd = 1e-9;
  s.seed = 42;
  io::Recording rec = simulateRecording(sim, cmd, time, {}, s);
  std::mt19937_64 rng(43);
  std::normal_distribution<double> N(0.0, 1.0);
  const int width = 10;
  std::vector<Eigen::Matrix<double, 6, 1>> white(static_cast<std::size_t>(rec.rows() + width));
  for (auto& w : white)
    for (int c = 0; c < 6; ++c) w[c] = N(rng);
  for (int k = 0; k < rec.rows(); ++k) {
    Eigen::Matrix<double, 6, 1> m = Eigen::Matrix<double, 6, 1>::Zero();
    for (int j = 0; j < width; ++j) m += white[static_cast<std::size_t>(k + j)];
    m /= std::sqrt(static_cast<double>(width));  // unit variance after the filter
    rec.tip_position.row(k) += pos_sd * m.head<3>().transpose();
    rec.tip_tangent.row(k) += tan_sd * m.tail<3>().transpose();
    rec.tip_tangent.row(k).normalize();
  }
  return rec;
}

}  // namespace

// A filtered stream: consecutive rows share most of their error, so differences between neighbouring rows are far
// smaller than the error and not independent. The estimate tests its own assumption: the second differences are
// serially correlated, the noise is said to be unknown (not white, not supported), and nothing is named. Given the
// tracker's true error level, nothing is named either.
TEST(Noise, AFilteredStreamIsNotTakenForWhiteNoise) {
  const Robot r = robot("tube_pair_B");
  const io::Recording rec = filteredStream(r, 3e-4, 0.3 * kDeg);
  const DiagnosisReport rep = diagnose(r, rec);
  for (Quantity q : {Quantity::TipPosition, Quantity::TipTangent}) {
    const NoiseEstimate& e = rep.noise.by_quantity.at(q);
    EXPECT_FALSE(e.white) << toString(q) << ": " << e.note;
    EXPECT_FALSE(e.supported) << toString(q);
  }
  EXPECT_TRUE(rep.verdict.empty()) << rep.summary;
  EXPECT_TRUE(contains(rep.summary, "cannot be told")) << rep.summary;
  DiagnoseOptions given;
  given.noise = parseGivenNoise("tip_position=0.3mm,tip_tangent=0.3deg");
  const DiagnosisReport told = diagnose(r, rec, given);
  EXPECT_TRUE(told.verdict.empty()) << told.summary;
}

// A filtered stream (0.1 mm, 0.1 deg) of the pair with boundary friction 0.2: the selection would name
// boundary_friction, but against a noise the recording cannot establish nothing is named. The verdict is empty and
// `unexplained` is present (docs/formats.md:
// `[]` without `unexplained` would say that the nominal model explains the data), naming what would explain it; given
// the tracker's noise, friction is named.
TEST(Noise, AFilteredStreamWithFrictionSaysAMismatchRemainsNotThatTheNominalModelExplainsIt) {
  const Robot r = robot("tube_pair_B");
  const io::Recording rec = filteredStream(r.withFriction({0.2, 0.0}), 1e-4, 0.1 * kDeg);
  const DiagnosisReport rep = diagnose(r, rec);
  EXPECT_TRUE(rep.verdict.empty()) << rep.summary;
  EXPECT_TRUE(rep.unexplained.present) << rep.summary;
  EXPECT_TRUE(contains(rep.unexplained.where, "boundary_friction")) << rep.unexplained.where;
  DiagnoseOptions given;
  given.noise = parseGivenNoise("tip_position=0.1mm,tip_tangent=0.1deg");
  const DiagnosisReport told = diagnose(r, rec, given);
  EXPECT_EQ(told.verdict, std::vector<std::string>{"boundary_friction"}) << told.summary;
}

// A pose set of a robot with several stable equilibria at most poses (the Med-MPD lung robot: the other one ~21 mm
// away), where the robot really moved straight from pose to pose (continuation over large rotations winds the tubes
// up). By default the replay follows the rows in the order taken, never lands on an unstable equilibrium, and every
// row whose replayed equilibrium is not the one reached from rest is listed in branch_ambiguous_rows. Told that the
// robot was re-homed between poses (--branch rest), the rows whose measurement lies nearer another equilibrium are
// left out. Nothing is left out of the model, so nothing may be named either way.
TEST(PoseSet, EveryRowIsOnTheBranchFromRestOrListed) {
  const Robot r = robot("medmpd_lung");
  ActuationOptions a;
  a.pattern = ActuationPattern::Random;
  a.rows = 40;
  a.dt = 0;
  a.seed = 12;
  Eigen::VectorXd time;
  std::vector<Configuration> cmd = actuation(r, a, time);
  SimulationOptions s;
  s.twist = false;
  s.position_sd = 3e-4;
  s.tangent_sd = 0.3 * kDeg;
  s.seed = 13;
  s.predict.replay.branch = BranchRule::Path;  // what the robot did
  const io::Recording rec = simulateRecording(r, cmd, time, {}, s);
  Workspace ws;
  PredictOptions rest;
  rest.replay.branch = BranchRule::Rest;
  const Prediction from_rest = predict(r, cmd, time, {}, ws, rest), along = predict(r, cmd, time, {}, ws);
  int off = 0;                 // measured rows on another branch than the one reached from rest
  std::set<int> replayed_off;  // rows (1-based) replayed on another branch than the one reached from rest
  for (int k = 0; k < rec.rows(); ++k) {
    if (!from_rest.ok[static_cast<std::size_t>(k)]) continue;
    if (rec.tip_position.row(k).allFinite() && (rec.tip_position.row(k) - from_rest.tip_position.row(k)).norm() > 5e-3)
      ++off;
    if (along.ok[static_cast<std::size_t>(k)] &&
        (along.tip_position.row(k) - from_rest.tip_position.row(k)).norm() > 5e-3)
      replayed_off.insert(k + 1);
  }
  ASSERT_GT(off, 0) << "the case must hold rows on another branch";
  ASSERT_FALSE(replayed_off.empty());
  const DiagnosisReport rep = diagnose(r, rec);
  EXPECT_EQ(rep.branch, "path");
  std::set<int> listed;
  for (const BranchAmbiguousRow& b : rep.branch_ambiguous_rows) {
    EXPECT_FALSE(b.alternatives_mm.empty());
    listed.insert(b.row);
  }
  for (int row : replayed_off) EXPECT_TRUE(listed.count(row)) << "row " << row << " is on another branch, unlisted";
  EXPECT_TRUE(rep.verdict.empty()) << rep.summary;
  EXPECT_TRUE(contains(reportToJson(rep), "\"branch_ambiguous_rows\""));

  DiagnoseOptions o;
  o.predict.replay.branch = BranchRule::Rest;
  const DiagnosisReport homed = diagnose(r, rec, o);
  EXPECT_EQ(homed.branch, "rest");
  int excluded = 0;
  for (const BranchAmbiguousRow& b : homed.branch_ambiguous_rows) excluded += b.excluded;
  EXPECT_GE(excluded + static_cast<int>(homed.failed_rows.size()), off) << homed.summary;
  EXPECT_TRUE(homed.verdict.empty()) << homed.summary;
}

// A null recording of the real Dupont-lab design on the real joint path, measured like the real log (1 mm, 1.5 deg,
// an unknown tracker frame): an empty verdict and no unexplained remainder.
TEST(RealDesign, NullRecordingMeasuredLikeTheRealLogRaisesNoAlarm) {
  const std::optional<io::Recording> loaded = test::realLog();
  if (!loaded) GTEST_SKIP() << ctr_test::missingData(test::kRealLogFile);
  const io::Recording& real = *loaded;
  const Robot r = robot("dupont_lab_3tube");
  SimulationOptions s;
  s.twist = false;
  s.position_sd = 1e-3;
  s.tangent_sd = 1.5 * kDeg;
  Registration reg;
  reg.rotation = Eigen::AngleAxisd(0.3, Eigen::Vector3d(0.2, 1, -0.4).normalized()).toRotationMatrix();
  reg.translation = Eigen::Vector3d(0.01, -0.02, 0.15);
  reg.tip_offset = 0.001;
  s.sensor_frame = reg;
  s.seed = 17;
  const io::Recording rec = simulateRecording(r, real.commands, real.time, {}, s);
  DiagnoseOptions o;
  o.frame = FrameMode::Unknown;
  const DiagnosisReport rep = diagnose(r, rec, o);
  EXPECT_TRUE(rep.verdict.empty()) << rep.summary;
  EXPECT_FALSE(rep.unexplained.present) << rep.summary;
  const NoiseEstimate& t = rep.noise.by_quantity.at(Quantity::TipTangent);
  EXPECT_NEAR(t.sigma / (1.5 * kDeg), 1.0, 0.15) << t.note;
}

// An eccentric gear on the tube-2 drive (6 deg sin alpha_2): not library physics. The tool describes the remainder
// by its structure (a transmission error of the tube-2 drive, one cycle per turn, ~6 deg) and names no library effect
// for it (before, a 0.23 N tip load was named).
TEST(OutsideTheLibrary, AnEccentricGearIsDescribedNotNamed) {
  const Robot r = robot("tube_pair_B");
  ActuationOptions a;
  a.pattern = ActuationPattern::RandomWalk;
  a.rows = 150;
  a.dt = 0.1;
  a.seed = 5;
  Eigen::VectorXd time;
  const std::vector<Configuration> cmd = actuation(r, a, time);
  std::vector<Configuration> real = cmd;
  for (Configuration& q : real) q.alpha[1] += 6 * kDeg * std::sin(q.alpha[1]);
  SimulationOptions s;
  s.position_sd = 1e-4;
  s.tangent_sd = 0.2 * kDeg;
  s.seed = 5;
  io::Recording rec = simulateRecording(r, real, time, {}, s);
  rec.commands = cmd;  // the log holds the commands, not what the drive did
  const DiagnosisReport rep = diagnose(r, rec);
  EXPECT_TRUE(rep.verdict.empty()) << rep.summary;
  ASSERT_TRUE(rep.unexplained.present) << rep.summary;
  ASSERT_FALSE(rep.unexplained.described.empty()) << rep.summary;
  const GenericDescription& g = rep.unexplained.described.front();
  EXPECT_EQ(g.model.kind, EffectKind::DrivePeriodic);
  EXPECT_EQ(g.model.tube, 2);
  EXPECT_NEAR(std::hypot(g.model.coef[0], g.model.coef[1]), 6 * kDeg, 1.2 * kDeg) << g.description;
  EXPECT_TRUE(contains(g.description, "one cycle per turn")) << g.description;
  EXPECT_TRUE(contains(rep.summary, "transmission error")) << rep.summary;
  for (const Finding& f : rep.findings)
    if (f.accepted) {
      EXPECT_FALSE(f.named) << f.effect.label();
    }
}
