/// @file file.hpp
/// @brief Reading and writing whole files, with the file named in every error.
#pragma once

#include <string>

#include "ctr/io/input_error.hpp"

namespace ctr::io {

/// @brief Writes a whole file atomically (temporary file in the same folder + rename). Throws InputError.
void writeFileAtomic(const std::string& path, const std::string& content);
/// @brief Reads a whole file (at most 1 GiB). Throws InputError if it cannot be read.
std::string readFile(const std::string& path);

}  // namespace ctr::io
