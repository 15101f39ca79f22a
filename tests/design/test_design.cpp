// Tests of ctr::design: the design space (parsing, constraints), the sampler (never leaves the constraints), the
// verdict for a target no design reaches, and a small design run on an easy query.
#include <gtest/gtest.h>

#include <unistd.h>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "ctr/design/output.hpp"
#include "ctr/design/search.hpp"
#include "ctr/design/space.hpp"
#include "ctr/io/file.hpp"
#include "ctr/io/input_error.hpp"
#include "ctr/io/robot_yaml.hpp"

using namespace ctr;
using namespace ctr::design;
namespace fs = std::filesystem;

namespace {

std::string src(const std::string& rel) {
  return std::string(CTR_SOURCE_DIR) + "/" + rel;
}

// A space with several stock sizes per tube, a tight strain limit and lengths whose ranges overlap (so that the
// repair of the nesting in length is exercised).
const char* kSpace = R"(
name: test_space
strain_limit: 0.03
nesting_clearance: 0.00005
material: {youngs_modulus: 60e9, poisson_ratio: 0.33, density: 6450}
actuation: {max_extension: 0.12}
length_step: 0.01
catalogue:
  - {name: a, outer_diameter: 0.0024, inner_diameter: 0.002}
  - {name: b, outer_diameter: 0.0019, wall_thickness: 0.0002}
  - {name: c, outer_diameter: 0.0014, inner_diameter: 0.001}
  - {name: d, outer_diameter: 0.0009, inner_diameter: 0.0006}
tubes:
  - name: outer
    straight_length: [0.02, 0.10]
    curved_length: [0.0, 0.06]
    curvature: [0, 60]
    sizes: [a, b]
  - name: middle
    straight_length: [0.02, 0.12]
    curved_length: [0.01, 0.06]
    curvature: [5, 80]
    sizes: [b, c]
  - name: inner
    straight_length: [0.05, 0.15]
    curved_length: 0.03
    curvature: [0, 90]
)";

void expectSpaceError(const std::string& text, const std::string& key_part, const std::string& what = "") {
  try {
    parseSpace(text, "space.yaml");
    FAIL() << "expected an InputError naming " << key_part;
  } catch (const io::InputError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("space.yaml"), std::string::npos) << m;
    EXPECT_NE(m.find(key_part), std::string::npos) << m;
    if (!what.empty()) {
      EXPECT_NE(m.find(what), std::string::npos) << m;
    }
  }
}

// Writes a small, fast test anatomy: a coarse map (5 mm) of a 30 cm box with a wall of points beside the insertion
// axis, base at the origin inserting along +z, and two targets: one the robots of the space reach, one beyond them.
std::string writeEasyProblem(const fs::path& dir) {
  fs::create_directories(dir);
  {
    std::ofstream pts(dir / "wall.xyz");
    for (double y = -0.03; y <= 0.03; y += 0.004)
      for (double z = 0.02; z <= 0.10; z += 0.004) pts << -0.03 << " " << y << " " << z << "\n";
  }
  {
    std::ofstream env(dir / "env.yaml");
    env << "name: easy\nresolution: 0.005\npadding: 0.2\nbounds: {min: [-0.16, -0.16, -0.02], max: [0.16, 0.16, 0.3], "
           "units: m}\n"
           "obstacles:\n  - points: wall.xyz\n    units: m\n"
           "starts:\n  base: {position: [0, 0, 0], direction: [0, 0, 1], x_axis: [1, 0, 0], units: m}\n"
           "targets:\n  near: [0.012, 0.0, 0.085]\n  far: [0.15, 0.0, 0.0]\n";
  }
  {
    std::ofstream robot(dir / "robot.yaml");
    robot
        << "name: easy_robot\ntubes:\n"
           "  - {name: outer, straight_length: 0.05, curved_length: 0.03, curvature: 10, youngs_modulus: 60e9,\n"
           "     poisson_ratio: 0.33, outer_diameter: 0.0016, inner_diameter: 0.0012, translation_limits: [-0.08, 0]}\n"
           "  - {name: inner, straight_length: 0.09, curved_length: 0.02, curvature: 15, youngs_modulus: 60e9,\n"
           "     poisson_ratio: 0.33, outer_diameter: 0.001, inner_diameter: 0.0006,"
           " translation_limits: [-0.11, -0.01]}\n";
  }
  return (dir / "robot.yaml").string();
}

std::string writeQuery(const fs::path& dir, const std::string& name, const std::string& target) {
  const fs::path p = dir / (name + ".yaml");
  std::ofstream q(p);
  q << "name: " << name << "\nrobot: robot.yaml\nenvironment: env.yaml\n"
    << "start: {alpha: [0, 0], beta: [-0.075, -0.105], history: positive}\n"
    << "goal: {target: " << target << ", tolerance: 0.003}\n"
    << "mode: frictionless\nplanner: rrtconnect\ntime_limit: 2\nseed: 1\n"
    << "environment_resolution: 0.005\n";
  return p.string();
}

fs::path tempDir(const std::string& name) {
  const fs::path d = fs::temp_directory_path() / ("ctr_test_design_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(d);
  return d;
}

}  // namespace

TEST(DesignSpace, ParsesRangesCatalogueAndConstraints) {
  const DesignSpace s = parseSpace(kSpace, "space.yaml");
  ASSERT_EQ(s.tubes.size(), 3u);
  ASSERT_EQ(s.catalogue.size(), 4u);
  EXPECT_NEAR(s.catalogue[1].inner_diameter, 0.0015, 1e-12);  // from the wall thickness
  EXPECT_EQ(s.tubes[2].sizes.size(), 4u);                     // no `sizes`: the whole catalogue
  EXPECT_TRUE(s.tubes[2].curved_length.fixed());
  // Nesting with the clearance: a/b, a/c, b/c then an inner size that fits; never the same size twice.
  for (const auto& combo : s.size_combinations())
    for (std::size_t i = 1; i < combo.size(); ++i)
      EXPECT_GE(s.catalogue[combo[i - 1]].inner_diameter - s.catalogue[combo[i]].outer_diameter,
                s.nesting_clearance - 1e-12);
  EXPECT_FALSE(s.size_combinations().empty());
}

TEST(DesignSpace, BadInputNamesTheFileLineAndKey) {
  expectSpaceError(std::string(kSpace) + "bogus: 1\n", "bogus", "unknown key");
  std::string t = kSpace;
  t.replace(t.find("curvature: [0, 60]"), 18, "curvature: [60, 0]");
  expectSpaceError(t, "tubes[0].curvature", "impossible range");
  t = kSpace;
  t.replace(t.find("curvature: [5, 80]"), 18, "curvature: [300, 400]");
  expectSpaceError(t, "tubes[1].curvature", "strain limit");
  t = kSpace;
  t.replace(t.find("sizes: [b, c]"), 13, "sizes: [a]");  // cannot nest inside a or b
  expectSpaceError(t, "tubes", "nests");
  t = kSpace;
  t.replace(t.find("sizes: [b, c]"), 13, "sizes: [zz]");
  expectSpaceError(t, "tubes[1].sizes", "not in the catalogue");
  t = kSpace;
  t.replace(t.find("straight_length: [0.05, 0.15]"), 29, "straight_length: 0.005");  // inner tube shorter than middle
  expectSpaceError(t, "tubes[2]", "impossible ranges");
}

TEST(DesignSampler, NeverProducesACandidateThatViolatesStrainOrNesting) {
  const DesignSpace s = parseSpace(kSpace, "space.yaml");
  Sampler sampler(s, 42);
  std::mt19937_64 rng(7);
  int checked = 0;
  for (int gen = 0; gen < 40; ++gen) {
    std::vector<Candidate> cands = sampler.generation(25);
    for (const Candidate& c : cands) {
      ++checked;
      ASSERT_EQ(violation(s, c), "");
      for (int i = 0; i < 3; ++i) {
        EXPECT_LE(strain(s, c, i), s.strain_limit * (1 + 1e-12));
        if (i > 0) {
          const auto& o = c.tubes[i - 1];
          const auto& t = c.tubes[i];
          EXPECT_GE(s.catalogue[o.size].inner_diameter - s.catalogue[t.size].outer_diameter,
                    s.nesting_clearance - 1e-12);
          EXPECT_GE(t.straight_length + t.curved_length, o.straight_length + o.curved_length + s.length_step - 1e-12);
        }
      }
      // Every candidate is a loadable robot with admissible translations.
      Tube bt;
      bt.name = "t";
      bt.straight_length = 0.1;
      bt.bending_stiffness = bt.torsional_stiffness = 1e-3;
      const Robot r = makeRobot(s, c, Robot("base", {c.tubes.size(), bt}), "d");
      EXPECT_EQ(io::parseRobot(io::robotToYaml(r), "r.yaml").size(), 3);
    }
    // Re-fit to a random ranking (the sampler must stay within the constraints whatever the objective says).
    std::shuffle(cands.begin(), cands.end(), rng);
    sampler.update(cands);
  }
  EXPECT_EQ(checked, 1000);
  // The sampler's distribution contracted toward the elites but stays in the unit cube.
  for (double m : sampler.mean()) {
    EXPECT_GE(m, 0.0);
    EXPECT_LE(m, 1.0);
  }
}

TEST(DesignSpace, DefaultSpaceOfALungRobotContainsIt) {
  const Robot lung = io::loadRobot(src("examples/robots/medmpd_lung.yaml"));
  const DesignSpace s = defaultSpace(lung);
  ASSERT_EQ(s.tubes.size(), 3u);
  const auto c = candidateOf(s, lung);
  ASSERT_TRUE(c.has_value());
  const Robot r = makeRobot(s, *c, lung, "same");
  for (int i = 0; i < 3; ++i) {
    EXPECT_NEAR(r.tube(i).bending_stiffness, lung.tube(i).bending_stiffness, 1e-9 * lung.tube(i).bending_stiffness);
    EXPECT_NEAR((*r.tube(i).translation_limits)[0], (*lung.tube(i).translation_limits)[0], 1e-12);
    EXPECT_NEAR((*r.tube(i).translation_limits)[1], (*lung.tube(i).translation_limits)[1], 1e-12);
  }
  // The straight needle stays straight; the curvature ranges respect the strain limit.
  EXPECT_EQ(s.tubes[2].curvature.max, 0.0);
  for (int i = 0; i < 2; ++i) EXPECT_LE(s.tubes[i].curvature.max * 0.5 * lung.tube(i).outer_diameter, 0.06 + 1e-12);
  // The start keeps the distal ends.
  Configuration start(Eigen::Vector3d::Zero(), Eigen::Vector3d(-0.118, -0.218, -0.318)), out;
  Candidate longer = *c;
  longer.tubes[0].straight_length += 0.01;
  longer.tubes[1].straight_length += 0.01;
  longer.tubes[2].straight_length += 0.01;
  const Robot rl = makeRobot(s, longer, lung, "longer");
  ASSERT_TRUE(adaptStart(lung, start, rl, out));
  for (int i = 0; i < 3; ++i)
    EXPECT_NEAR(out.beta[i] + rl.tube(i).length(), start.beta[i] + lung.tube(i).length(), 1e-12);
}

TEST(DesignSearch, ATargetOutsideEveryDesignIsReportedWithTheClosestDistance) {
  const fs::path dir = tempDir("far");
  writeEasyProblem(dir);
  const std::string qf = writeQuery(dir, "far", "far");
  Designer d({planner::loadQuery(qf)}, std::nullopt);
  DesignOptions o;
  o.evaluations = 4;
  o.population = 2;
  o.threads = 2;
  o.probe_time = 0.3;
  o.probe_candidates = 30;
  const DesignResult r = d.run(o);
  EXPECT_FALSE(r.solved);
  ASSERT_TRUE(r.best.has_value());
  EXPECT_EQ(r.best->queries[0].stage, QueryOutcome::Stage::Unreachable);
  // The longest robot of the space reaches 0.165 m + base; the target lies 0.15 m sideways at the base plane.
  EXPECT_GT(r.best->queries[0].closest, 0.02);
  EXPECT_NE(r.message.find("closest tip distance reached"), std::string::npos) << r.message;
  EXPECT_NE(r.message.find("'far'"), std::string::npos) << r.message;
  EXPECT_EQ(r.evaluations.size(), 4u);
  fs::remove_all(dir);
}

TEST(DesignSearch, ASmallRunSolvesAnEasyQueryAndWritesALoadableRobot) {
  const fs::path dir = tempDir("easy");
  writeEasyProblem(dir);
  const std::string qf = writeQuery(dir, "easy", "near");
  Designer d({planner::loadQuery(qf)}, std::nullopt);
  DesignOptions o;
  o.evaluations = 4;
  o.population = 2;
  o.threads = 2;
  o.probe_time = 0.5;
  o.plan_time = 2.0;
  o.confirm_seeds = 1;
  const DesignResult r = d.run(o);
  ASSERT_TRUE(r.best.has_value());
  EXPECT_TRUE(r.solved) << r.message;
  const fs::path out = dir / "out";
  writeDesign(d, r, o, "0/1", out.string());
  // The robot loads, lies in the space and within the strain limit; the query copy plans with it.
  const Robot robot = io::loadRobot((out / "robot.yaml").string());
  for (int i = 0; i < robot.size(); ++i)
    EXPECT_LE(std::abs(robot.tube(i).curvature) * 0.5 * robot.tube(i).outer_diameter, d.space().strain_limit + 1e-12);
  const planner::Query q = planner::loadQuery((out / "queries" / "easy.yaml").string());
  EXPECT_EQ(fs::path(q.robot).filename(), "robot.yaml");
  planner::CtrPlanner p(q);
  p.checkStart();
  const nlohmann::json j = nlohmann::json::parse(std::ifstream(out / "result.json"));
  EXPECT_EQ(j["solved"], r.solved);
  EXPECT_EQ(j["evaluations"].size(), 4u);
  EXPECT_TRUE(j["queries"][0]["plan"]["solved"].get<bool>());
  EXPECT_TRUE(fs::exists(out / "paths" / "easy.csv"));
  // Merging the run as a single shard reproduces its design.
  const std::string merged = mergeDesigns({out.string()}, (dir / "merged").string(), false);
  EXPECT_EQ(io::readFile((dir / "merged" / "robot.yaml").string()), io::readFile((out / "robot.yaml").string()));
  fs::remove_all(dir);
}

TEST(DesignSearch, ShardsOfARunMergeIntoTheBestDesignAndAMissingShardIsAnError) {
  const fs::path dir = tempDir("shards");
  writeEasyProblem(dir);
  const std::string qf = writeQuery(dir, "easy", "near");
  Designer d({planner::loadQuery(qf)}, std::nullopt);
  DesignOptions o;
  o.starts = 2;
  o.evaluations = 2;
  o.population = 2;
  o.threads = 2;
  o.probe_time = 0.3;
  o.plan_time = 1.0;
  o.confirm_seeds = 0;
  std::vector<DesignResult> parts;
  for (int s = 0; s < 2; ++s) {
    DesignOptions os = o;
    os.start_indices = {s};
    parts.push_back(d.run(os));
    writeDesign(d, parts.back(), os, std::to_string(s) + "/2",
                (dir / "run" / "shards" / ("shard-" + std::to_string(s) + "-of-2")).string());
  }
  // One shard alone: an error naming the missing one, and nothing written.
  fs::rename(dir / "run" / "shards" / "shard-1-of-2", dir / "aside");
  try {
    mergeDesigns({(dir / "run").string()}, (dir / "merged").string(), false);
    FAIL() << "expected an InputError for the missing shard";
  } catch (const io::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("1/2"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(fs::exists(dir / "merged"));
  fs::rename(dir / "aside", dir / "run" / "shards" / "shard-1-of-2");
  const nlohmann::json m =
      nlohmann::json::parse(mergeDesigns({(dir / "run").string()}, (dir / "merged").string(), false));
  EXPECT_EQ(m["evaluations"].size(), 4u);
  EXPECT_EQ(m["shards"].size(), 2u);
  // The merged design is the better of the two shards' bests.
  const Evaluation& b =
      parts[0].best->score.better(parts[1].best->score) || !parts[1].best ? *parts[0].best : *parts[1].best;
  EXPECT_NEAR(m["design"]["score"]["badness"].get<double>(), b.score.badness, 1e-12);
  EXPECT_TRUE(fs::exists(dir / "merged" / "result.json"));
  fs::remove_all(dir);
}
