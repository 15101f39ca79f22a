// The data folder (io/data.hpp).
#include "ctr/io/data.hpp"

#include <cstdlib>
#include <filesystem>

#ifndef CTR_DEFAULT_DATA_DIR
#define CTR_DEFAULT_DATA_DIR "data"
#endif

namespace ctr::io {
namespace {
constexpr const char* kVariable = "${CTR_DATA}";
}  // namespace

std::string dataDirectory() {
  const char* env = std::getenv("CTR_DATA");
  return env && *env ? std::string(env) : std::string(CTR_DEFAULT_DATA_DIR);
}

bool isDataPath(const std::string& path) {
  return path.rfind(kVariable, 0) == 0;
}

std::string expandDataPath(const std::string& path) {
  if (!isDataPath(path)) return path;
  return dataDirectory() + path.substr(std::char_traits<char>::length(kVariable));
}

std::string missingDataMessage(const std::string& path) {
  namespace fs = std::filesystem;
  const fs::path dir = fs::path(dataDirectory()).lexically_normal();
  const fs::path rel = fs::path(expandDataPath(path)).lexically_normal().lexically_relative(dir);
  const std::string set = rel.empty() || *rel.begin() == ".." ? std::string() : rel.begin()->string();
  std::string m = path + " not found";
  if (!set.empty()) m += ": data set '" + set + "' is not in " + dir.string();
  if (set == "recordings")  // not public: it comes with the shared folder beside the checkout
    return m + " (the recordings with known truth are in ../shared/data beside the checkout; set CTR_DATA to it)";
  return m + " (run scripts/fetch-data.sh to fetch the public data sets, or set CTR_DATA to their folder)";
}

}  // namespace ctr::io
