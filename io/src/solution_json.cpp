#include "ctr/io/solution_json.hpp"

#include <nlohmann/json.hpp>

namespace ctr::io {

std::string solutionJson(const Solution& sol, int indent) {
  nlohmann::json j;
  j["converged"] = sol.converged();
  j["stable"] = sol.summary.stable;
  j["status"] = toString(sol.summary.status);
  j["stability"] = sol.summary.stability;
  j["iterations"] = sol.summary.iterations;
  j["tip_position"] = {sol.tip_position.x(), sol.tip_position.y(), sol.tip_position.z()};
  const Eigen::Vector3d t = sol.tipTangent();
  j["tip_tangent"] = {t.x(), t.y(), t.z()};
  j["twist"] = nlohmann::json::array();
  for (int k = 0; k < sol.twist.size(); ++k) j["twist"].push_back(sol.twist[k]);
  j["base_twist_rate"] = nlohmann::json::array();
  for (int k = 0; k < sol.base_twist_rate.size(); ++k) j["base_twist_rate"].push_back(sol.base_twist_rate[k]);
  j["moments"] = nlohmann::json::array();
  for (const auto& m : sol.moments)
    j["moments"].push_back({{"kind", toString(m.kind)}, {"tube", m.tube + 1}, {"s", m.s}, {"magnitude", m.magnitude}});
  if (!sol.summary.message.empty()) j["message"] = sol.summary.message;
  return j.dump(indent);
}

}  // namespace ctr::io
