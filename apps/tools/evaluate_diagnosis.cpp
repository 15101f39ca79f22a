// Evaluation of `ctr diagnose` on concealed cases built with the injection path: random actuation order, noise as
// large as the effect in single samples, position-only recordings in an unknown frame, 3-tube robots with
// translations, two effects at once, sensor latency, null cases. Prints a per-case table and a confusion table
// (Markdown). Build target: ctr_evaluate_diagnosis.
// Usage: ctr_evaluate_diagnosis [--quick] [--verbose] [--calibrate] [--out FILE.md]
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <map>
#include <set>
#include <sstream>

#include "ctr/diagnosis/diagnose.hpp"
#include "ctr/diagnosis/simulate.hpp"
#include "ctr/io/robot_yaml.hpp"

using namespace ctr;
using namespace ctr::diagnosis;

namespace {

struct Case {
  std::string name, robot;
  std::vector<Effect> effects;
  ActuationPattern pattern = ActuationPattern::Sweep;
  int rows = 73;
  bool translate = false, timed = false;
  double noise = 1.0;          // multiple of the public-case noise (0.5 deg, 0.1 mm, 0.2 deg)
  bool position_only = false;  // tips only, in an unknown sensor frame
  unsigned seed = 1;
};

std::string label(const std::vector<std::string>& v) {
  if (v.empty()) return "none";
  std::vector<std::string> s = v;
  std::sort(s.begin(), s.end());
  s.erase(std::unique(s.begin(), s.end()), s.end());
  std::string out;
  for (const auto& x : s) out += (out.empty() ? "" : "+") + x;
  return out;
}

std::vector<Case> cases(bool quick) {
  const double deg = M_PI / 180;
  std::vector<Case> c;
  auto add = [&](Case k) { c.push_back(k); };
  // name, robot, effects, pattern, rows, translate, timed, noise, position_only, seed
  add({"null_sweep_A", "tube_pair_A", {}, ActuationPattern::Sweep, 73, false, false, 1, false, 1});
  add({"null_random_B_noisy", "tube_pair_B", {}, ActuationPattern::Random, 60, false, false, 4, false, 2});
  add({"null_walk_3tube_timed", "three_tube_generic", {}, ActuationPattern::RandomWalk, 120, true, true, 1, false, 3});
  add({"null_walk_B_posonly", "tube_pair_B", {}, ActuationPattern::RandomWalk, 120, false, false, 2, true, 4});
  add({"friction_sweep_A", "tube_pair_A", {{EffectKind::BoundaryFriction, 0, 0.08}}, ActuationPattern::Sweep, 73, false, false, 1, false, 5});
  add({"friction_random_B_noisy", "tube_pair_B", {{EffectKind::BoundaryFriction, 0, 0.06}}, ActuationPattern::Random, 45, false, false, 4, false, 6});
  add({"friction_walk_B_posonly", "tube_pair_B", {{EffectKind::BoundaryFriction, 0, 0.1}}, ActuationPattern::RandomWalk, 120, false, false, 2, true, 7});
  add({"poisson_sweep_A", "tube_pair_A", {{EffectKind::TorsionalStiffness, 0, 0.3}}, ActuationPattern::Sweep, 73, false, false, 3, false, 8});
  add({"precurv_walk_3tube", "three_tube_generic", {{EffectKind::Precurvature, 3, 14.0}}, ActuationPattern::RandomWalk, 120, true, false, 2, false, 9});
  add({"bending_sweep_B", "tube_pair_B", {{EffectKind::BendingStiffness, 2, 0.075}}, ActuationPattern::Sweep, 73, false, false, 1, false, 10});
  add({"backlash_walk_A_noisy", "tube_pair_A", {{EffectKind::ActuatorBacklash, 2, 8 * deg}}, ActuationPattern::RandomWalk, 120, false, false, 4, false, 11});
  add({"offset_walk_3tube_posonly", "three_tube_generic", {{EffectKind::ActuatorOffset, 2, 10 * deg}}, ActuationPattern::RandomWalk, 120, true, false, 2, true, 12});
  add({"latency_walk_A", "tube_pair_A", {{EffectKind::SensorLatency, 0, 0.3}}, ActuationPattern::RandomWalk, 120, false, true, 2, false, 13});
  add({"friction+poisson_sweep_B", "tube_pair_B", {{EffectKind::BoundaryFriction, 0, 0.06}, {EffectKind::TorsionalStiffness, 0, 0.3}}, ActuationPattern::Sweep, 73, false, false, 1, false, 14});
  add({"offset+backlash_walk_B", "tube_pair_B", {{EffectKind::ActuatorOffset, 2, 6 * deg}, {EffectKind::ActuatorBacklash, 2, 10 * deg}}, ActuationPattern::RandomWalk, 120, false, false, 2, false, 15});
  if (!quick) {
    add({"null_sweep_B_posonly", "tube_pair_B", {}, ActuationPattern::Sweep, 73, false, false, 1, true, 16});
    add({"null_random_3tube", "three_tube_generic", {}, ActuationPattern::Random, 80, true, false, 2, false, 17});
    add({"friction_walk_3tube_timed", "three_tube_generic", {{EffectKind::BoundaryFriction, 0, 0.1}}, ActuationPattern::RandomWalk, 120, true, true, 1, false, 18});
    add({"poisson_random_B_noisy", "tube_pair_B", {{EffectKind::TorsionalStiffness, 0, 0.2}}, ActuationPattern::Random, 80, false, false, 4, false, 19});
    add({"precurv_sweep_A", "tube_pair_A", {{EffectKind::Precurvature, 1, 5.0}}, ActuationPattern::Sweep, 73, false, false, 1, false, 20});
    add({"backlash_sweep_B_posonly", "tube_pair_B", {{EffectKind::ActuatorBacklash, 2, 12 * deg}}, ActuationPattern::Sweep, 73, false, false, 1, true, 21});
    add({"offset_random_A_noisy", "tube_pair_A", {{EffectKind::ActuatorOffset, 2, 8 * deg}}, ActuationPattern::Random, 80, false, false, 4, false, 22});
    add({"latency_walk_3tube_posonly", "three_tube_generic", {{EffectKind::SensorLatency, 0, 0.2}}, ActuationPattern::RandomWalk, 150, true, true, 1, true, 23});
    add({"latency+friction_walk_B", "tube_pair_B", {{EffectKind::SensorLatency, 0, 0.3}, {EffectKind::BoundaryFriction, 0, 0.05}}, ActuationPattern::RandomWalk, 120, false, true, 1, false, 24});
    add({"toffset_walk_3tube", "three_tube_generic", {{EffectKind::TranslationOffset, 3, 0.004}}, ActuationPattern::RandomWalk, 120, true, false, 2, false, 25});
    add({"tbacklash_walk_3tube_posonly", "three_tube_generic", {{EffectKind::TranslationBacklash, 3, 0.003}}, ActuationPattern::RandomWalk, 150, true, false, 1, true, 26});
    // External loads: the descriptions have no density and no load; gravity weighs nitinol tubes. The
    // Dupont-lab robot sags 0.1-0.2 mm under its weight (three_tube_generic: 4 um, invisible at any noise here).
    add({"gravity_walk_dupont", "dupont_lab_3tube", {parseEffect("gravity:scale=1,direction=0,-1,0")}, ActuationPattern::RandomWalk, 150, true, false, 1, false, 27});
    add({"gravity_random_dupont_noisy", "dupont_lab_3tube", {parseEffect("gravity:scale=1,direction=1,0,0")}, ActuationPattern::Random, 100, true, false, 2, false, 28});
    add({"tipload_random_B_noisy", "tube_pair_B", {parseEffect("tip_load:force=0.02,-0.03,0.01")}, ActuationPattern::Random, 80, false, false, 4, false, 29});
    add({"tipload+offset_walk_dupont", "dupont_lab_3tube", {parseEffect("tip_load:force=-0.02,0.02,0"), {EffectKind::ActuatorOffset, 2, 6 * deg}}, ActuationPattern::RandomWalk, 120, true, false, 2, false, 30});
  }
  return c;
}

}  // namespace

int main(int argc, char** argv) {
  bool quick = false, verbose = false, calibrate = false;
  int max_effects = DiagnoseOptions{}.max_effects;
  std::string out, only, robots = std::string(CTR_SOURCE_DIR_EVAL) + "/examples/robots";
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--quick") quick = true;
    else if (a == "--verbose") verbose = true;
    else if (a == "--calibrate") calibrate = true;
    else if (a == "--max-effects" && i + 1 < argc) max_effects = std::atoi(argv[++i]);
    else if (a == "--out" && i + 1 < argc) out = argv[++i];
    else if (a == "--only" && i + 1 < argc) only = argv[++i];
    else if (a == "--robots" && i + 1 < argc) robots = argv[++i];
    else {
      std::cerr << "usage: ctr_evaluate_diagnosis [--quick] [--verbose] [--calibrate] [--max-effects N] [--out FILE.md] "
                   "[--only NAME_SUBSTRING] [--robots DIR]\n";
      return 2;
    }
  }
  const std::string dir = robots + "/";
  std::ostringstream table;
  table << "| case | truth | verdict | parameters (true -> fitted) | held-out RMSE before -> after | s | ok |\n"
        << "|---|---|---|---|---|---|---|\n";
  std::map<std::string, std::map<std::string, int>> confusion;  // truth label -> verdict label -> count
  std::map<std::string, std::array<int, 3>> per_effect;          // kind -> {true positives, misses, false positives}
  int correct = 0, total = 0, params_ok = 0, params_total = 0, ambiguous_with_truth = 0;
  for (const Case& k : cases(quick)) {
    if (!only.empty() && k.name.find(only) == std::string::npos) continue;
    const Robot robot = io::loadRobot(dir + k.robot + ".yaml");
    ActuationOptions a;
    a.pattern = k.pattern;
    a.rows = k.rows;
    a.translate = k.translate;
    a.dt = k.timed ? 0.1 : 0.0;
    a.seed = k.seed;
    std::vector<Configuration> cmd;
    Eigen::VectorXd time;
    makeActuation(robot, a, cmd, time);
    SimulationOptions s;
    s.twist_sd *= k.noise;
    s.position_sd *= k.noise;
    s.tangent_sd *= k.noise;
    s.seed = k.seed + 100;
    DiagnoseOptions o;
    o.max_effects = max_effects;
    o.calibrate_description = calibrate;
    if (verbose) o.progress = [](const DiagnoseProgress& p) { std::cerr << "  " << p.message << "\n"; };
    if (k.position_only) {
      s.twist = s.tip_tangent = false;
      Registration reg;
      reg.rotation = Eigen::AngleAxisd(0.8, Eigen::Vector3d(1, -2, 0.5).normalized()).toRotationMatrix();
      reg.translation = Eigen::Vector3d(0.03, -0.08, 0.2);
      reg.tip_offset = 0.003;
      s.sensor_frame = reg;
      o.frame = FrameMode::Unknown;
    }
    const auto t0 = std::chrono::steady_clock::now();
    io::Recording rec;
    try {
      rec = simulateRecording(robot, cmd, time, k.effects, s);
    } catch (const std::exception& e) {
      std::cerr << k.name << ": simulation failed: " << e.what() << "\n";
      continue;
    }
    const DiagnosisReport rep = diagnose(robot, rec, o);
    const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (verbose) {
      std::cerr << "---- " << k.name << "\n" << rep.summary << "\n";
      for (const Finding& f : rep.findings)
        std::cerr << "  round " << f.round << (f.accepted ? " accepted " : " rejected ") << f.effect.label() << " ("
                  << f.effect.valueText() << ") dBIC " << f.delta_bic << " held-out p " << f.heldout_p << "\n";
    }
    std::vector<std::string> truth;
    for (const Effect& e : k.effects) truth.push_back(toString(e.kind));
    const std::string tl = label(truth), vl = label(rep.verdict);
    const bool ok = tl == vl;
    // Not exact but honest: every verdict entry ("X or Y": the recording cannot tell) contains a true effect and
    // every true effect is in an entry.
    bool covers = !ok && !rep.verdict.empty();
    std::set<std::string> covered;
    for (const std::string& entry : rep.verdict) {
      bool has_truth = false;
      std::size_t from = 0;
      while (true) {
        const std::size_t at = entry.find(" or ", from);
        const std::string alt = entry.substr(from, at == std::string::npos ? std::string::npos : at - from);
        if (std::find(truth.begin(), truth.end(), alt) != truth.end()) {
          has_truth = true;
          covered.insert(alt);
        }
        if (at == std::string::npos) break;
        from = at + 4;
      }
      covers = covers && has_truth;
    }
    covers = covers && covered.size() == std::set<std::string>(truth.begin(), truth.end()).size();
    ++total;
    correct += ok;
    ambiguous_with_truth += covers;
    confusion[tl][vl]++;
    std::set<std::string> ts(truth.begin(), truth.end()), vs(rep.verdict.begin(), rep.verdict.end());
    for (const auto& t : ts) per_effect[t][vs.count(t) ? 0 : 1]++;
    for (const auto& v : vs)
      if (!ts.count(v)) per_effect[v][2]++;
    std::ostringstream par;
    for (const Effect& e : k.effects) {
      for (const Effect& f : rep.final_effects)
        if (f.kind == e.kind && (!isPerTube(e.kind) || f.tube == e.tube)) {
          // Vector kinds (tip_load, gravity): the fitted vector within 20 % of the true one's length.
          const bool vector = parameterCount(e.kind) == 3;
          const bool good = vector ? (f.vec - e.vec).norm() <= 0.2 * e.vec.norm()
                                   : std::abs(f.value - e.value) <= 0.2 * std::abs(e.value);
          params_total++;
          params_ok += good;
          char b[240];
          if (vector)
            std::snprintf(b, sizeof b, "%s -> %s%s; ", e.valueText().c_str(), f.valueText().c_str(), good ? "" : " (off)");
          else
            std::snprintf(b, sizeof b, "%s %.4g -> %.4g%s; ", parameterName(e.kind), e.value, f.value,
                          good ? "" : " (off)");
          par << b;
        }
    }
    std::ostringstream ho;
    for (const auto& kv : rep.baseline.heldout_rmse) {
      const double after = rep.final.heldout_rmse.count(kv.first) ? rep.final.heldout_rmse.at(kv.first) : kv.second;
      char b[160];
      std::snprintf(b, sizeof b, "%s %.3g -> %.3g; ", kv.first.c_str(), kv.second, after);
      ho << b;
    }
    char sec[32];
    std::snprintf(sec, sizeof sec, "%.1f", secs);
    table << "| " << k.name << " | " << tl << " | " << vl << " | " << par.str() << " | " << ho.str() << " | " << sec
          << " | " << (ok ? "yes" : covers ? "ambiguous, truth included" : "**no**") << " |\n";
    std::cerr << k.name << ": truth " << tl << ", verdict " << vl << (ok ? "  OK" : covers ? "  AMBIGUOUS" : "  WRONG")
              << " (" << sec << " s)\n";
  }
  std::ostringstream md;
  md << "## Concealed-case evaluation (" << (quick ? "quick" : "full") << ")\n\n" << table.str() << "\n";
  md << "Verdict exactly right: " << correct << " / " << total << "; ambiguous with the truth among the alternatives: "
     << ambiguous_with_truth << "; wrong: " << total - correct - ambiguous_with_truth << "; parameters within 20 %: "
     << params_ok << " / " << params_total << ".\n\n### Confusion table (rows: truth, columns: verdict)\n\n";
  std::set<std::string> cols;
  for (const auto& r : confusion)
    for (const auto& c : r.second) cols.insert(c.first);
  md << "| truth \\ verdict |";
  for (const auto& c : cols) md << " " << c << " |";
  md << "\n|---|";
  for (std::size_t i = 0; i < cols.size(); ++i) md << "---|";
  md << "\n";
  for (const auto& r : confusion) {
    md << "| " << r.first << " |";
    for (const auto& c : cols) md << " " << (r.second.count(c) ? std::to_string(r.second.at(c)) : "") << " |";
    md << "\n";
  }
  md << "\n### Per effect\n\n| effect | detected | missed | false positives |\n|---|---|---|---|\n";
  for (const auto& kv : per_effect)
    md << "| " << kv.first << " | " << kv.second[0] << " | " << kv.second[1] << " | " << kv.second[2] << " |\n";
  std::cout << md.str();
  if (!out.empty()) std::ofstream(out) << md.str();
  return 0;
}
