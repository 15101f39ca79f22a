// `ctr simulate`: replay an actuation sequence through the stateful (friction) model and write a recording.
#include <iostream>

#include "commands.hpp"
#include "ctr/io/recording.hpp"
#include "ctr/io/robot_yaml.hpp"
#include "ctr/model/replay.hpp"

namespace ctr::cli {

void registerSimulate(CLI::App& app, Action& action) {
  struct Opts {
    std::string robot, actuation, out, branch = toString(BranchRule::Path);
    bool allow_failures = false;
    FrictionCli friction;
    LoadsCli loads;
  };
  auto o = std::make_shared<Opts>();
  CLI::App* sub =
      app.add_subcommand("simulate", "Replay an actuation CSV (alpha_*, beta_* rows in order) and write a recording");
  sub->add_option("--robot", o->robot, "Robot description YAML")->required();
  sub->add_option("--actuation", o->actuation, "CSV with alpha_1..n, beta_1..n (and optional time) columns")
      ->required();
  sub->add_option("--out", o->out, "Recording CSV to write (docs/formats.md columns)")->required()->type_name("FILE");
  sub->add_flag("--allow-failures", o->allow_failures, "Write rows that did not converge with empty measurements");
  sub->add_option("--branch", o->branch,
                  "How each row's equilibrium is reached: path (default: continuation along the move from the previous "
                  "row), rest (from rest: the robot re-homed between rows); docs/friction.md \"Replaying a sequence\"")
      ->check(branchRuleValidator());
  o->friction.add(sub);
  o->loads.add(sub);
  sub->callback([o, &action]() {
    action = [o]() {
      checkOutputPath("--out", o->out, {{"--robot", o->robot}, {"--actuation", o->actuation}});
      const Robot robot = o->loads.apply(o->friction.apply(io::loadRobot(o->robot)));
      io::Recording act = io::loadRecording(o->actuation, robot.size(), false);
      // Logged rows are rounded: violations up to kAdmissibilityTolerance are projected (docs/formats.md
      // "Admissibility tolerance"); larger ones name the file, line and row.
      for (int r = 0; r < act.rows(); ++r) {
        const Admissibility adm = projectAdmissible(robot, act.commands[static_cast<std::size_t>(r)]);
        if (!adm)
          throw io::InputError(o->actuation, act.lineOf(r), "",
                               "row " + std::to_string(r + 1) + " is not admissible: " + adm.message);
      }
      Workspace ws;
      ReplayOptions ro;
      ro.friction = o->friction.options();
      ro.branch = parseBranchRule(o->branch);
      const std::vector<ReplayRow> res = replay(robot, act.commands, ws, ro);
      const int n = robot.size();
      io::Recording rec;
      rec.tubes = n;
      rec.commands = act.commands;
      rec.time = act.time;
      const int rows = act.rows();
      rec.twist = Eigen::MatrixXd::Constant(rows, n - 1, std::numeric_limits<double>::quiet_NaN());
      rec.tip_position = Eigen::MatrixXd::Constant(rows, 3, std::numeric_limits<double>::quiet_NaN());
      rec.tip_tangent = Eigen::MatrixXd::Constant(rows, 3, std::numeric_limits<double>::quiet_NaN());
      int failures = 0;
      for (int r = 0; r < rows; ++r) {
        const ReplayRow& row = res[static_cast<std::size_t>(r)];
        if (!row.ok) {
          // A snap is a prediction (the robot jumps to another branch; where it lands is not quasi-static): the row is
          // written empty with a warning, as the diagnosis leaves it out. Anything else is a failure.
          const bool snap = row.failure == Failure::Snapped;
          failures += snap ? 0 : 1;
          std::cerr << "warning: row " << r + 1 << (snap ? " " : " could not be evaluated: ") << row.message << "\n";
          continue;
        }
        const Solution& s = row.result.solution;
        if (n > 1) rec.twist.row(r) = s.twist.transpose();
        rec.tip_position.row(r) = s.tip_position.transpose();
        rec.tip_tangent.row(r) = s.tipTangent().transpose();
      }
      if (n == 1) rec.twist.resize(rows, 0);
      if (failures && !o->allow_failures) {
        std::cerr << "error: " << failures << " of " << rows
                  << " rows could not be evaluated; nothing written (use --allow-failures to write them empty)\n";
        return static_cast<int>(kRuntimeFailure);
      }
      io::saveRecording(rec, o->out);
      std::cerr << "wrote " << rows << " rows to " << o->out << "\n";
      return static_cast<int>(kOk);
    };
  });
}

}  // namespace ctr::cli
