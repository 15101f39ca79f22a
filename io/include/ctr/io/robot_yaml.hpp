/// @file robot_yaml.hpp
/// @brief Robot description YAML (docs/formats.md): load with validation, save.
#pragma once

#include <string>

#include "ctr/io/input_error.hpp"
#include "ctr/model/robot.hpp"

namespace ctr::io {

/// @brief Loads and validates a robot YAML file. Throws InputError naming the file, line, tube and key.
Robot loadRobot(const std::string& path);
/// @brief Parses robot YAML text; `source` names it in error messages.
Robot parseRobot(const std::string& text, const std::string& source);
/// @brief YAML text of a robot (round-trips through parseRobot).
std::string robotToYaml(const Robot& robot);
/// @brief Writes a robot YAML file atomically.
void saveRobot(const Robot& robot, const std::string& path);

}  // namespace ctr::io
