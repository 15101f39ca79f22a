#include "ctr/planner/query.hpp"

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <filesystem>
#include <set>
#include <sstream>

#include "ctr/io/file.hpp"
#include "ctr/io/input_error.hpp"
#include "ctr/io/yaml_reader.hpp"

namespace ctr::planner {
namespace {

using io::InputError;

struct Ctx : io::YamlReader {
  bool check_files = true;
  Eigen::VectorXd vec(const YAML::Node& n, const std::string& key, int size = -1) const {
    if (!n.IsSequence()) fail(n, key, "must be a list of numbers");
    Eigen::VectorXd v(static_cast<int>(n.size()));
    for (std::size_t i = 0; i < n.size(); ++i)
      v[static_cast<int>(i)] = number(n[i], key + "[" + std::to_string(i) + "]");
    if (size >= 0 && v.size() != size)
      fail(n, key, "needs " + std::to_string(size) + " values, has " + std::to_string(v.size()));
    return v;
  }
  std::string path(const YAML::Node& n, const std::string& key, const std::string& base) const {
    const std::string p = text(n, key);
    std::filesystem::path fp(p);
    if (fp.is_relative()) fp = std::filesystem::path(base) / fp;
    if (check_files && !std::filesystem::exists(fp)) fail(n, key, "file not found: " + fp.string());
    return fp.lexically_normal().string();
  }
};

// A value (lo = hi) or a range [lo, hi] of one of the robot's values.
RangeDimension range(const Ctx& c, const YAML::Node& n, const std::string& key, RangeDimension::Kind kind, int tube) {
  RangeDimension d;
  d.kind = kind;
  d.tube = tube;
  if (n.IsSequence()) {
    const Eigen::VectorXd v = c.vec(n, key, 2);
    if (!(v[0] <= v[1])) c.fail(n, key, "a range [lo, hi] needs lo <= hi");
    d.lo = v[0];
    d.hi = v[1];
  } else {
    d.lo = d.hi = c.number(n, key);
  }
  return d;
}

Configuration configuration(const Ctx& c, const YAML::Node& n, const std::string& where) {
  if (!n.IsMap()) c.fail(n, where, "must be a map with alpha and beta");
  c.allowOnly(n, where, {"alpha", "beta", "history", "approach"});
  if (!n["alpha"]) c.fail(n, where + ".alpha", "missing");
  if (!n["beta"]) c.fail(n, where + ".beta", "missing");
  const Eigen::VectorXd a = c.vec(n["alpha"], where + ".alpha");
  const Eigen::VectorXd b = c.vec(n["beta"], where + ".beta", static_cast<int>(a.size()));
  return Configuration(a, b);
}

}  // namespace

std::vector<std::string> plannerNames(Mode mode) {
  if (mode == Mode::Exact) return {"rrt", "kpiece", "sst", "est", "pdst", "portfolio"};
  return {"rrtconnect", "portfolio", "rrt",    "rrtstar", "bitstar", "prm",
          "prmstar",    "lazyprm",   "kpiece", "bkpiece", "est",     "sbl"};
}

namespace {
Query parseQueryYaml(const std::string& text, const std::string& source, const std::string& base_dir,
                     bool check_files) {
  Ctx c;
  c.file = source;
  c.check_files = check_files;
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::ParserException& e) {
    throw InputError(source, e.mark.line + 1, "", std::string("not valid YAML: ") + e.msg);
  }
  if (!root.IsMap()) throw InputError(source, 0, "", "a query must be a YAML map");
  c.allowOnly(root, "",
              {"name", "robot", "environment", "base_start", "friction", "start", "goal", "loads", "mode", "planner",
               "time_limit", "time_limit_clock", "seed", "objective", "replay", "resolution", "environment_resolution",
               "actuation", "robot_uncertainty"});
  Query q;
  q.file = source;
  // Lines of the keys (two levels) for messages about problems detected later.
  for (const auto& kv : root) {
    const std::string k = kv.first.Scalar();
    q.key_lines[k] = kv.first.Mark().line + 1;
    if (kv.second.IsMap())
      for (const auto& kv2 : kv.second) q.key_lines[k + "." + kv2.first.Scalar()] = kv2.first.Mark().line + 1;
  }
  q.name = root["name"] ? c.text(root["name"], "name") : std::filesystem::path(source).stem().string();
  for (const char* k : {"robot", "environment", "start", "goal"})
    if (!root[k]) throw InputError(source, 0, k, "missing (a query needs robot, environment, start and goal)");
  q.robot = c.path(root["robot"], "robot", base_dir);
  q.environment = c.path(root["environment"], "environment", base_dir);
  if (root["base_start"]) q.base_start = c.text(root["base_start"], "base_start");
  if (root["friction"]) {
    const YAML::Node f = root["friction"];
    if (!f.IsMap()) c.fail(f, "friction", "must be a map with boundary and/or distributed");
    c.allowOnly(f, "friction", {"boundary", "distributed"});
    FrictionCoefficients fc;
    // A number, or a range [lo, hi] (the robot at its middle; robust mode plans for all of it).
    auto coefficient = [&](const char* key, RangeDimension::Kind kind, double& value) {
      const std::string name = std::string("friction.") + key;
      if (!f[key]) return;
      if (f[key].IsSequence()) {
        const RangeDimension d = range(c, f[key], name, kind, 0);
        value = 0.5 * (d.lo + d.hi);
        q.ranges.push_back(d);
      } else {
        value = c.number(f[key], name);
      }
      if (value < 0 || (f[key].IsSequence() && q.ranges.back().lo < 0)) c.fail(f[key], name, "must be >= 0");
    };
    coefficient("boundary", RangeDimension::Kind::BoundaryFriction, fc.boundary);
    coefficient("distributed", RangeDimension::Kind::DistributedFriction, fc.distributed);
    q.friction = fc;
  }
  if (root["actuation"]) {
    // Values or ranges of the robot's drives: a list of {tube, rotation: {offset, play}, translation: {...}}.
    const YAML::Node a = root["actuation"];
    if (!a.IsSequence()) c.fail(a, "actuation", "must be a list of {tube, rotation, translation}");
    for (std::size_t i = 0; i < a.size(); ++i) {
      const std::string where = "actuation[" + std::to_string(i) + "]";
      const YAML::Node e = a[i];
      if (!e.IsMap()) c.fail(e, where, "must be a map with tube and rotation and/or translation");
      c.allowOnly(e, where, {"tube", "rotation", "translation"});
      if (!e["tube"]) c.fail(e, where + ".tube", "missing (1 = the outermost tube)");
      const double tube = c.number(e["tube"], where + ".tube");
      if (tube < 1 || tube != std::floor(tube)) c.fail(e["tube"], where + ".tube", "must be a tube number >= 1");
      for (const bool rotation : {true, false}) {
        const char* joint = rotation ? "rotation" : "translation";
        const YAML::Node j = e[joint];
        if (!j) continue;
        const std::string jw = where + "." + joint;
        if (!j.IsMap()) c.fail(j, jw, "must be a map with offset and/or play");
        c.allowOnly(j, jw, {"offset", "play"});
        using K = RangeDimension::Kind;
        if (j["offset"])
          q.ranges.push_back(range(c, j["offset"], jw + ".offset", rotation ? K::RotationOffset : K::TranslationOffset,
                                   static_cast<int>(tube)));
        if (j["play"])
          q.ranges.push_back(range(c, j["play"], jw + ".play", rotation ? K::RotationPlay : K::TranslationPlay,
                                   static_cast<int>(tube)));
      }
    }
  }
  if (root["robot_uncertainty"]) {
    // A diagnosis's 95 % intervals; the query's own ranges replace its range of the same value.
    q.robot_uncertainty = c.path(root["robot_uncertainty"], "robot_uncertainty", base_dir);
    if (std::filesystem::exists(q.robot_uncertainty)) {
      for (const RangeDimension& d : rangesFromDiagnosis(q.robot_uncertainty, &q.uncertainty_skipped)) {
        bool given = false;
        for (const RangeDimension& e : q.ranges) given = given || (e.kind == d.kind && e.tube == d.tube);
        if (!given) q.ranges.push_back(d);
      }
    }
  }
  if (root["loads"]) {
    const YAML::Node l = root["loads"];
    if (!l.IsMap()) c.fail(l, "loads", "must be a map with gravity, tip_force, tip_moment and/or frame");
    c.allowOnly(l, "loads", {"gravity", "tip_force", "tip_moment", "frame"});
    Loads loads;
    if (l["gravity"]) loads.gravity = c.vec(l["gravity"], "loads.gravity", 3);
    if (l["tip_force"]) loads.tip_force = c.vec(l["tip_force"], "loads.tip_force", 3);
    if (l["tip_moment"]) loads.tip_moment = c.vec(l["tip_moment"], "loads.tip_moment", 3);
    if (l["frame"]) {
      const std::string f = c.text(l["frame"], "loads.frame");
      if (f == "environment") {
        q.loads_frame = Query::LoadsFrame::Environment;
      } else if (f != "base") {
        c.fail(l["frame"], "loads.frame", "'" + f + "' is not base or environment");
      }
    }
    q.loads = loads;
  }
  const YAML::Node st = root["start"];
  q.start = configuration(c, st, "start");
  if (st["history"]) {
    const std::string h = c.text(st["history"], "start.history");
    bool known = false;
    for (StartHistory::Kind k : {StartHistory::Kind::Rest, StartHistory::Kind::Positive, StartHistory::Kind::Negative})
      if (h == toString(k)) {
        q.history.kind = k;
        known = true;
      }
    if (!known) c.fail(st["history"], "start.history", "'" + h + "' is not one of rest, positive, negative");
  }
  if (st["approach"]) {
    q.history.approach = c.number(st["approach"], "start.approach");
    if (!(q.history.approach > 0)) c.fail(st["approach"], "start.approach", "must be > 0 (rad)");
  }
  const YAML::Node g = root["goal"];
  if (!g.IsMap()) c.fail(g, "goal", "must be a map");
  c.allowOnly(g, "goal",
              {"target", "position", "tolerance", "direction", "cone_angle", "configuration", "final_approach"});
  const int kinds = (g["target"] ? 1 : 0) + (g["position"] ? 1 : 0) + (g["configuration"] ? 1 : 0);
  if (kinds != 1) c.fail(g, "goal", "give exactly one of target (a named target), position [x,y,z] or configuration");
  if (g["configuration"]) {
    q.goal_configuration = configuration(c, g["configuration"], "goal.configuration");
    if (q.goal_configuration->size() != q.start.size())
      c.fail(g["configuration"], "goal.configuration", "has a different number of tubes than start");
    if (g["tolerance"]) q.goal_configuration_tolerance = c.number(g["tolerance"], "goal.tolerance");
    if (g["final_approach"])
      c.fail(g["final_approach"], "goal.final_approach",
             "applies to a tip goal (target or position), not a configuration");
  } else {
    TipGoalSpec spec;
    if (g["position"]) spec.position = c.vec(g["position"], "goal.position", 3);
    if (g["target"]) q.target_name = c.text(g["target"], "goal.target");
    if (g["tolerance"]) spec.tolerance = c.number(g["tolerance"], "goal.tolerance");
    if (!(spec.tolerance > 0)) c.fail(g["tolerance"], "goal.tolerance", "must be > 0 (m)");
    if (g["direction"]) {
      const Eigen::Vector3d d = c.vec(g["direction"], "goal.direction", 3);
      if (d.norm() < 1e-9) c.fail(g["direction"], "goal.direction", "must be a non-zero vector");
      spec.direction = d.normalized();
    }
    if (g["cone_angle"]) spec.cone_angle = c.number(g["cone_angle"], "goal.cone_angle");
    if (g["final_approach"]) spec.final_approach = c.boolean(g["final_approach"], "goal.final_approach");
    q.tip_goal = spec;
  }
  if (root["mode"]) {
    try {
      q.mode = parseMode(c.text(root["mode"], "mode"));
    } catch (const std::invalid_argument& e) {
      c.fail(root["mode"], "mode", e.what());
    }
  }
  if (root["planner"]) {
    q.planner = c.text(root["planner"], "planner");
    const auto names = plannerNames(q.mode);
    if (q.planner != "default" && std::find(names.begin(), names.end(), q.planner) == names.end()) {
      std::string known;
      for (const auto& x : names) known += (known.empty() ? "" : ", ") + x;
      c.fail(root["planner"], "planner",
             "'" + q.planner + "' is not a planner of mode " + toString(q.mode) + " (" + known + ")");
    }
  }
  if (root["time_limit"]) {
    q.time_limit = c.number(root["time_limit"], "time_limit");
    if (!(q.time_limit > 0)) c.fail(root["time_limit"], "time_limit", "must be > 0 seconds");
  }
  if (root["time_limit_clock"]) {
    const std::string clk = c.text(root["time_limit_clock"], "time_limit_clock");
    if (clk != "wall" && clk != "cpu")
      c.fail(root["time_limit_clock"], "time_limit_clock", "must be wall or cpu, not '" + clk + "'");
    q.cpu_time_limit = clk == "cpu";
  }
  if (root["seed"]) {
    const double s = c.number(root["seed"], "seed");
    if (s < 0 || s != std::floor(s)) c.fail(root["seed"], "seed", "must be a non-negative integer");
    q.seed = static_cast<std::uint64_t>(s);
  }
  if (root["objective"]) {
    q.objective = c.text(root["objective"], "objective");
    if (q.objective != "path_length" && q.objective != "clearance")
      c.fail(root["objective"], "objective", "'" + q.objective + "' is not path_length or clearance");
  }
  if (root["replay"]) {
    const YAML::Node r = root["replay"];
    c.allowOnly(r, "replay", {"rotation_step", "translation_step"});
    if (r["rotation_step"]) q.replay_rotation_step = c.number(r["rotation_step"], "replay.rotation_step");
    if (r["translation_step"]) q.replay_translation_step = c.number(r["translation_step"], "replay.translation_step");
    if (!(q.replay_rotation_step > 0) || !(q.replay_translation_step > 0)) c.fail(r, "replay", "steps must be > 0");
  }
  q.resolution_rotation = q.replay_rotation_step;  // default: check motions at the replay resolution
  q.resolution_translation = q.replay_translation_step;
  if (root["resolution"]) {
    const YAML::Node r = root["resolution"];
    c.allowOnly(r, "resolution", {"rotation", "translation"});
    if (r["rotation"]) q.resolution_rotation = c.number(r["rotation"], "resolution.rotation");
    if (r["translation"]) q.resolution_translation = c.number(r["translation"], "resolution.translation");
    if (!(q.resolution_rotation > 0) || !(q.resolution_translation > 0)) c.fail(r, "resolution", "must be > 0");
  }
  if (root["environment_resolution"]) {
    q.env_resolution = c.number(root["environment_resolution"], "environment_resolution");
    if (!(q.env_resolution > 0)) c.fail(root["environment_resolution"], "environment_resolution", "must be > 0 (m)");
  }
  return q;
}
}  // namespace

Query parseQuery(const std::string& text, const std::string& source, const std::string& base_dir, bool check_files) {
  try {
    return parseQueryYaml(text, source, base_dir, check_files);
  } catch (const YAML::Exception& e) {
    // A node of the wrong kind where a map is expected (e.g. `resolution: 1`) throws from yaml-cpp's operator[]:
    // bad input, reported with its line (it used to escape as YAML::BadSubscript; found by fuzz_query_yaml in CI).
    throw InputError(source, e.mark.line >= 0 ? e.mark.line + 1 : 0, "", "malformed query: " + e.msg);
  }
}

Query loadQuery(const std::string& path) {
  const std::string text = io::readFile(path);
  if (text.find_first_not_of(" \t\r\n") == std::string::npos) throw io::InputError(path, 0, "", "empty query file");
  return parseQuery(text, path, std::filesystem::path(path).parent_path().string());
}

int Query::lineOf(const std::string& key) const {
  for (std::string k = key;;) {
    const auto it = key_lines.find(k);
    if (it != key_lines.end()) return it->second;
    const auto dot = k.rfind('.');
    if (dot == std::string::npos) return 0;
    k.erase(dot);
  }
}

}  // namespace ctr::planner
