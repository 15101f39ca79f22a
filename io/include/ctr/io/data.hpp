/// @file data.hpp
/// @brief Where the public data sets the examples, tests and benchmarks use are found (Med-MPD planning environments,
/// the Dupont-lab recording, the recordings with known truth): one folder, fetched by scripts/fetch-data.sh.
#pragma once

#include <string>

namespace ctr::io {

/// @brief The folder of the data sets: the environment variable CTR_DATA when set, else the folder chosen when the
/// library was built (CMake: -DCTR_DATA=DIR, else ../shared/data beside the checkout, else data/ in the checkout).
std::string dataDirectory();

/// @brief True if `path` starts with "${CTR_DATA}" (a path into the data folder, as the example environments give).
bool isDataPath(const std::string& path);

/// @brief `path` with a leading "${CTR_DATA}" replaced by dataDirectory(); any other path unchanged.
std::string expandDataPath(const std::string& path);

/// @brief The one message for a data file that is not there: the file, its data set (the first folder below the data
/// folder), where it was looked for and how to get it (scripts/fetch-data.sh, or CTR_DATA).
std::string missingDataMessage(const std::string& path);

}  // namespace ctr::io
