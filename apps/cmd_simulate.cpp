// `ctr simulate`: replay an actuation sequence through the stateful (friction) model and write a recording.
#include <iostream>

#include "commands.hpp"
#include "ctr/io/recording.hpp"
#include "ctr/io/robot_yaml.hpp"
#include "ctr/model/friction.hpp"

namespace ctr::cli {

void registerSimulate(CLI::App& app, Action& action) {
  struct Opts {
    std::string robot, actuation, out;
    bool allow_failures = false;
    FrictionCli friction;
    LoadsCli loads;
  };
  auto o = std::make_shared<Opts>();
  CLI::App* sub = app.add_subcommand("simulate", "Replay an actuation CSV (alpha_*, beta_* rows in order) and write a recording");
  sub->add_option("--robot", o->robot, "Robot description YAML")->required();
  sub->add_option("--actuation", o->actuation, "CSV with alpha_1..n, beta_1..n (and optional time) columns")->required();
  sub->add_option("--out", o->out, "Recording CSV to write (formats.md columns)")->required();
  sub->add_flag("--allow-failures", o->allow_failures, "Write rows that did not converge with empty measurements");
  o->friction.add(sub);
  o->loads.add(sub);
  sub->callback([o, &action]() {
    action = [o]() {
      checkOutputPath("--out", o->out, {{"--robot", o->robot}, {"--actuation", o->actuation}});
      const Robot robot = o->loads.apply(o->friction.apply(io::loadRobot(o->robot)));
      io::Recording act = io::loadRecording(o->actuation, robot.size(), false);
      // Logged rows are rounded: violations up to kAdmissibilityTolerance are projected (docs/formats-io.md
      // "Admissibility tolerance"); larger ones name the file, line and row.
      for (int r = 0; r < act.rows(); ++r) {
        const Admissibility adm = projectAdmissible(robot, act.commands[static_cast<std::size_t>(r)]);
        if (!adm)
          throw io::InputError(o->actuation, act.lineOf(r), "", "row " + std::to_string(r + 1) + " is not admissible: " +
                                                            adm.message);
      }
      Workspace ws;
      const std::vector<StepResult> res = replay(robot, act.commands, ws, o->friction.options());
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
        const Solution& s = res[static_cast<std::size_t>(r)].solution;
        if (!s.converged()) {
          ++failures;
          std::cerr << "warning: row " << r + 1 << " did not converge: " << res[static_cast<std::size_t>(r)].summary.message
                    << "\n";
          continue;
        }
        if (n > 1) rec.twist.row(r) = s.twist.transpose();
        rec.tip_position.row(r) = s.tip_position.transpose();
        rec.tip_tangent.row(r) = s.tipTangent().transpose();
      }
      if (n == 1) rec.twist.resize(rows, 0);
      if (failures && !o->allow_failures) {
        std::cerr << "error: " << failures << " of " << rows
                  << " rows did not converge; nothing written (use --allow-failures to write them empty)\n";
        return static_cast<int>(kRuntimeFailure);
      }
      io::saveRecording(rec, o->out);
      std::cerr << "wrote " << rows << " rows to " << o->out << "\n";
      return static_cast<int>(kOk);
    };
  });
}

}  // namespace ctr::cli
