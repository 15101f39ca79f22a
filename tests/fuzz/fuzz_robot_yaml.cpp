// Fuzz target: robot description YAML (ctr::io::parseRobot, and robotToYaml round trip of accepted robots).
#include <string>

#include "ctr/io/robot_yaml.hpp"
#include "fuzz_common.hpp"

CTR_FUZZ_TARGET(robot_yaml) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const ctr::Robot robot = ctr::io::parseRobot(text, "fuzz.yaml");
    // An accepted robot must survive a save / parse round trip.
    (void)ctr::io::parseRobot(ctr::io::robotToYaml(robot), "roundtrip.yaml");
  } catch (const ctr::io::InputError&) {
  }
  return 0;
}
