/// @file
/// Benchmark campaigns (docs/planning.md "Benchmark campaigns"; file format in docs/formats.md "Campaign"):
/// queries x planners x modes x seeds, each such unit run `runs_per_seed` times by ompl::tools::Benchmark. The units
/// are a pure function of the campaign file, and a shard (i of N) is a deterministic, balanced part of them, so a
/// Slurm job array or GNU parallel runs a campaign unchanged (ctr/campaign/run.hpp); the merge checks completeness
/// and builds the Planner Arena database (ctr/campaign/merge.hpp).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace ctr::campaign {

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

/// Part `index` (0-based) of `count` of a campaign's units.
struct Shard {
  std::size_t index = 0;
  std::size_t count = 1;
  /// "I/N", as in `--shard I/N`.
  std::string label() const;
};

/// A campaign as loaded from its YAML file (loadCampaign) or read back from its JSON record (campaignFromJson).
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
  /// The units of a shard: unit k of units() goes to shard k mod count (round robin over the sorted list: every unit
  /// in exactly one shard, shard sizes differ by at most one, and each query's seeds are spread over the shards, so
  /// hard and easy queries mix). Throws std::invalid_argument unless index < count.
  std::vector<CampaignUnit> shard(const Shard& shard) const;
  /// The campaign as JSON (written beside the runs as campaign.json; the merge reads it back).
  std::string toJson() const;
};

/// True when the YAML file looks like a campaign (a top-level `queries:` key) rather than a query.
bool isCampaignFile(const std::string& path);

/// Parses and checks a campaign: unknown keys, types, empty lists, duplicates, unknown modes, planners unknown in a
/// mode, query files that do not load, two queries with the same name. Throws io::InputError naming file/line/key.
Campaign loadCampaign(const std::string& path);

/// Reads Campaign::toJson() back (throws io::InputError naming `source`).
Campaign campaignFromJson(const std::string& json, const std::string& source);

/// Parses "I/N" (0 <= I < N); throws std::invalid_argument saying what is wrong with `text`.
Shard parseShard(const std::string& text);

}  // namespace ctr::campaign
