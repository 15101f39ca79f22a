// Several recordings of one robot diagnosed together (diagnoseRecordings): three recordings of one simulated tube pair
// with one drive play and one boundary friction, each with other motions and another tracker registration (an unknown
// frame); the shared effects named once within 10 %, an effect of one recording only reported as not shared.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <iostream>
#include <nlohmann/json.hpp>

#include "actuation_cases.hpp"
#include "ctr/diagnosis/diagnose.hpp"
#include "ctr/diagnosis/simulate.hpp"
#include "ctr/io/robot_yaml.hpp"

using namespace ctr;
using namespace ctr::diagnosis;

namespace {

const double kDeg = M_PI / 180.0;
const Effect kPlay{EffectKind::ActuatorBacklash, 2, 10 * kDeg};
const Effect kFriction{EffectKind::BoundaryFriction, 0, 0.1};

Robot tubePairB() {
  return io::loadRobot(std::string(CTR_SOURCE_DIR) + "/examples/robots/tube_pair_B.yaml");
}

/// The tracker frame of recording k: each recording registered anew (another rotation, translation and sensor offset).
Registration trackerFrame(int k) {
  Registration g;
  const Eigen::Vector3d axes[] = {{0.3, -1, 0.2}, {1, 0.4, -0.5}, {-0.2, 0.3, 1}};
  g.rotation = Eigen::AngleAxisd(0.4 + 0.5 * k, axes[k % 3].normalized()).toRotationMatrix();
  g.translation = Eigen::Vector3d(0.05 - 0.03 * k, 0.1, -0.02 + 0.02 * k);
  g.tip_offset = 0.002 * (k + 1);
  return g;
}

/// Recording k: a random walk (k = 0, 1: other seeds and speeds) or the paper's sweep (k = 2), 0.1 s apart.
io::Recording recording(const Robot& robot, int k, const std::vector<Effect>& effects) {
  ActuationOptions a = k < 2 ? test::randomWalk(k == 0 ? 150 : 120, false, 0.1, 3 + 5 * k) : ActuationOptions{};
  if (k == 1) a.max_speed = 2.0;
  std::vector<Configuration> cmd;
  Eigen::VectorXd time;
  makeActuation(robot, a, cmd, time);
  SimulationOptions s;
  s.sensor_frame = trackerFrame(k);
  s.seed = 21 + static_cast<std::uint64_t>(k);
  return simulateRecording(robot, cmd, time, effects, s);
}

/// The three recordings diagnosed together in an unknown frame; `extra` is injected into recording `into` only.
MultiDiagnosisReport diagnoseThree(const Robot& robot, const Effect* extra = nullptr, int into = 1) {
  std::vector<io::Recording> recs;
  for (int k = 0; k < 3; ++k) {
    std::vector<Effect> effects{kPlay, kFriction};
    if (extra && k == into) effects.push_back(*extra);
    recs.push_back(recording(robot, k, effects));
  }
  MultiDiagnoseOptions o;
  o.diagnose.frame = FrameMode::Unknown;
  return diagnoseRecordings(robot, recs, {"walk.csv", "slow_walk.csv", "sweep.csv"}, o);
}

const JointEffect* find(const MultiDiagnosisReport& r, EffectKind kind) {
  for (const JointEffect& j : r.effects)
    if (j.effect.kind == kind) return &j;
  return nullptr;
}

/// The shared play and friction: named once each, within 10 % of the truth, applied by diagnosedRobot.
void expectSharedPlayAndFriction(const Robot& robot, const MultiDiagnosisReport& r) {
  std::cout << r.summary << " (" << r.seconds << " s)\n";
  for (std::size_t i = 0; i < r.recordings.size(); ++i) {
    std::cout << "  alone, " << r.names[i] << ":";
    for (const Effect& e : r.recordings[i].final_effects) std::cout << " " << e.label() << " " << e.valueText() << ";";
    std::cout << "\n";
  }
  std::vector<std::string> verdict = r.verdict;
  std::sort(verdict.begin(), verdict.end());
  EXPECT_EQ(verdict, (std::vector<std::string>{"actuator_backlash", "boundary_friction"})) << r.summary;
  const JointEffect* play = find(r, EffectKind::ActuatorBacklash);
  const JointEffect* friction = find(r, EffectKind::BoundaryFriction);
  ASSERT_NE(play, nullptr) << r.summary;
  ASSERT_NE(friction, nullptr) << r.summary;
  EXPECT_EQ(play->agreement, Agreement::Shared) << play->explanation;
  EXPECT_EQ(friction->agreement, Agreement::Shared) << friction->explanation;
  EXPECT_EQ(play->effect.tube, 2);
  EXPECT_NEAR(play->effect.value, kPlay.value, 0.1 * kPlay.value) << r.summary;
  EXPECT_NEAR(friction->effect.value, kFriction.value, 0.1 * kFriction.value) << r.summary;
  // One value per shared effect, with its interval; every recording's value is listed beside it.
  for (const JointEffect* j : {play, friction}) {
    EXPECT_EQ(j->per_recording.size(), 3u);
    ASSERT_FALSE(j->parameters.empty());
    EXPECT_FALSE(j->parameters.back().interval95.empty());
  }
  const Robot found = diagnosedRobot(robot, r);
  EXPECT_DOUBLE_EQ(found.tube(1).rotation_drive.play, play->effect.value);
  EXPECT_DOUBLE_EQ(found.friction().boundary, friction->effect.value);
  // Each recording has its own registration in the joint fit.
  ASSERT_EQ(r.fits.size(), 3u);
  EXPECT_GT((r.fits[0].registration.rotation - r.fits[1].registration.rotation).norm(), 0.1);
}

}  // namespace

TEST(MultiRecording, SharedPlayAndFrictionAreNamedOnceWithinTenPercent) {
  const Robot robot = tubePairB();
  const MultiDiagnosisReport r = diagnoseThree(robot);
  expectSharedPlayAndFriction(robot, r);
  for (const JointEffect& j : r.effects)
    EXPECT_TRUE(j.agreement == Agreement::Shared || j.agreement == Agreement::OfTheRecording)
        << j.effect.label() << ": " << j.explanation;
  // The JSON: each recording's own diagnosis as the single-recording document, and the shared verdict.
  const nlohmann::json js = nlohmann::json::parse(reportToJson(r));
  ASSERT_EQ(js["recordings"].size(), 3u);
  EXPECT_EQ(js["recordings"][0]["diagnosis"].dump(), nlohmann::json::parse(reportToJson(r.recordings[0])).dump());
  EXPECT_EQ(js["shared_verdict"].size(), 2u);
}

TEST(MultiRecording, ADriveOffsetOfOneRecordingIsNotShared) {
  const Robot robot = tubePairB();
  const Effect offset{EffectKind::ActuatorOffset, 2, 8 * kDeg};
  const MultiDiagnosisReport r = diagnoseThree(robot, &offset, 1);
  expectSharedPlayAndFriction(robot, r);
  const JointEffect* j = find(r, EffectKind::ActuatorOffset);
  ASSERT_NE(j, nullptr) << r.summary;
  EXPECT_NE(j->agreement, Agreement::Shared) << j->explanation;
  EXPECT_EQ(j->agreement, Agreement::Differs) << j->explanation;
  EXPECT_EQ(diagnosedRobot(robot, r).tube(1).rotation_drive.offset, 0.0);
  const std::string yaml = diagnosedRobotYaml(robot, r);
  EXPECT_NE(yaml.find("actuator_offset[tube 2] (differs)"), std::string::npos) << yaml;
}

TEST(MultiRecording, ALatencyOfOneRecordingIsAnEffectOfThatRecording) {
  const Robot robot = tubePairB();
  const Effect latency{EffectKind::SensorLatency, 0, 0.3};
  const MultiDiagnosisReport r = diagnoseThree(robot, &latency, 0);
  expectSharedPlayAndFriction(robot, r);
  const JointEffect* j = find(r, EffectKind::SensorLatency);
  ASSERT_NE(j, nullptr) << r.summary;
  EXPECT_EQ(j->agreement, Agreement::OfTheRecording);
  EXPECT_LT(j->p, r.alpha) << j->explanation;  // its values differ between the recordings
  for (const RecordingValue& v : j->per_recording) {
    if (v.recording == 0) {
      EXPECT_NEAR(v.effect.value, 0.3, 0.03);
    }
  }
}

TEST(MultiRecording, FewerThanTwoRecordingsOrAWrongRobotAreRefused) {
  const Robot robot = tubePairB();
  const io::Recording one = recording(robot, 2, {});
  EXPECT_THROW(diagnoseRecordings(robot, {one}, {"a.csv"}), std::invalid_argument);
  io::Recording wrong = one;
  wrong.tubes = 3;
  try {
    diagnoseRecordings(robot, {one, wrong}, {"a.csv", "b.csv"});
    FAIL() << "a recording of another robot was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("b.csv"), std::string::npos) << e.what();
  }
}
