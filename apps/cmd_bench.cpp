// `ctr bench`: OMPL benchmarks of planners (ompl::tools::Benchmark) with every solution replayed through the
// friction model. Input: one query (planners / runs / time on the command line), or a campaign file (queries x
// planners x modes x seeds; `--shard i/N` runs a deterministic part, for Slurm job arrays and GNU parallel).
// `ctr bench merge DIR... --out OUT` checks that a campaign is complete and writes the Planner Arena database
// (OMPL's ompl_benchmark_statistics), summary.json and an HTML report.
#include <ompl/base/PlannerTerminationCondition.h>
#include <ompl/tools/benchmark/Benchmark.h>
#include <ompl/util/Console.h>
#include <ompl/util/RandomNumbers.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>
#include <sstream>
#include <tuple>

#include "campaign.hpp"
#include "commands.hpp"
#include "ctr/environments/environment_yaml.hpp"
#include "ctr/io/file.hpp"
#include "ctr/io/robot_yaml.hpp"
#include "ctr/planner/planner.hpp"
#include "ctr/planner/stopwatch.hpp"
#include "html_report.hpp"
#include "progress.hpp"

namespace fs = std::filesystem;
namespace ob = ompl::base;
using nlohmann::json;

namespace ctr::cli {
namespace {

// ---------------------------------------------------------------------------------------------------------------
// Planner decorator: stops its planner after `seconds` of process CPU time (campaign `cpu_time: true`); the
// benchmark's own termination condition is wall-clock only. Name, parameters and specs are the wrapped planner's, so
// the database shows the same planners with or without it.
class CpuLimited : public ob::Planner {
 public:
  CpuLimited(ob::PlannerPtr inner, double seconds)
      : ob::Planner(inner->getSpaceInformation(), inner->getName()), inner_(std::move(inner)), seconds_(seconds) {
    params_ = inner_->params();
    specs_ = inner_->getSpecs();
  }
  ob::PlannerStatus solve(const ob::PlannerTerminationCondition& ptc) override {
    checkValidity();
    const planner::Stopwatch watch(true);
    const double limit = seconds_;
    const ob::PlannerTerminationCondition cpu([&watch, limit] { return watch.seconds() >= limit; });
    inner_->setProblemDefinition(pdef_);
    return inner_->solve(ob::plannerOrTerminationCondition(ptc, cpu));
  }
  void setup() override {
    ob::Planner::setup();
    inner_->setProblemDefinition(pdef_);
    if (!inner_->isSetup()) inner_->setup();
  }
  void clear() override {
    ob::Planner::clear();
    inner_->clear();
  }
  void getPlannerData(ob::PlannerData& data) const override { inner_->getPlannerData(data); }

 private:
  ob::PlannerPtr inner_;
  double seconds_;
};

double processCpuSeconds() {
  timespec ts{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

// OMPL's seed generator, reset for every unit so a unit's random streams depend on its seed only (not on which
// shard or process runs it). OMPL logs an error when re-seeding after the first generator exists; silenced here.
void reseedOmpl(std::uint64_t seed) {
  const auto level = ompl::msg::getLogLevel();
  ompl::msg::setLogLevel(ompl::msg::LOG_NONE);
  ompl::RNG::setSeed(static_cast<std::uint_fast32_t>(seed));
  ompl::msg::setLogLevel(level);
}

std::string readText(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

std::string isoNow() {
  const std::time_t t = std::time(nullptr);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", std::gmtime(&t));
  return buf;
}

std::string hostName() {
  char buf[256] = {0};
  if (::gethostname(buf, sizeof buf - 1) != 0) return "unknown";
  return buf;
}

json replayJson(const planner::PlanResult& r) {
  return {{"solved", r.solved},
          {"completed", r.replay.completed},
          {"collision_free", r.replay.collision_free},
          {"stable", r.replay.stable},
          {"goal_reached", r.replay.goal_reached},
          {"collisions", r.replay.collisions},
          {"snaps", r.replay.snaps},
          {"tip_error", std::isfinite(r.replay.tip_error) ? json(r.replay.tip_error) : json(nullptr)},
          {"min_clearance", std::isfinite(r.replay.min_clearance) ? json(r.replay.min_clearance) : json(nullptr)},
          {"path_length", r.path_length},
          {"failure", toString(r.replay.failure)},
          {"first_failure", r.replay.first_failure}};
}

// Replay properties added to every OMPL run (solved or not, so every run has the same columns).
void addReplayProperties(ompl::tools::Benchmark::RunProperties& run, const planner::PlanResult* r) {
  run["replay_solved BOOLEAN"] = r && r->solved ? "1" : "0";
  run["replay_collision_free BOOLEAN"] = r && r->replay.collision_free ? "1" : "0";
  run["replay_collisions INTEGER"] = std::to_string(r ? r->replay.collisions : 0);
  run["replay_snaps INTEGER"] = std::to_string(r ? r->replay.snaps : 0);
  if (r) {
    run["replay_tip_error REAL"] = std::to_string(r->replay.tip_error);
    run["replay_min_clearance REAL"] = std::to_string(r->replay.min_clearance);
  }
}

json experimentJson(const ompl::tools::Benchmark::CompleteExperiment& e) {
  json planners = json::array();
  for (const auto& p : e.planners) {
    json progress = json::array();
    for (const auto& run : p.runsProgressData) progress.push_back(run);
    planners.push_back({{"name", p.name},
                        {"common", p.common},
                        {"progress_properties", p.progressPropertyNames},
                        {"progress", progress}});
  }
  return {
      {"name", e.name},
      {"max_time", e.maxTime},
      {"max_mem", e.maxMem},
      {"run_count", e.runCount},
      {"start_time_us", std::chrono::duration_cast<std::chrono::microseconds>(e.startTime.time_since_epoch()).count()},
      {"total_duration", e.totalDuration},
      {"setup_info", e.setupInfo},
      {"seed", e.seed},
      {"host", e.host},
      {"cpu_info", e.cpuInfo},
      {"planners", planners}};
}

// ---------------------------------------------------------------------------------------------------------------
// One query, planners from the command line (the original `ctr bench`).
struct BenchOpts {
  std::string input, planners, out, mode, shard;
  int runs = 10;
  double time = 5;
  bool quiet = false;
  // merge
  std::vector<std::string> dirs;
  std::string merge_out, html;
  bool allow_incomplete = false;
};

int benchQuery(const BenchOpts& b) {
  planner::Query q = planner::loadQuery(b.input);
  if (!b.mode.empty()) q.mode = planner::parseMode(b.mode);
  planner::CtrPlanner p(q);
  p.checkStart();
  std::vector<std::string> names;
  if (b.planners.empty()) {
    names.push_back(q.planner);
  } else {
    std::stringstream ss(b.planners);
    std::string x;
    while (std::getline(ss, x, ',')) names.push_back(x);
  }
  std::vector<ob::PlannerPtr> planners;
  for (const auto& n : names) planners.push_back(p.makePlanner(n));  // throws for unknown names (exit 2)
  // Goal configurations for sampleable tip goals (RRTConnect, PRM, BIT* need them), found once before the runs.
  const std::size_t pool = p.prepareGoal(b.time);
  if (q.tip_goal && pool == 0)
    std::cerr << "warning: no goal configuration found by IK; planners can only reach the goal region by chance\n";
  fs::create_directories(b.out);
  Progress progress("bench " + q.name, planners.size() * static_cast<std::size_t>(b.runs), "runs", b.quiet);
  json summary = json::array();
  std::map<std::string, json> per;
  auto post = [&p, &per, &progress](const ob::PlannerPtr& planner, ompl::tools::Benchmark::RunProperties& run) {
    const bool has = run.count("solved BOOLEAN") && run["solved BOOLEAN"] == "1";
    auto& s = per[planner->getName()];
    if (s.is_null()) s = json::object();
    s["runs"] = s.value("runs", 0) + 1;
    if (has) {
      const planner::PlanResult r = p.replaySolution(planner->getName(), std::stod(run["time REAL"]), true);
      addReplayProperties(run, &r);
      s["planner_solved"] = s.value("planner_solved", 0) + 1;
      s["replay_solved"] = s.value("replay_solved", 0) + (r.solved ? 1 : 0);
      s["replay_failures"] = s.value("replay_failures", 0) + (r.solved ? 0 : 1);
      s["time_sum"] = s.value("time_sum", 0.0) + std::stod(run["time REAL"]);
      s["path_length_sum"] = s.value("path_length_sum", 0.0) + r.path_length;
    } else {
      addReplayProperties(run, nullptr);
    }
    progress.advance();
  };
  ompl::tools::Benchmark::Request req(b.time, 4096.0, static_cast<unsigned int>(b.runs), 0.5, false, false, false);
  const std::string logfile = (fs::path(b.out) / (q.name + "_" + planner::toString(q.mode) + ".log")).string();
  auto runBench = [&](auto& setup) {
    ompl::tools::Benchmark bench(setup, q.name);
    for (auto& pl : planners) bench.addPlanner(pl);
    bench.setPostRunEvent(post);
    bench.benchmark(req);
    std::ostringstream os;
    bench.saveResultsToStream(os);
    io::writeFileAtomic(logfile, os.str());
  };
  if (p.geometricSetup())
    runBench(*p.geometricSetup());
  else
    runBench(*p.controlSetup());
  progress.finish();
  for (auto& [name, s] : per) {
    const int runs = s.value("runs", 0), solved = s.value("planner_solved", 0);
    json row = {{"planner", name},
                {"mode", planner::toString(q.mode)},
                {"runs", runs},
                {"planner_success_rate", runs ? double(solved) / runs : 0.0},
                {"replay_success_rate", runs ? double(s.value("replay_solved", 0)) / runs : 0.0},
                {"replay_failures", s.value("replay_failures", 0)},
                {"mean_time_to_solution", solved ? s.value("time_sum", 0.0) / solved : 0.0},
                {"mean_path_length", solved ? s.value("path_length_sum", 0.0) / solved : 0.0}};
    summary.push_back(row);
  }
  io::writeFileAtomic((fs::path(b.out) / "summary.json").string(), summary.dump(2) + "\n");
  std::cout << summary.dump(2) << "\n"
            << "OMPL log: " << logfile << "\n";
  return kOk;
}

// ---------------------------------------------------------------------------------------------------------------
// A campaign shard.
constexpr const char* kUnitFormat = "ctr-bench-unit/1";

struct LoadedQuery {
  std::string file;
  std::optional<Robot> robot;
  std::optional<environments::Environment> environment;
};

json runUnit(const Campaign& c, const CampaignUnit& u, LoadedQuery& cache, const std::string& shard_label,
             Progress& progress) {
  planner::Query q = planner::loadQuery(c.queries[u.query].file);
  q.mode = planner::parseMode(u.mode);
  q.planner = u.planner;
  q.seed = u.seed;
  q.time_limit = c.time_limit;
  q.cpu_time_limit = c.cpu_time;
  if (cache.file != q.file) {  // units are sorted by query: each shard loads a query's robot and map once
    cache.file.clear();
    cache.environment.reset();
    environments::BuildOptions bo;
    if (q.env_resolution > 0) bo.resolution = q.env_resolution;
    cache.robot = io::loadRobot(q.robot);
    cache.environment = environments::loadEnvironment(q.environment, bo);
    cache.file = q.file;
  }
  reseedOmpl(u.seed);
  planner::CtrPlanner p(q, *cache.robot, *cache.environment);
  p.checkStart();
  ob::PlannerPtr planner = p.makePlanner(u.planner);
  if (c.cpu_time) planner = std::make_shared<CpuLimited>(planner, c.time_limit);
  const planner::Stopwatch unit_watch;
  const std::size_t pool = p.prepareGoal(c.time_limit);
  json runs = json::array();
  double cpu0 = 0.0;
  int run_index = 0;
  auto pre = [&cpu0](const ob::PlannerPtr&) { cpu0 = processCpuSeconds(); };
  auto post = [&](const ob::PlannerPtr& pl, ompl::tools::Benchmark::RunProperties& run) {
    const double cpu = processCpuSeconds() - cpu0;
    run["seed INTEGER"] = std::to_string(u.seed);
    run["goal_pool INTEGER"] = std::to_string(pool);
    run["cpu_time REAL"] = std::to_string(cpu);
    if (run.count("time REAL")) run["wall_time REAL"] = run["time REAL"];
    if (c.cpu_time) run["time REAL"] = std::to_string(cpu);  // Planner Arena's time axis on the campaign's clock
    const bool has = run.count("solved BOOLEAN") && run["solved BOOLEAN"] == "1";
    json replay = nullptr;
    if (has) {
      const planner::PlanResult r = p.replaySolution(pl->getName(), std::stod(run["time REAL"]), true);
      addReplayProperties(run, &r);
      replay = replayJson(r);
    } else {
      addReplayProperties(run, nullptr);
    }
    runs.push_back({{"run", run_index++},
                    {"planner_solved", has},
                    {"time", std::stod(run.count("time REAL") ? run["time REAL"] : std::string("0"))},
                    {"replay", replay},
                    {"ompl", run}});
    progress.advance();
  };
  const double wall_cap = c.cpu_time ? 10.0 * c.time_limit + 10.0 : c.time_limit;
  ompl::tools::Benchmark::Request req(wall_cap, 4096.0, static_cast<unsigned int>(c.runs_per_seed), 0.5, false, false,
                                      false);
  const std::string experiment = u.query_name + "_" + u.mode;
  std::string log;
  json exp;
  auto runBench = [&](auto& setup) {
    ompl::tools::Benchmark bench(setup, experiment);
    bench.addPlanner(planner);
    bench.setPreRunEvent(pre);
    bench.setPostRunEvent(post);
    bench.benchmark(req);
    std::ostringstream os;
    bench.saveResultsToStream(os);
    log = os.str();
    exp = experimentJson(bench.getRecordedExperimentData());
  };
  if (p.geometricSetup())
    runBench(*p.geometricSetup());
  else
    runBench(*p.controlSetup());
  json rec;
  rec["format"] = kUnitFormat;
  rec["campaign"] = c.name;
  rec["fingerprint"] = c.fingerprint;
  rec["unit"] = {{"id", u.id()},           {"query", u.query_name}, {"query_file", c.queries[u.query].file},
                 {"mode", u.mode},         {"planner", u.planner},  {"seed", u.seed},
                 {"runs", c.runs_per_seed}};
  rec["shard"] = shard_label;
  rec["host"] = hostName();
  rec["finished"] = isoNow();
  rec["seconds"] = unit_watch.seconds();
  rec["time_limit"] = c.time_limit;
  rec["clock"] = c.cpu_time ? "cpu" : "wall";
  rec["goal_pool"] = pool;
  rec["experiment"] = exp;
  rec["runs"] = runs;
  rec["log"] = log;
  return rec;
}

int benchCampaign(const BenchOpts& b) {
  for (const auto& [opt, given] :
       {std::pair<std::string, bool>{"--planners", !b.planners.empty()}, {"--mode", !b.mode.empty()}})
    if (given) throw UsageError(opt + ": not used with a campaign file (set it in " + b.input + ")");
  const Campaign c = loadCampaign(b.input);
  std::size_t index = 0, count = 1;
  if (!b.shard.empty()) std::tie(index, count) = parseShard(b.shard);
  const std::string shard_label = std::to_string(index) + "/" + std::to_string(count);
  const fs::path out(b.out), units_dir = out / "units";
  {
    std::error_code ec;
    if (fs::exists(out, ec) && !fs::is_directory(out, ec))
      throw UsageError("--out: '" + b.out + "' exists and is not a folder");
  }
  // A folder holds the runs of one campaign: refuse to mix (before any work).
  const fs::path manifest = out / "campaign.json";
  if (fs::exists(manifest)) {
    const Campaign old = campaignFromJson(readText(manifest), manifest.string());
    if (old.fingerprint != c.fingerprint)
      throw UsageError("--out: " + b.out + " holds the runs of another campaign ('" + old.name + "' from " + old.file +
                       ", fingerprint " + old.fingerprint + "; this one: " + c.fingerprint +
                       "); use another --out folder");
  }
  const std::vector<CampaignUnit> units = c.shard(index, count);
  // Units already recorded in the folder (an interrupted shard run again) are kept, not run twice.
  std::vector<bool> done(units.size(), false);
  std::size_t kept = 0;
  for (std::size_t k = 0; k < units.size(); ++k) {
    const fs::path f = units_dir / (units[k].stem() + ".json");
    if (!fs::exists(f)) continue;
    json j;
    try {
      j = json::parse(readText(f));
    } catch (const json::exception&) {
      continue;  // unreadable record: run the unit again (the file is replaced atomically)
    }
    if (j.value("fingerprint", "") != c.fingerprint)
      throw UsageError("--out: " + f.string() + " belongs to another campaign (fingerprint " +
                       j.value("fingerprint", "?") + ", this one " + c.fingerprint + "); use another --out folder");
    if (j.contains("runs") && j["runs"].size() == static_cast<std::size_t>(c.runs_per_seed)) {
      done[k] = true;
      ++kept;
    }
  }
  fs::create_directories(units_dir);
  io::writeFileAtomic(manifest.string(), c.toJson());
  const std::size_t total_runs = units.size() * static_cast<std::size_t>(c.runs_per_seed);
  if (!b.quiet)
    std::cerr << "campaign '" << c.name << "' (" << c.units().size() << " units x " << c.runs_per_seed
              << " runs): shard " << shard_label << " has " << units.size() << " units, " << total_runs << " runs of "
              << c.time_limit << " s (" << (c.cpu_time ? "CPU" : "wall") << ")"
              << (kept ? ", " + std::to_string(kept) + " units already recorded in " + b.out : std::string()) << "\n";
  Progress progress("bench shard " + shard_label, total_runs, "runs", b.quiet);
  progress.advance(kept * static_cast<std::size_t>(c.runs_per_seed));
  LoadedQuery cache;
  const planner::Stopwatch watch;
  json ran = json::array();
  for (std::size_t k = 0; k < units.size(); ++k) {
    if (done[k]) continue;
    progress.setDetail(units[k].id());
    const json rec = runUnit(c, units[k], cache, shard_label, progress);
    // The OMPL log first, the record last: a record is the mark of a complete unit.
    io::writeFileAtomic((units_dir / (units[k].stem() + ".log")).string(), rec["log"].get<std::string>());
    json r = rec;
    r.erase("log");
    io::writeFileAtomic((units_dir / (units[k].stem() + ".json")).string(), r.dump(1) + "\n");
    ran.push_back(units[k].id());
  }
  progress.setDetail("");
  progress.finish();
  json shard = {{"campaign", c.name},   {"fingerprint", c.fingerprint}, {"shard", shard_label},  {"host", hostName()},
                {"finished", isoNow()}, {"seconds", watch.seconds()},   {"units", units.size()}, {"units_run", ran},
                {"units_kept", kept}};
  fs::create_directories(out / "shards");
  io::writeFileAtomic(
      (out / "shards" / ("shard-" + std::to_string(index) + "-of-" + std::to_string(count) + ".json")).string(),
      shard.dump(2) + "\n");
  std::cout << "shard " << shard_label << ": " << units.size() << " units (" << ran.size() << " run, " << kept
            << " already recorded) in " << Progress::duration(watch.seconds()) << "; records in " << units_dir.string()
            << "\n";
  return kOk;
}

}  // namespace

// The bench subcommand and its `merge` (cmd_bench_merge.cpp).
int benchMerge(const std::vector<std::string>& dirs, const std::string& out, const std::string& html,
               bool allow_incomplete, bool quiet);

void registerBench(CLI::App& app, Action& action) {
  auto b = std::make_shared<BenchOpts>();
  CLI::App* bs = app.add_subcommand(
      "bench",
      "Benchmark planners with ompl::tools::Benchmark (+ replay of every solution): one query, or a campaign file "
      "(queries x planners x modes x seeds; --shard i/N for Slurm arrays / GNU parallel); `ctr bench merge` joins "
      "the shards into a Planner Arena database");
  bs->add_option("input", b->input, "Query YAML, or campaign YAML (docs/planning.md \"Benchmark campaigns\")");
  bs->add_option("--mode", b->mode, "Query only: override the mode (exact, robust, frictionless)");
  bs->add_option("--planners", b->planners, "Query only: comma-separated planner names (default: the query's)");
  bs->add_option("--runs", b->runs, "Query only: runs per planner")->check(finitePositive());
  bs->add_option("--time", b->time, "Query only: time limit per run (s)")->check(finitePositive());
  bs->add_option("--out", b->out, "Output folder (OMPL logs + run records; query: .log + summary.json)")
      ->type_name("DIR");
  bs->add_option("--shard", b->shard,
                 "Campaign only: run part I of N (0 <= I < N), e.g. $SLURM_ARRAY_TASK_ID/$SLURM_ARRAY_TASK_COUNT");
  bs->add_flag("--quiet", b->quiet, "No progress on stderr");
  CLI::App* ms = bs->add_subcommand(
      "merge",
      "Check that a campaign's runs are complete (every run once) and write OUT/benchmark.db (Planner Arena, "
      "via OMPL's ompl_benchmark_statistics), OUT/summary.json and optionally an HTML report");
  ms->add_option("dirs", b->dirs, "Output folders of `ctr bench CAMPAIGN.yaml --out DIR` (one or several)")->required();
  ms->add_option("--out", b->merge_out, "Folder for benchmark.db, summary.json and logs/")
      ->required()
      ->type_name("DIR");
  ms->add_option("--html", b->html, "Write the campaign report (success rates, time to solution, replay outcomes)")
      ->type_name("FILE");
  ms->add_flag("--allow-incomplete", b->allow_incomplete,
               "Merge what is there and list the missing runs as warnings (duplicates are always an error)");
  ms->add_flag("--quiet", b->quiet, "No progress on stderr");
  ms->callback([b, &action]() {
    action = [b]() { return benchMerge(b->dirs, b->merge_out, b->html, b->allow_incomplete, b->quiet); };
  });
  bs->callback([b, bs, ms, &action]() {
    if (ms->parsed()) return;
    action = [b, bs]() {
      if (b->input.empty()) throw UsageError("bench: a query or campaign file is required (or `ctr bench merge`)");
      if (b->out.empty()) throw UsageError("--out is required");
      {
        std::error_code ec;
        if (fs::exists(b->out, ec) && !fs::is_directory(b->out, ec))
          throw UsageError("--out: '" + b->out + "' exists and is not a folder");
      }
      if (isCampaignFile(b->input)) {
        for (const char* opt : {"--runs", "--time"})
          if (bs->count(opt))
            throw UsageError(std::string(opt) + ": not used with a campaign file (set it in " + b->input + ")");
        return benchCampaign(*b);
      }
      if (!b->shard.empty()) throw UsageError("--shard: only for campaign files (" + b->input + " is a query)");
      return benchQuery(*b);
    };
  });
}

}  // namespace ctr::cli
