#include "ctr/io/input_error.hpp"

#include <utility>

namespace ctr::io {
namespace {

// "FILE:LINE: key 'KEY': MESSAGE", leaving out the parts that are unknown.
std::string format(const std::string& file, int line, const std::string& key, const std::string& message) {
  std::string out = file.empty() ? std::string("<input>") : file;
  if (line > 0) out += ":" + std::to_string(line);
  out += ": ";
  if (!key.empty()) out += "key '" + key + "': ";
  out += message;
  return out;
}

}  // namespace

InputError::InputError(std::string file, int line, std::string key, std::string message)
    : std::runtime_error(format(file, line, key, message)),
      file_(std::move(file)),
      key_(std::move(key)),
      message_(std::move(message)),
      line_(line > 0 ? line : 0) {}

}  // namespace ctr::io
