// Fuzz target: environment description YAML (ctr::environments::parseEnvironmentDescription), and building of
// descriptions whose only source is procedural, with a bounded grid.
//
// Relative paths resolve against an empty private scratch folder; inputs containing '/' or '\\' (absolute paths,
// "../") are skipped so that the parser never opens files outside it (Med-MPD start/target files are opened at
// parse time).
#include <cstring>
#include <string>

#include "ctr/environments/environment_yaml.hpp"
#include "ctr/io/input_error.hpp"
#include "fuzz_common.hpp"

CTR_FUZZ_TARGET(environment_yaml) {
  if (size == 0 || std::memchr(data, '/', size) || std::memchr(data, '\\', size)) return 0;
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const ctr::environments::EnvironmentDescription d =
        ctr::environments::parseEnvironmentDescription(text, "fuzz.yaml", ctr::fuzz::scratchDir().string());
    // Build only self-contained descriptions (procedural), coarse and with a small cell cap: building has to stay
    // bounded by BuildOptions::max_cells whatever the description says.
    if (d.obstacles.empty() && d.stay_inside &&
        d.stay_inside->kind == ctr::environments::SourceSpec::Kind::Procedural) {
      ctr::environments::BuildOptions options;
      options.resolution = 4e-3;
      options.max_cells = 100000;
      (void)ctr::environments::buildEnvironment(d, options);
    }
  } catch (const ctr::io::InputError&) {
  }
  return 0;
}
