// Tests of ctr::design: the design space (parsing, constraints), the gaco search (never leaves the constraints,
// seeded, the fitness's order), the finalists' independent plans (counted in the ranking, reported in result.json),
// the verdict for a target no design reaches, and a small design run on an easy query.
#include <gtest/gtest.h>

#include <unistd.h>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <nlohmann/json.hpp>
#include <set>

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

std::string writeQuery(const fs::path& dir, const std::string& name, const std::string& target,
                       const std::string& time_limit = "2") {
  const fs::path p = dir / (name + ".yaml");
  std::ofstream q(p);
  q << "name: " << name << "\nrobot: robot.yaml\nenvironment: env.yaml\n"
    << "start: {alpha: [0, 0], beta: [-0.075, -0.105], history: positive}\n"
    << "goal: {target: " << target << ", tolerance: 0.003}\n"
    << "mode: frictionless\nplanner: rrtconnect\ntime_limit: " << time_limit << "\nseed: 1\n"
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

// Checks the constraints of a candidate (strain, diameter nesting, length nesting, a loadable robot).
void expectWithinConstraints(const DesignSpace& s, const Candidate& c) {
  ASSERT_EQ(violation(s, c), "");
  for (int i = 0; i < 3; ++i) {
    EXPECT_LE(strain(s, c, i), s.strain_limit * (1 + 1e-12));
    if (i > 0) {
      const auto& o = c.tubes[i - 1];
      const auto& t = c.tubes[i];
      EXPECT_GE(s.catalogue[o.size].inner_diameter - s.catalogue[t.size].outer_diameter, s.nesting_clearance - 1e-12);
      EXPECT_GE(t.straight_length + t.curved_length, o.straight_length + o.curved_length + s.length_step - 1e-12);
    }
  }
  Tube bt;
  bt.name = "t";
  bt.straight_length = 0.1;
  bt.bending_stiffness = bt.torsional_stiffness = 1e-3;
  const Robot r = makeRobot(s, c, Robot("base", {c.tubes.size(), bt}), "d");
  EXPECT_EQ(io::parseRobot(io::robotToYaml(r), "r.yaml").size(), 3);
}

// A search of 1,000 candidates by pagmo's gaco under an objective that ranks candidates at random (a hash of the
// candidate): every candidate it evaluates satisfies the constraints, whatever the objective says.
TEST(DesignSearch, NeverEvaluatesACandidateThatViolatesStrainOrNesting) {
  const DesignSpace s = parseSpace(kSpace, "space.yaml");
  const Decoder dec(s);
  ASSERT_EQ(dec.integerDimension(), 1u);
  // The box's corners and centre decode (repaired) within the constraints.
  const auto [lo, hi] = dec.bounds();
  for (int corner = 0; corner < 1 << 3; ++corner) {
    std::vector<double> x(dec.dimension());
    for (std::size_t j = 0; j < x.size(); ++j) x[j] = ((corner >> (j % 3)) & 1) ? hi[j] : lo[j];
    expectWithinConstraints(s, dec.decode(x));
  }
  std::mutex m;
  std::vector<Candidate> seen;
  const EvaluateFn random_rank = [&](const Candidate& c, std::size_t) {
    Evaluation ev;
    std::size_t h = 0;
    for (const auto& t : c.tubes)
      h = h * 1000003 ^ std::hash<double>()(t.straight_length + 3 * t.curved_length + 7 * t.curvature + t.size);
    ev.score.badness = 1.0 + static_cast<double>(h % 1000) / 1000.0;
    ev.score.length = 0.1;
    std::lock_guard<std::mutex> lock(m);
    seen.push_back(c);
    return ev;
  };
  DesignOptions o;
  o.evaluations = 1000;
  o.population = 25;
  o.threads = 2;
  const std::vector<Evaluation> evals = searchStart(s, 0, o, std::nullopt, random_rank, [] { return false; });
  ASSERT_EQ(evals.size(), 1000u);
  ASSERT_EQ(seen.size(), 1000u);
  for (const Candidate& c : seen) expectWithinConstraints(s, c);
  std::set<std::vector<int>> combos;
  for (std::size_t i = 0; i < evals.size(); ++i) {
    EXPECT_EQ(evals[i].index, i);
    EXPECT_EQ(evals[i].generation, static_cast<int>(i / 25));
    std::vector<int> sizes;
    for (const auto& t : evals[i].candidate.tubes) sizes.push_back(t.size);
    combos.insert(sizes);
  }
  EXPECT_GT(combos.size(), 1u);  // the integer variable varies
}

// The search is pagmo's gaco: on a smooth objective it improves on its first generation, starts with the given
// candidate, and the same seed gives the same candidates.
TEST(DesignSearch, TheSearchIsSeededAndImprovesOnASmoothObjective) {
  const DesignSpace s = parseSpace(kSpace, "space.yaml");
  const Decoder dec(s);
  const std::vector<double> target{0.3, 0.6, 0.2, 0.7, 0.4, 0.5, 0.9, 0.5, 0.1};
  const EvaluateFn smooth = [&](const Candidate& c, std::size_t) {
    Evaluation ev;
    const std::vector<double> x = dec.encode(c);
    double d = 0.0;
    for (std::size_t j = 0; j < target.size(); ++j) d += (x[j] - target[j]) * (x[j] - target[j]);
    ev.score.badness = 1.0 + d;
    ev.score.length = 0.1;
    return ev;
  };
  const Candidate first = dec.decode(std::vector<double>(dec.dimension(), 0.0));
  DesignOptions o;
  o.evaluations = 200;
  o.population = 10;
  o.threads = 2;
  o.seed = 5;
  auto never = [] { return false; };
  const std::vector<Evaluation> a = searchStart(s, 3, o, first, smooth, never);
  const std::vector<Evaluation> b = searchStart(s, 3, o, first, smooth, never);
  ASSERT_EQ(a.size(), 200u);
  ASSERT_EQ(b.size(), 200u);
  EXPECT_EQ(dec.encode(a[0].candidate), dec.encode(first));
  for (std::size_t i = 0; i < a.size(); ++i) EXPECT_EQ(dec.encode(a[i].candidate), dec.encode(b[i].candidate)) << i;
  double first_gen = 1e9, last_gen = 1e9;
  for (std::size_t i = 0; i < 10; ++i) first_gen = std::min(first_gen, a[i].score.badness);
  for (std::size_t i = 150; i < 200; ++i) last_gen = std::min(last_gen, a[i].score.badness);
  EXPECT_LT(last_gen, first_gen);
  // Another start draws other candidates.
  const std::vector<Evaluation> c = searchStart(s, 4, o, std::nullopt, smooth, never);
  EXPECT_NE(dec.encode(a[1].candidate), dec.encode(c[1].candidate));
  // Past the budget in the last batch nothing is evaluated: 23 candidates with 10 per generation.
  o.evaluations = 23;
  EXPECT_EQ(searchStart(s, 0, o, std::nullopt, smooth, never).size(), 23u);
}

// The search's scalar fitness orders scores lexicographically: badness first, then clearance in 0.1 mm bins, then
// the length.
TEST(DesignSearch, TheFitnessOrdersScoresLexicographically) {
  auto sc = [](double badness, double clearance, double length) {
    Score s;
    s.badness = badness;
    s.clearance = badness == 0.0 ? clearance : -std::numeric_limits<double>::infinity();
    s.length = length;
    return s;
  };
  // A finalist: the success rate of its independent plans first, then clearance and length; every finalist ranks
  // above every candidate that was not confirmed.
  auto fin = [&](double rate, double clearance, double length) {
    Score s = sc(0.0, clearance, length);
    s.success_rate = rate;
    return s;
  };
  const std::vector<Score> ranked{fin(1.0, 0.0001, 0.30),
                                  fin(1.0, 0.0001, 0.31),
                                  fin(1.0, -0.0002, 0.01),
                                  fin(0.875, 0.05, 0.05),
                                  fin(0.8, 0.002, 0.1),
                                  fin(0.0, 0.9, 0.01),
                                  sc(0.0, 0.00125, 0.30),
                                  sc(0.0, 0.00125, 0.31),
                                  sc(0.0, 0.00119, 0.10),
                                  sc(0.0, 0.00015, 0.2),
                                  sc(0.0, 0.0, 0.05),
                                  sc(0.0, -0.0002, 0.01),
                                  sc(1e-6, 0, 0.5),
                                  sc(1e-6, 0, 0.6),
                                  sc(0.5, 0, 0.01),
                                  sc(0.500002, 0, 0.0),
                                  sc(3.999, 0, 0.2),
                                  sc(7.2, 0, 0.1),
                                  Score{}};
  for (std::size_t i = 0; i < ranked.size(); ++i)
    for (std::size_t j = 0; j < ranked.size(); ++j) {
      EXPECT_EQ(ranked[i].better(ranked[j]), i < j) << i << " vs " << j;
      EXPECT_EQ(ranked[i].fitness() < ranked[j].fitness(), i < j) << i << " vs " << j;
    }
}

// Two finalists of one query: `a` has the larger clearance (the search ranks it first) but its independent plans
// fail, `b`'s pass. The success rate must rank `b` first, make it the design kept and be written to result.json.
TEST(DesignSearch, AFinalistWhoseIndependentPlansFailRanksBelowOneWhosePlansPass) {
  auto evaluation = [](std::size_t index, double clearance, const std::string& robot) {
    Evaluation e;
    e.index = index;
    e.robot_yaml = robot;
    e.candidate.tubes.resize(2);
    e.candidate.tubes[0].straight_length = 0.05;
    e.candidate.tubes[1].straight_length = 0.09;
    QueryOutcome q;
    q.stage = QueryOutcome::Stage::Solved;
    q.plans = q.plans_solved = 2;
    q.min_clearance = clearance;
    e.queries = {q};
    e.score = scoreOf(e.queries, e.candidate);
    return e;
  };
  auto confirm = [](Evaluation& e, std::size_t k, const std::vector<bool>& solved) {
    for (std::size_t j = 0; j < solved.size(); ++j) {
      ConfirmationPlan p;
      p.seed = 100 + j;
      p.path_found = true;  // a path whose replay was not clean is not solved
      p.solved = solved[j];
      p.min_clearance = solved[j] ? 0.0002 : -0.0001;
      e.queries[k].confirmation.push_back(p);
    }
    e.score = scoreOf(e.queries, e.candidate);
  };
  std::vector<Evaluation> evals{evaluation(0, 0.0005, "a"), evaluation(1, 0.0001, "b"), evaluation(2, 0.0004, "a"),
                                evaluation(3, 0.0009, "c")};
  evals[3].queries[0].stage = QueryOutcome::Stage::NoPath;  // unsolved: never a finalist
  evals[3].score = scoreOf(evals[3].queries, evals[3].candidate);
  // Before confirmation the search ranks a first; the finalists are the solved ones, distinct robots, best first.
  EXPECT_TRUE(evals[0].score.better(evals[1].score));
  EXPECT_FALSE(evals[0].score.confirmed());
  EXPECT_EQ(finalistsOf(evals, 3), (std::vector<std::size_t>{0, 1}));
  EXPECT_EQ(finalistsOf(evals, 1), (std::vector<std::size_t>{0}));
  confirm(evals[0], 0, {true, false, false, true, false, false, true, false});
  confirm(evals[1], 0, {true, true, true, true, true, true, true, true});
  EXPECT_DOUBLE_EQ(evals[0].score.success_rate, 3.0 / 8.0);
  EXPECT_DOUBLE_EQ(evals[1].score.success_rate, 1.0);
  EXPECT_TRUE(evals[1].score.better(evals[0].score));
  // A finalist that failed ranks above the candidates that were not confirmed (the kept design is a finalist).
  EXPECT_TRUE(evals[0].score.better(evals[2].score));
  const std::optional<Evaluation> best = bestOf(evals);
  ASSERT_TRUE(best.has_value());
  EXPECT_EQ(best->index, 1u);
  EXPECT_NE(verdict(evals, best, {"q"}, 0.8).find("'q' 8/8"), std::string::npos) << verdict(evals, best, {"q"}, 0.8);
  const std::string failed = verdict(evals, evals[0], {"q"}, 0.8);
  EXPECT_NE(failed.find("no design plans reliably"), std::string::npos) << failed;
  EXPECT_NE(failed.find("'q' 3/8"), std::string::npos) << failed;
  // With several queries the rate is the least of theirs.
  Evaluation two = evaluation(4, 0.0005, "d");
  two.queries.push_back(two.queries[0]);
  confirm(two, 0, {true, true, true, true});
  confirm(two, 1, {true, false, true, false});
  EXPECT_DOUBLE_EQ(two.score.success_rate, 0.5);

  // result.json: the kept design's rate, seeds and counts; every finalist, best first; every plan in evaluations.
  const fs::path dir = tempDir("finalists");
  writeEasyProblem(dir);
  const Designer d({planner::loadQuery(writeQuery(dir, "q", "near"))}, std::nullopt);
  DesignResult r;
  r.evaluations = evals;
  r.finalists = {1, 0};
  r.confirmation_seeds = {100, 101, 102, 103, 104, 105, 106, 107};
  r.best = best;
  DesignOptions o;
  const nlohmann::json j = nlohmann::json::parse(resultJson(d, r, o, "0/1"));
  EXPECT_EQ(j["options"]["finalists"], o.finalists);
  EXPECT_EQ(j["options"]["finalist_plans"], o.finalist_plans);
  EXPECT_DOUBLE_EQ(j["confirmation"]["success_rate"].get<double>(), 1.0);
  EXPECT_EQ(j["confirmation"]["plans"], 8);
  EXPECT_EQ(j["confirmation"]["solved"], 8);
  EXPECT_EQ(j["confirmation"]["seeds"].size(), 8u);
  EXPECT_TRUE(j["confirmation"]["passed"].get<bool>());
  EXPECT_EQ(j["confirmation"]["queries"][0]["query"], "q");
  EXPECT_EQ(j["queries"][0]["confirmation"]["solved"], 8);
  EXPECT_DOUBLE_EQ(j["design"]["score"]["success_rate"].get<double>(), 1.0);
  ASSERT_EQ(j["finalists"].size(), 2u);
  EXPECT_EQ(j["finalists"][0]["index"], 1);
  EXPECT_EQ(j["finalists"][1]["index"], 0);
  EXPECT_EQ(j["finalists"][1]["solved"], 3);
  EXPECT_DOUBLE_EQ(j["finalists"][1]["success_rate"].get<double>(), 0.375);
  const auto& runs = j["evaluations"][0]["queries"][0]["confirmation"];
  EXPECT_EQ(runs["paths_found"], 8);
  EXPECT_EQ(runs["solved"], 3);
  ASSERT_EQ(runs["runs"].size(), 8u);
  EXPECT_EQ(runs["runs"][1]["seed"], 101);
  EXPECT_FALSE(runs["runs"][1]["solved"].get<bool>());
  EXPECT_TRUE(j["evaluations"][2]["score"]["success_rate"].is_null());
  EXPECT_FALSE(j["evaluations"][2]["queries"][0].contains("confirmation"));
  fs::remove_all(dir);
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
  o.finalists = 2;
  o.finalist_plans = 3;
  const DesignResult r = d.run(o);
  ASSERT_TRUE(r.best.has_value());
  EXPECT_TRUE(r.solved) << r.message;
  // The design kept is the best finalist, confirmed by 3 independent plans.
  ASSERT_FALSE(r.finalists.empty());
  EXPECT_EQ(r.best->index, r.evaluations[r.finalists.front()].index);
  ASSERT_EQ(r.best->queries[0].confirmation.size(), 3u);
  EXPECT_EQ(r.confirmation_seeds, confirmationSeeds(o.seed, 3));
  EXPECT_DOUBLE_EQ(r.best->score.success_rate, r.best->queries[0].confirmationSolved() / 3.0);
  EXPECT_GE(r.best->score.success_rate, o.finalist_rate);
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
  EXPECT_DOUBLE_EQ(j["confirmation"]["success_rate"].get<double>(), r.best->score.success_rate);
  EXPECT_EQ(j["confirmation"]["seeds"].size(), 3u);
  EXPECT_EQ(j["finalists"].size(), r.finalists.size());
  EXPECT_TRUE(fs::exists(out / "paths" / "easy.csv"));
  // Merging the run as a single shard reproduces its design.
  const std::string merged = mergeDesigns({out.string()}, (dir / "merged").string(), false);
  EXPECT_EQ(io::readFile((dir / "merged" / "robot.yaml").string()), io::readFile((out / "robot.yaml").string()));
  fs::remove_all(dir);
}

// The finalists are planned as `ctr plan` plans the written query: with the query's own time limit, not the search's
// --plan-time. A query whose own limit is far too short for any plan is solved in the search (2 s), but no design
// passes its independent plans, so the run is not solved; without finalists the same search is.
TEST(DesignSearch, TheFinalistsArePlannedWithTheWrittenQuerysSettings) {
  const fs::path dir = tempDir("written");
  writeEasyProblem(dir);
  const Designer d({planner::loadQuery(writeQuery(dir, "easy", "near", "0.000001"))}, std::nullopt);
  DesignOptions o;
  o.evaluations = 2;
  o.population = 2;
  o.threads = 2;
  o.probe_time = 0.5;
  o.plan_time = 2.0;
  o.confirm_seeds = 0;
  o.finalists = 0;
  const DesignResult search_only = d.run(o);
  ASSERT_TRUE(search_only.best.has_value());
  ASSERT_TRUE(search_only.solved) << search_only.message;
  EXPECT_FALSE(search_only.best->score.confirmed());
  o.finalists = 2;
  o.finalist_plans = 2;
  const DesignResult r = d.run(o);
  ASSERT_TRUE(r.best.has_value());
  EXPECT_TRUE(r.best->score.solved());  // the search's plans
  EXPECT_TRUE(r.best->score.confirmed());
  EXPECT_EQ(r.best->score.success_rate, 0.0);
  EXPECT_FALSE(r.solved);
  EXPECT_NE(r.message.find("no design plans reliably"), std::string::npos) << r.message;
  for (const ConfirmationPlan& p : r.best->queries[0].confirmation) EXPECT_FALSE(p.solved) << p.seed;
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
  o.finalist_plans = 2;
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
  EXPECT_EQ(m["finalists"].size(), parts[0].finalists.size() + parts[1].finalists.size());
  // The merged design is the better of the two shards' bests.
  const Evaluation& b =
      parts[0].best->score.better(parts[1].best->score) || !parts[1].best ? *parts[0].best : *parts[1].best;
  EXPECT_NEAR(m["design"]["score"]["badness"].get<double>(), b.score.badness, 1e-12);
  EXPECT_TRUE(fs::exists(dir / "merged" / "result.json"));
  fs::remove_all(dir);
}
