// The `ctr env` command: info / build / check, JSON output, exit code 2 and no partial output on bad inputs.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "env_test_util.hpp"

namespace ctr::environments {
namespace {

#ifdef CTR_CLI_PATH
struct CliRun {
  int code = -1;
  std::string out, err;
};

CliRun run(const test::TempDir& dir, const std::string& args) {
  const std::string out = dir.file("stdout.txt"), err = dir.file("stderr.txt");
  const std::string cmd = std::string("'") + CTR_CLI_PATH + "' " + args + " > '" + out + "' 2> '" + err + "'";
  const int status = std::system(cmd.c_str());
  CliRun r;
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  std::ifstream o(out), e(err);
  std::stringstream so, se;
  so << o.rdbuf();
  se << e.rdbuf();
  r.out = so.str();
  r.err = se.str();
  return r;
}

const std::string kExamples = std::string(CTR_SOURCE_DIR) + "/examples";

#define REQUIRE_CLI() \
  if (!std::filesystem::exists(CTR_CLI_PATH)) GTEST_SKIP() << "the ctr command is not built (" << CTR_CLI_PATH << ")"

TEST(CliEnv, InfoBuildCheck) {
  REQUIRE_CLI();
  test::TempDir dir;
  const std::string env = kExamples + "/environments/proc_intracardiac.yaml";
  CliRun info = run(dir, "env info '" + env + "' --json");
  ASSERT_EQ(info.code, 0) << info.err;
  const auto j = nlohmann::json::parse(info.out);
  EXPECT_EQ(j["name"], "proc_intracardiac");
  EXPECT_DOUBLE_EQ(j["resolution"].get<double>(), 0.001);
  EXPECT_EQ(j["targets"].size(), 4u);
  EXPECT_GT(j["occupied_volume"].get<double>(), 0.0);
  EXPECT_EQ(j["base_pose"]["occupancy"], "free");
  CliRun text = run(dir, "env info '" + env + "'");
  ASSERT_EQ(text.code, 0);
  EXPECT_NE(text.out.find("bounds"), std::string::npos);
  EXPECT_NE(text.out.find("target       foramen"), std::string::npos);

  const std::string bt = dir.file("heart.bt");
  CliRun build = run(dir, "env build '" + env + "' -o '" + bt + "'");
  ASSERT_EQ(build.code, 0) << build.err;
  EXPECT_TRUE(std::filesystem::exists(bt));
  EXPECT_FALSE(std::filesystem::exists(bt + ".tmp"));

  const std::string robot = kExamples + "/robots/proc_intracardiac.yaml";
  CliRun check =
      run(dir, "env check '" + env + "' --robot '" + robot + "' --alpha 0,3.14159,0 --beta -0.12,-0.15,-0.19 --json");
  ASSERT_EQ(check.code, 0) << check.err;
  const auto c = nlohmann::json::parse(check.out);
  EXPECT_TRUE(c.contains("collision"));
  EXPECT_TRUE(c.contains("clearance"));
  EXPECT_TRUE(c.contains("first_colliding_section"));
  EXPECT_EQ(c["collision"].get<bool>(), !c["first_colliding_section"].is_null());
  // Up the vena cava into the atrium, the curved tubes turned apart: no collision, a few mm of clearance.
  EXPECT_FALSE(c["collision"].get<bool>());
  EXPECT_GT(c["clearance"].get<double>(), 0.001);
  // Pushed through the atrium into its roof: a collision with a first colliding section.
  CliRun wall =
      run(dir, "env check '" + env + "' --robot '" + robot + "' --alpha 0,0,0 --beta -0.01,-0.07,-0.12 --json");
  ASSERT_EQ(wall.code, 0) << wall.err;
  const auto w = nlohmann::json::parse(wall.out);
  EXPECT_TRUE(w["collision"].get<bool>());
  EXPECT_EQ(w["first_colliding_section"]["tube"].get<int>(), 1);
  EXPECT_LT(w["clearance"].get<double>(), 0.0);
}

TEST(CliEnv, BadInputsExitTwoWithoutOutput) {
  REQUIRE_CLI();
  test::TempDir dir;
  const std::string out = dir.file("out.bt");
  // Missing description.
  CliRun a = run(dir, "env build '" + dir.file("missing.yaml") + "' -o '" + out + "'");
  EXPECT_EQ(a.code, 2);
  EXPECT_NE(a.err.find("missing.yaml"), std::string::npos);
  // Corrupt octree source.
  dir.write("bad.bt", "# Octomap OcTree binary file\nid OcTree\nsize 3\nres 0.01\ndata\n");
  dir.write("bad.yaml", "obstacles: [{octomap: bad.bt}]\n");
  CliRun b = run(dir, "env build '" + dir.file("bad.yaml") + "' -o '" + out + "'");
  EXPECT_EQ(b.code, 2);
  EXPECT_NE(b.err.find("bad.bt"), std::string::npos);
  // Unknown label and target outside the map.
  dir.write("pts.xyz", "0 0 0\n0.01 0.01 0.01\n");
  dir.write("t.yaml", "obstacles: [{points: pts.xyz}]\ntargets: {far: [1, 1, 1]}\n");
  CliRun c = run(dir, "env info '" + dir.file("t.yaml") + "'");
  EXPECT_EQ(c.code, 2);
  EXPECT_NE(c.err.find("outside the map"), std::string::npos);
  // Unknown start name; wrong number of --alpha values; bad output extension.
  CliRun d = run(dir, "env info '" + kExamples + "/environments/proc_intracardiac.yaml' --start nowhere");
  EXPECT_EQ(d.code, 2);
  EXPECT_NE(d.err.find("nowhere"), std::string::npos);
  CliRun e = run(dir, "env check '" + kExamples + "/environments/proc_intracardiac.yaml' --robot '" + kExamples +
                          "/robots/proc_intracardiac.yaml' --alpha 0,0");
  EXPECT_EQ(e.code, 2);
  CliRun f =
      run(dir, "env build '" + kExamples + "/environments/proc_intracardiac.yaml' -o '" + dir.file("x.png") + "'");
  EXPECT_EQ(f.code, 2);
  // No partial output anywhere.
  EXPECT_FALSE(std::filesystem::exists(out));
  EXPECT_FALSE(std::filesystem::exists(out + ".tmp"));
  EXPECT_FALSE(std::filesystem::exists(dir.file("x.png")));
}
#else
TEST(CliEnv, NotBuilt) {
  GTEST_SKIP() << "ctr_cli is not part of this build";
}
#endif

}  // namespace
}  // namespace ctr::environments
