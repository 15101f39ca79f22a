// A real Med-MPD lung environment (skipped when the data folder has no Med-MPD), at a coarse resolution to keep the
// suite fast.
#include <gtest/gtest.h>

#include <filesystem>

#include "../data_sets.hpp"
#include "ctr/environments/collision.hpp"
#include "ctr/environments/environment_yaml.hpp"
#include "ctr/io/robot_yaml.hpp"
#include "env_test_util.hpp"

namespace ctr::environments {
namespace {

const std::string kExamples = std::string(CTR_SOURCE_DIR) + "/examples";

bool haveMedMpd() {
  return ctr_test::haveData("med-mpd/Lungs/Patient1/vessels.nii.gz");
}

TEST(MedMpd, LungPatient1) {
  if (!haveMedMpd()) GTEST_SKIP() << ctr_test::missingData("med-mpd/Lungs/Patient1/vessels.nii.gz");
  BuildOptions bo;
  bo.resolution = 0.003;  // the 1 mm build is measured in bench_environments
  const Environment env = loadEnvironment(kExamples + "/environments/medmpd_lung_patient1.yaml", bo);
  EXPECT_EQ(env.name(), "medmpd_lung_patient1");
  EXPECT_DOUBLE_EQ(env.resolution(), 0.003);
  // The CT covers about 274 x 182 x 358 mm in RAS metres.
  EXPECT_NEAR(env.bounds().size().x(), 0.274, 0.01);
  EXPECT_NEAR(env.bounds().size().z(), 0.358, 0.01);
  const OccupancyStats st = env.stats();
  EXPECT_GT(st.occupied_volume, 50e-6);  // vessels: > 50 cm^3
  EXPECT_LT(st.occupied_volume, 600e-6);
  ASSERT_EQ(env.starts().size(), 5u);
  EXPECT_EQ(env.basePoseSource(), "start1");
  // start1.txt: translation (43.05, 148.87, 1226.85) mm; z column (0.681, 0.728, -0.083).
  EXPECT_TRUE(
      env.basePose().translation().isApprox(Eigen::Vector3d(0.04305291433, 0.14886545644, 1.22684838867), 1e-9));
  EXPECT_TRUE(
      env.basePose().linear().col(2).isApprox(Eigen::Vector3d(0.6809441759, 0.7276179667, -0.0829886967), 1e-6));
  const NamedTarget& nodule = env.target("nodule");
  EXPECT_TRUE(nodule.position.isApprox(Eigen::Vector3d(0.06487506397, 0.20112493055, 1.21191394043), 1e-9));
  EXPECT_TRUE(env.bounds().contains(nodule.position));
  EXPECT_NEAR((nodule.position - env.basePose().translation()).norm(), 0.0585687, 1e-6);
  EXPECT_NE(env.occupancy(nodule.position), Occupancy::Unknown);
  EXPECT_DOUBLE_EQ(env.collisionDefaults().exclude_proximal, 0.003);

  // Collision and clearance of the example lung robot: the straight insertion is evaluated consistently.
  const Robot robot = io::loadRobot(kExamples + "/robots/medmpd_lung.yaml");
  auto shared = std::make_shared<const Environment>(env);
  CollisionOptions opt = CollisionOptions::fromEnvironment(env);
  CollisionChecker checker(shared, robot, opt);
  ASSERT_NE(checker.distanceField(), nullptr);
  Workspace ws;
  Configuration q = Configuration::zeros(3);
  q.beta << -0.12, -0.21, -0.30;  // outer tube retracted, tip 20 mm beyond the start pose
  ASSERT_TRUE(checkAdmissible(robot, q));
  const Solution sol = solve(robot, q, ws);
  ASSERT_TRUE(sol.converged());
  auto query = checker.query();
  const CollisionResult r = checker.check(sol, query);
  const ClearanceResult c = checker.clearance(sol, query);
  EXPECT_TRUE(c.complete);
  // Collision and clearance agree up to the clearance accuracy (a few cells at 3 mm).
  if (r.collision) {
    EXPECT_LT(c.clearance, 0.009);
  } else {
    EXPECT_GT(c.clearance, -0.009);
  }
}

TEST(MedMpd, AllExampleDescriptionsParse) {
  if (!haveMedMpd()) GTEST_SKIP() << ctr_test::missingData("med-mpd/Lungs/Patient1/vessels.nii.gz");
  for (const char* name :
       {"medmpd_lung_patient1", "medmpd_lung_patient2", "medmpd_lung_patient3", "medmpd_lung_patient4",
        "medmpd_lung_patient5", "medmpd_brain_patient1", "medmpd_brain_patient2", "medmpd_liver_patient1",
        "proc_intracardiac", "proc_airway", "proc_sinus"}) {
    const EnvironmentDescription d = loadEnvironmentDescription(kExamples + "/environments/" + name + ".yaml");
    EXPECT_EQ(d.name, name);
    EXPECT_FALSE(d.targets.empty() && !d.stay_inside) << name;
  }
  for (const char* name :
       {"medmpd_lung", "medmpd_brain", "medmpd_liver", "proc_intracardiac", "proc_airway", "proc_sinus"})
    EXPECT_NO_THROW(io::loadRobot(kExamples + "/robots/" + name + ".yaml")) << name;
}

}  // namespace
}  // namespace ctr::environments
