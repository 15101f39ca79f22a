// Runs the `ctr` executable: output formats, exit codes, negative-number lists, no partial output files.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "run_process.hpp"

namespace fs = std::filesystem;

namespace {

using ctr_test::Proc;

Proc run(const std::string& args) {
  return ctr_test::runShell(std::string(CTR_EXE) + " " + args,
                        fs::temp_directory_path() / ("ctr_cli_" + std::to_string(::getpid())));
}

std::string robot(const std::string& name) { return std::string(CTR_SOURCE_DIR) + "/examples/robots/" + name; }

fs::path tmp(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("ctr_cli_out_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  return dir / name;
}

}  // namespace

TEST(Cli, FkJsonHasTheDocumentedKeys) {
  const Proc r = run("fk --robot " + robot("tube_pair_B.yaml") + " --alpha 0,90deg --beta -0.018,-0.018 --json");
  ASSERT_EQ(r.code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_TRUE(j.at("converged").get<bool>());
  EXPECT_TRUE(j.at("stable").get<bool>());
  EXPECT_EQ(j.at("tip_position").size(), 3u);
  EXPECT_EQ(j.at("tip_tangent").size(), 3u);
  ASSERT_EQ(j.at("twist").size(), 1u);
  EXPECT_NEAR(j["twist"][0].get<double>(), 0.8206, 1e-3);
  // Exactly one JSON object on stdout.
  EXPECT_EQ(std::count(r.out.begin(), r.out.end(), '\n'), 1);
}

TEST(Cli, NegativeListsWorkWithSpaceAndEquals) {
  const Proc a = run("fk --robot " + robot("tube_pair_B.yaml") + " --beta -0.018,-0.018 --alpha=0,1.5 --json");
  const Proc b = run("fk --robot " + robot("tube_pair_B.yaml") + " --beta=-0.018,-0.018 --alpha 0,1.5 --json");
  const Proc c = run("fk --robot " + robot("tube_pair_B.yaml") + " --beta -0.018,-0.018 --alpha -1,-0.5 --json");
  ASSERT_EQ(a.code, 0) << a.err;
  ASSERT_EQ(b.code, 0) << b.err;
  ASSERT_EQ(c.code, 0) << c.err;
  EXPECT_EQ(a.out, b.out);
  // (-1, -0.5) is (0, 0.5) rotated by -1 rad about z: same twist, tip rotated.
  const auto jc = nlohmann::json::parse(c.out);
  const auto jr = nlohmann::json::parse(
      run("fk --robot " + robot("tube_pair_B.yaml") + " --beta -0.018,-0.018 --alpha 0,0.5 --json").out);
  EXPECT_NEAR(jc["twist"][0].get<double>(), jr["twist"][0].get<double>(), 1e-9);
  const double x = jr["tip_position"][0], y = jr["tip_position"][1];
  EXPECT_NEAR(jc["tip_position"][0].get<double>(), std::cos(-1.0) * x - std::sin(-1.0) * y, 1e-9);
  EXPECT_NEAR(jc["tip_position"][1].get<double>(), std::sin(-1.0) * x + std::cos(-1.0) * y, 1e-9);
}

TEST(Cli, ShapeCsvIsWrittenAtTheRequestedResolution) {
  const fs::path f = tmp("shape.csv");
  fs::remove(f);
  const Proc r = run("fk --robot " + robot("tube_pair_B.yaml") + " --alpha 0,1 --beta -0.018,-0.018 --shape " +
                    f.string() + " --shape-step 0.002");
  ASSERT_EQ(r.code, 0) << r.err;
  std::ifstream in(f);
  std::string line;
  std::getline(in, line);
  EXPECT_EQ(line, "s,x,y,z");
  int rows = 0;
  while (std::getline(in, line)) ++rows;
  EXPECT_EQ(rows, 76);  // 0 .. 0.150 m every 2 mm
}

TEST(Cli, BadInputsExitTwoWithClearMessages) {
  const Proc missing = run("fk --robot /nonexistent/robot.yaml");
  EXPECT_EQ(missing.code, 2);
  EXPECT_NE(missing.err.find("/nonexistent/robot.yaml"), std::string::npos) << missing.err;
  const Proc count = run("fk --robot " + robot("tube_pair_B.yaml") + " --alpha 0,1,2");
  EXPECT_EQ(count.code, 2);
  EXPECT_NE(count.err.find("--alpha"), std::string::npos) << count.err;
  const Proc notnum = run("fk --robot " + robot("tube_pair_B.yaml") + " --alpha 0,abc");
  EXPECT_EQ(notnum.code, 2);
  EXPECT_NE(notnum.err.find("abc"), std::string::npos) << notnum.err;
  const Proc inadm = run("fk --robot " + robot("tube_pair_B.yaml") + " --beta -0.01,0");
  EXPECT_EQ(inadm.code, 2);
  EXPECT_NE(inadm.err.find("beta_2"), std::string::npos) << inadm.err;
  const Proc unknown = run("fk --robot " + robot("tube_pair_B.yaml") + " --bogus 1");
  EXPECT_EQ(unknown.code, 2);
  const Proc tube = run("sweep --robot " + robot("tube_pair_B.yaml") + " --tube 5 --from 0 --to 1 --step 0.1");
  EXPECT_EQ(tube.code, 2);
  EXPECT_NE(tube.err.find("--tube"), std::string::npos) << tube.err;
}

TEST(Cli, HelpOnEverySubcommand) {
  for (const char* sub : {"", "fk", "ik", "sweep", "simulate", "demo"}) {
    const Proc r = run(std::string(sub) + " --help");
    EXPECT_EQ(r.code, 0) << sub;
    EXPECT_NE(r.out.find("--help"), std::string::npos) << sub;
    // The usage line names the program and the subcommand.
    const std::string usage = std::string("Usage: ctr ") + (*sub ? std::string(sub) + " " : "") + "[OPTIONS]";
    EXPECT_NE(r.out.find(usage), std::string::npos) << r.out;
  }
}

TEST(Cli, SweepBothDirectionsWithFrictionShowsTheEnvelope) {
  const fs::path f = tmp("sweep.csv");
  const Proc r = run("sweep --robot " + robot("tube_pair_B.yaml") +
                    " --tube 2 --from 0 --to 360deg --step 30deg --both-directions --boundary-friction 0.12 --csv " +
                    f.string());
  ASSERT_EQ(r.code, 0) << r.err;
  std::ifstream in(f);
  std::string header;
  std::getline(in, header);
  EXPECT_EQ(header.rfind("alpha_1,alpha_2,beta_1,beta_2,twist_2,tip_x,tip_y,tip_z,tip_tx,tip_ty,tip_tz,direction,stable", 0),
            0u)
      << header;
  std::vector<std::vector<double>> rows;
  std::string line;
  while (std::getline(in, line)) {
    std::vector<double> v;
    std::stringstream ss(line);
    std::string cell;
    while (std::getline(ss, cell, ',')) v.push_back(std::stod(cell));
    rows.push_back(v);
  }
  ASSERT_EQ(rows.size(), 25u);
  // Row 6 (180 deg up) vs row 18 (180 deg down): different twists (column 4).
  EXPECT_NEAR(rows[6][1], M_PI, 1e-12);
  EXPECT_NEAR(rows[18][1], M_PI, 1e-12);
  EXPECT_GT(rows[18][4] - rows[6][4], 1.0);
  EXPECT_EQ(rows[6][11], 1);
  EXPECT_EQ(rows[18][11], -1);
}

// External loads: --tip-force/--tip-moment/--gravity on fk, sweep, simulate; `loads:` in the robot YAML;
// fk --jacobian adds the exact tip Jacobian and compliance.
namespace {

// tube_pair_B with linear densities (and optionally a loads block) written to a temporary file.
std::string heavyPair(const std::string& loads = "") {
  const fs::path f = tmp(loads.empty() ? "heavy_pair.yaml" : "heavy_pair_loads.yaml");
  std::ifstream in(robot("tube_pair_B.yaml"));
  std::ofstream out(f);
  std::string line;
  while (std::getline(in, line)) {
    out << line << "\n";
    if (line.find("inner_diameter") != std::string::npos) out << "    density: 6450\n";
  }
  out << loads;
  return f.string();
}

std::vector<double> tipOf(const std::string& json) {
  const auto j = nlohmann::json::parse(json);
  return j.at("tip_position").get<std::vector<double>>();
}

}  // namespace

TEST(Cli, FkWithLoadsAndJacobian) {
  const std::string base = "fk --robot " + robot("tube_pair_B.yaml") + " --alpha 0,1 --beta -0.018,-0.018 --json";
  const Proc free = run(base);
  const Proc loaded = run(base + " --tip-force 0.1,-0.05,0 --tip-moment 0,0,0.002");
  ASSERT_EQ(free.code, 0) << free.err;
  ASSERT_EQ(loaded.code, 0) << loaded.err;
  const std::vector<double> a = tipOf(free.out), b = tipOf(loaded.out);
  EXPECT_GT(std::hypot(a[0] - b[0], a[1] - b[1]), 1e-3);
  // The same keys with and without loads; jacobian/compliance only with --jacobian.
  const auto jf = nlohmann::json::parse(free.out), jl = nlohmann::json::parse(loaded.out);
  for (auto it = jf.begin(); it != jf.end(); ++it) EXPECT_TRUE(jl.contains(it.key())) << it.key();
  EXPECT_EQ(jf.size(), jl.size());
  EXPECT_FALSE(jl.contains("jacobian"));
  const std::string loads = " --tip-force 0.1,-0.05,0 --tip-moment 0,0,0.002";
  const Proc jac = run(base + loads + " --jacobian");
  ASSERT_EQ(jac.code, 0) << jac.err;
  const auto j = nlohmann::json::parse(jac.out);
  ASSERT_EQ(j.at("jacobian").size(), 6u);
  ASSERT_EQ(j["jacobian"][0].size(), 4u);  // alpha_1, alpha_2, beta_1, beta_2
  ASSERT_EQ(j.at("compliance").size(), 6u);
  ASSERT_EQ(j["compliance"][0].size(), 6u);
  // The alpha_2 column against central differences of two more runs (printed with round-trip precision).
  const double h = 1e-5;
  const std::string pre = "fk --robot " + robot("tube_pair_B.yaml") + " --beta -0.018,-0.018 --json" + loads;
  const std::vector<double> p = tipOf(run(pre + " --alpha 0," + std::to_string(1 + h)).out);
  const std::vector<double> m = tipOf(run(pre + " --alpha 0," + std::to_string(1 - h)).out);
  double err = 0, size = 0;
  for (int k = 0; k < 3; ++k) {
    const double fd = (p[static_cast<std::size_t>(k)] - m[static_cast<std::size_t>(k)]) / (2 * h);
    const double ex = j["jacobian"][static_cast<std::size_t>(k)][1].get<double>();
    err = std::max(err, std::abs(fd - ex));
    size = std::max(size, std::abs(ex));
  }
  EXPECT_LT(err, 1e-5 * size);
  // Bad load values: exit 2 naming the option.
  const Proc bad = run(base + " --gravity 0,-9.81");
  EXPECT_EQ(bad.code, 2);
  EXPECT_NE(bad.err.find("--gravity"), std::string::npos) << bad.err;
  const Proc bad2 = run(base + " --tip-force 0,abc,0");
  EXPECT_EQ(bad2.code, 2);
  EXPECT_NE(bad2.err.find("--tip-force"), std::string::npos) << bad2.err;
}

TEST(Cli, LoadsFromTheRobotFileAndOverriddenOnTheCommandLine) {
  const std::string heavy = heavyPair();
  const std::string with_loads = heavyPair("loads:\n  gravity: [0, -9.81, 0]\n");
  const std::string q = " --alpha 0,1 --beta -0.018,-0.018 --json";
  const std::vector<double> none = tipOf(run("fk --robot " + heavy + q).out);
  const Proc file = run("fk --robot " + with_loads + q);
  const Proc cli = run("fk --robot " + heavy + q + " --gravity 0,-9.81,0");
  ASSERT_EQ(file.code, 0) << file.err;
  ASSERT_EQ(cli.code, 0) << cli.err;
  EXPECT_EQ(tipOf(file.out), tipOf(cli.out));  // the same load from the file or the command line
  EXPECT_LT(tipOf(file.out)[1], none[1] - 1e-5);  // sags toward -y
  // The command line replaces the file's entry.
  const Proc off = run("fk --robot " + with_loads + q + " --gravity 0,0,0");
  ASSERT_EQ(off.code, 0) << off.err;
  const std::vector<double> o = tipOf(off.out);
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(o[static_cast<std::size_t>(k)], none[static_cast<std::size_t>(k)], 1e-12);
  // Gravity on a robot without densities: a warning, no effect.
  const Proc weightless = run("fk --robot " + robot("tube_pair_B.yaml") + q + " --gravity 0,-9.81,0");
  EXPECT_EQ(weightless.code, 0);
  EXPECT_NE(weightless.err.find("no effect"), std::string::npos) << weightless.err;
}

TEST(Cli, SweepAndSimulateUnderLoads) {
  const std::string heavy = heavyPair();
  const fs::path f0 = tmp("sweep0.csv"), f1 = tmp("sweep1.csv");
  const std::string sweep = "sweep --robot " + heavy +
                            " --tube 2 --from 0 --to 180deg --step 30deg --both-directions --boundary-friction 0.1 --csv ";
  const Proc a = run(sweep + f0.string());
  const Proc b = run(sweep + f1.string() + " --gravity 0,-9.81,0 --tip-force 0,0,-0.05");
  ASSERT_EQ(a.code, 0) << a.err;
  ASSERT_EQ(b.code, 0) << b.err;
  auto readRows = [](const fs::path& p) {
    std::ifstream in(p);
    std::string line;
    std::getline(in, line);
    std::vector<std::string> rows;
    while (std::getline(in, line)) rows.push_back(line);
    return rows;
  };
  const auto ra = readRows(f0), rb = readRows(f1);
  ASSERT_EQ(ra.size(), 13u);
  ASSERT_EQ(rb.size(), ra.size());
  EXPECT_NE(ra[3], rb[3]);  // the loads change the shape
  // simulate: loads apply too.
  const fs::path act = tmp("act_loads.csv"), o0 = tmp("rec0.csv"), o1 = tmp("rec1.csv");
  {
    std::ofstream s(act);
    s << "alpha_1,alpha_2,beta_1,beta_2\n";
    for (int k = 0; k <= 6; ++k) s << "0," << k * 0.3 << ",-0.018,-0.018\n";
  }
  const std::string sim = "simulate --robot " + heavy + " --actuation " + act.string() + " --out ";
  ASSERT_EQ(run(sim + o0.string()).code, 0);
  const Proc s1 = run(sim + o1.string() + " --tip-moment 0.001,0,0");
  ASSERT_EQ(s1.code, 0) << s1.err;
  EXPECT_NE(readRows(o0), readRows(o1));
}

TEST(Cli, InjectedTipLoadIsSimulatedWithTheLoadedModel) {
  // `ctr recording inject --effect tip_load:...` (no noise, frictionless): every row's tip is the loaded model's, as
  // `ctr fk --tip-force` gives it, and the truth file carries the force.
  const fs::path act = tmp("act_load.csv"), out = tmp("rec_load.csv"), truth = tmp("rec_load.truth.json");
  {
    std::ofstream a(act);
    a << "alpha_1,alpha_2,beta_1,beta_2\n";
    for (int k = 0; k < 4; ++k) a << "0," << 0.4 * k << ",-0.018,-0.018\n";
  }
  const Proc r = run("recording inject --robot " + robot("tube_pair_B.yaml") + " --actuation " + act.string() +
                     " --effect tip_load:force=0.1,-0.05,0 --noise-position 0 --noise-twist 0 --noise-tangent 0"
                     " --measure tip_position --out " + out.string() + " --truth " + truth.string());
  ASSERT_EQ(r.code, 0) << r.err;
  std::ifstream in(out);
  std::string line;
  std::getline(in, line);
  ASSERT_EQ(line, "alpha_1,alpha_2,beta_1,beta_2,tip_x,tip_y,tip_z");
  int rows = 0;
  double moved = 0.0;
  while (std::getline(in, line)) {
    std::vector<double> v;
    std::stringstream ss(line);
    for (std::string c; std::getline(ss, c, ',');) v.push_back(std::stod(c));
    ASSERT_EQ(v.size(), 7u) << line;
    const std::string cfg = " --alpha 0," + std::to_string(v[1]) + " --beta -0.018,-0.018 --json";
    const std::vector<double> loaded = tipOf(run("fk --robot " + robot("tube_pair_B.yaml") + cfg +
                                                 " --tip-force 0.1,-0.05,0").out);
    const std::vector<double> free = tipOf(run("fk --robot " + robot("tube_pair_B.yaml") + cfg).out);
    ASSERT_EQ(loaded.size(), 3u);
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(v[static_cast<std::size_t>(4 + k)], loaded[static_cast<std::size_t>(k)], 1e-9);
    moved = std::max(moved, std::hypot(loaded[0] - free[0], loaded[1] - free[1]));
    ++rows;
  }
  EXPECT_EQ(rows, 4);
  EXPECT_GT(moved, 1e-3);  // the load is visible (mm), so the comparison above tells the models apart
  std::ifstream tj(truth);
  const auto j = nlohmann::json::parse(tj);
  ASSERT_EQ(j.at("effects").size(), 1u);
  EXPECT_EQ(j["effects"][0]["effect"], "tip_load");
  EXPECT_EQ(j["effects"][0]["force"], nlohmann::json::array({0.1, -0.05, 0.0}));
}

TEST(Cli, SimulateWritesARecordingAndNothingOnBadInput) {
  const fs::path act = tmp("act.csv"), out = tmp("rec.csv");
  {
    std::ofstream a(act);
    a << "alpha_1,alpha_2,beta_1,beta_2\n";
    for (int k = 0; k <= 12; ++k) a << "0," << k * 0.3 << ",-0.018,-0.018\n";
    for (int k = 11; k >= 0; --k) a << "0," << k * 0.3 << ",-0.018,-0.018\n";
  }
  fs::remove(out);
  const Proc r = run("simulate --robot " + robot("tube_pair_B.yaml") + " --actuation " + act.string() + " --out " +
                    out.string() + " --boundary-friction 0.1");
  ASSERT_EQ(r.code, 0) << r.err;
  ASSERT_TRUE(fs::exists(out));
  std::ifstream in(out);
  std::string header;
  std::getline(in, header);
  EXPECT_NE(header.find("twist_2"), std::string::npos);
  EXPECT_NE(header.find("tip_tz"), std::string::npos);
  // Bad actuation (inadmissible row): exit 2 and no output file.
  {
    std::ofstream a(act);
    a << "alpha_1,alpha_2,beta_1,beta_2\n0,0,-0.018,-0.018\n0,0,-0.010,0.0\n";
  }
  fs::remove(out);
  const Proc bad = run("simulate --robot " + robot("tube_pair_B.yaml") + " --actuation " + act.string() + " --out " +
                      out.string());
  EXPECT_EQ(bad.code, 2);
  EXPECT_NE(bad.err.find(act.string()), std::string::npos) << bad.err;
  EXPECT_FALSE(fs::exists(out));
}

namespace {

// Rows of a CSV with a header: the named columns as numbers (empty cells NaN).
std::vector<std::vector<double>> csvColumns(const fs::path& file, const std::vector<std::string>& names) {
  std::ifstream in(file);
  std::string line, cell;
  std::getline(in, line);
  std::vector<std::string> header;
  std::stringstream hs(line);
  while (std::getline(hs, cell, ',')) header.push_back(cell);
  std::vector<int> index;
  for (const std::string& n : names) {
    const auto it = std::find(header.begin(), header.end(), n);
    index.push_back(it == header.end() ? -1 : static_cast<int>(it - header.begin()));
  }
  std::vector<std::vector<double>> rows;
  while (std::getline(in, line)) {
    std::vector<std::string> cells;
    std::stringstream ss(line);
    while (std::getline(ss, cell, ',')) cells.push_back(cell);
    std::vector<double> row;
    for (int i : index)
      row.push_back(i >= 0 && i < static_cast<int>(cells.size()) && !cells[static_cast<std::size_t>(i)].empty()
                        ? std::stod(cells[static_cast<std::size_t>(i)])
                        : std::nan(""));
    rows.push_back(row);
  }
  return rows;
}

std::string list(const nlohmann::json& a) {
  std::string s;
  for (const auto& v : a) s += (s.empty() ? "" : ",") + nlohmann::json(v.get<double>()).dump();
  return s;
}

}  // namespace

TEST(Cli, IkJsonHasTheDocumentedKeysAndTheAnswerChecksOutWithFk) {
  const std::string R = robot("dupont_lab_3tube.yaml");
  const auto fk =
      nlohmann::json::parse(run("fk --robot " + R + " --alpha 0.3,0.9,-1.2 --beta -0.01,-0.02,-0.1 --json").out);
  const std::string target = list(fk["tip_position"]);
  const Proc r = run("ik --robot " + R + " --target " + target + " --json -");
  ASSERT_EQ(r.code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  for (const char* key : {"reached", "status", "alpha", "beta", "tip_error", "closest", "stable", "stability",
                          "branch_dependent", "iterations", "evaluations", "starts", "message", "robot"})
    EXPECT_TRUE(j.contains(key)) << key;
  EXPECT_TRUE(j["reached"].get<bool>());
  EXPECT_LE(j["tip_error"].get<double>(), 1e-5);
  // The answer, given to `ctr fk`, puts the tip on the target.
  const auto back = nlohmann::json::parse(
      run("fk --robot " + R + " --alpha " + list(j["alpha"]) + " --beta " + list(j["beta"]) + " --json").out);
  double d2 = 0.0;
  for (int i = 0; i < 3; ++i) {
    const double d = back["tip_position"][i].get<double>() - fk["tip_position"][i].get<double>();
    d2 += d * d;
  }
  EXPECT_LE(std::sqrt(d2), 1e-5 + 1e-9);
  // Text output without --json.
  const Proc t = run("ik --robot " + R + " --target " + target);
  EXPECT_EQ(t.code, 0) << t.err;
  EXPECT_NE(t.out.find("reached:   yes"), std::string::npos) << t.out;
}

TEST(Cli, IkUnreachableTargetExitsOneWithTheClosestPoint) {
  const fs::path out = tmp("ik_far.json");
  fs::remove(out);
  const Proc r =
      run("ik --robot " + robot("dupont_lab_3tube.yaml") + " --target 0,0,1 --restarts 2 --json " + out.string());
  EXPECT_EQ(r.code, 1) << r.err;
  EXPECT_NE(r.err.find("not reached"), std::string::npos) << r.err;
  std::ifstream in(out);
  const auto j = nlohmann::json::parse(in);
  EXPECT_FALSE(j["reached"].get<bool>());
  ASSERT_EQ(j["closest"].size(), 3u);
  EXPECT_GT(j["tip_error"].get<double>(), 0.5);
  EXPECT_GT(j["closest"][2].get<double>(), 0.2);  // the closest point is up the axis
}

TEST(Cli, IkFrictionPathCommandsReplayThroughSimulate) {
  // A 20-point arc of the 10 mm circle around the tip of the Dupont-lab robot, mu' = 0.1, reached from a positive
  // approach: the commands written by --out, replayed by `ctr simulate`, put the tip on the targets; the friction-blind
  // commands would not.
  const std::string R = robot("dupont_lab_3tube.yaml");
  const std::string from = " --from-alpha 0,0.5,-1 --from-beta 0,-0.017,-0.09";
  const auto fk = nlohmann::json::parse(run("fk --robot " + R + " --alpha 0,0.5,-1 --beta 0,-0.017,-0.09 --json").out);
  const fs::path targets = tmp("ik_arc.csv"), cmd = tmp("ik_cmd.csv"), js = tmp("ik_arc.json"), rec = tmp("ik_rec.csv");
  std::vector<std::array<double, 3>> pts;
  {
    std::ofstream t(targets);
    t << "tip_x,tip_y,tip_z,time\n";
    for (int k = 0; k < 20; ++k) {
      const double a = 2.0 * M_PI * k / 40.0;
      const std::array<double, 3> p = {fk["tip_position"][0].get<double>() - 0.005 + 0.005 * std::cos(a),
                                       fk["tip_position"][1].get<double>() + 0.005 * std::sin(a),
                                       fk["tip_position"][2].get<double>()};
      pts.push_back(p);
      t << nlohmann::json(p[0]).dump() << "," << nlohmann::json(p[1]).dump() << "," << nlohmann::json(p[2]).dump()
        << "," << 0.01 * k << "\n";
    }
  }
  for (const fs::path& f : {cmd, js, rec}) fs::remove(f);
  const Proc r = run("ik --robot " + R + from + " --boundary-friction 0.1 --history positive --targets " +
                     targets.string() + " --out " + cmd.string() + " --json " + js.string());
  ASSERT_EQ(r.code, 0) << r.err;
  std::ifstream in(js);
  const auto j = nlohmann::json::parse(in);
  EXPECT_TRUE(j["reached"].get<bool>());
  ASSERT_EQ(j["rows"].size(), 20u);
  EXPECT_EQ(j["friction"]["start_rows"].get<int>(), 2);  // the approach's start, the --from configuration
  EXPECT_GT(j["friction"]["blind_tip_error_rms"].get<double>(), 5.0 * j["tip_error_rms"].get<double>());
  EXPECT_TRUE(j["rows"][0]["friction"].contains("blind_tip_error"));
  // Replay the commands through the stateful model with `ctr simulate`.
  const Proc s =
      run("simulate --robot " + R + " --boundary-friction 0.1 --actuation " + cmd.string() + " --out " + rec.string());
  ASSERT_EQ(s.code, 0) << s.err;
  const auto tips = csvColumns(rec, {"tip_x", "tip_y", "tip_z", "time"});
  ASSERT_EQ(tips.size(), 22u);
  EXPECT_TRUE(std::isnan(tips[0][3]) && std::isnan(tips[1][3]));  // the start rows have no time
  for (std::size_t k = 0; k < pts.size(); ++k) {
    const auto& t = tips[k + 2];
    EXPECT_NEAR(t[3], 0.01 * k, 1e-12);
    EXPECT_LE(std::hypot(t[0] - pts[k][0], t[1] - pts[k][1], t[2] - pts[k][2]), 1e-5 + 1e-9) << k;
  }
}

// Admissibility tolerance (docs/formats.md): a configuration whose inner tube ends where the outer tube ends, with
// the values rounded as in a log (1e-10 m off), is projected; a 1 mm violation is still an input error (exit 2).
TEST(Cli, FkProjectsRoundedCoincidentEndsAndRefusesLargerViolations) {
  const std::string base = "fk --robot " + robot("tube_pair_B.yaml") + " --alpha 0,1 --json --beta ";
  const Proc exact = run(base + "-0.018,-0.018");
  ASSERT_EQ(exact.code, 0) << exact.err;
  const Proc rounded = run(base + "-0.018,-0.0180000001");
  ASSERT_EQ(rounded.code, 0) << rounded.err;
  EXPECT_EQ(rounded.out, exact.out);  // projected onto coincident ends: the very same configuration
  const Proc mm = run(base + "-0.018,-0.019");
  EXPECT_EQ(mm.code, 2);
  EXPECT_NE(mm.err.find("--beta"), std::string::npos) << mm.err;
  EXPECT_NE(mm.err.find("not admissible"), std::string::npos) << mm.err;
  EXPECT_NE(mm.err.find("distal end of tube 2"), std::string::npos) << mm.err;
  EXPECT_TRUE(mm.out.empty()) << mm.out;
  // A 3-tube robot (ends coincide at beta = -0.10, -0.16, -0.21), and beta_1 slightly above 0 in sweep.
  const std::string heart = "fk --robot " + robot("proc_intracardiac.yaml") + " --json --beta ";
  const Proc h = run(heart + "-0.10,-0.16,-0.21");
  ASSERT_EQ(h.code, 0) << h.err;
  const Proc hr = run(heart + "-0.1,-0.1600000001,-0.2100000004");
  ASSERT_EQ(hr.code, 0) << hr.err;
  const auto jh = nlohmann::json::parse(h.out), jhr = nlohmann::json::parse(hr.out);
  for (int d = 0; d < 3; ++d)
    EXPECT_NEAR(jhr["tip_position"][d].get<double>(), jh["tip_position"][d].get<double>(), 1e-9);
  const Proc sweep = run("sweep --robot " + robot("tube_pair_B.yaml") +
                         " --tube 2 --from 0 --to 0.2 --step 0.1 --beta 0.0000003,0.0000003");
  EXPECT_EQ(sweep.code, 0) << sweep.err;
  // First data row: alpha_1,alpha_2,beta_1,beta_2,... with the translations projected to 0.
  const std::string row = sweep.out.substr(sweep.out.find('\n') + 1);
  EXPECT_EQ(row.rfind("0,0,0,0,", 0), 0u) << sweep.out;
  const Proc sweep_bad = run("sweep --robot " + robot("tube_pair_B.yaml") +
                             " --tube 2 --from 0 --to 0.2 --step 0.1 --beta 0.001,0.001");
  EXPECT_EQ(sweep_bad.code, 2);
  EXPECT_NE(sweep_bad.err.find("--beta"), std::string::npos) << sweep_bad.err;
  EXPECT_NE(sweep_bad.err.find("beta_1"), std::string::npos) << sweep_bad.err;
}

TEST(Cli, SimulateProjectsRoundedRowsAndNamesARowBeyondTheTolerance) {
  const fs::path act = tmp("act_rounded.csv"), out = tmp("rec_rounded.csv"), ref = tmp("rec_exact.csv");
  auto write = [&](const std::string& beta_2) {
    std::ofstream a(act);
    a << "alpha_1,alpha_2,beta_1,beta_2\n# logged with rounded translations\n";
    for (int k = 0; k <= 4; ++k) a << "0," << k * 0.3 << ",-0.018," << (k == 2 ? beta_2 : "-0.018") << "\n";
  };
  const std::string cmd = "simulate --robot " + robot("tube_pair_B.yaml") + " --boundary-friction 0.1 --actuation " +
                          act.string() + " --out ";
  write("-0.018");
  fs::remove(ref);
  const Proc exact = run(cmd + ref.string());
  ASSERT_EQ(exact.code, 0) << exact.err;
  write("-0.0180000001");  // row 3: the inner end 1e-10 m behind the outer end
  fs::remove(out);
  const Proc rounded = run(cmd + out.string());
  ASSERT_EQ(rounded.code, 0) << rounded.err;
  auto text = [](const fs::path& f) {
    std::ifstream in(f);
    std::stringstream ss;
    ss << in.rdbuf();
    return ss.str();
  };
  EXPECT_EQ(text(out), text(ref));  // the row was projected onto coincident ends
  write("-0.019");  // row 3 (line 5: header, comment, rows 1-2 before it) 1 mm behind
  fs::remove(out);
  const Proc bad = run(cmd + out.string());
  EXPECT_EQ(bad.code, 2);
  EXPECT_NE(bad.err.find(act.string() + ":5"), std::string::npos) << bad.err;
  EXPECT_NE(bad.err.find("row 3 is not admissible"), std::string::npos) << bad.err;
  EXPECT_NE(bad.err.find("distal end of tube 2"), std::string::npos) << bad.err;
  EXPECT_FALSE(fs::exists(out));
}

TEST(Cli, DemoPaperSweep) {
  const Proc r = run("demo --paper");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("Tube pair B"), std::string::npos);
  EXPECT_NE(r.out.find("180"), std::string::npos);
}

#ifdef CTR_TEST_PLANNER
TEST(Cli, BenchWritesOmplLogAndReplaySummary) {
  const fs::path out = tmp("bench");
  fs::remove_all(out);
  const Proc r = run("bench " + std::string(CTR_SOURCE_DIR) +
                     "/examples/queries/proc_intracardiac.yaml --planners kpiece --runs 1 --time 5 --out " + out.string());
  ASSERT_EQ(r.code, 0) << r.err;
  ASSERT_TRUE(fs::exists(out / "summary.json"));
  ASSERT_TRUE(fs::exists(out / "proc_intracardiac_exact.log"));
  std::ifstream in(out / "summary.json");
  const auto j = nlohmann::json::parse(in);
  ASSERT_EQ(j.size(), 1u);
  EXPECT_EQ(j[0]["planner"], "KPIECE1");
  EXPECT_EQ(j[0]["runs"], 1);
  EXPECT_EQ(j[0]["replay_failures"], 0);
  const Proc bad = run("bench " + std::string(CTR_SOURCE_DIR) +
                       "/examples/queries/proc_intracardiac.yaml --planners astar --runs 1 --time 1 --out " + out.string());
  EXPECT_EQ(bad.code, 2);
  EXPECT_NE(bad.err.find("astar"), std::string::npos) << bad.err;
}

TEST(Cli, BenchFillsTheGoalPoolForSampleableGoalPlanners) {
  // RRTConnect grows a tree from sampled goals: `ctr bench` must fill the tip goal's pool before the runs (it did
  // not, and RRTConnect found "insufficient states in sampleable goal region"). Robust mode via --mode.
  const fs::path out = tmp("bench_robust");
  fs::remove_all(out);
  const Proc r = run("bench " + std::string(CTR_SOURCE_DIR) +
                     "/examples/queries/proc_intracardiac.yaml --mode robust --planners rrtconnect --runs 1 --time 20 "
                     "--out " + out.string());
  ASSERT_EQ(r.code, 0) << r.err;
  ASSERT_TRUE(fs::exists(out / "proc_intracardiac_robust.log"));
  std::ifstream in(out / "summary.json");
  const auto j = nlohmann::json::parse(in);
  ASSERT_EQ(j.size(), 1u);
  EXPECT_EQ(j[0]["planner"], "RRTConnect");
  EXPECT_EQ(j[0]["mode"], "robust");
  EXPECT_EQ(j[0]["planner_success_rate"], 1.0);
  EXPECT_EQ(j[0]["replay_failures"], 0);
}

TEST(Cli, DemoPlansTheEmbeddedDefaultAndWritesThePath) {
  const fs::path f = tmp("demo_path.csv");
  fs::remove(f);
  const Proc r = run("demo --path " + f.string());
  ASSERT_EQ(r.code, 0) << r.out << r.err;
  EXPECT_NE(r.out.find("\"solved\": true"), std::string::npos) << r.out;
  ASSERT_TRUE(fs::exists(f));
  std::ifstream in(f);
  std::string header;
  std::getline(in, header);
  EXPECT_EQ(header.rfind("alpha_1,alpha_2,alpha_3,beta_1,beta_2,beta_3,twist_2,twist_3,tip_x", 0), 0u) << header;
  EXPECT_NE(header.find("_mode"), std::string::npos);
}
#endif

namespace {

// The options of one --help text: name -> the type CLI11 prints after it, without its check (":NONNEGATIVE") and
// default ("=-"); "" for a flag.
std::map<std::string, std::string> helpOptions(const std::string& help) {
  std::map<std::string, std::string> out;
  std::istringstream in(help);
  std::string line;
  const std::regex option(R"(^\s+(?:-\w,)?(--[\w-]+)(?: (\S+))?)");
  while (std::getline(in, line)) {
    std::smatch m;
    if (std::regex_search(line, m, option))
      out[m[1]] = m[2].matched ? m[2].str().substr(0, m[2].str().find_first_of(":=")) : "";
  }
  return out;
}

// The subcommands a --help text lists.
std::vector<std::string> helpSubcommands(const std::string& help) {
  std::vector<std::string> out;
  std::istringstream in(help);
  std::string line;
  bool in_list = false;
  while (std::getline(in, line)) {
    if (line.rfind("Subcommands:", 0) == 0) {
      in_list = true;
      continue;
    }
    if (in_list && line.size() > 2 && line[0] == ' ' && line[1] == ' ' && line[2] != ' ') {
      std::istringstream w(line);
      std::string name;
      w >> name;
      out.push_back(name);
    } else if (in_list && !line.empty() && line[0] != ' ') {
      in_list = false;
    }
  }
  return out;
}

}  // namespace

TEST(Cli, EveryOutputOptionMeansTheSameInEverySubcommand) {
  // Every subcommand, walked through --help: --json [FILE|-] (a file, or standard output with - or no value),
  // --csv FILE|- (standard output with -), --html a FILE ([FILE] with a default), --out a FILE or a DIR, --seed and
  // --threads an INT, --quiet a flag.
  std::vector<std::string> todo{""};
  int walked = 0, json = 0;
  while (!todo.empty()) {
    const std::string cmd = todo.back();
    todo.pop_back();
    const Proc r = run(cmd + " --help");
    ASSERT_EQ(r.code, 0) << "ctr" << cmd << " --help: " << r.err;
    ++walked;
    for (const std::string& s : helpSubcommands(r.out)) todo.push_back(cmd + " " + s);
    for (const auto& [name, type] : helpOptions(r.out)) {
      SCOPED_TRACE("ctr" + cmd + " " + name + " " + type);
      if (name == "--json") {
        ++json;
        EXPECT_EQ(type, "[FILE|-]");
      } else if (name == "--csv") {
        EXPECT_EQ(type, "FILE|-");
      } else if (name == "--html") {
        EXPECT_TRUE(type == "FILE" || type == "[FILE]");
      } else if (name == "--out") {
        EXPECT_TRUE(type == "FILE" || type == "DIR");
      } else if (name == "--seed" || name == "--threads") {
        EXPECT_EQ(type, "INT");
      } else if (name == "--quiet") {
        EXPECT_EQ(type, "");
      }
    }
  }
  EXPECT_GE(walked, 17);  // ctr, 12 subcommands, env info/build/check, recording import/inject, bench/design merge
  EXPECT_EQ(json, 6);     // fk, ik, env info, env check, diagnose, plan
}

TEST(Cli, JsonGoesToAFileOrToStandardOutput) {
  const std::string fk = "fk --robot " + robot("tube_pair_B.yaml") + " --alpha 0,90deg --beta -0.018,-0.018";
  const Proc bare = run(fk + " --json");
  const Proc dash = run(fk + " --json -");
  ASSERT_EQ(bare.code, 0) << bare.err;
  ASSERT_EQ(dash.code, 0) << dash.err;
  EXPECT_EQ(bare.out, dash.out);
  EXPECT_TRUE(nlohmann::json::parse(dash.out).is_object());
  const fs::path file = tmp("fk.json");
  fs::remove(file);
  const Proc to_file = run(fk + " --json " + file.string());
  ASSERT_EQ(to_file.code, 0) << to_file.err;
  std::ifstream in(file);
  std::stringstream text;
  text << in.rdbuf();
  EXPECT_EQ(text.str(), dash.out);                      // the same object in the file
  EXPECT_EQ(to_file.out.find('{'), std::string::npos);  // and the words on standard output
  EXPECT_NE(to_file.out.find("tip"), std::string::npos) << to_file.out;
  // The robot file is an input: refused as a --json target, nothing written.
  const Proc clobber = run(fk + " --json " + robot("tube_pair_B.yaml"));
  EXPECT_EQ(clobber.code, 2);
}

TEST(Cli, AnHtmlValueThatIsNotAnHtmlFileIsRefusedNotOverwritten) {
  // `ctr design --html [FILE]` takes an optional value: a query written right after it would be taken for the report.
  // It is refused (exit 2) and left as it was.
  const fs::path q1 = tmp("q1.yaml"), q2 = tmp("q2.yaml");
  for (const fs::path& q : {q1, q2})
    fs::copy_file(std::string(CTR_SOURCE_DIR) + "/examples/queries/proc_intracardiac.yaml", q,
                  fs::copy_options::overwrite_existing);
  const auto before = fs::file_size(q1);
  const Proc r = run("design --html " + q1.string() + " " + q2.string() + " --out " + tmp("design_out").string());
  EXPECT_EQ(r.code, 2) << r.err;
  EXPECT_EQ(fs::file_size(q1), before);
  EXPECT_FALSE(fs::exists(tmp("design_out")));
}
