// Running benchmarks (ctr/campaign/run.hpp): a campaign shard's units, or one query's planners, through
// ompl::tools::Benchmark, with every solution replayed through the friction model.
#include "ctr/campaign/run.hpp"

#include <ompl/base/PlannerTerminationCondition.h>
#include <ompl/tools/benchmark/Benchmark.h>
#include <ompl/util/Console.h>
#include <ompl/util/RandomNumbers.h>

#include <chrono>
#include <cmath>
#include <ctime>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>

#include "ctr/environments/environment_yaml.hpp"
#include "ctr/io/file.hpp"
#include "ctr/io/input_error.hpp"
#include "ctr/io/robot_yaml.hpp"
#include "ctr/planner/planner.hpp"
#include "ctr/planner/result_json.hpp"
#include "ctr/planner/stopwatch.hpp"
#include "records.hpp"

namespace fs = std::filesystem;
namespace ob = ompl::base;
using nlohmann::json;

namespace ctr::campaign {
namespace {

using detail::hostName;
using detail::isoNow;
using detail::readText;

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

// A run's replay in its record: the plan's replay object (planner::replayJson) with whether the run counts as solved
// (planned and replayed clean) and the path length.
json recordReplay(const planner::PlanResult& r) {
  json j = json::parse(planner::replayJson(r));
  j["solved"] = r.solved;
  j["path_length"] = r.path_length;
  return j;
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

struct LoadedQuery {
  std::string file;
  std::optional<Robot> robot;
  std::optional<environments::Environment> environment;
};

// One unit: its runs through ompl::tools::Benchmark, each solution replayed; the record (with the OMPL log under
// "log", which runCampaign writes to its own file).
json runUnit(const Campaign& c, const CampaignUnit& u, LoadedQuery& cache, const std::string& shard_label,
             RunObserver& observer) {
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
      replay = recordReplay(r);
    } else {
      addReplayProperties(run, nullptr);
    }
    runs.push_back({{"run", run_index++},
                    {"planner_solved", has},
                    {"time", std::stod(run.count("time REAL") ? run["time REAL"] : std::string("0"))},
                    {"replay", replay},
                    {"ompl", run}});
    observer.runFinished();
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
  rec["format"] = detail::kUnitFormat;
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

}  // namespace

RunSummary runCampaign(const Campaign& c, const RunOptions& options) {
  RunObserver silent;
  RunObserver& observer = options.observer ? *options.observer : silent;
  const std::vector<CampaignUnit> units = c.shard(options.shard);  // throws for a shard that is not I/N
  const std::string shard_label = options.shard.label();
  detail::requireOutputFolder(options.out, "runCampaign");
  const fs::path out(options.out), units_dir = out / "units";
  // A folder holds the runs of one campaign: refuse to mix (before any work).
  const fs::path manifest = out / "campaign.json";
  if (fs::exists(manifest)) {
    const Campaign old = campaignFromJson(readText(manifest), manifest.string());
    if (old.fingerprint != c.fingerprint)
      throw io::InputError(manifest.string(), 0, "fingerprint",
                           options.out + " holds the runs of another campaign ('" + old.name + "' from " + old.file +
                               ", fingerprint " + old.fingerprint + "; this one: " + c.fingerprint +
                               "); use another output folder");
  }
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
      throw io::InputError(f.string(), 0, "fingerprint",
                           "belongs to another campaign (fingerprint " + j.value("fingerprint", "?") + ", this one " +
                               c.fingerprint + "); use another output folder");
    if (j.contains("runs") && j["runs"].size() == static_cast<std::size_t>(c.runs_per_seed)) {
      done[k] = true;
      ++kept;
    }
  }
  fs::create_directories(units_dir);
  io::writeFileAtomic(manifest.string(), c.toJson());
  const auto runs_per_unit = static_cast<std::size_t>(c.runs_per_seed);
  observer.started(units.size() * runs_per_unit, kept * runs_per_unit);
  LoadedQuery cache;
  const planner::Stopwatch watch;
  RunSummary summary;
  summary.shard = shard_label;
  summary.units = units.size();
  summary.units_kept = kept;
  summary.records = units_dir.string();
  for (std::size_t k = 0; k < units.size(); ++k) {
    if (done[k]) continue;
    observer.unitStarted(units[k]);
    const json rec = runUnit(c, units[k], cache, shard_label, observer);
    // The OMPL log first, the record last: a record is the mark of a complete unit.
    io::writeFileAtomic((units_dir / (units[k].stem() + ".log")).string(), rec["log"].get<std::string>());
    json r = rec;
    r.erase("log");
    io::writeFileAtomic((units_dir / (units[k].stem() + ".json")).string(), r.dump(1) + "\n");
    summary.units_run.push_back(units[k].id());
  }
  summary.seconds = watch.seconds();
  const json shard = {{"campaign", c.name},    {"fingerprint", c.fingerprint},   {"shard", shard_label},
                      {"host", hostName()},    {"finished", isoNow()},           {"seconds", summary.seconds},
                      {"units", units.size()}, {"units_run", summary.units_run}, {"units_kept", kept}};
  fs::create_directories(out / "shards");
  summary.shard_record =
      (out / "shards" /
       ("shard-" + std::to_string(options.shard.index) + "-of-" + std::to_string(options.shard.count) + ".json"))
          .string();
  io::writeFileAtomic(summary.shard_record, shard.dump(2) + "\n");
  return summary;
}

std::string BenchmarkSummary::toJson() const {
  json summary = json::array();
  for (const auto& r : rows)
    summary.push_back({{"planner", r.planner},
                       {"mode", r.mode},
                       {"runs", r.runs},
                       {"planner_success_rate", r.planner_success_rate},
                       {"replay_success_rate", r.replay_success_rate},
                       {"replay_failures", r.replay_failures},
                       {"mean_time_to_solution", r.mean_time_to_solution},
                       {"mean_path_length", r.mean_path_length}});
  return summary.dump(2);
}

BenchmarkSummary benchmarkQuery(const planner::Query& q, const BenchmarkOptions& options) {
  if (options.runs < 1) throw std::invalid_argument("benchmarkQuery: runs must be >= 1");
  if (!(options.time_limit > 0) || !std::isfinite(options.time_limit))
    throw std::invalid_argument("benchmarkQuery: time_limit must be > 0 s");
  detail::requireOutputFolder(options.out, "benchmarkQuery");
  RunObserver silent;
  RunObserver& observer = options.observer ? *options.observer : silent;
  planner::CtrPlanner p(q);
  p.checkStart();
  std::vector<std::string> names = options.planners;
  if (names.empty()) names.push_back(q.planner);
  std::vector<ob::PlannerPtr> planners;
  for (const auto& n : names) planners.push_back(p.makePlanner(n));  // throws for unknown names
  BenchmarkSummary result;
  result.tip_goal = q.tip_goal.has_value();
  // Goal configurations for sampleable tip goals (RRTConnect, PRM, BIT* need them), found once before the runs.
  result.goal_pool = p.prepareGoal(options.time_limit);
  if (result.tip_goal && result.goal_pool == 0)
    observer.warning("no goal configuration found by IK; planners can only reach the goal region by chance");
  fs::create_directories(options.out);
  observer.started(planners.size() * static_cast<std::size_t>(options.runs), 0);
  struct Tally {
    int runs = 0, planner_solved = 0, replay_solved = 0, replay_failures = 0;
    double time_sum = 0.0, path_length_sum = 0.0;
  };
  std::map<std::string, Tally> per;
  auto post = [&p, &per, &observer](const ob::PlannerPtr& planner, ompl::tools::Benchmark::RunProperties& run) {
    const bool has = run.count("solved BOOLEAN") && run["solved BOOLEAN"] == "1";
    Tally& s = per[planner->getName()];
    ++s.runs;
    if (has) {
      const planner::PlanResult r = p.replaySolution(planner->getName(), std::stod(run["time REAL"]), true);
      addReplayProperties(run, &r);
      ++s.planner_solved;
      s.replay_solved += r.solved ? 1 : 0;
      s.replay_failures += r.solved ? 0 : 1;
      s.time_sum += std::stod(run["time REAL"]);
      s.path_length_sum += r.path_length;
    } else {
      addReplayProperties(run, nullptr);
    }
    observer.runFinished();
  };
  ompl::tools::Benchmark::Request req(options.time_limit, 4096.0, static_cast<unsigned int>(options.runs), 0.5, false,
                                      false, false);
  result.log = (fs::path(options.out) / (q.name + "_" + planner::toString(q.mode) + ".log")).string();
  auto runBench = [&](auto& setup) {
    ompl::tools::Benchmark bench(setup, q.name);
    for (auto& pl : planners) bench.addPlanner(pl);
    bench.setPostRunEvent(post);
    bench.benchmark(req);
    std::ostringstream os;
    bench.saveResultsToStream(os);
    io::writeFileAtomic(result.log, os.str());
  };
  if (p.geometricSetup())
    runBench(*p.geometricSetup());
  else
    runBench(*p.controlSetup());
  for (const auto& [name, s] : per) {
    BenchmarkRow row;
    row.planner = name;
    row.mode = planner::toString(q.mode);
    row.runs = s.runs;
    row.planner_success_rate = s.runs ? double(s.planner_solved) / s.runs : 0.0;
    row.replay_success_rate = s.runs ? double(s.replay_solved) / s.runs : 0.0;
    row.replay_failures = s.replay_failures;
    row.mean_time_to_solution = s.planner_solved ? s.time_sum / s.planner_solved : 0.0;
    row.mean_path_length = s.planner_solved ? s.path_length_sum / s.planner_solved : 0.0;
    result.rows.push_back(row);
  }
  result.summary_file = (fs::path(options.out) / "summary.json").string();
  io::writeFileAtomic(result.summary_file, result.toJson() + "\n");
  return result;
}

}  // namespace ctr::campaign
