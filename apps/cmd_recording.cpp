// `ctr recording import|inject`: convert lab recordings; build recordings with injected effects and noise.
#include <iostream>
#include <random>
#include <sstream>

#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "ctr/diagnosis/import.hpp"
#include "ctr/diagnosis/simulate.hpp"
#include "ctr/io/file.hpp"
#include "ctr/io/recording.hpp"
#include "ctr/io/robot_yaml.hpp"
#include "ctr/model/replay.hpp"

namespace ctr::cli {

namespace {

void registerImport(CLI::App* parent, Action& action) {
  struct Opts {
    std::string format = "table", input, out, unwrap, delimiter;
    std::vector<std::string> columns;
    int tubes = 0, skip_rows = 0;
  };
  auto o = std::make_shared<Opts>();
  CLI::App* sub = parent->add_subcommand(
      "import",
      "Convert a lab table (whitespace/comma columns) into a docs/formats.md recording: column mapping, unit "
      "scaling, sign flips, angle unwrapping");
  sub->add_option("--format", o->format, "dupont-lab (hjhdog1/ConcentricTubes jointTipTrajectory) or table")
      ->check(CLI::IsMember({"dupont-lab", "table"}));
  sub->add_option("--input", o->input, "Source table")->required();
  sub->add_option("--out", o->out, "Recording CSV to write")->required()->type_name("FILE");
  sub->add_option("--column", o->columns,
                  "NAME=COLUMN[*SCALE][+OFFSET] (1-based column; e.g. beta_1=5*0.001, tip_tx=11*-1); repeatable; "
                  "overrides the preset");
  sub->add_option("--unwrap", o->unwrap, "Comma-separated columns holding wrapped angles (e.g. alpha_1,alpha_2)");
  sub->add_option("--tubes", o->tubes, "Number of tubes (default: from the alpha_* mappings)");
  sub->add_option("--skip-rows", o->skip_rows, "Header lines to skip");
  sub->add_option("--delimiter", o->delimiter, "Column delimiter (default: whitespace or comma, detected)");
  sub->callback([o, &action]() {
    action = [o]() {
      checkOutputPath("--out", o->out, {{"--input", o->input}});
      diagnosis::ImportOptions io =
          o->format == "dupont-lab" ? diagnosis::dupontLabImportOptions() : diagnosis::ImportOptions{};
      for (const auto& c : o->columns) {
        try {
          io.columns[diagnosis::parseColumnMapping(c).first] = diagnosis::parseColumnMapping(c).second;
        } catch (const std::invalid_argument& e) {
          throw UsageError(std::string("--column: ") + e.what());
        }
      }
      if (!o->unwrap.empty()) {
        io.unwrap.clear();
        std::stringstream ss(o->unwrap);
        std::string item;
        while (std::getline(ss, item, ',')) io.unwrap.push_back(item);
      }
      if (o->tubes > 0) io.tubes = o->tubes;
      io.skip_rows = o->skip_rows;
      io.delimiter = o->delimiter;
      if (io.columns.empty()) throw UsageError("no column mapping: use --format dupont-lab or --column NAME=COLUMN");
      const io::Recording rec = diagnosis::importTable(o->input, io);
      for (const auto& w : rec.warnings) std::cerr << "warning: " << w << "\n";
      io::saveRecording(rec, o->out);
      std::cerr << "imported " << rec.rows() << " rows, " << rec.tubes << " tubes -> " << o->out << "\n";
      return kOk;
    };
  });
}

void registerInject(CLI::App* parent, Action& action) {
  struct Opts {
    std::string robot, actuation, pattern = "sweep", out, truth, measure = "twist,tip_position,tip_tangent";
    std::vector<std::string> effects;
    std::string noise_twist = "0.5deg", noise_tangent = "0.2deg", repeat_tangent = "0",
                branch = toString(BranchRule::Path);
    double noise_position = 1e-4, dt = 0.1, step_deg = 10, max_speed = 1.0, returns = 0.0, repeat_position = 0.0;
    int rows = 150, frames = 1;
    bool translate = false, sensor_frame = false;
    unsigned long long seed = 1;
  };
  auto o = std::make_shared<Opts>();
  CLI::App* sub = parent->add_subcommand(
      "inject", "Simulate a recording with effects injected (same forward model the diagnosis fits) plus noise");
  sub->add_option("--robot", o->robot, "Nominal robot description YAML")->required();
  sub->add_option("--actuation", o->actuation, "Actuation CSV (alpha_*, beta_*, optional time); default: --pattern");
  sub->add_option("--pattern", o->pattern,
                  "Generated actuation: sweep (paper protocol), random (random order), random-walk")
      ->check(
          CLI::IsMember({toString(diagnosis::ActuationPattern::Sweep), toString(diagnosis::ActuationPattern::Random),
                         toString(diagnosis::ActuationPattern::RandomWalk)}));
  sub->add_option("--rows", o->rows, "Rows of random / random-walk patterns");
  sub->add_option("--step-deg", o->step_deg, "Sweep step (deg)");
  sub->add_option("--dt", o->dt, "Time step of the generated time column (s); 0 = no time column");
  sub->add_option("--max-speed", o->max_speed, "Random-walk rotation speed (rad/s)");
  sub->add_flag("--translate", o->translate, "Also vary the innermost tube's translation");
  sub->add_option("--returns", o->returns, "Random pattern: fraction of poses that return to an earlier pose")
      ->check(CLI::Range(0.0, 0.9));
  sub->add_option("--frames", o->frames, "Log every pose this many times in a row (a tracker's repeated frames)")
      ->check(CLI::Range(1, 1000));
  sub->add_option(
         "--branch", o->branch,
         "How the robot reaches each row: path (default: straight from the previous row), rest (from rest); as "
         "`ctr simulate --branch`")
      ->check(branchRuleValidator());
  sub->add_option("--effect", o->effects,
                  "Effect to inject, e.g. boundary_friction:mu=0.12, "
                  "actuator_backlash:tube=2,width=12deg, tip_load:force=0.05,0,-0.1 (N, base "
                  "frame) or gravity:scale=1,direction=0,-1,0 (repeatable; loads are "
                  "simulated with the loaded model)");
  sub->add_option("--noise-twist", o->noise_twist, "Twist noise sd (rad or deg suffix)");
  sub->add_option("--noise-position", o->noise_position, "Tip position noise sd per component (m)");
  sub->add_option("--noise-tangent", o->noise_tangent, "Tangent noise sd per component (rad or deg suffix)");
  sub->add_option("--repeatability-position", o->repeat_position,
                  "Tip position error drawn once per visit of a pose, per component (m): a robot that does not return "
                  "exactly; the --noise-* values are then the frame-to-frame jitter");
  sub->add_option("--repeatability-tangent", o->repeat_tangent,
                  "Tangent error drawn once per visit, per component (rad or deg suffix)");
  sub->add_option("--measure", o->measure, "Recorded quantities: comma list of twist, tip_position, tip_tangent");
  sub->add_flag("--sensor-frame", o->sensor_frame, "Express tips in a random rigid sensor frame (for --frame unknown)");
  sub->add_option("--seed", o->seed, "Random seed")->check(CLI::NonNegativeNumber)->type_name("INT");
  sub->add_option("--out", o->out, "Recording CSV to write")->required()->type_name("FILE");
  sub->add_option("--truth", o->truth, "Truth JSON to write (verdict + parameters)");
  sub->callback([o, &action]() {
    action = [o]() {
      checkOutputPath("--out", o->out, {{"--robot", o->robot}, {"--actuation", o->actuation}});
      checkOutputPath("--truth", o->truth, {{"--robot", o->robot}, {"--actuation", o->actuation}, {"--out", o->out}});
      const Robot robot = io::loadRobot(o->robot);
      std::vector<diagnosis::Effect> effects;
      for (const auto& e : o->effects) {
        try {
          effects.push_back(diagnosis::parseEffect(e));
        } catch (const std::invalid_argument& ex) {
          throw UsageError(std::string("--effect: ") + ex.what());
        }
      }
      for (const auto& e : effects)
        if (e.kind == diagnosis::EffectKind::Gravity && !diagnosis::gravityUnavailable(robot).empty())
          throw UsageError("--effect gravity: robot '" + robot.name() + "': " + diagnosis::gravityUnavailable(robot));
      std::vector<Configuration> commands;
      Eigen::VectorXd time;
      if (!o->actuation.empty()) {
        const io::Recording act = io::loadRecording(o->actuation, robot.size(), false);
        commands = act.commands;
        time = act.time;
        // Rows within the admissibility tolerance are kept as logged (the model projects them); larger violations
        // are errors naming the row.
        for (std::size_t r = 0; r < commands.size(); ++r) {
          Configuration q = commands[r];
          const Admissibility adm = projectAdmissible(robot, q);
          if (!adm)
            throw io::InputError(o->actuation, act.lineOf(static_cast<int>(r)), "",
                                 "row " + std::to_string(r + 1) + " is not admissible: " + adm.message);
        }
      } else {
        diagnosis::ActuationOptions a;
        for (diagnosis::ActuationPattern p : {diagnosis::ActuationPattern::Sweep, diagnosis::ActuationPattern::Random,
                                              diagnosis::ActuationPattern::RandomWalk})
          if (o->pattern == toString(p)) a.pattern = p;
        a.rows = o->rows;
        a.step_deg = o->step_deg;
        a.dt = o->dt;
        a.max_speed = o->max_speed;
        a.translate = o->translate;
        a.returns = o->returns;
        a.frames = o->frames;
        a.seed = o->seed;
        diagnosis::makeActuation(robot, a, commands, time);
        for (std::size_t r = 0; r < commands.size(); ++r) {
          const Admissibility adm = checkAdmissible(robot, commands[r]);
          if (!adm) throw UsageError("actuation row " + std::to_string(r + 1) + " is not admissible: " + adm.message);
        }
      }
      diagnosis::SimulationOptions s;
      s.twist_sd = parseNumber(o->noise_twist, "--noise-twist", true);
      s.tangent_sd = parseNumber(o->noise_tangent, "--noise-tangent", true);
      s.position_sd = o->noise_position;
      s.repeatability_position_sd = o->repeat_position;
      s.repeatability_tangent_sd = parseNumber(o->repeat_tangent, "--repeatability-tangent", true);
      s.predict.replay.branch = parseBranchRule(o->branch);
      s.twist = o->measure.find("twist") != std::string::npos;
      s.tip_position = o->measure.find("tip_position") != std::string::npos;
      s.tip_tangent = o->measure.find("tip_tangent") != std::string::npos;
      if (!s.twist && !s.tip_position && !s.tip_tangent) throw UsageError("--measure: nothing to record");
      s.seed = o->seed;
      if (o->sensor_frame) {
        std::mt19937_64 rng(o->seed ^ 0x5eed5eedULL);
        std::normal_distribution<double> N(0.0, 1.0);
        diagnosis::Registration reg;
        Eigen::Vector4d qv(N(rng), N(rng), N(rng), N(rng));
        reg.rotation = Eigen::Quaterniond(qv.normalized()).toRotationMatrix();
        reg.translation = Eigen::Vector3d(N(rng), N(rng), N(rng)) * 0.05;
        reg.tip_offset = 0.005;
        s.sensor_frame = reg;
      }
      const io::Recording rec = diagnosis::simulateRecording(robot, commands, time, effects, s);
      io::saveRecording(rec, o->out);
      if (!o->truth.empty()) {
        nlohmann::json t;
        std::vector<std::string> v;
        nlohmann::json list = nlohmann::json::array();
        for (const auto& e : effects) {
          v.push_back(diagnosis::toString(e.kind));
          nlohmann::json x{{"effect", diagnosis::toString(e.kind)}};
          for (const diagnosis::NamedParameter& p : diagnosis::namedParameters(e)) {
            if (p.name == "tube")
              x["tube"] = e.tube;
            else if (p.value.size() == 1)
              x[p.name] = p.value.front();
            else
              x[p.name] = p.value;
          }
          list.push_back(x);
        }
        t["verdict"] = v;
        t["effects"] = list;
        io::writeFileAtomic(o->truth, t.dump(1) + "\n");
      }
      std::cerr << "wrote " << rec.rows() << " rows -> " << o->out << "\n";
      return kOk;
    };
  });
}

}  // namespace

void registerRecording(CLI::App& app, Action& action) {
  CLI::App* sub = app.add_subcommand("recording", "Recording tools: import lab formats, inject effects");
  sub->require_subcommand(1);
  registerImport(sub, action);
  registerInject(sub, action);
}

}  // namespace ctr::cli
