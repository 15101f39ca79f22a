// `ctr ik`: inverse kinematics of one tip target or a path of targets; friction-aware with boundary friction (the
// command that puts the tip on the target through the stateful stick-slip model), with the friction-blind comparison.
#include <cmath>
#include <iomanip>
#include <iostream>
#include <optional>
#include <sstream>

#include "commands.hpp"
#include "ctr/io/file.hpp"
#include "ctr/io/ik_json.hpp"
#include "ctr/io/recording.hpp"
#include "ctr/io/robot_yaml.hpp"
#include "ctr/io/tip_path.hpp"
#include "ctr/model/friction_ik.hpp"
#include "ctr/model/ik.hpp"
#include "output.hpp"

namespace ctr::cli {

namespace {

Approach parseHistory(const std::string& h) {
  for (Approach a : {Approach::Positive, Approach::Negative})
    if (h == toString(a)) return a;
  return Approach::Rest;
}

}  // namespace

void registerIk(CLI::App& app, Action& action) {
  struct Opts {
    std::string robot, target, direction, targets, out, json, history = "rest";
    ConfigOptions from;
    LoadsCli loads;
    double boundary = -1.0, weight = 0.01, tolerance = 1e-5, approach = 0.5;
    int restarts = 8;
    std::uint64_t seed = 1;
  };
  auto o = std::make_shared<Opts>();
  CLI::App* sub = app.add_subcommand(
      "ik", "Inverse kinematics: actuator values that put the tip on a target (friction-aware with boundary friction)");
  sub->add_option("--robot", o->robot, "Robot description YAML")->required();
  sub->add_option("--target", o->target, "Tip target x,y,z (m, base frame)");
  sub->add_option("--direction", o->direction, "Desired tip direction dx,dy,dz (base frame; normalised)");
  sub->add_option("--direction-weight", o->weight,
                  "Weight of the direction in the cost |p - p*|^2 + w^2 |t - d|^2 (m; default 0.01)")
      ->check(finiteNonNegative());
  sub->add_option("--targets", o->targets,
                  "CSV of tip targets reached in order (tip_x,tip_y,tip_z; optional tip_tx,tip_ty,tip_tz, time)");
  sub->add_option("--out", o->out, "Write the commands to this actuation CSV (alpha_*, beta_*; ctr simulate reads it)")
      ->type_name("FILE");
  addJsonOption(sub, o->json, "the result");
  o->from.add(sub, "from-");
  sub->add_option("--boundary-friction", o->boundary,
                  "Lumped friction coefficient mu' (overrides the robot's); > 0 makes the inverse friction-aware")
      ->check(finiteNonNegative());
  sub->add_option("--history", o->history,
                  "How the robot reached the --from configuration: rest (default), positive or negative (every tube "
                  "turned that way relative to its outer neighbour by --approach)")
      ->check(CLI::IsMember({toString(Approach::Rest), toString(Approach::Positive), toString(Approach::Negative)}));
  sub->add_option("--approach", o->approach, "Rotation of that approach (rad; default 0.5)")->check(finitePositive());
  sub->add_option("--tolerance", o->tolerance, "Tip distance accepted as reached (m; default 1e-5)")
      ->check(finitePositive());
  sub->add_option("--restarts", o->restarts, "Further random starts when a start does not reach (default 8)")
      ->check(CLI::NonNegativeNumber);
  sub->add_option("--seed", o->seed, "Seed of the random starts (default 1)")
      ->check(CLI::NonNegativeNumber)
      ->type_name("INT");
  o->loads.add(sub);
  sub->callback([o, &action]() {
    action = [o]() {
      const bool to_stdout = o->json == kStandardOutput;
      if (o->target.empty() == o->targets.empty())
        throw UsageError("give exactly one of --target X,Y,Z and --targets PATH.csv");
      if (!o->direction.empty() && o->target.empty())
        throw UsageError("--direction goes with --target; a path gives directions in tip_tx, tip_ty, tip_tz columns");
      checkOutputTarget("--json", o->json, {{"--robot", o->robot}, {"--targets", o->targets}});
      checkOutputPath("--out", o->out, {{"--robot", o->robot}, {"--targets", o->targets}, {"--json", o->json}});

      Robot robot = o->loads.apply(io::loadRobot(o->robot));
      if (o->boundary >= 0.0) {
        FrictionCoefficients f = robot.friction();
        f.boundary = o->boundary;
        robot = robot.withFriction(f);
      }
      const double mu = robot.friction().boundary;
      const bool friction = mu > 0.0;
      if (!friction && o->history != "rest")
        std::cerr << "warning: --history has no effect without boundary friction (--boundary-friction or the robot's "
                     "friction.boundary)\n";

      // Targets.
      std::vector<IkTarget> targets;
      io::TipPath path;
      if (!o->target.empty()) {
        const std::vector<double> p = parseList(o->target, "--target", false);
        if (p.size() != 3)
          throw UsageError("--target: expected three numbers x,y,z (m), got " + std::to_string(p.size()));
        IkTarget t(Eigen::Vector3d(p[0], p[1], p[2]));
        if (!o->direction.empty()) {
          const std::vector<double> d = parseList(o->direction, "--direction", false);
          if (d.size() != 3)
            throw UsageError("--direction: expected three numbers dx,dy,dz, got " + std::to_string(d.size()));
          const Eigen::Vector3d dv(d[0], d[1], d[2]);
          if (!(dv.norm() > 0.0)) throw UsageError("--direction: must not be the zero vector");
          t.direction = dv;
        }
        t.direction_weight = o->weight;
        targets.push_back(t);
      } else {
        path = io::loadTipPath(o->targets);
        for (const std::string& w : path.warnings) std::cerr << "warning: " << o->targets << ": " << w << "\n";
        for (int r = 0; r < path.rows(); ++r) {
          IkTarget t(path.position.row(r).transpose());
          if (path.hasDirection() && !std::isnan(path.direction(r, 0))) t.direction = path.direction.row(r).transpose();
          t.direction_weight = o->weight;
          targets.push_back(t);
        }
      }

      IkOptions ik;
      ik.tolerance = o->tolerance;
      ik.restarts = o->restarts;
      ik.seed = o->seed;
      const Configuration start = o->from.resolve(robot);  // default: the configuration of `ctr fk`
      Workspace ws;

      // Solve: friction-aware from the start's hysteresis state, or frictionless (cold without --from, then warm).
      io::IkReport report;
      report.robot = robot.name();
      report.path = !o->targets.empty();
      for (const IkTarget& t : targets) report.with_direction = report.with_direction || t.direction.has_value();
      std::vector<Configuration> commands, prefix;
      if (friction) {
        FrictionIkOptions fo;
        fo.ik = ik;
        const Approach approach = parseHistory(o->history);
        const StepResult st = approachState(robot, start, approach, o->approach, ws, fo.friction);
        if (!st.summary.converged || !st.state.valid)
          throw std::runtime_error("the model did not converge at the start configuration (--history " + o->history +
                                   "): " + st.summary.message);
        // The commands file begins with the rows that bring the robot into this state (the replay of `ctr simulate`
        // then starts from the same state): the approach's start, then the start configuration.
        if (approach != Approach::Rest) prefix.push_back(approachStart(robot, start, approach, o->approach));
        prefix.push_back(start);
        report.friction = io::IkReport::Friction{mu, o->history, o->approach, start, static_cast<int>(prefix.size())};
        for (const FrictionIkResult& r : frictionInverseKinematicsPath(robot, st.state, targets, ws, fo))
          report.rows.emplace_back(r, hasActuation(robot));
      } else {
        for (const IkResult& r : inverseKinematicsPath(robot, targets, o->from.given() ? &start : nullptr, ws, ik))
          report.rows.emplace_back(r, hasActuation(robot));
      }
      int reached = 0;
      std::vector<double> errors, blind_errors;
      for (const io::IkReport::Row& r : report.rows) {
        commands.push_back(r.q);
        reached += r.summary.reached();
        errors.push_back(r.summary.tip_error);
        if (r.cost) blind_errors.push_back(r.cost->blind_tip_error);
      }
      const bool all = reached == static_cast<int>(targets.size());
      const std::string text = io::ikReportJson(report) + "\n";

      if (!o->out.empty()) {
        io::Recording rec;
        rec.tubes = robot.size();
        rec.commands = prefix;
        rec.commands.insert(rec.commands.end(), commands.begin(), commands.end());
        if (path.hasTime()) {
          rec.time = Eigen::VectorXd::Constant(rec.rows(), std::numeric_limits<double>::quiet_NaN());
          rec.time.tail(path.rows()) = path.time;
        }
        io::writeFileAtomic(o->out, io::recordingToCsv(rec));
      }
      if (to_stdout) {
        std::cout << text;
      } else {
        if (!o->json.empty()) io::writeFileAtomic(o->json, text);
        auto rms = [](const std::vector<double>& v) {
          double s = 0.0;
          for (double x : v) s += x * x;
          return std::sqrt(s / static_cast<double>(std::max<std::size_t>(1, v.size())));
        };
        std::ostringstream os;
        os << std::setprecision(6);
        if (!report.path) {
          const io::IkReport::Row& r = report.rows.front();
          os << "reached:   " << (r.summary.reached() ? "yes" : "no") << "\n";
          os << "alpha:     " << r.q.alpha.transpose() << " rad\nbeta:      " << r.q.beta.transpose() << " m\n";
          os << "tip error: " << r.summary.tip_error << " m\n";
          if (r.cost)
            os << "friction-blind command (frictionless IK) leaves the tip " << r.cost->blind_tip_error << " m off\n";
        } else {
          os << "reached:   " << reached << " of " << targets.size() << " targets\n";
          os << "tip error: RMS " << rms(errors) << " m\n";
          if (friction) os << "friction-blind commands: tip error RMS " << rms(blind_errors) << " m\n";
        }
        std::cout << os.str();
      }
      if (!all) {
        for (std::size_t k = 0; k < report.rows.size(); ++k)
          if (!report.rows[k].summary.reached()) {
            std::cerr << "error: " << (report.path ? "target " + std::to_string(k + 1) + ": " : std::string())
                      << report.rows[k].summary.message << "\n";
            break;
          }
        return static_cast<int>(kRuntimeFailure);
      }
      return static_cast<int>(kOk);
    };
  });
}

}  // namespace ctr::cli
