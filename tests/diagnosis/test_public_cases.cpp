// The public recordings with known truth (recordings/ in the data folder, written by an independent simulator): by
// default (no branch rule, no noise given) the verdict of the truth, each parameter within 15 % (friction within 10 %
// where the recording has tracker glitches, which must be listed), held-out RMSE down. Set 2 are continuous motions
// sampled coarsely (10-70 deg between rows): they fail when rows after large moves are reached from rest.
#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <nlohmann/json.hpp>

#include "../data_sets.hpp"
#include "ctr/diagnosis/diagnose.hpp"
#include "ctr/io/recording.hpp"
#include "ctr/io/robot_yaml.hpp"

using namespace ctr;
using namespace ctr::diagnosis;

namespace {
struct Case {
  const char* name;
};

class PublicCase : public ::testing::TestWithParam<const char*> {};

TEST_P(PublicCase, VerdictParametersAndHeldOut) {
  const std::string base = ctr_test::dataPath(std::string("recordings/") + GetParam());
  std::ifstream tf(base + ".truth.json");
  if (!tf) GTEST_SKIP() << ctr_test::missingData(std::string("recordings/") + GetParam() + ".truth.json");
  const nlohmann::json truth = nlohmann::json::parse(tf);
  const Robot robot = io::loadRobot(base + ".robot.yaml");
  const io::Recording rec = io::loadRecording(base + ".csv", robot.size(), true);
  const DiagnosisReport rep = diagnose(robot, rec, DiagnoseOptions{});
  std::vector<std::string> expected = truth["verdict"].get<std::vector<std::string>>(), verdict = rep.verdict;
  std::sort(expected.begin(), expected.end());
  std::sort(verdict.begin(), verdict.end());
  EXPECT_EQ(verdict, expected) << reportToJson(rep);
  const bool glitches = std::string(GetParam()).find("glitches") != std::string::npos;
  if (glitches) {
    EXPECT_GE(rep.outlier_rows.size(), 6u);
    EXPECT_LE(rep.outlier_rows.size(), 10u);
    EXPECT_FALSE(rep.unexplained.present) << "glitches reported as physics outside the library";
  } else {
    EXPECT_TRUE(rep.outlier_rows.empty()) << rep.outlier_rows.size() << " rows called glitches";
  }
  for (const Effect& e : rep.final_effects) {
    const std::string p = parameterName(e.kind);
    ASSERT_TRUE(truth.contains(p)) << p;
    const double t = truth[p].get<double>();
    EXPECT_NEAR(e.value, t, (glitches ? 0.10 : 0.15) * std::abs(t)) << e.label();
    if (truth.contains("tube")) {
      EXPECT_EQ(e.tube, truth["tube"].get<int>());
    }
  }
  for (const auto& kv : rep.baseline.heldout_rmse) {
    if (expected.empty()) {
      EXPECT_LE(rep.final.heldout_rmse.at(kv.first), kv.second * 1.0001);
    } else {
      EXPECT_LT(rep.final.heldout_rmse.at(kv.first), kv.second) << kv.first;
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Recordings, PublicCase,
                         ::testing::Values("pub_null_sweep_A", "pub_friction_sweep_B", "pub_poisson_sweep_B",
                                           "pub_backlash_sweep_A", "pub_offset_sweep_B", "pub_friction_coarse_walk_B",
                                           "pub_latency_friction_coarse_walk_A", "pub_precurvature_coarse_walk_T3",
                                           "pub_glitches_friction_walk_B"));
}  // namespace
