// Output helpers of the `ctr` command (JSON of a solution, text summary, CSV rows).
#pragma once

#include <nlohmann/json.hpp>
#include <ostream>
#include <string>
#include <vector>

#include "ctr/model/kinematics.hpp"

namespace ctr::cli {

/// {"converged","stable","tip_position","tip_tangent","twist", ...}
nlohmann::json solutionJson(const Solution& sol);
/// Human-readable summary.
void printSolution(std::ostream& os, const Solution& sol);
/// "s,x,y,z" CSV of backbone points.
std::string backboneCsv(const std::vector<BackbonePoint>& pts);
/// Round-trip representation of a double (17 significant digits).
std::string num(double v);

}  // namespace ctr::cli
