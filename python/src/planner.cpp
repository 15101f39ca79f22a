// Bindings of ctr::planner: queries, CtrPlanner(...).solve() and the result with its path and replay report.
#include "ctr/planner/planner.hpp"
#include "common.hpp"
#include "ctr/io/input_error.hpp"
#include "ctr/planner/result_json.hpp"

namespace ctr::py {

namespace {

using pyb::arg;

/// A plan result with what its arrays need (robot size, base pose) and the query it answers.
struct Result {
  std::shared_ptr<const planner::PlanResult> r;
  std::shared_ptr<const planner::Context> ctx;
  planner::Query query;
};

/// The replay report of a Result (shares the result's data).
struct Replay {
  std::shared_ptr<const planner::PlanResult> r;
  std::shared_ptr<const planner::Context> ctx;
  const planner::ReplayReport& rep() const { return r->replay; }
};

/// The `ctr plan --json` object (planner::resultJson, as the CLI writes it): same keys and values.
pyb::object resultDict(const planner::Query& q, const planner::PlanResult& r) {
  return pyb::module_::import("json").attr("loads")(planner::resultJson(q, r, -1));
}

pyb::array_t<double> pathArray(const std::vector<Configuration>& path, int n) {
  const auto K = static_cast<pyb::ssize_t>(path.size());
  pyb::array_t<double> a({K, pyb::ssize_t(2 * n)});
  auto v = a.mutable_unchecked<2>();
  for (pyb::ssize_t k = 0; k < K; ++k)
    for (int i = 0; i < n; ++i) {
      v(k, i) = path[static_cast<std::size_t>(k)].alpha[i];
      v(k, n + i) = path[static_cast<std::size_t>(k)].beta[i];
    }
  return a;
}

pyb::object optionalConfiguration(const std::optional<Configuration>& q) {
  return q ? pyb::object(configurationTuple(*q)) : pyb::object(pyb::none());
}

Configuration configurationFromTuple(const pyb::handle& h, const std::string& what) {
  const pyb::sequence s = pyb::reinterpret_borrow<pyb::sequence>(h);
  if (!pyb::isinstance<pyb::sequence>(h) || pyb::len(s) != 2) throw pyb::value_error(what + ": expected (alpha, beta)");
  Configuration q(toVector(s[0], what + " alpha"), toVector(s[1], what + " beta"));
  if (q.alpha.size() != q.beta.size()) throw pyb::value_error(what + ": alpha and beta differ in length");
  return q;
}

}  // namespace

void registerPlanner(pyb::module_& m) {
  pyb::class_<planner::Query>(m, "Query",
                              "A planning query (docs/planning.md): robot, environment, start and its history, goal, "
                              "mode, planner, time limit, seed. Load with ctr.load_query(path); fields can be changed "
                              "before planning (the CLI's --mode, --planner, --time, --seed, --cpu-time).")
      .def_readonly("file", &planner::Query::file)
      .def_readwrite("name", &planner::Query::name)
      .def_readwrite("robot", &planner::Query::robot, "Robot YAML path.")
      .def_readwrite("environment", &planner::Query::environment, "Environment YAML path.")
      .def_readwrite("base_start", &planner::Query::base_start)
      .def_property(
          "mode", [](const planner::Query& q) { return std::string(planner::toString(q.mode)); },
          [](planner::Query& q, const std::string& s) { q.mode = planner::parseMode(s); },
          "'exact', 'robust' or 'frictionless'.")
      .def_readwrite("planner", &planner::Query::planner)
      .def_property(
          "time_limit", [](const planner::Query& q) { return q.time_limit; },
          [](planner::Query& q, double t) {
            if (!(t > 0.0) || !std::isfinite(t)) throw pyb::value_error("time_limit: must be a finite number > 0");
            q.time_limit = t;
          },
          "Seconds.")
      .def_readwrite("cpu_time_limit", &planner::Query::cpu_time_limit)
      .def_readwrite("seed", &planner::Query::seed)
      .def_readwrite("objective", &planner::Query::objective)
      .def_readwrite("replay_rotation_step", &planner::Query::replay_rotation_step)
      .def_readwrite("replay_translation_step", &planner::Query::replay_translation_step)
      .def_readwrite("resolution_rotation", &planner::Query::resolution_rotation)
      .def_readwrite("resolution_translation", &planner::Query::resolution_translation)
      .def_readwrite("env_resolution", &planner::Query::env_resolution)
      .def_readwrite("goal_configuration_tolerance", &planner::Query::goal_configuration_tolerance)
      .def_readonly("target_name", &planner::Query::target_name)
      .def_property_readonly(
          "ranges",
          [](const planner::Query& q) {
            pyb::list l;
            for (const planner::RangeDimension& d : q.ranges) {
              pyb::dict e;
              e["name"] = d.name();
              e["lo"] = d.lo;
              e["hi"] = d.hi;
              l.append(e);
            }
            return l;
          },
          "Ranges (and values, lo == hi) of the robot's friction and drives: [{name, lo, hi}] (docs/planning.md "
          "\"Ranges\").")
      .def_property(
          "start", [](const planner::Query& q) { return configurationTuple(q.start); },
          [](planner::Query& q, const pyb::object& v) { q.start = configurationFromTuple(v, "start"); },
          "(alpha, beta) of the start.")
      .def_property_readonly(
          "history",
          [](const planner::Query& q) {
            pyb::dict d;
            d["kind"] = toString(q.history.kind);
            d["approach"] = q.history.approach;
            d["path"] = configurationArrays(q.history.path, q.start.size());
            return d;
          },
          "How the robot arrived at the start.")
      .def_property_readonly(
          "tip_goal",
          [](const planner::Query& q) -> pyb::object {
            if (!q.tip_goal) return pyb::none();
            pyb::dict d;
            d["position"] = array3(q.tip_goal->position);
            d["tolerance"] = q.tip_goal->tolerance;
            d["direction"] = q.tip_goal->direction ? pyb::object(array3(*q.tip_goal->direction)) : pyb::none();
            d["cone_angle"] = q.tip_goal->cone_angle;
            d["final_approach"] = q.tip_goal->final_approach;
            return std::move(d);
          },
          "Tip goal (world): position, tolerance, direction, cone_angle, final_approach; None for a goal "
          "configuration. A named "
          "target's "
          "position is resolved in the environment by CtrPlanner: read it from planner.query.")
      .def_property_readonly("goal_configuration",
                             [](const planner::Query& q) { return optionalConfiguration(q.goal_configuration); })
      .def_property(
          "friction",
          [](const planner::Query& q) -> pyb::object {
            if (!q.friction) return pyb::none();
            pyb::dict d;
            d["boundary"] = q.friction->boundary;
            d["distributed"] = q.friction->distributed;
            return std::move(d);
          },
          [](planner::Query& q, const pyb::object& v) {
            if (v.is_none()) {
              q.friction.reset();
              return;
            }
            const pyb::dict d = v.cast<pyb::dict>();
            FrictionCoefficients f;
            if (d.contains("boundary")) f.boundary = d["boundary"].cast<double>();
            if (d.contains("distributed")) f.distributed = d["distributed"].cast<double>();
            q.friction = f;
          },
          "Override of the robot's friction ({'boundary', 'distributed'}) or None.")
      .def_property(
          "loads",
          [](const planner::Query& q) -> pyb::object {
            if (!q.loads) return pyb::none();
            pyb::dict d;
            d["gravity"] = array3(q.loads->gravity);
            d["tip_force"] = array3(q.loads->tip_force);
            d["tip_moment"] = array3(q.loads->tip_moment);
            d["frame"] = q.loads_frame == planner::Query::LoadsFrame::Environment ? "environment" : "base";
            return std::move(d);
          },
          [](planner::Query& q, const pyb::object& v) {
            if (v.is_none()) {
              q.loads.reset();
              return;
            }
            const pyb::dict d = v.cast<pyb::dict>();
            Loads l;
            planner::Query::LoadsFrame frame = planner::Query::LoadsFrame::Base;
            for (const auto& kv : d) {
              const std::string k = kv.first.cast<std::string>();
              if (k == "frame") {
                const std::string f = kv.second.cast<std::string>();
                if (f != "base" && f != "environment")
                  throw pyb::value_error("loads: frame '" + f + "' is not base or environment");
                frame = f == "environment" ? planner::Query::LoadsFrame::Environment : planner::Query::LoadsFrame::Base;
                continue;
              }
              Eigen::Vector3d* dst = k == "gravity"      ? &l.gravity
                                     : k == "tip_force"  ? &l.tip_force
                                     : k == "tip_moment" ? &l.tip_moment
                                                         : nullptr;
              if (!dst)
                throw pyb::value_error("loads: unknown key '" + k + "' (gravity, tip_force, tip_moment, frame)");
              const Eigen::VectorXd x = toVector(kv.second, "loads " + k);
              if (x.size() != 3 || !x.allFinite()) throw pyb::value_error("loads: " + k + ": expected 3 finite values");
              *dst = x;
            }
            q.loads = l;
            q.loads_frame = frame;
          },
          "Override of the robot's loads ({'gravity', 'tip_force', 'tip_moment', 'frame': 'base' | 'environment'}; "
          "vectors in that frame) or None.")
      .def("line_of", &planner::Query::lineOf, arg("key"), "Line of a key in the query file (0 if unknown).")
      .def("__copy__", [](const planner::Query& q) { return planner::Query(q); })
      .def("__deepcopy__", [](const planner::Query& q, const pyb::dict&) { return planner::Query(q); })
      .def("__repr__", [](const planner::Query& q) {
        return "<ctr.Query '" + q.name + "', " + planner::toString(q.mode) + ", " + q.planner + ", " +
               pyb::repr(pyb::float_(q.time_limit)).cast<std::string>() + " s>";
      });

  m.def(
      "load_query", [](const std::filesystem::path& path) { return planner::loadQuery(path.string()); }, arg("path"),
      "Parses a query file. Raises ctr.InputError naming the file, line and key.");
  m.def("parse_query", &planner::parseQuery, arg("text"), arg("source") = "<string>", arg("base_dir") = ".",
        arg("check_files") = true, "Parses query text; relative paths resolve against base_dir.");
  m.def(
      "planner_names", [](const std::string& mode) { return planner::plannerNames(planner::parseMode(mode)); },
      arg("mode") = toString(planner::Mode::Exact), "Known planner names of a mode.");

  pyb::class_<Replay>(m, "ReplayReport",
                      "The planned path replayed at fine resolution through the stateful friction model: the summary "
                      "and per-step arrays.")
      .def_property_readonly("completed", [](const Replay& p) { return p.rep().completed; })
      .def_property_readonly("collision_free", [](const Replay& p) { return p.rep().collision_free; })
      .def_property_readonly("stable", [](const Replay& p) { return p.rep().stable; })
      .def_property_readonly("goal_reached", [](const Replay& p) { return p.rep().goal_reached; })
      .def_property_readonly("tip_error", [](const Replay& p) { return p.rep().tip_error; })
      .def_property_readonly("direction_error", [](const Replay& p) { return p.rep().direction_error; })
      .def_property_readonly("min_clearance", [](const Replay& p) { return p.rep().min_clearance; })
      .def_property_readonly("steps", [](const Replay& p) { return p.rep().steps; })
      .def_property_readonly("collisions", [](const Replay& p) { return p.rep().collisions; })
      .def_property_readonly("snaps", [](const Replay& p) { return p.rep().snaps; })
      .def_property_readonly("unstable", [](const Replay& p) { return p.rep().unstable; })
      .def_property_readonly("failure", [](const Replay& p) { return std::string(toString(p.rep().failure)); })
      .def_property_readonly(
          "message", [](const Replay& p) { return p.rep().message; },
          "What went wrong first, in words, with the step ('' when nothing did; `failure` is the same as a value).")
      .def_property_readonly(
          "first_failure", [](const Replay& p) { return p.rep().message; },
          "Deprecated alias of `message`; will be removed in the next release (use `message`).")
      .def_property_readonly("ok", [](const Replay& p) { return p.rep().ok(); })
      .def("__len__", [](const Replay& p) { return p.rep().points.size(); })
      .def_property_readonly(
          "alpha",
          [](const Replay& p) {
            std::vector<Configuration> qs;
            for (const auto& pt : p.rep().points) qs.push_back(pt.q);
            return pyb::object(configurationArrays(qs, p.ctx->robot().size())[0]);
          },
          "(M, n) commanded rotations at every replay step (unwrapped).")
      .def_property_readonly(
          "beta",
          [](const Replay& p) {
            std::vector<Configuration> qs;
            for (const auto& pt : p.rep().points) qs.push_back(pt.q);
            return pyb::object(configurationArrays(qs, p.ctx->robot().size())[1]);
          },
          "(M, n) commanded translations.")
      .def(
          "tip_positions",
          [](const Replay& p, bool world) {
            const auto& pts = p.rep().points;
            Eigen::MatrixXd P(pts.size(), 3);
            for (std::size_t k = 0; k < pts.size(); ++k) {
              const Eigen::Vector3d t = pts[k].solution.tip_position;
              P.row(static_cast<Eigen::Index>(k)) = (world ? Eigen::Vector3d(p.ctx->basePose() * t) : t).transpose();
            }
            return P;
          },
          arg("world") = true, "(M, 3) tip positions at every replay step, world frame (or the base frame).")
      .def_property_readonly(
          "clearance",
          [](const Replay& p) {
            Eigen::VectorXd c(p.rep().points.size());
            for (std::size_t k = 0; k < p.rep().points.size(); ++k)
              c[static_cast<Eigen::Index>(k)] = p.rep().points[k].clearance;
            return c;
          },
          "(M,) distance-field clearance at every replay step (m).")
      .def_property_readonly(
          "valid",
          [](const Replay& p) {
            pyb::array_t<bool> v(static_cast<pyb::ssize_t>(p.rep().points.size()));
            for (std::size_t k = 0; k < p.rep().points.size(); ++k)
              v.mutable_at(static_cast<pyb::ssize_t>(k)) = p.rep().points[k].valid;
            return v;
          },
          "(M,) converged, stable, no snap, collision-free.")
      .def_property_readonly(
          "twist",
          [](const Replay& p) {
            const int n = p.ctx->robot().size();
            Eigen::MatrixXd w = Eigen::MatrixXd::Constant(p.rep().points.size(), std::max(n - 1, 0), NAN);
            for (std::size_t k = 0; k < p.rep().points.size(); ++k) {
              const Solution& s = p.rep().points[k].solution;
              if (s.converged() && s.twist.size() == n - 1) w.row(static_cast<Eigen::Index>(k)) = s.twist.transpose();
            }
            return w;
          },
          "(M, n-1) twist at every replay step (rad).")
      .def_property_readonly(
          "states",
          [](const Replay& p) {
            pyb::list l;
            for (const auto& pt : p.rep().points) l.append(pyb::cast(pt.hysteresis));
            return l;
          },
          "HysteresisState after every replay step.")
      .def_property_readonly(
          "solutions",
          [](const Replay& p) {
            pyb::list l;
            for (const auto& pt : p.rep().points) l.append(pyb::cast(pt.solution));
            return l;
          },
          "Solution at every replay step (base frame, without backbone).")
      .def(
          "csv", [](const Replay& p) { return planner::replayCsv(p.ctx->robot(), p.rep()); },
          "The `ctr plan --path` CSV text (recording columns + clearance, validity, hysteresis).")
      .def("__repr__", [](const Replay& p) {
        return "<ctr.ReplayReport " + std::to_string(p.rep().steps) + " steps, " +
               (p.rep().ok() ? std::string("ok") : "failed: " + p.rep().message) + ">";
      });

  pyb::class_<Result>(m, "PlanResult", "Result of planning + replay; to_dict() is the `ctr plan --json` object.")
      .def_property_readonly(
          "solved", [](const Result& x) { return x.r->solved; },
          "Planner found a path AND its replay is collision-free, stable and reaches the goal.")
      .def_property_readonly("planner_solved", [](const Result& x) { return x.r->planner_solved; })
      .def_property_readonly("mode", [](const Result& x) { return std::string(planner::toString(x.r->mode)); })
      .def_property_readonly("planner", [](const Result& x) { return x.r->planner; })
      .def_property_readonly("planning_time", [](const Result& x) { return x.r->planning_time; })
      .def_property_readonly("planning_wall_time", [](const Result& x) { return x.r->planning_wall_time; })
      .def_property_readonly("replay_time", [](const Result& x) { return x.r->replay_time; })
      .def_property_readonly("path_length", [](const Result& x) { return x.r->path_length; })
      .def_property_readonly("goal_pool", [](const Result& x) { return x.r->goal_pool; })
      .def_property_readonly(
          "final_approach",
          [](const Result& x) -> pyb::object {
            if (!x.r->final_approach) return pyb::none();
            return pathArray({*x.r->final_approach}, x.ctx->robot().size());
          },
          "Robust mode: the final approach move the path ends with, (1, 2n) [alpha_1..alpha_n, beta_1..beta_n], or "
          "None.")
      .def_property_readonly("message", [](const Result& x) { return x.r->message; })
      .def_property_readonly(
          "path", [](const Result& x) { return pathArray(x.r->path, x.ctx->robot().size()); },
          "(K, 2n) waypoints [alpha_1..alpha_n, beta_1..beta_n] from the start (unwrapped rotations).")
      .def_property_readonly(
          "path_alpha",
          [](const Result& x) { return pyb::object(configurationArrays(x.r->path, x.ctx->robot().size())[0]); })
      .def_property_readonly(
          "path_beta",
          [](const Result& x) { return pyb::object(configurationArrays(x.r->path, x.ctx->robot().size())[1]); })
      .def_property_readonly("replay",
                             [](const Result& x) {
                               return Replay{x.r, x.ctx};
                             })
      .def_property_readonly("query", [](const Result& x) { return x.query; })
      .def_property_readonly(
          "range_replay",
          [](const Result& x) {
            return x.r->range_replay ? pyb::object(resultDict(x.query, *x.r)["range_replay"])
                                     : pyb::object(pyb::none());
          },
          "With ranges (robust mode): the path replayed at every corner of the ranges and at 20 samples inside them, "
          "as the JSON's range_replay (docs/formats.md); None without ranges or when the replay at the middle failed.")
      .def(
          "to_dict", [](const Result& x) { return resultDict(x.query, *x.r); },
          "The `ctr plan --json` object of this result.")
      .def("__repr__", [](const Result& x) {
        return std::string("<ctr.PlanResult ") + (x.r->solved ? "solved" : "not solved") + ", " + x.r->planner + ", " +
               std::to_string(x.r->path.size()) + " waypoints" + (x.r->message.empty() ? "" : ": " + x.r->message) +
               ">";
      });

  pyb::class_<planner::CtrPlanner>(m, "CtrPlanner",
                                   "A planning problem built from a query (robot, environment, collision checker, OMPL "
                                   "set-up). solve() plans within the time limit, then replays the path through the "
                                   "friction model. One solve at a time per planner (build one planner per thread). "
                                   "OMPL's random seed is the first planner's query seed, set once per process.")
      .def(pyb::init([](const planner::Query& q) {
             pyb::gil_scoped_release release;
             return std::make_unique<planner::CtrPlanner>(q);
           }),
           arg("query"), "Loads the query's robot and environment (ctr.InputError for bad files); no GIL.")
      .def(pyb::init(
               [](const planner::Query& q, const Robot& robot, const std::shared_ptr<environments::Environment>& e) {
                 if (!e) throw pyb::value_error("environment: None");
                 pyb::gil_scoped_release release;
                 return std::make_unique<planner::CtrPlanner>(q, robot, *e);
               }),
           arg("query"), arg("robot"), arg("environment"),
           "With a robot and an environment already loaded (the query's paths are then ignored).")
      .def_property_readonly("query", &planner::CtrPlanner::query, "The query as planned (start projected).")
      .def_property_readonly(
          "robot", [](const planner::CtrPlanner& p) { return p.context()->robot(); },
          "The robot with the query's friction.")
      .def_property_readonly("environment",
                             [](const planner::CtrPlanner& p) {
                               return std::const_pointer_cast<environments::Environment>(p.context()->environmentPtr());
                             })
      .def(
          "check_start",
          [](const planner::CtrPlanner& p) {
            pyb::gil_scoped_release release;
            p.checkStart();
          },
          "Raises ctr.InputError when the start does not converge or is invalid (as `ctr plan` before planning).")
      .def(
          "solve",
          [](planner::CtrPlanner& p, const std::optional<std::string>& planner, std::optional<double> time_limit,
             bool check_start) {
            Result x;
            x.ctx = p.context();
            x.query = p.query();
            {
              pyb::gil_scoped_release release;
              if (check_start) p.checkStart();
              if (planner || time_limit) {
                const std::string name = planner.value_or(p.query().planner);
                const double t = time_limit.value_or(p.query().time_limit);
                if (!(t > 0.0)) throw std::invalid_argument("time_limit: must be > 0");
                p.makePlanner(name);  // unknown planner: ValueError before planning
                x.r = std::make_shared<const planner::PlanResult>(p.solve(name, t));
                x.query.planner = name;
                x.query.time_limit = t;
              } else {
                p.makePlanner(p.query().planner);
                x.r = std::make_shared<const planner::PlanResult>(p.solve());
              }
            }
            return x;
          },
          arg("planner") = pyb::none(), arg("time_limit") = pyb::none(), arg("check_start") = true,
          "Plans (the query's planner and time limit, or these), then replays the path; never reports an unreplayed "
          "path as solved. With check_start, an invalid start raises ctr.InputError first (as `ctr plan`). No GIL.");
}

}  // namespace ctr::py
