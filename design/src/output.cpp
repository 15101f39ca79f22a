#include "ctr/design/output.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "ctr/io/file.hpp"
#include "ctr/io/input_error.hpp"

namespace fs = std::filesystem;
using nlohmann::json;

namespace ctr::design {
namespace {

json num(double v) {
  return std::isfinite(v) ? json(v) : json(nullptr);
}

json vecJson(const Eigen::VectorXd& v) {
  json a = json::array();
  for (int i = 0; i < v.size(); ++i) a.push_back(v[i]);
  return a;
}

json candidateJson(const DesignSpace& space, const Candidate& c) {
  json tubes = json::array();
  for (std::size_t i = 0; i < c.tubes.size(); ++i) {
    const auto& t = c.tubes[i];
    const TubeSize& sz = space.catalogue.at(static_cast<std::size_t>(t.size));
    tubes.push_back({{"name", space.tubes[i].name},
                     {"straight_length", t.straight_length},
                     {"curved_length", t.curved_length},
                     {"curvature", t.curvature},
                     {"size", sz.name},
                     {"outer_diameter", sz.outer_diameter},
                     {"inner_diameter", sz.inner_diameter},
                     {"strain", strain(space, c, static_cast<int>(i))}});
  }
  return tubes;
}

json scoreJson(const Score& s) {
  return {{"solved", s.solved()},
          {"badness", num(s.badness)},
          {"clearance", num(s.clearance)},
          {"length", num(s.length)},
          {"success_rate", s.confirmed() ? json(s.success_rate) : json(nullptr)}};
}

// A query's independent plans of a finalist: counts and rate, with every plan when `runs`.
json confirmationJson(const QueryOutcome& q, bool runs) {
  int found = 0;
  json plans = json::array();
  for (const ConfirmationPlan& p : q.confirmation) {
    found += p.path_found ? 1 : 0;
    plans.push_back({{"seed", p.seed},
                     {"path_found", p.path_found},
                     {"solved", p.solved},
                     {"min_clearance", num(p.min_clearance)},
                     {"planning_time", p.planning_time},
                     {"message", p.message}});
  }
  const int n = static_cast<int>(q.confirmation.size());
  json j = {{"plans", n},
            {"paths_found", found},
            {"solved", q.confirmationSolved()},
            {"success_rate", n > 0 ? json(static_cast<double>(q.confirmationSolved()) / n) : json(nullptr)}};
  if (runs) j["runs"] = plans;
  return j;
}

Score scoreFrom(const json& j) {
  Score s;
  auto get = [&](const char* k, double dflt) { return j.contains(k) && j[k].is_number() ? j[k].get<double>() : dflt; };
  s.badness = get("badness", std::numeric_limits<double>::infinity());
  s.clearance = get("clearance", -std::numeric_limits<double>::infinity());
  s.length = get("length", std::numeric_limits<double>::infinity());
  s.success_rate = get("success_rate", -1.0);
  return s;
}

json evaluationJson(const DesignSpace& space, const Evaluation& e) {
  json qs = json::array();
  for (const QueryOutcome& q : e.queries)
    qs.push_back({{"stage", toString(q.stage)},
                  {"closest", num(q.closest)},
                  {"goal_clearance", num(q.goal_clearance)},
                  {"goal_collision_length", num(q.goal_collision_length)},
                  {"goal_collision_tubes", q.goal_collision_tubes},
                  {"ik_tried", q.ik_tried},
                  {"ik_on_target", q.ik_on_target},
                  {"valid_goals", q.valid_goals},
                  {"plans", q.plans},
                  {"plans_solved", q.plans_solved},
                  {"min_clearance", num(q.min_clearance)},
                  {"seconds", q.seconds},
                  {"message", q.message}});
  for (std::size_t k = 0; k < e.queries.size(); ++k)
    if (!e.queries[k].confirmation.empty()) qs[k]["confirmation"] = confirmationJson(e.queries[k], true);
  return {{"start", e.start},
          {"index", e.index},
          {"generation", e.generation},
          {"seconds", e.seconds},
          {"score", scoreJson(e.score)},
          {"design", candidateJson(space, e.candidate)},
          {"queries", qs}};
}

std::string fingerprint(const Designer& d, const DesignOptions& o) {
  std::ostringstream s;
  for (const auto& q : d.queries()) {
    s << q.file << "\n";
    try {
      s << io::readFile(q.file);
    } catch (const std::exception&) {
    }
  }
  s << spaceToYaml(d.space()) << o.seed << "/" << o.starts << "/" << o.evaluations << "/" << o.population << "/"
    << o.probe_time << "/" << o.probe_candidates << "/" << o.probe_goals << "/" << o.plan_time << "/" << o.planner
    << "/" << o.confirm_seeds << "/" << o.finalists << "/" << o.finalist_plans << "/" << o.finalist_rate;
  std::ostringstream h;
  h << std::hex << std::hash<std::string>{}(s.str());
  return h.str();
}

std::string relative(const std::string& path, const std::string& dir) {
  return fs::relative(fs::absolute(path), fs::absolute(dir)).lexically_normal().string();
}

}  // namespace

std::string queryFileStem(const std::string& query_name) {
  std::string s = query_name;
  for (char& c : s)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' || c == '.')) c = '_';
  return s;
}

std::string designedQueryYaml(const std::string& query_file, const std::string& robot_path, const Configuration& start,
                              const std::string& dir) {
  YAML::Node root = YAML::Load(io::readFile(query_file));
  const fs::path base = fs::path(query_file).parent_path();
  auto resolve = [&](const std::string& p) { return fs::path(p).is_relative() ? (base / p).string() : p; };
  root["robot"] = relative(robot_path, dir);
  root["environment"] = relative(resolve(root["environment"].as<std::string>()), dir);
  YAML::Node a(YAML::NodeType::Sequence), b(YAML::NodeType::Sequence);
  for (int i = 0; i < start.size(); ++i) {
    a.push_back(start.alpha[i]);
    b.push_back(start.beta[i]);
  }
  a.SetStyle(YAML::EmitterStyle::Flow);
  b.SetStyle(YAML::EmitterStyle::Flow);
  root["start"]["alpha"] = a;
  root["start"]["beta"] = b;
  YAML::Emitter em;
  em.SetDoublePrecision(17);
  em << root;
  return "# " + fs::path(query_file).filename().string() +
         " with the designed robot (ctr design; start: every tube's distal end where the query puts it)\n" +
         em.c_str() + "\n";
}

std::string resultJson(const Designer& d, const DesignResult& r, const DesignOptions& o, const std::string& shard) {
  json j;
  j["solved"] = r.solved;
  j["message"] = r.message;
  j["shard"] = shard;
  j["fingerprint"] = fingerprint(d, o);
  j["wall_time"] = r.wall_time;
  j["budget_exhausted"] = r.budget_exhausted;
  j["objective"] =
      "feasibility first (per query: 0 solved with clean replays, 1 no clean path, 2 no valid goal, 3 target not "
      "reached, 4 invalid start, plus a progress within the stage), then the largest minimum clearance along the "
      "replayed paths (0.1 mm bins), then the shortest longest tube";
  j["options"] = {{"seed", o.seed},
                  {"starts", o.starts},
                  {"evaluations", o.evaluations},
                  {"population", o.population},
                  {"time_limit", o.time_limit},
                  {"probe_time", o.probe_time},
                  {"probe_candidates", o.probe_candidates},
                  {"probe_goals", o.probe_goals},
                  {"plan_time", o.plan_time},
                  {"planner", o.planner},
                  {"confirm_seeds", o.confirm_seeds},
                  {"finalists", o.finalists},
                  {"finalist_plans", o.finalist_plans},
                  {"finalist_rate", o.finalist_rate}};
  json starts = json::array();
  if (o.start_indices.empty())
    for (int s = 0; s < o.starts; ++s) starts.push_back(s);
  else
    for (int s : o.start_indices) starts.push_back(s);
  j["starts_run"] = starts;
  j["space"] = spaceToYaml(d.space());
  json queries = json::array();
  for (std::size_t k = 0; k < d.queries().size(); ++k) {
    const planner::Query& q = d.queries()[k];
    json e = {{"query", q.name}, {"file", fs::absolute(q.file).lexically_normal().string()}};
    if (r.best && k < r.best->queries.size()) {
      const QueryOutcome& b = r.best->queries[k];
      e["stage"] = toString(b.stage);
      e["start"] = {{"alpha", vecJson(b.start.alpha)}, {"beta", vecJson(b.start.beta)}};
      e["plan"] = b.plan_json.empty() ? json(nullptr) : json::parse(b.plan_json);
      if (!b.message.empty()) e["message"] = b.message;
      if (!b.confirmation.empty()) e["confirmation"] = confirmationJson(b, false);
    }
    queries.push_back(e);
  }
  j["queries"] = queries;
  // The query's own robot (the first query's), for comparison with the design.
  {
    const Robot& b = d.baseRobot();
    json tubes = json::array();
    for (const Tube& t : b.tubes())
      tubes.push_back({{"name", t.name},
                       {"straight_length", t.straight_length},
                       {"curved_length", t.curved_length},
                       {"curvature", t.curvature},
                       {"outer_diameter", t.outer_diameter},
                       {"inner_diameter", t.inner_diameter},
                       {"strain", t.curvature * 0.5 * t.outer_diameter}});
    j["base"] = {{"robot", b.name()}, {"tubes", tubes}, {"in_space", d.baseCandidate().has_value()}};
  }
  if (r.best) {
    j["design"] = evaluationJson(d.space(), *r.best);
    j["design"]["robot"] = r.best->robot_yaml;
  } else {
    j["design"] = nullptr;
  }
  // The kept design's independent plans (null when it was not confirmed), and every finalist's, best first.
  if (r.best && r.best->score.confirmed()) {
    int plans = 0, solved = 0;
    json per = json::array();
    for (std::size_t k = 0; k < r.best->queries.size(); ++k) {
      const QueryOutcome& q = r.best->queries[k];
      plans += static_cast<int>(q.confirmation.size());
      solved += q.confirmationSolved();
      json e = confirmationJson(q, false);
      e["query"] = k < d.queries().size() ? d.queries()[k].name : std::to_string(k);
      per.push_back(e);
    }
    j["confirmation"] = {{"seeds", r.confirmation_seeds},
                         {"plans", plans},
                         {"solved", solved},
                         {"success_rate", r.best->score.success_rate},
                         {"required_rate", o.finalist_rate},
                         {"passed", r.best->score.success_rate >= o.finalist_rate},
                         {"queries", per}};
  } else {
    j["confirmation"] = nullptr;
  }
  json fin = json::array();
  for (std::size_t i : r.finalists) {
    const Evaluation& e = r.evaluations.at(i);
    int plans = 0, solved = 0;
    for (const QueryOutcome& q : e.queries) {
      plans += static_cast<int>(q.confirmation.size());
      solved += q.confirmationSolved();
    }
    fin.push_back({{"start", e.start},
                   {"index", e.index},
                   {"plans", plans},
                   {"solved", solved},
                   {"success_rate", e.score.confirmed() ? json(e.score.success_rate) : json(nullptr)},
                   {"score", scoreJson(e.score)}});
  }
  j["finalists"] = fin;
  json evs = json::array();
  for (const Evaluation& e : r.evaluations) evs.push_back(evaluationJson(d.space(), e));
  j["evaluations"] = evs;
  return j.dump(2);
}

void writeDesign(const Designer& d, const DesignResult& r, const DesignOptions& o, const std::string& shard,
                 const std::string& dir) {
  fs::create_directories(dir);
  const std::string robot_path = (fs::path(dir) / "robot.yaml").string();
  if (r.best && !r.best->robot_yaml.empty()) {
    io::writeFileAtomic(robot_path, r.best->robot_yaml);
    fs::create_directories(fs::path(dir) / "queries");
    for (std::size_t k = 0; k < d.queries().size(); ++k) {
      const QueryOutcome& b = r.best->queries[k];
      const std::string name = queryFileStem(d.queries()[k].name);
      if (b.start.size() > 0) {
        const fs::path qd = fs::path(dir) / "queries";
        io::writeFileAtomic((qd / (name + ".yaml")).string(),
                            designedQueryYaml(d.queries()[k].file, robot_path, b.start, qd.string()));
      }
      if (!b.path_csv.empty()) {
        fs::create_directories(fs::path(dir) / "paths");
        io::writeFileAtomic((fs::path(dir) / "paths" / (name + ".csv")).string(), b.path_csv);
      }
    }
  }
  io::writeFileAtomic((fs::path(dir) / "space.yaml").string(), spaceToYaml(d.space()));
  io::writeFileAtomic((fs::path(dir) / "result.json").string(), resultJson(d, r, o, shard) + "\n");
}

std::string mergeDesigns(const std::vector<std::string>& dirs, const std::string& out, bool allow_incomplete) {
  struct Part {
    fs::path dir;
    json j;
  };
  std::vector<Part> parts;
  for (const std::string& d : dirs) {
    std::vector<fs::path> found;
    if (fs::exists(fs::path(d) / "shards"))
      for (const auto& e : fs::directory_iterator(fs::path(d) / "shards"))
        if (fs::exists(e.path() / "result.json")) found.push_back(e.path());
    if (found.empty() && fs::exists(fs::path(d) / "result.json")) found.push_back(d);
    if (found.empty()) throw io::InputError(d, 0, "", "no design shard here (DIR/shards/*/result.json)");
    std::sort(found.begin(), found.end());
    for (const fs::path& p : found) {
      const std::string f = (p / "result.json").string();
      json j;
      try {
        j = json::parse(io::readFile(f));
      } catch (const json::exception& e) {
        throw io::InputError(f, 0, "", std::string("not a design result: ") + e.what());
      }
      for (const char* k : {"shard", "fingerprint", "evaluations", "queries"})
        if (!j.contains(k)) throw io::InputError(f, 0, k, "missing (not a design result)");
      parts.push_back({p, std::move(j)});
    }
  }
  const std::string fp = parts.front().j["fingerprint"].get<std::string>();
  std::size_t count = 0;
  std::map<std::size_t, fs::path> seen;
  for (const Part& p : parts) {
    const std::string f = (p.dir / "result.json").string();
    if (p.j["fingerprint"].get<std::string>() != fp)
      throw io::InputError(f, 0, "fingerprint", "belongs to another design run (other queries, space or options)");
    const std::string s = p.j["shard"].is_string() ? p.j["shard"].get<std::string>() : p.j["shard"].dump();
    unsigned long i = 0, n = 0;
    char extra = 0;
    if (std::sscanf(s.c_str(), "%lu/%lu%c", &i, &n, &extra) != 2 || n == 0 || i >= n)
      throw io::InputError(f, 0, "shard",
                           "'" + s + "' is not I/N with 0 <= I < N" +
                               (s == "merged" ? " (a merged result is not a shard: merge the shard folders)" : ""));
    if (count == 0) count = n;
    if (n != count)
      throw io::InputError(f, 0, "shard", "shard " + s + " of another shard count than " + std::to_string(count));
    if (seen.count(i))
      throw io::InputError(f, 0, "shard", "shard " + s + " twice: " + seen[i].string() + " and " + p.dir.string());
    seen[i] = p.dir;
  }
  std::string missing;
  for (std::size_t i = 0; i < count; ++i)
    if (!seen.count(i)) missing += (missing.empty() ? "" : ", ") + std::to_string(i) + "/" + std::to_string(count);
  if (!missing.empty() && !allow_incomplete)
    throw io::InputError(dirs.front(), 0, "", "missing shards: " + missing + " (--allow-incomplete merges the rest)");
  // The best design over the shards (the objective of search.hpp; ties: the lowest shard).
  const Part* best = nullptr;
  Score best_score;
  for (const Part& p : parts) {
    if (p.j["design"].is_null()) continue;
    const Score s = scoreFrom(p.j["design"]["score"]);
    if (!best || s.better(best_score)) {
      best = &p;
      best_score = s;
    }
  }
  json m = best ? best->j : parts.front().j;
  json evs = json::array();
  json shards = json::array();
  double wall = 0.0;
  for (const Part& p : parts) {
    for (const auto& e : p.j["evaluations"]) evs.push_back(e);
    shards.push_back(
        {{"shard", p.j["shard"]}, {"dir", p.dir.string()}, {"wall_time", p.j["wall_time"]}, {"solved", p.j["solved"]}});
    wall = std::max(wall, p.j.value("wall_time", 0.0));
  }
  m["evaluations"] = evs;
  // Every shard's finalists, best first (each shard confirmed its own).
  std::vector<json> fins;
  for (const Part& p : parts)
    if (p.j.contains("finalists"))
      for (const auto& f : p.j["finalists"]) fins.push_back(f);
  std::stable_sort(fins.begin(), fins.end(), [](const json& a, const json& b) {
    return scoreFrom(a.value("score", json::object())).better(scoreFrom(b.value("score", json::object())));
  });
  m["finalists"] = fins;
  m["shards"] = shards;
  m["shard"] = "merged";
  m["wall_time"] = wall;
  if (!missing.empty()) m["missing_shards"] = missing;
  json starts = json::array();
  for (const Part& p : parts)
    for (const auto& s : p.j["starts_run"]) starts.push_back(s);
  m["starts_run"] = starts;
  // Write: robot, queries and paths of the best, then the result.
  fs::create_directories(out);
  if (best) {
    const std::string robot_path = (fs::path(out) / "robot.yaml").string();
    io::writeFileAtomic(robot_path, io::readFile((best->dir / "robot.yaml").string()));
    for (const auto& q : m["queries"]) {
      const std::string name = queryFileStem(q["query"].get<std::string>());
      if (q.contains("start")) {
        const auto a = q["start"]["alpha"].get<std::vector<double>>();
        const auto b = q["start"]["beta"].get<std::vector<double>>();
        Configuration st(Eigen::Map<const Eigen::VectorXd>(a.data(), static_cast<Eigen::Index>(a.size())),
                         Eigen::Map<const Eigen::VectorXd>(b.data(), static_cast<Eigen::Index>(b.size())));
        const fs::path qd = fs::path(out) / "queries";
        fs::create_directories(qd);
        io::writeFileAtomic((qd / (name + ".yaml")).string(),
                            designedQueryYaml(q["file"].get<std::string>(), robot_path, st, qd.string()));
      }
      const fs::path csv = best->dir / "paths" / (name + ".csv");
      if (fs::exists(csv)) {
        fs::create_directories(fs::path(out) / "paths");
        io::writeFileAtomic((fs::path(out) / "paths" / (name + ".csv")).string(), io::readFile(csv.string()));
      }
    }
  }
  if (!m["space"].is_null())
    io::writeFileAtomic((fs::path(out) / "space.yaml").string(), m["space"].get<std::string>());
  const std::string text = m.dump(2);
  io::writeFileAtomic((fs::path(out) / "result.json").string(), text + "\n");
  return text;
}

}  // namespace ctr::design
