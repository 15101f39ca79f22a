/// @file
/// Merging a campaign's records (`ctr bench merge`): checks completeness (every (query, mode, planner, seed) exactly
/// once, with all its runs; names each missing or duplicated one), writes one OMPL log per (query, mode) experiment
/// with OMPL's own writer, turns them into OUT/benchmark.db with OMPL's ompl_benchmark_statistics (the database
/// Planner Arena reads), and writes OUT/summary.json (format in docs/formats.md "Campaign summary").
#pragma once

#include <cstddef>
#include <string>
#include <vector>

namespace ctr::campaign {

/// Options of mergeCampaign.
struct MergeOptions {
  /// Merge what is there and list the missing units in MergeSummary::missing (duplicates are always an error).
  bool allow_incomplete = false;
  /// OMPL's ompl_benchmark_statistics (Debian package ompl-demos). Empty: the environment variable
  /// CTR_OMPL_BENCHMARK_STATISTICS, else the first one on PATH.
  std::string statistics_tool;
};

/// What mergeCampaign wrote.
struct MergeSummary {
  std::string campaign;  ///< The campaign's name.
  std::size_t expected_units = 0, units = 0;
  std::size_t expected_runs = 0, runs = 0;
  std::vector<std::string> missing;      ///< Ids of the missing units (only with allow_incomplete).
  std::vector<std::string> experiments;  ///< The (query, mode) experiments of the database.
  std::string database;                  ///< OUT/benchmark.db (Planner Arena).
  std::string summary_file;              ///< OUT/summary.json.
  std::string logs;                      ///< OUT/logs: the merged OMPL logs.
  std::string summary_json;              ///< The contents of summary.json (the campaign report reads it).
  /// Every unit of the campaign is there.
  bool complete() const { return missing.empty(); }
};

/// Merges the output folders of one campaign's shards (`dirs`, each written by runCampaign) into `out`. Nothing is
/// written unless everything is: the outputs are staged in a folder inside `out` and moved into place at the end.
/// Throws io::InputError for folders that are not a campaign's, records of another campaign, duplicated or
/// incomplete units and (without allow_incomplete) missing ones, each named; std::runtime_error when
/// ompl_benchmark_statistics is not found or fails.
MergeSummary mergeCampaign(const std::vector<std::string>& dirs, const std::string& out, const MergeOptions& options);

}  // namespace ctr::campaign
