/// @file
/// Running benchmarks: a shard of a campaign (runCampaign) or one query with planners of the caller's choice
/// (benchmarkQuery). Every run is an ompl::tools::Benchmark run, and every solution is replayed through the friction
/// model (planner::CtrPlanner::replaySolution); the records are what `ctr bench` writes and the merge reads.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "ctr/campaign/campaign.hpp"
#include "ctr/planner/query.hpp"

namespace ctr::campaign {

/// Receives the progress of a benchmark (the CLI draws its progress line with it). Every method has an empty default.
/// Called from the thread that runs the benchmark.
class RunObserver {
 public:
  virtual ~RunObserver() = default;
  /// Before the first run: `runs` runs are to be done, `kept_runs` of them were recorded before (an interrupted
  /// shard run again) and are not run again.
  virtual void started(std::size_t runs, std::size_t kept_runs) {
    (void)runs;
    (void)kept_runs;
  }
  /// A unit begins (campaigns only).
  virtual void unitStarted(const CampaignUnit& unit) { (void)unit; }
  /// One run ended (solved or not; its solution, if any, replayed).
  virtual void runFinished() {}
  /// Something the user should know before the runs ("no goal configuration found by IK; ...").
  virtual void warning(const std::string& text) { (void)text; }
};

/// Options of runCampaign.
struct RunOptions {
  std::string out;                  ///< Output folder (created; may hold earlier runs of the same campaign).
  Shard shard;                      ///< The part to run (default: all of it, 0/1).
  RunObserver* observer = nullptr;  ///< Progress (optional; not owned).
};

/// What runCampaign did.
struct RunSummary {
  std::string shard;                   ///< "I/N".
  std::size_t units = 0;               ///< Units of the shard.
  std::vector<std::string> units_run;  ///< Ids of the units run now (CampaignUnit::id).
  std::size_t units_kept = 0;          ///< Units already recorded in the folder, not run again.
  double seconds = 0.0;                ///< Wall time.
  std::string records;                 ///< The folder of the unit records (OUT/units).
  std::string shard_record;            ///< OUT/shards/shard-I-of-N.json.
};

/// Runs the units of `options.shard` and writes, per unit, its OMPL log and its record (OUT/units/STEM.log and
/// STEM.json, the record last: a record marks a complete unit), OUT/campaign.json and the shard's record. Units whose
/// record is already in the folder are kept, not run again. Throws io::InputError before any work when the folder
/// holds the runs of another campaign or is not a folder, and std::invalid_argument for a shard that is not I/N.
RunSummary runCampaign(const Campaign& campaign, const RunOptions& options);

/// Options of benchmarkQuery.
struct BenchmarkOptions {
  std::vector<std::string> planners;  ///< Planner names (empty: the query's planner).
  int runs = 10;                      ///< Runs per planner.
  double time_limit = 5.0;            ///< Seconds per run (wall clock).
  std::string out;                    ///< Output folder: QUERY_MODE.log (OMPL's log) and summary.json.
  RunObserver* observer = nullptr;    ///< Progress (optional; not owned).
};

/// One planner's results in benchmarkQuery.
struct BenchmarkRow {
  std::string planner, mode;
  int runs = 0;
  double planner_success_rate = 0.0;  ///< Share of runs the planner solved.
  double replay_success_rate = 0.0;   ///< Share of runs whose solution also replays clean.
  int replay_failures = 0;            ///< Solved runs whose replay failed.
  double mean_time_to_solution = 0.0;
  double mean_path_length = 0.0;
};

/// What benchmarkQuery did.
struct BenchmarkSummary {
  std::vector<BenchmarkRow> rows;  ///< One per planner, sorted by name.
  /// Goal configurations found by IK before the runs. For a tip goal, 0 means the planners can reach the goal region
  /// only by chance (RRTConnect, PRM and BIT* sample the goal from this pool).
  std::size_t goal_pool = 0;
  bool tip_goal = false;     ///< The query's goal is a tip position.
  std::string log;           ///< The OMPL log written.
  std::string summary_file;  ///< summary.json written (the rows as JSON).
  /// The rows as the JSON array written to summary.json.
  std::string toJson() const;
};

/// Benchmarks planners on one query (ompl::tools::Benchmark, `options.runs` runs per planner) and replays every
/// solution. Throws io::InputError / std::invalid_argument for unknown planner names or a start that is not valid.
BenchmarkSummary benchmarkQuery(const planner::Query& query, const BenchmarkOptions& options);

}  // namespace ctr::campaign
