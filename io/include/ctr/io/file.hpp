/// @file file.hpp
/// @brief Reading and writing whole files, with the file named in every error.
#pragma once

#include <string>

#include "ctr/io/input_error.hpp"

namespace ctr::io {

/// @brief Writes a whole file atomically (temporary file in the same folder + rename). Throws InputError.
void writeFileAtomic(const std::string& path, const std::string& content);
/// @brief Reads a whole file (at most 1 GiB); a path that starts with "${CTR_DATA}" is a file of the data folder
/// (io/data.hpp). Throws InputError if it cannot be read (for a missing data file: missingDataMessage).
std::string readFile(const std::string& path);

}  // namespace ctr::io
