// `ctr ik`: inverse kinematics of one tip target or a path of targets; friction-aware with boundary friction (the
// command that puts the tip on the target through the stateful stick-slip model), with the friction-blind comparison.
#include <nlohmann/json.hpp>

#include <cmath>
#include <iomanip>
#include <iostream>
#include <optional>
#include <sstream>

#include "commands.hpp"
#include "ctr/io/recording.hpp"
#include "ctr/io/robot_yaml.hpp"
#include "ctr/io/tip_path.hpp"
#include "ctr/model/friction_ik.hpp"
#include "ctr/model/ik.hpp"
#include "output.hpp"

namespace ctr::cli {

namespace {

nlohmann::json vec(const Eigen::VectorXd& v) {
  nlohmann::json a = nlohmann::json::array();
  for (Eigen::Index i = 0; i < v.size(); ++i) a.push_back(std::isfinite(v[i]) ? nlohmann::json(v[i]) : nullptr);
  return a;
}

nlohmann::json number(double v) {
  return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr);
}

// One target's answer: the keys of docs/ik.md.
nlohmann::json answerJson(const Configuration& q, const IkSummary& s, bool with_direction) {
  nlohmann::json j;
  j["reached"] = s.reached();
  j["status"] = toString(s.status);
  j["alpha"] = vec(q.alpha);
  j["beta"] = vec(q.beta);
  j["tip_error"] = number(s.tip_error);
  j["closest"] = s.status == IkStatus::Failed ? nlohmann::json(nullptr) : vec(s.closest);
  if (with_direction) j["direction_error"] = number(s.direction_error);
  j["stable"] = s.stable;
  j["stability"] = number(s.stability);
  j["branch_dependent"] = s.branch_dependent;
  j["iterations"] = s.iterations;
  j["evaluations"] = s.evaluations;
  j["starts"] = s.starts;
  j["message"] = s.message;
  return j;
}

nlohmann::json costJson(const FrictionCost& c) {
  nlohmann::json j;
  j["blind_alpha"] = vec(c.blind_q.alpha);
  j["blind_beta"] = vec(c.blind_q.beta);
  j["blind_reached"] = c.blind_reached;
  j["blind_tip"] = vec(c.blind_tip);
  j["blind_tip_error"] = number(c.blind_tip_error);
  j["alpha_difference"] = number(c.alpha_difference);
  j["beta_difference"] = number(c.beta_difference);
  return j;
}

Approach parseHistory(const std::string& h) {
  if (h == "positive") return Approach::Positive;
  if (h == "negative") return Approach::Negative;
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
  sub->add_option("--out", o->out, "Write the commands to this actuation CSV (alpha_*, beta_*; ctr simulate reads it)");
  sub->add_option("--json", o->json, "Write the result as JSON to this file, or - for standard output");
  o->from.add(sub, "from-");
  sub->add_option("--boundary-friction", o->boundary,
                  "Lumped friction coefficient mu' (overrides the robot's); > 0 makes the inverse friction-aware")
      ->check(finiteNonNegative());
  sub->add_option("--history", o->history,
                  "How the robot reached the --from configuration: rest (default), positive or negative (every tube "
                  "turned that way relative to its outer neighbour by --approach)")
      ->check(CLI::IsMember({"rest", "positive", "negative"}));
  sub->add_option("--approach", o->approach, "Rotation of that approach (rad; default 0.5)")->check(finitePositive());
  sub->add_option("--tolerance", o->tolerance, "Tip distance accepted as reached (m; default 1e-5)")
      ->check(finitePositive());
  sub->add_option("--restarts", o->restarts, "Further random starts when a start does not reach (default 8)")
      ->check(CLI::NonNegativeNumber);
  sub->add_option("--seed", o->seed, "Seed of the random starts (default 1)");
  o->loads.add(sub);
  sub->callback([o, &action]() {
    action = [o]() {
      const bool to_stdout = o->json == "-";
      if (o->target.empty() == o->targets.empty())
        throw UsageError("give exactly one of --target X,Y,Z and --targets PATH.csv");
      if (!o->direction.empty() && o->target.empty())
        throw UsageError("--direction goes with --target; a path gives directions in tip_tx, tip_ty, tip_tz columns");
      if (!to_stdout) checkOutputPath("--json", o->json, {{"--robot", o->robot}, {"--targets", o->targets}});
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
      bool with_direction = false;
      for (const IkTarget& t : targets) with_direction = with_direction || t.direction.has_value();

      IkOptions ik;
      ik.tolerance = o->tolerance;
      ik.restarts = o->restarts;
      ik.seed = o->seed;
      const Configuration start = o->from.resolve(robot);  // default: the configuration of `ctr fk`
      Workspace ws;

      // Solve: friction-aware from the start's hysteresis state, or frictionless (cold without --from, then warm).
      std::vector<Configuration> commands, prefix;
      std::vector<nlohmann::json> rows;
      std::vector<double> errors, blind_errors;
      int reached = 0;
      if (friction) {
        FrictionIkOptions fo;
        fo.ik = ik;
        const Approach approach = parseHistory(o->history);
        const StepResult st = approachState(robot, start, approach, o->approach, ws, fo.friction);
        // The commands file begins with the rows that bring the robot into this state (the replay of `ctr simulate`
        // then starts from the same state): the approach's start, then the start configuration.
        if (approach != Approach::Rest) prefix.push_back(approachStart(robot, start, approach, o->approach));
        prefix.push_back(start);
        if (!st.summary.converged || !st.state.valid)
          throw std::runtime_error("the model did not converge at the start configuration (--history " + o->history +
                                   "): " + st.summary.message);
        const std::vector<FrictionIkResult> res = frictionInverseKinematicsPath(robot, st.state, targets, ws, fo);
        for (const FrictionIkResult& r : res) {
          nlohmann::json j = answerJson(r.q, r.summary, with_direction);
          j["friction"] = costJson(r.cost);
          rows.push_back(j);
          commands.push_back(r.q);
          errors.push_back(r.summary.tip_error);
          blind_errors.push_back(r.cost.blind_tip_error);
          reached += r.summary.reached();
        }
      } else {
        std::optional<IkResult> prev;
        for (const IkTarget& t : targets) {
          IkResult r = prev && prev->summary.status != IkStatus::Failed ? inverseKinematics(robot, t, *prev, ws, ik)
                       : o->from.given()                                ? inverseKinematics(robot, t, start, ws, ik)
                                                                        : inverseKinematics(robot, t, ws, ik);
          rows.push_back(answerJson(r.q, r.summary, with_direction));
          commands.push_back(r.q);
          errors.push_back(r.summary.tip_error);
          reached += r.summary.reached();
          prev = std::move(r);
        }
      }

      auto rms = [](const std::vector<double>& v) {
        double s = 0.0;
        for (double x : v) s += x * x;
        return v.empty() ? 0.0 : std::sqrt(s / static_cast<double>(v.size()));
      };
      auto maxOf = [](const std::vector<double>& v) {
        double m = 0.0;
        for (double x : v) m = std::isfinite(x) ? std::max(m, x) : std::numeric_limits<double>::infinity();
        return m;
      };
      const bool all = reached == static_cast<int>(targets.size());
      nlohmann::json out;
      nlohmann::json fr;
      if (friction) {
        fr["boundary"] = mu;
        fr["history"] = o->history;
        fr["approach"] = o->approach;
        fr["start_alpha"] = vec(start.alpha);
        fr["start_beta"] = vec(start.beta);
        fr["start_rows"] = prefix.size();  // rows of --out before the first target's command
      }
      if (o->targets.empty()) {
        out = rows.front();
        if (friction) out["friction"].update(fr);
      } else {
        out["reached"] = all;
        out["targets"] = targets.size();
        out["reached_count"] = reached;
        out["tip_error_max"] = number(maxOf(errors));
        out["tip_error_rms"] = number(rms(errors));
        if (friction) {
          fr["blind_tip_error_max"] = number(maxOf(blind_errors));
          fr["blind_tip_error_rms"] = number(rms(blind_errors));
          out["friction"] = fr;
        }
        out["rows"] = rows;
      }
      out["robot"] = robot.name();
      const std::string text = out.dump() + "\n";

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
        std::ostringstream os;
        os << std::setprecision(6);
        if (o->targets.empty()) {
          const nlohmann::json& r = rows.front();
          os << "reached:   " << (r["reached"].get<bool>() ? "yes" : "no") << "\n";
          os << "alpha:     " << r["alpha"].dump() << " rad\nbeta:      " << r["beta"].dump() << " m\n";
          os << "tip error: " << errors.front() << " m\n";
          if (friction)
            os << "friction-blind command (frictionless IK) leaves the tip " << blind_errors.front() << " m off\n";
        } else {
          os << "reached:   " << reached << " of " << targets.size() << " targets\n";
          os << "tip error: RMS " << rms(errors) << " m, max " << maxOf(errors) << " m\n";
          if (friction)
            os << "friction-blind commands: tip error RMS " << rms(blind_errors) << " m, max " << maxOf(blind_errors)
               << " m\n";
        }
        std::cout << os.str();
      }
      if (!all) {
        for (std::size_t k = 0; k < rows.size(); ++k)
          if (!rows[k]["reached"].get<bool>()) {
            std::cerr << "error: " << (targets.size() > 1 ? "target " + std::to_string(k + 1) + ": " : std::string())
                      << rows[k]["message"].get<std::string>() << "\n";
            break;
          }
        return static_cast<int>(kRuntimeFailure);
      }
      return static_cast<int>(kOk);
    };
  });
}

}  // namespace ctr::cli
