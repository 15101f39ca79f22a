// Merging a campaign's records into the Planner Arena database (ctr/campaign/merge.hpp).
#include "ctr/campaign/merge.hpp"

#include <fcntl.h>
#include <ompl/base/spaces/RealVectorStateSpace.h>
#include <ompl/geometric/SimpleSetup.h>
#include <ompl/tools/benchmark/Benchmark.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>
#include <sstream>
#include <stdexcept>
#include <tuple>

#include "ctr/campaign/campaign.hpp"
#include "ctr/io/file.hpp"
#include "ctr/io/input_error.hpp"
#include "records.hpp"

namespace fs = std::filesystem;
namespace ob = ompl::base;
using nlohmann::json;

namespace ctr::campaign {
namespace {

using Bench = ompl::tools::Benchmark;

// Writes a CompleteExperiment in OMPL's log format with OMPL's own writer (Benchmark::saveResultsToStream), so the
// merged logs are exactly what ompl_benchmark_statistics reads.
class ExperimentWriter : public Bench {
 public:
  explicit ExperimentWriter(const CompleteExperiment& e) : Bench(dummySetup(), e.name) { exp_ = e; }

 private:
  static ompl::geometric::SimpleSetup& dummySetup() {
    static ompl::geometric::SimpleSetup ss(std::make_shared<ob::RealVectorStateSpace>(1));
    return ss;
  }
};

using detail::readText;

struct Record {
  fs::path file;
  json j;
};

// The OMPL tool that turns benchmark logs into the Planner Arena database (Debian package ompl-demos).
std::string statisticsTool(const std::string& given) {
  if (!given.empty()) return given;
  if (const char* e = std::getenv("CTR_OMPL_BENCHMARK_STATISTICS")) return e;
  const char* path = std::getenv("PATH");
  std::stringstream ss(path ? path : "/usr/bin:/bin");
  std::string dir;
  while (std::getline(ss, dir, ':')) {
    const fs::path c = fs::path(dir.empty() ? "." : dir) / "ompl_benchmark_statistics";
    if (::access(c.c_str(), X_OK) == 0) return c.string();
  }
  throw std::runtime_error(
      "ompl_benchmark_statistics not found on PATH: it builds the Planner Arena database from the OMPL logs; install "
      "the Debian package ompl-demos (scripts/install-deps.sh does), or set CTR_OMPL_BENCHMARK_STATISTICS to the "
      "script's path. The merged OMPL logs are not written either.");
}

// Runs a program (no shell) with stdout and stderr into `log`; returns its exit status (-1 if it could not start).
int runProgram(const std::vector<std::string>& argv, const fs::path& log) {
  std::vector<char*> args;
  for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  const pid_t pid = ::fork();
  if (pid < 0) return -1;
  if (pid == 0) {
    const int fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (fd >= 0) {
      ::dup2(fd, 1);
      ::dup2(fd, 2);
    }
    ::execv(args[0], args.data());
    ::_exit(127);
  }
  int st = 0;
  if (::waitpid(pid, &st, 0) < 0) return -1;
  return WIFEXITED(st) ? WEXITSTATUS(st) : -1;
}

std::string outcomeOf(const json& run) {
  if (!run.value("planner_solved", false)) return "unsolved";
  const json& r = run["replay"];
  if (r.is_null()) return "other";
  if (r.value("solved", false)) return "clean";
  if (r.value("collisions", 0) > 0) return "collision";
  if (r.value("snaps", 0) > 0) return "snap";
  if (!r.value("goal_reached", false)) return "goal missed";
  return "other";
}

json stats(std::vector<double> v) {
  if (v.empty()) return {{"min", nullptr}, {"median", nullptr}, {"mean", nullptr}, {"max", nullptr}};
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  const double median = n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
  double sum = 0;
  for (double x : v) sum += x;
  return {{"min", v.front()}, {"median", median}, {"mean", sum / static_cast<double>(n)}, {"max", v.back()}};
}

}  // namespace

MergeSummary mergeCampaign(const std::vector<std::string>& dirs, const std::string& out, const MergeOptions& options) {
  if (dirs.empty()) throw std::invalid_argument("mergeCampaign: no folders to merge");
  detail::requireOutputFolder(out, "mergeCampaign");
  const bool allow_incomplete = options.allow_incomplete;
  // 1. The campaign: every folder must hold runs of the same one.
  std::optional<Campaign> campaign;
  std::string campaign_dir;
  for (const auto& d : dirs) {
    const fs::path m = fs::path(d) / "campaign.json";
    if (!fs::is_directory(d)) throw io::InputError(d, 0, "", "not a folder");
    if (!fs::exists(m))
      throw io::InputError(d, 0, "", "no campaign.json: not an output folder of `ctr bench CAMPAIGN.yaml --out DIR`");
    Campaign c = campaignFromJson(readText(m), m.string());
    if (campaign && c.fingerprint != campaign->fingerprint)
      throw io::InputError(m.string(), 0, "fingerprint",
                           "runs of another campaign ('" + c.name + "', " + c.fingerprint + ") than in " +
                               campaign_dir + " ('" + campaign->name + "', " + campaign->fingerprint + ")");
    if (!campaign) {
      campaign = std::move(c);
      campaign_dir = d;
    }
  }
  const Campaign& c = *campaign;
  const std::vector<CampaignUnit> units = c.units();
  std::map<std::string, std::size_t> index;
  for (std::size_t k = 0; k < units.size(); ++k) index[units[k].id()] = k;

  // 2. The records: each unit exactly once, with all its runs.
  std::vector<std::vector<Record>> found(units.size());
  std::vector<std::string> problems;
  std::set<fs::path> seen_dirs;
  for (const auto& d : dirs) {
    const fs::path ud = fs::weakly_canonical(fs::path(d) / "units");
    if (!seen_dirs.insert(ud).second) continue;  // the same folder given twice is one folder
    if (!fs::is_directory(ud)) continue;
    std::vector<fs::path> files;
    for (const auto& e : fs::directory_iterator(ud))
      if (e.path().extension() == ".json") files.push_back(e.path());
    std::sort(files.begin(), files.end());
    for (const auto& f : files) {
      json j;
      try {
        j = json::parse(readText(f));
      } catch (const json::exception& e) {
        throw io::InputError(f.string(), 0, "", std::string("unreadable run record: ") + e.what());
      }
      if (j.value("format", "") != "ctr-bench-unit/1")
        throw io::InputError(f.string(), 0, "format", "not a ctr run record");
      if (j.value("fingerprint", "") != c.fingerprint)
        throw io::InputError(f.string(), 0, "fingerprint",
                             "a run of another campaign (" + j.value("fingerprint", "?") + ")");
      const std::string id = j["unit"].value("id", "");
      if (!index.count(id)) throw io::InputError(f.string(), 0, "unit", "'" + id + "' is not a unit of the campaign");
      found[index[id]].push_back({f, std::move(j)});
    }
  }
  std::size_t missing_units = 0, missing_runs = 0, runs_total = 0;
  json missing = json::array();
  for (std::size_t k = 0; k < units.size(); ++k) {
    const auto& f = found[k];
    if (f.empty()) {
      ++missing_units;
      missing_runs += static_cast<std::size_t>(c.runs_per_seed);
      missing.push_back(units[k].id());
      continue;
    }
    if (f.size() > 1) {
      std::string where;
      for (const auto& r : f) where += (where.empty() ? "" : ", ") + r.file.string();
      problems.push_back("duplicated: " + units[k].id() + " (" + std::to_string(f.size() * c.runs_per_seed) +
                         " runs instead of " + std::to_string(c.runs_per_seed) + ") in " + where);
      continue;
    }
    const std::size_t n = f[0].j["runs"].size();
    runs_total += n;
    if (n != static_cast<std::size_t>(c.runs_per_seed))
      problems.push_back("incomplete: " + units[k].id() + " has " + std::to_string(n) + " of " +
                         std::to_string(c.runs_per_seed) + " runs (" + f[0].file.string() + ")");
  }
  const std::size_t expected_runs = units.size() * static_cast<std::size_t>(c.runs_per_seed);
  if (!problems.empty() || (missing_units && !allow_incomplete)) {
    std::string msg = "campaign '" + c.name + "' is not complete in " + std::to_string(dirs.size()) +
                      " folder(s): " + std::to_string(expected_runs) + " runs expected (" +
                      std::to_string(units.size()) + " units x " + std::to_string(c.runs_per_seed) + ")";
    if (missing_units)
      msg += "; missing " + std::to_string(missing_units) + " unit(s), " + std::to_string(missing_runs) + " run(s):";
    for (const auto& m : missing) msg += "\n  missing: " + m.get<std::string>();
    for (const auto& p : problems) msg += "\n  " + p;
    if (problems.empty()) msg += "\n(run the missing shards, or merge with --allow-incomplete)";
    throw io::InputError(dirs.front(), 0, "", msg);
  }

  // 3. One OMPL experiment per (query, mode): the runs of every planner and seed, in the campaign's unit order.
  const std::string tool = statisticsTool(options.statistics_tool);
  std::map<std::string, Bench::CompleteExperiment> experiments;
  std::map<std::string, std::map<std::string, std::size_t>> planner_slot;
  for (std::size_t k = 0; k < units.size(); ++k) {
    if (found[k].empty()) continue;
    const json& r = found[k][0].j;
    const json& ex = r["experiment"];
    const std::string name = ex.value("name", units[k].query_name + "_" + units[k].mode);
    const bool first = !experiments.count(name);
    Bench::CompleteExperiment& e = experiments[name];
    const auto start =
        ompl::time::point(std::chrono::microseconds(ex.value("start_time_us", static_cast<long long>(0))));
    if (first) {
      e.name = name;
      e.maxTime = ex.value("max_time", c.time_limit);
      e.maxMem = ex.value("max_mem", 4096.0);
      e.runCount = static_cast<unsigned int>(c.seeds.size() * static_cast<std::size_t>(c.runs_per_seed));
      e.startTime = start;
      e.totalDuration = 0;
      e.setupInfo = ex.value("setup_info", "");
      e.seed = static_cast<std::uint_fast32_t>(c.seeds.front());
      e.host = "";
      e.cpuInfo = ex.value("cpu_info", "");
    }
    e.startTime = std::min(e.startTime, start);
    e.totalDuration += ex.value("total_duration", 0.0);
    const std::string host = ex.value("host", r.value("host", "unknown"));
    if (("," + e.host + ",").find("," + host + ",") == std::string::npos) e.host += (e.host.empty() ? "" : ",") + host;
    for (const json& pj : ex["planners"]) {
      const std::string pname = pj.value("name", "");
      auto& slots = planner_slot[name];
      if (!slots.count(pname)) {
        slots[pname] = e.planners.size();
        Bench::PlannerExperiment pe;
        pe.name = pname;
        pe.common = pj.value("common", Bench::RunProperties{});
        pe.progressPropertyNames = pj.value("progress_properties", std::vector<std::string>{});
        e.planners.push_back(pe);
      }
      Bench::PlannerExperiment& pe = e.planners[slots[pname]];
      for (const json& run : r["runs"]) pe.runs.push_back(run["ompl"].get<Bench::RunProperties>());
      const auto names = pj.value("progress_properties", std::vector<std::string>{});
      if (names == pe.progressPropertyNames) {
        for (const json& pr : pj["progress"]) pe.runsProgressData.push_back(pr.get<Bench::RunProgressData>());
      }
    }
  }
  // Progress data are written only when every run has them (OMPL's reader pairs them with the runs).
  for (auto& [name, e] : experiments)
    for (auto& pe : e.planners)
      if (pe.runsProgressData.size() != pe.runs.size()) {
        pe.runsProgressData.clear();
        pe.progressPropertyNames.clear();
      }

  // 4. Everything is written into a staging folder inside OUT, then moved into place: no partial output.
  fs::create_directories(out);
  const fs::path stage = fs::path(out) / (".merge-" + std::to_string(::getpid()));
  fs::remove_all(stage);
  fs::create_directories(stage / "logs");
  struct Cleanup {
    fs::path p;
    ~Cleanup() {
      std::error_code ec;
      fs::remove_all(p, ec);
    }
  } cleanup{stage};
  std::vector<std::string> argv = {tool};
  for (const auto& [name, e] : experiments) {
    std::ostringstream os;
    ExperimentWriter w(e);
    w.saveResultsToStream(os);
    const fs::path f = stage / "logs" / (name + ".log");
    std::ofstream(f, std::ios::binary) << os.str();
    argv.push_back(f.string());
  }
  argv.push_back("-d");
  argv.push_back((stage / "benchmark.db").string());
  const fs::path tool_log = stage / "ompl_benchmark_statistics.out";
  const int rc = runProgram(argv, tool_log);
  if (rc != 0 || !fs::exists(stage / "benchmark.db")) {
    std::string tail = readText(tool_log);
    if (tail.size() > 2000) tail = "..." + tail.substr(tail.size() - 2000);
    throw std::runtime_error(tool + " failed (exit " + std::to_string(rc) + "):\n" + tail);
  }

  // 5. summary.json: per query / mode / planner.
  json rows = json::array(), runs_detail = json::array();
  std::map<std::tuple<std::string, std::string, std::string>, std::vector<std::size_t>> groups;
  for (std::size_t k = 0; k < units.size(); ++k)
    if (!found[k].empty()) groups[{units[k].query_name, units[k].mode, units[k].planner}].push_back(k);
  for (const auto& [key, ks] : groups) {
    const auto& [query, mode, planner] = key;
    int runs = 0, solved = 0, clean = 0, collisions = 0, snaps = 0, missed = 0, other = 0;
    std::vector<double> times;
    json seeds = json::array(), tts = json::array();
    std::string ompl_name;
    for (std::size_t k : ks) {
      const json& r = found[k][0].j;
      seeds.push_back(units[k].seed);
      if (!r["experiment"]["planners"].empty()) ompl_name = r["experiment"]["planners"][0].value("name", "");
      for (const json& run : r["runs"]) {
        ++runs;
        const std::string o = outcomeOf(run);
        const double t = run.value("time", 0.0);
        if (run.value("planner_solved", false)) {
          ++solved;
          times.push_back(t);
          tts.push_back(t);
        } else {
          tts.push_back(nullptr);
        }
        clean += o == "clean";
        collisions += o == "collision";
        snaps += o == "snap";
        missed += o == "goal missed";
        other += o == "other";
        const json& rp = run["replay"];
        runs_detail.push_back({{"query", query},
                               {"mode", mode},
                               {"planner", planner},
                               {"seed", units[k].seed},
                               {"run", run.value("run", 0)},
                               {"planner_solved", run.value("planner_solved", false)},
                               {"outcome", o},
                               {"time", t},
                               {"tip_error", rp.is_null() ? json(nullptr) : rp["tip_error"]},
                               {"min_clearance", rp.is_null() ? json(nullptr) : rp["min_clearance"]}});
      }
    }
    rows.push_back({{"query", query},
                    {"mode", mode},
                    {"planner", planner},
                    {"ompl_planner", ompl_name},
                    {"seeds", seeds},
                    {"runs", runs},
                    {"solved", solved},
                    {"replay_clean", clean},
                    {"replay_collisions", collisions},
                    {"replay_snaps", snaps},
                    {"replay_goal_missed", missed},
                    {"replay_other", other},
                    {"success_rate", runs ? double(solved) / runs : 0.0},
                    {"replay_clean_rate", runs ? double(clean) / runs : 0.0},
                    {"time", stats(times)},
                    {"times", tts}});
  }
  json summary = {{"format", "ctr-bench-summary/1"},
                  {"campaign", c.name},
                  {"campaign_file", c.file},
                  {"fingerprint", c.fingerprint},
                  {"time_limit", c.time_limit},
                  {"clock", c.cpu_time ? "cpu" : "wall"},
                  {"runs_per_seed", c.runs_per_seed},
                  {"complete", missing_units == 0},
                  {"expected_units", units.size()},
                  {"units", units.size() - missing_units},
                  {"expected_runs", expected_runs},
                  {"runs", runs_total},
                  {"missing", missing},
                  {"database", "benchmark.db"},
                  {"experiments", json::array()},
                  {"rows", rows},
                  {"run_outcomes", runs_detail}};
  for (const auto& [name, e] : experiments) summary["experiments"].push_back(name);
  io::writeFileAtomic((stage / "summary.json").string(), summary.dump(1) + "\n");

  // 6. Into place.
  const fs::path logs = fs::path(out) / "logs";
  fs::remove_all(logs);
  fs::rename(stage / "logs", logs);
  fs::rename(stage / "benchmark.db", fs::path(out) / "benchmark.db");
  fs::rename(stage / "summary.json", fs::path(out) / "summary.json");
  MergeSummary result;
  result.campaign = c.name;
  result.expected_units = units.size();
  result.units = units.size() - missing_units;
  result.expected_runs = expected_runs;
  result.runs = runs_total;
  for (const auto& m : missing) result.missing.push_back(m.get<std::string>());
  for (const auto& [name, e] : experiments) result.experiments.push_back(name);
  result.database = (fs::path(out) / "benchmark.db").string();
  result.summary_file = (fs::path(out) / "summary.json").string();
  result.logs = logs.string();
  result.summary_json = summary.dump(1) + "\n";
  return result;
}

}  // namespace ctr::campaign
