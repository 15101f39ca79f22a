// The public recordings with known truth (../shared/data/recordings): verdict, parameter within 20 %,
// held-out RMSE down.
#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>

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
  const std::string base = std::string(CTR_SHARED_DIR) + "/data/recordings/" + GetParam();
  std::ifstream tf(base + ".truth.json");
  if (!tf) GTEST_SKIP() << "no " << base;
  const nlohmann::json truth = nlohmann::json::parse(tf);
  const Robot robot = io::loadRobot(base + ".robot.yaml");
  const io::Recording rec = io::loadRecording(base + ".csv", robot.size(), true);
  const DiagnosisReport rep = diagnose(robot, rec, DiagnoseOptions{});
  const std::vector<std::string> expected = truth["verdict"].get<std::vector<std::string>>();
  EXPECT_EQ(rep.verdict, expected) << reportToJson(rep);
  for (const Effect& e : rep.final_effects) {
    const std::string p = parameterName(e.kind);
    ASSERT_TRUE(truth.contains(p)) << p;
    const double t = truth[p].get<double>();
    EXPECT_NEAR(e.value, t, 0.2 * std::abs(t)) << e.label();
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
                                           "pub_backlash_sweep_A", "pub_offset_sweep_B"));
}  // namespace
