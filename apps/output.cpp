#include "output.hpp"

#include "ctr/io/solution_json.hpp"

#include <cstdio>
#include <iomanip>
#include <sstream>

namespace ctr::cli {

std::string num(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

nlohmann::json solutionJson(const Solution& sol) { return nlohmann::json::parse(io::solutionJson(sol)); }

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
