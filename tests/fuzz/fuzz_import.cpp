// Fuzz target: the real-data importer (ctr::diagnosis::importTableText). Leading lines "@NAME=COL[*S][+O]" are
// column mappings (parseColumnMapping; they replace the Dupont-lab preset), "@tubes=N", "@skip=N", "@delim=X",
// "@unwrap=NAME" set the other options; the rest is the table.
#include <string>

#include "ctr/diagnosis/import.hpp"
#include "fuzz_common.hpp"

CTR_FUZZ_TARGET(import) {
  std::string text(reinterpret_cast<const char*>(data), size);
  ctr::diagnosis::ImportOptions options = ctr::diagnosis::dupontLabImportOptions();
  bool custom = false;
  while (!text.empty() && text[0] == '@') {
    const auto nl = text.find('\n');
    const std::string line = text.substr(1, nl == std::string::npos ? std::string::npos : nl - 1);
    text = nl == std::string::npos ? std::string() : text.substr(nl + 1);
    auto value = [&](const char* key) -> const char* {
      const std::string k = std::string(key) + "=";
      return line.rfind(k, 0) == 0 ? line.c_str() + k.size() : nullptr;
    };
    if (const char* v = value("tubes")) {
      options.tubes = std::atoi(v) % 8;  // bounded: the importer is not the place that limits n
    } else if (const char* v = value("skip")) {
      options.skip_rows = std::atoi(v) % 1000;
    } else if (const char* v = value("delim")) {
      options.delimiter = v;
    } else if (const char* v = value("unwrap")) {
      options.unwrap.push_back(v);
    } else if (line == "nonorm") {
      options.normalize_tangent = false;
    } else {
      try {
        auto m = ctr::diagnosis::parseColumnMapping(line);
        if (!custom) {
          options.columns.clear();
          options.unwrap.clear();
          custom = true;
        }
        options.columns[m.first] = m.second;
      } catch (const std::invalid_argument&) {
      }
    }
  }
  try {
    (void)ctr::diagnosis::importTableText(text, "fuzz.txt", options);
  } catch (const ctr::io::InputError&) {
  }
  return 0;
}
