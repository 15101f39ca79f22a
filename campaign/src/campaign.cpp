#include "ctr/campaign/campaign.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <stdexcept>

#include "ctr/io/input_error.hpp"
#include "ctr/io/yaml_reader.hpp"
#include "ctr/planner/query.hpp"

namespace fs = std::filesystem;

namespace ctr::campaign {

namespace {

using io::InputError;

// The bytes of a file for the campaign's fingerprint; "" for what is not a readable file (an environment given by name,
// a folder), which io::readFile would refuse.
std::string contentsOrEmpty(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

std::uint64_t fnv1a(const std::string& s, std::uint64_t h = 1469598103934665603ull) {
  for (unsigned char c : s) {
    h ^= c;
    h *= 1099511628211ull;
  }
  return h;
}

int lineOf(const YAML::Node& n) {
  return io::YamlReader::lineOf(n);
}

// A name usable in file names and OMPL log lines (no spaces, no slashes).
bool plainName(const std::string& s) {
  if (s.empty()) return false;
  for (char c : s)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' || c == '.')) return false;
  return true;
}

std::vector<std::string> stringList(const std::string& file, const YAML::Node& n, const std::string& key) {
  if (!n.IsSequence() || n.size() == 0) throw InputError(file, lineOf(n), key, "must be a non-empty list");
  std::vector<std::string> out;
  std::set<std::string> seen;
  for (std::size_t i = 0; i < n.size(); ++i) {
    const std::string k = key + "[" + std::to_string(i) + "]";
    if (!n[i].IsScalar() || n[i].Scalar().empty()) throw InputError(file, lineOf(n[i]), k, "must be a name");
    if (!seen.insert(n[i].Scalar()).second)
      throw InputError(file, lineOf(n[i]), k, "'" + n[i].Scalar() + "' is listed twice");
    out.push_back(n[i].Scalar());
  }
  return out;
}

}  // namespace

std::string CampaignUnit::id() const {
  return query_name + "/" + mode + "/" + planner + "/seed-" + std::to_string(seed);
}

std::string CampaignUnit::stem() const {
  return query_name + "__" + mode + "__" + planner + "__seed-" + std::to_string(seed);
}

std::vector<CampaignUnit> Campaign::units() const {
  std::vector<std::size_t> qorder(queries.size());
  for (std::size_t i = 0; i < qorder.size(); ++i) qorder[i] = i;
  std::sort(qorder.begin(), qorder.end(),
            [&](std::size_t a, std::size_t b) { return queries[a].name < queries[b].name; });
  std::vector<std::string> m = modes, p = planners;
  std::vector<std::uint64_t> s = seeds;
  std::sort(m.begin(), m.end());
  std::sort(p.begin(), p.end());
  std::sort(s.begin(), s.end());
  std::vector<CampaignUnit> out;
  for (std::size_t q : qorder)
    for (const auto& mode : m)
      for (const auto& planner : p)
        for (std::uint64_t seed : s) {
          CampaignUnit u;
          u.query = q;
          u.query_name = queries[q].name;
          u.mode = mode;
          u.planner = planner;
          u.seed = seed;
          out.push_back(u);
        }
  return out;
}

std::string Shard::label() const {
  return std::to_string(index) + "/" + std::to_string(count);
}

std::vector<CampaignUnit> Campaign::shard(const Shard& part) const {
  if (part.count == 0 || part.index >= part.count)
    throw std::invalid_argument("Campaign::shard: shard " + part.label() + " is not I/N with 0 <= I < N");
  const std::vector<CampaignUnit> all = units();
  std::vector<CampaignUnit> out;
  for (std::size_t k = 0; k < all.size(); ++k)
    if (k % part.count == part.index) out.push_back(all[k]);
  return out;
}

std::string Campaign::toJson() const {
  nlohmann::json j;
  j["format"] = "ctr-bench-campaign/1";
  j["file"] = file;
  j["name"] = name;
  j["fingerprint"] = fingerprint;
  j["queries"] = nlohmann::json::array();
  for (const auto& q : queries) j["queries"].push_back({{"file", q.file}, {"name", q.name}});
  j["planners"] = planners;
  j["modes"] = modes;
  j["seeds"] = seeds;
  j["time_limit"] = time_limit;
  j["runs_per_seed"] = runs_per_seed;
  j["cpu_time"] = cpu_time;
  j["units"] = units().size();
  return j.dump(2) + "\n";
}

Campaign campaignFromJson(const std::string& text, const std::string& source) {
  Campaign c;
  try {
    const auto j = nlohmann::json::parse(text);
    if (j.value("format", "") != "ctr-bench-campaign/1")
      throw InputError(source, 0, "format", "not a ctr campaign record");
    c.file = j.at("file").get<std::string>();
    c.name = j.at("name").get<std::string>();
    c.fingerprint = j.at("fingerprint").get<std::string>();
    for (const auto& q : j.at("queries"))
      c.queries.push_back({q.at("file").get<std::string>(), q.at("name").get<std::string>()});
    c.planners = j.at("planners").get<std::vector<std::string>>();
    c.modes = j.at("modes").get<std::vector<std::string>>();
    c.seeds = j.at("seeds").get<std::vector<std::uint64_t>>();
    c.time_limit = j.at("time_limit").get<double>();
    c.runs_per_seed = j.at("runs_per_seed").get<int>();
    c.cpu_time = j.at("cpu_time").get<bool>();
  } catch (const nlohmann::json::exception& e) {
    throw InputError(source, 0, "", std::string("malformed campaign record: ") + e.what());
  }
  return c;
}

bool isCampaignFile(const std::string& path) {
  try {
    const YAML::Node root = YAML::LoadFile(path);
    return root.IsMap() && root["queries"];
  } catch (const YAML::Exception&) {
    return false;  // loadQuery reports the syntax error with its line
  }
}

Campaign loadCampaign(const std::string& path) {
  if (!fs::exists(path)) throw InputError(path, 0, "", "file not found");
  YAML::Node root;
  try {
    root = YAML::LoadFile(path);
  } catch (const YAML::Exception& e) {
    throw InputError(path, e.mark.line + 1, "", "YAML syntax error: " + e.msg);
  }
  if (!root.IsMap())
    throw InputError(path, 0, "", "a campaign is a YAML map (queries, planners, modes, seeds, time_limit)");
  const io::YamlReader R{path};
  R.allowOnly(root, "", {"name", "queries", "planners", "modes", "seeds", "time_limit", "runs_per_seed", "cpu_time"});
  for (const char* k : {"queries", "planners", "modes", "seeds", "time_limit"})
    if (!root[k]) throw InputError(path, 0, k, "missing");
  Campaign c;
  c.file = fs::path(path).lexically_normal().string();
  c.name = fs::path(path).stem().string();
  if (root["name"]) {
    c.name = R.text(root["name"], "name");
    if (!plainName(c.name))
      throw InputError(path, lineOf(root["name"]), "name", "must be a name of letters, digits, '_', '-' or '.'");
  }
  const fs::path base = fs::path(path).parent_path();
  // Queries: load each (errors name the query file); names must be unique (they name the runs).
  const YAML::Node qn = root["queries"];
  const std::vector<std::string> qfiles = stringList(path, qn, "queries");
  std::map<std::string, std::size_t> names;
  std::uint64_t h = fnv1a("ctr-bench-campaign/1");
  for (std::size_t i = 0; i < qfiles.size(); ++i) {
    const std::string key = "queries[" + std::to_string(i) + "]";
    fs::path qp(qfiles[i]);
    if (qp.is_relative()) qp = base / qp;
    qp = qp.lexically_normal();
    if (!fs::exists(qp)) throw InputError(path, lineOf(qn[i]), key, "query file not found: " + qp.string());
    const planner::Query q = planner::loadQuery(qp.string());
    if (!plainName(q.name))
      throw InputError(path, lineOf(qn[i]), key,
                       "query name '" + q.name + "' must consist of letters, digits, '_', '-' or '.'");
    if (names.count(q.name))
      throw InputError(path, lineOf(qn[i]), key,
                       "query name '" + q.name + "' is also the name of queries[" + std::to_string(names[q.name]) +
                           "]; query names identify the runs and must be unique");
    names[q.name] = i;
    c.queries.push_back({qp.string(), q.name});
    h = fnv1a(q.name + "\n" + contentsOrEmpty(qp.string()) + "\n" + contentsOrEmpty(q.robot) + "\n" +
                  contentsOrEmpty(q.environment),
              h);
  }
  c.modes = stringList(path, root["modes"], "modes");
  for (std::size_t i = 0; i < c.modes.size(); ++i) {
    try {
      planner::parseMode(c.modes[i]);
    } catch (const std::exception&) {
      throw InputError(path, lineOf(root["modes"][i]), "modes[" + std::to_string(i) + "]",
                       "unknown mode '" + c.modes[i] + "' (exact, robust, frictionless)");
    }
  }
  c.planners = stringList(path, root["planners"], "planners");
  for (std::size_t i = 0; i < c.planners.size(); ++i) {
    if (!plainName(c.planners[i]))
      throw InputError(path, lineOf(root["planners"][i]), "planners[" + std::to_string(i) + "]",
                       "must be a planner name");
    for (const auto& m : c.modes) {
      const auto ok = planner::plannerNames(planner::parseMode(m));
      if (c.planners[i] != "default" && std::find(ok.begin(), ok.end(), c.planners[i]) == ok.end()) {
        std::string list;
        for (const auto& x : ok) list += (list.empty() ? "" : ", ") + x;
        throw InputError(path, lineOf(root["planners"][i]), "planners[" + std::to_string(i) + "]",
                         "planner '" + c.planners[i] + "' is not available in mode " + m + " (" + list + ")");
      }
    }
  }
  const YAML::Node sn = root["seeds"];
  if (!sn.IsSequence() || sn.size() == 0)
    throw InputError(path, lineOf(sn), "seeds", "must be a non-empty list of integers");
  std::set<std::uint64_t> seen;
  for (std::size_t i = 0; i < sn.size(); ++i) {
    const std::string key = "seeds[" + std::to_string(i) + "]";
    long long v = 0;
    try {
      v = sn[i].as<long long>();
    } catch (const YAML::Exception&) {
      throw InputError(path, lineOf(sn[i]), key, "must be an integer");
    }
    if (v < 1 || v > 4294967295LL)
      throw InputError(path, lineOf(sn[i]), key, "must be between 1 and 4294967295 (OMPL seeds)");
    if (!seen.insert(static_cast<std::uint64_t>(v)).second)
      throw InputError(path, lineOf(sn[i]), key, "seed " + std::to_string(v) + " is listed twice");
    c.seeds.push_back(static_cast<std::uint64_t>(v));
  }
  c.time_limit = R.number(root["time_limit"], "time_limit");
  if (c.time_limit <= 0) throw InputError(path, lineOf(root["time_limit"]), "time_limit", "must be > 0 s");
  if (root["runs_per_seed"]) {
    try {
      c.runs_per_seed = root["runs_per_seed"].as<int>();
    } catch (const YAML::Exception&) {
      throw InputError(path, lineOf(root["runs_per_seed"]), "runs_per_seed", "must be an integer");
    }
    if (c.runs_per_seed < 1 || c.runs_per_seed > 100000)
      throw InputError(path, lineOf(root["runs_per_seed"]), "runs_per_seed", "must be between 1 and 100000");
  }
  if (root["cpu_time"]) c.cpu_time = R.boolean(root["cpu_time"], "cpu_time");
  std::ostringstream def;
  def.precision(17);
  for (const auto& m : c.modes) def << "mode " << m << "\n";
  for (const auto& p : c.planners) def << "planner " << p << "\n";
  for (auto s : c.seeds) def << "seed " << s << "\n";
  def << "time " << c.time_limit << "\nruns " << c.runs_per_seed << "\ncpu " << c.cpu_time << "\n";
  h = fnv1a(def.str(), h);
  char buf[17];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(h));
  c.fingerprint = buf;
  return c;
}

Shard parseShard(const std::string& text) {
  const auto slash = text.find('/');
  auto bad = [&]() {
    return std::invalid_argument("'" + text +
                                 "' is not I/N with 0 <= I < N (e.g. $SLURM_ARRAY_TASK_ID/$SLURM_ARRAY_TASK_COUNT "
                                 "with --array=0-(N-1))");
  };
  if (slash == std::string::npos) throw bad();
  const std::string a = text.substr(0, slash), b = text.substr(slash + 1);
  auto digits = [](const std::string& s) {
    return !s.empty() && s.size() < 10 && std::all_of(s.begin(), s.end(), [](char c) { return c >= '0' && c <= '9'; });
  };
  if (!digits(a) || !digits(b)) throw bad();
  const std::size_t i = std::stoul(a), n = std::stoul(b);
  if (n == 0 || i >= n) throw bad();
  return Shard{i, n};
}

}  // namespace ctr::campaign
