// Bindings of the inverse kinematics (ctr/model/ik.hpp, friction_ik.hpp): ctr.ik and ctr.ik_path with the keys of
// `ctr ik --json` (io::ikReportJson), numpy arrays in and out.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>

#include "common.hpp"
#include "ctr/io/ik_json.hpp"
#include "ctr/model/friction_ik.hpp"
#include "ctr/model/ik.hpp"

namespace ctr::py {

namespace {

using pyb::arg;

Approach parseHistory(const std::string& h) {
  for (Approach a : {Approach::Rest, Approach::Positive, Approach::Negative})
    if (h == toString(a)) return a;
  throw pyb::value_error("history '" + h + "': expected 'rest', 'positive' or 'negative'");
}

Eigen::Vector3d vector3(const pyb::handle& obj, const std::string& what) {
  const Eigen::VectorXd v = toVector(obj, what);
  if (v.size() != 3) throw pyb::value_error(what + ": expected three numbers x, y, z, got " + std::to_string(v.size()));
  if (!v.allFinite()) throw pyb::value_error(what + ": values must be finite");
  return v;
}

// The keys of one answer whose values are vectors: numpy arrays in the returned dicts.
bool isVectorKey(const std::string& k) {
  for (const char* v :
       {"alpha", "beta", "closest", "blind_alpha", "blind_beta", "blind_tip", "start_alpha", "start_beta"})
    if (k == v) return true;
  return false;
}

// A dict of the report JSON with its vectors as numpy arrays (None stays None; null numbers become NaN).
pyb::object withArrays(const pyb::object& value) {
  const pyb::module_ np = pyb::module_::import("numpy");
  if (!pyb::isinstance<pyb::dict>(value)) return value;
  pyb::dict out;
  for (const auto& item : pyb::reinterpret_borrow<pyb::dict>(value)) {
    const std::string key = pyb::str(item.first).cast<std::string>();
    if (isVectorKey(key) && !item.second.is_none())
      out[item.first] = np.attr("array")(item.second, pyb::arg("dtype") = "float64");
    else if (pyb::isinstance<pyb::dict>(item.second))
      out[item.first] = withArrays(pyb::reinterpret_borrow<pyb::object>(item.second));
    else
      out[item.first] = item.second;
  }
  return std::move(out);
}

// A list of answer dicts (the "rows" of a path report) as one dict of arrays with the same keys: numbers stacked
// (null -> NaN), vectors as (K, m) arrays (NaN rows where null: not computed), booleans as bool arrays (float with NaN
// when some are null), strings as lists; nested dicts likewise.
pyb::dict columns(const pyb::list& rows) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  pyb::dict d;
  if (rows.empty()) return d;
  const auto K = static_cast<pyb::ssize_t>(rows.size());
  for (const auto& item : pyb::reinterpret_borrow<pyb::dict>(rows[0])) {
    const std::string key = pyb::str(item.first).cast<std::string>();
    std::vector<pyb::object> values;
    pyb::object sample = pyb::none();
    bool any_null = false;
    std::size_t width = 0;
    for (const pyb::handle row : rows) {
      const pyb::dict r = pyb::reinterpret_borrow<pyb::dict>(row);
      pyb::object v = r.contains(item.first) ? pyb::reinterpret_borrow<pyb::object>(r[item.first]) : pyb::none();
      if (pyb::isinstance<pyb::list>(v)) width = std::max(width, pyb::len(v));
      any_null = any_null || v.is_none();
      if (sample.is_none() && !v.is_none()) sample = v;
      values.push_back(std::move(v));
    }
    if (pyb::isinstance<pyb::dict>(sample)) {
      pyb::list sub;
      for (const pyb::object& v : values) sub.append(v.is_none() ? pyb::dict() : v);
      d[item.first] = columns(sub);
    } else if (pyb::isinstance<pyb::str>(sample)) {
      pyb::list l;
      for (const pyb::object& v : values) l.append(v);
      d[item.first] = l;
    } else if (pyb::isinstance<pyb::bool_>(sample) && !any_null) {
      pyb::array_t<bool> a(K);
      for (pyb::ssize_t k = 0; k < K; ++k) a.mutable_at(k) = values[static_cast<std::size_t>(k)].cast<bool>();
      d[item.first] = a;
    } else if (pyb::isinstance<pyb::list>(sample)) {
      pyb::array_t<double> a({K, static_cast<pyb::ssize_t>(width)});
      for (pyb::ssize_t k = 0; k < K; ++k) {
        const pyb::object& v = values[static_cast<std::size_t>(k)];
        const std::size_t n = pyb::isinstance<pyb::list>(v) ? pyb::len(v) : 0;
        for (std::size_t c = 0; c < width; ++c) {
          pyb::object x = pyb::none();
          if (c < n) x = pyb::reinterpret_borrow<pyb::list>(v)[c];
          a.mutable_at(k, static_cast<pyb::ssize_t>(c)) = x.is_none() ? nan : x.cast<double>();
        }
      }
      d[item.first] = a;
    } else if ((key == "iterations" || key == "evaluations" || key == "starts") && !any_null) {
      pyb::array_t<std::int64_t> a(K);
      for (pyb::ssize_t k = 0; k < K; ++k) a.mutable_at(k) = values[static_cast<std::size_t>(k)].cast<std::int64_t>();
      d[item.first] = a;
    } else {
      pyb::array_t<double> a(K);
      for (pyb::ssize_t k = 0; k < K; ++k) {
        const pyb::object& v = values[static_cast<std::size_t>(k)];
        a.mutable_at(k) = v.is_none() ? nan : v.cast<double>();
      }
      d[item.first] = a;
    }
  }
  return d;
}

struct Inputs {
  std::vector<IkTarget> targets;
  Configuration start;
  bool from = false;  // a start was given (alpha or beta)
};

Inputs inputs(const Robot& r, const pyb::object& targets, const pyb::object& directions, double weight,
              const pyb::object& alpha, const pyb::object& beta, bool path) {
  if (!(weight >= 0.0) || !std::isfinite(weight))
    throw pyb::value_error("direction_weight: must be finite and not negative");
  Inputs in;
  if (path) {
    const Eigen::MatrixXd P = toMatrix(targets, "targets", 3);
    if (P.rows() == 0) throw pyb::value_error("targets: no rows");
    Eigen::MatrixXd D;
    if (!directions.is_none()) {
      D = toMatrix(directions, "directions", 3);
      if (D.rows() != P.rows())
        throw pyb::value_error("directions has " + std::to_string(D.rows()) + " rows, targets " +
                               std::to_string(P.rows()));
    }
    for (Eigen::Index k = 0; k < P.rows(); ++k) {
      if (!P.row(k).allFinite()) throw pyb::value_error("targets: row " + std::to_string(k + 1) + " is not finite");
      IkTarget t(P.row(k).transpose());
      t.direction_weight = weight;
      if (D.size() && !D.row(k).hasNaN()) {
        if (!(D.row(k).norm() > 0.0) || !D.row(k).allFinite())
          throw pyb::value_error("directions: row " + std::to_string(k + 1) + " is not a finite non-zero vector");
        t.direction = D.row(k).transpose();
      }
      in.targets.push_back(t);
    }
  } else {
    IkTarget t(vector3(targets, "target"));
    t.direction_weight = weight;
    if (!directions.is_none()) {
      t.direction = vector3(directions, "direction");
      if (!(t.direction->norm() > 0.0)) throw pyb::value_error("direction: must not be the zero vector");
    }
    in.targets.push_back(t);
  }
  in.start = toConfiguration(r, alpha, beta);
  in.from = !alpha.is_none() || !beta.is_none();
  return in;
}

// Runs `ctr ik` in the library: friction-aware from `state`, or from the approach to the start when the robot has
// boundary friction; frictionless otherwise (cold without a start). Returns the report dict and the final state.
pyb::dict run(const Robot& r, const Inputs& in, const pyb::object& state, const std::string& history, double approach,
              const std::optional<IkOptions>& options, const std::optional<FrictionOptions>& friction_options,
              bool compare_blind, bool path) {
  const Approach ap = parseHistory(history);
  if (!(approach > 0.0) || !std::isfinite(approach)) throw pyb::value_error("approach: must be positive (rad)");
  const IkOptions ik = options.value_or(IkOptions{});
  io::IkReport report;
  report.robot = r.name();
  report.path = path;
  for (const IkTarget& t : in.targets) report.with_direction = report.with_direction || t.direction.has_value();
  const bool friction = !state.is_none() || r.friction().boundary > 0.0;
  std::optional<HysteresisState> final_state;
  std::optional<Solution> solution;
  std::vector<Configuration> prefix;
  {
    FrictionIkOptions fo;
    fo.ik = ik;
    if (friction_options) fo.friction = *friction_options;
    fo.compare_blind = compare_blind;
    HysteresisState from;
    if (!state.is_none()) {
      from = state.cast<HysteresisState>();
      if (!from.valid) throw pyb::value_error("state: not initialised (use ctr.initial_state first)");
      if (from.q.size() != r.size()) throw pyb::value_error("state: of a robot with another number of tubes");
    }
    pyb::gil_scoped_release release;
    if (friction) {
      if (state.is_none()) {
        const StepResult st = approachState(r, in.start, ap, approach, workspace(), fo.friction);
        if (!st.summary.converged || !st.state.valid)
          throw std::runtime_error("the model did not converge at the start configuration: " + st.summary.message);
        from = st.state;
        if (ap != Approach::Rest) prefix.push_back(approachStart(r, in.start, ap, approach));
        prefix.push_back(in.start);
        report.friction =
            io::IkReport::Friction{r.friction().boundary, history, approach, in.start, static_cast<int>(prefix.size())};
      } else {
        report.friction = io::IkReport::Friction{r.friction().boundary, "state", 0.0, from.lastCommand(), 0};
      }
      const std::vector<FrictionIkResult> res = frictionInverseKinematicsPath(r, from, in.targets, workspace(), fo);
      for (const FrictionIkResult& x : res) report.rows.emplace_back(x, hasActuation(r));
      final_state = res.back().step.state;
      solution = res.back().step.solution;
    } else {
      const std::vector<IkResult> res =
          inverseKinematicsPath(r, in.targets, in.from ? &in.start : nullptr, workspace(), ik);
      for (const IkResult& x : res) report.rows.emplace_back(x, hasActuation(r));
      solution = res.back().solution;
    }
  }
  pyb::dict d = withArrays(jsonLoads(io::ikReportJson(report)));
  if (path) {
    d["rows"] = columns(d["rows"]);
  } else {
    d["solution"] = *solution;
  }
  if (final_state) d["state"] = *final_state;
  if (friction && !prefix.empty()) {
    pyb::dict f = d["friction"];
    f["start_commands"] = configurationArrays(prefix, r.size());
  }
  return d;
}

}  // namespace

void registerIk(pyb::module_& m) {
  pyb::class_<IkOptions> iko(m, "IkOptions", "Options of the inverse kinematics (ctr::IkOptions; docs/ik.md).");
  iko.def_readwrite("tolerance", &IkOptions::tolerance, "Reached when the tip is within this distance (m).")
      .def_readwrite("direction_tolerance", &IkOptions::direction_tolerance, "... and the direction (rad).")
      .def_readwrite("max_iterations", &IkOptions::max_iterations)
      .def_readwrite("restarts", &IkOptions::restarts)
      .def_readwrite("cold_candidates", &IkOptions::cold_candidates)
      .def_readwrite("near_start", &IkOptions::near_start)
      .def_readwrite("max_cold_candidates", &IkOptions::max_cold_candidates)
      .def_readwrite("slow_start_horizon", &IkOptions::slow_start_horizon)
      .def_readwrite("seed", &IkOptions::seed)
      .def_readwrite("damping", &IkOptions::damping)
      .def_readwrite("translation_scale", &IkOptions::translation_scale)
      .def_readwrite("max_step", &IkOptions::max_step)
      .def_readwrite("min_protrusion", &IkOptions::min_protrusion)
      .def_readwrite("require_stable", &IkOptions::require_stable)
      .def_readwrite("check_branch", &IkOptions::check_branch)
      .def_readwrite("kinematics", &IkOptions::kinematics);
  addOptionsProtocol<IkOptions>(iko, {"tolerance", "direction_tolerance", "max_iterations", "restarts",
                                      "cold_candidates", "slow_start_horizon", "seed", "damping", "translation_scale",
                                      "max_step", "min_protrusion", "require_stable", "check_branch", "kinematics"});

  m.def(
      "ik",
      [](const Robot& r, const pyb::object& target, const pyb::object& direction, double direction_weight,
         const pyb::object& alpha, const pyb::object& beta, const pyb::object& state, const std::string& history,
         double approach, std::optional<IkOptions> options, std::optional<FrictionOptions> friction_options) {
        const Inputs in = inputs(r, target, direction, direction_weight, alpha, beta, false);
        return run(r, in, state, history, approach, options, friction_options, true, false);
      },
      arg("robot"), arg("target"), arg("direction") = pyb::none(), arg("direction_weight") = 0.01,
      arg("alpha") = pyb::none(), arg("beta") = pyb::none(), arg("state") = pyb::none(), arg("history") = "rest",
      arg("approach") = 0.5, arg("options") = pyb::none(), arg("friction_options") = pyb::none(),
      "`ctr ik`: actuator values that put the tip on `target` (x, y, z; m, base frame), optionally with a tip "
      "`direction` weighted by direction_weight (m). Friction-aware when `state` (a HysteresisState) is given or the "
      "robot has boundary friction (then from the robot at rest at (alpha, beta), or arrived there with history "
      "'positive' / 'negative' by `approach` rad): the command that puts the tip on the target through the stateful "
      "step, with the friction-blind comparison under 'friction'. Frictionless otherwise: warm from (alpha, beta) when "
      "given, cold from random starts when not. Dict with the keys of `ctr ik --json` (alpha, beta, closest as numpy "
      "arrays), plus 'solution' (the equilibrium) and, friction-aware, 'state' (the HysteresisState after the "
      "command). Runs without the GIL.");

  m.def(
      "ik_path",
      [](const Robot& r, const pyb::object& targets, const pyb::object& directions, double direction_weight,
         const pyb::object& alpha, const pyb::object& beta, const pyb::object& state, const std::string& history,
         double approach, std::optional<IkOptions> options, std::optional<FrictionOptions> friction_options,
         bool compare_blind) {
        const Inputs in = inputs(r, targets, directions, direction_weight, alpha, beta, true);
        return run(r, in, state, history, approach, options, friction_options, compare_blind, true);
      },
      arg("robot"), arg("targets"), arg("directions") = pyb::none(), arg("direction_weight") = 0.01,
      arg("alpha") = pyb::none(), arg("beta") = pyb::none(), arg("state") = pyb::none(), arg("history") = "rest",
      arg("approach") = 0.5, arg("options") = pyb::none(), arg("friction_options") = pyb::none(),
      arg("compare_blind") = true,
      "`ctr ik --targets`: a path of targets ((K, 3) array; optional (K, 3) directions, NaN rows for none), each from "
      "the previous answer (a servo loop; friction-aware: each from the state the previous command left). Same modes "
      "as ctr.ik. Dict with the keys of `ctr ik --targets --json` (reached, targets, reached_count, tip_error_max, "
      "tip_error_rms, friction, rows), 'rows' as columns: a dict of arrays over the targets (rows['alpha'], "
      "rows['beta'] (K, n); rows['tip_error'], rows['reached'] (K,); rows['closest'] (K, 3); friction-aware "
      "rows['friction']['blind_tip_error'], ...), plus 'state' (friction-aware: after the last command) and "
      "friction['start_commands'] (alpha, beta rows that bring the robot into the start state: ctr.simulate of them "
      "followed by the commands replays the path). Runs without the GIL.");
}

}  // namespace ctr::py
