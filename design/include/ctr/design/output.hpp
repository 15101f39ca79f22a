/// @file output.hpp
/// @brief What a design run writes (docs/design.md "Output"): DIR/robot.yaml (the best design, a normal robot
/// description), DIR/result.json (design, score, every query's plan result as `ctr plan --json` writes it, every
/// evaluation), DIR/paths/QUERY.csv (the replayed paths, as `ctr plan --path`), DIR/queries/QUERY.yaml (each query
/// with the designed robot and its adapted start, for `ctr plan`) and DIR/space.yaml (the design space searched);
/// and the merge of the shards of a run.
#pragma once

#include <string>
#include <vector>

#include "ctr/design/search.hpp"

namespace ctr::design {

/// @brief The file stem of a query's files in a design folder (queries/STEM.yaml, paths/STEM.csv): its name with
/// every character other than letters, digits, `_`, `-` and `.` replaced by `_`.
std::string queryFileStem(const std::string& query_name);

/// @brief The result as JSON text. `shard`: "I/N" of the part of the run (or "0/1").
std::string resultJson(const Designer& designer, const DesignResult& result, const DesignOptions& options,
                       const std::string& shard);

/// @brief A copy of the query file `query` (its text, with every key kept) whose robot is `robot_path` and whose
/// start is `start`; robot and environment paths relative to `dir`, the folder the copy is written to.
std::string designedQueryYaml(const std::string& query_file, const std::string& robot_path, const Configuration& start,
                              const std::string& dir);

/// @brief Writes the run's files into `dir` (created if missing; each file written atomically).
void writeDesign(const Designer& designer, const DesignResult& result, const DesignOptions& options,
                 const std::string& shard, const std::string& dir);

/// @brief Merges the shard outputs found in `dirs` (each DIR/shards/*/result.json, or DIR/result.json itself) into
/// `out`: the best design over every shard, with its robot, paths and queries, and every evaluation. Throws
/// ctr::io::InputError when a shard is missing or duplicated (unless `allow_incomplete`; duplicates always) or when
/// the shards belong to different runs. Nothing is written then. Returns the merged result JSON text.
std::string mergeDesigns(const std::vector<std::string>& dirs, const std::string& out, bool allow_incomplete);

}  // namespace ctr::design
