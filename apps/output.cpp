#include "output.hpp"

#include <cstdio>
#include <iomanip>
#include <sstream>

namespace ctr::cli {

std::string num(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

nlohmann::json solutionJson(const Solution& sol) {
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
    j["moments"].push_back({{"kind", m.kind == MomentKind::TubeEnd ? "tube_end" : "curvature_discontinuity"},
                            {"tube", m.tube + 1},
                            {"s", m.s},
                            {"magnitude", m.magnitude}});
  if (!sol.summary.message.empty()) j["message"] = sol.summary.message;
  return j;
}

void printSolution(std::ostream& os, const Solution& sol) {
  os << std::setprecision(6);
  os << "converged:    " << (sol.converged() ? "yes" : "no") << " (" << toString(sol.summary.status) << ", "
     << sol.summary.iterations << " iterations)\n";
  os << "stable:       " << (sol.summary.stable ? "yes" : "no") << " (stability measure " << sol.summary.stability
     << ")\n";
  os << "tip position: " << sol.tip_position.x() << " " << sol.tip_position.y() << " " << sol.tip_position.z()
     << " m\n";
  const Eigen::Vector3d t = sol.tipTangent();
  os << "tip tangent:  " << t.x() << " " << t.y() << " " << t.z() << "\n";
  for (int k = 0; k < sol.twist.size(); ++k) os << "twist_" << k + 2 << ":      " << sol.twist[k] << " rad\n";
}

std::string backboneCsv(const std::vector<BackbonePoint>& pts) {
  std::ostringstream os;
  os << "s,x,y,z\n";
  for (const auto& p : pts)
    os << num(p.s) << ',' << num(p.position.x()) << ',' << num(p.position.y()) << ',' << num(p.position.z()) << '\n';
  return os.str();
}

}  // namespace ctr::cli
