// Benchmark campaigns (`ctr bench CAMPAIGN.yaml`, docs/planning.md "Benchmark campaigns"): queries x planners x
// modes x seeds, each such unit run `runs_per_seed` times by ompl::tools::Benchmark. The units are a pure function
// of the campaign file, and `--shard i/N` runs a deterministic, balanced part of them, so a Slurm job array or GNU
// parallel runs a campaign unchanged; `ctr bench merge` checks completeness and builds the Planner Arena database.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace ctr::cli {

/// One query file of a campaign.
struct CampaignQuery {
  std::string file;  ///< Path (resolved against the campaign file's folder, lexically normal).
  std::string name;  ///< The query's name (its `name:` or file stem); unique within a campaign.
};

/// One (query, mode, planner, seed): run `runs_per_seed` times.
struct CampaignUnit {
  std::size_t query = 0;  ///< Index into Campaign::queries.
  std::string query_name, mode, planner;
  std::uint64_t seed = 0;
  /// "QUERY/MODE/PLANNER/seed-S": the identity of the unit in messages and records.
  std::string id() const;
  /// File stem of the unit's records: "QUERY__MODE__PLANNER__seed-S".
  std::string stem() const;
};

struct Campaign {
  std::string file;
  std::string name;  ///< `name:` or the file stem.
  std::vector<CampaignQuery> queries;
  std::vector<std::string> planners, modes;
  std::vector<std::uint64_t> seeds;
  double time_limit = 0.0;
  int runs_per_seed = 1;
  bool cpu_time = false;
  std::string fingerprint;  ///< Hash of everything that defines the runs (campaign values + query file contents).

  /// Every unit, sorted by (query name, mode, planner, seed).
  std::vector<CampaignUnit> units() const;
  /// The units of shard `index` (0-based) of `count`: unit k of units() goes to shard k mod count (round robin over
  /// the sorted list: every unit in exactly one shard, shard sizes differ by at most one, and each query's seeds
  /// are spread over the shards, so hard and easy queries mix).
  std::vector<CampaignUnit> shard(std::size_t index, std::size_t count) const;
  /// The campaign as JSON (written beside the runs; `ctr bench merge` reads it back).
  std::string toJson() const;
};

/// True when the YAML file looks like a campaign (a top-level `queries:` key) rather than a query.
bool isCampaignFile(const std::string& path);

/// Parses and checks a campaign: unknown keys, types, empty lists, duplicates, unknown modes, planners unknown in a
/// mode, query files that do not load, two queries with the same name. Throws io::InputError naming file/line/key.
Campaign loadCampaign(const std::string& path);

/// Reads Campaign::toJson() back (throws io::InputError naming `source`).
Campaign campaignFromJson(const std::string& json, const std::string& source);

/// Parses "i/N" (0 <= i < N); throws UsageError naming --shard.
std::pair<std::size_t, std::size_t> parseShard(const std::string& text);

}  // namespace ctr::cli
