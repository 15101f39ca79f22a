/// @file input_error.hpp
/// @brief The exception for bad input files: names the file, the line (when known) and the key/column.
#pragma once

#include <stdexcept>
#include <string>

namespace ctr::io {

/// @brief Bad user input (file missing, malformed, out of range). The CLI maps it to exit code 2.
/// what() reads "FILE:LINE: key 'KEY': MESSAGE" (parts omitted when unknown).
class InputError : public std::runtime_error {
public:
  InputError(std::string file, int line, std::string key, std::string message);
  const std::string& file() const { return file_; }
  int line() const { return line_; }  ///< 1-based; 0 when unknown.
  const std::string& key() const { return key_; }
  const std::string& message() const { return message_; }

private:
  std::string file_, key_, message_;
  int line_ = 0;
};

}  // namespace ctr::io
