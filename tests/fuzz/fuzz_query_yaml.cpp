// Fuzz target: planning query YAML (ctr::planner::parseQuery with check_files = false, so the robot / environment
// paths are only resolved, never opened).
#include <string>

#include "ctr/io/input_error.hpp"
#include "ctr/planner/query.hpp"
#include "fuzz_common.hpp"

CTR_FUZZ_TARGET(query_yaml) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    (void)ctr::planner::parseQuery(text, "fuzz.yaml", ctr::fuzz::scratchDir().string(), false);
  } catch (const ctr::io::InputError&) {
  }
  return 0;
}
