// The design report's data: the run's result.json with the replayed paths' clearance added.
#include <cmath>
#include <nlohmann/json.hpp>
#include <stdexcept>

#include "ctr/reports/reports.hpp"

namespace ctr::reports {

std::string designHtml(const std::string& result_json, const std::vector<DesignPathPlot>& paths,
                       const std::string& title) {
  using nlohmann::json;
  json j = json::parse(result_json);
  if (!j.is_object() || !j.contains("evaluations")) throw std::invalid_argument("designHtml: not a design result");
  j["kind"] = "design";
  json ps = json::array();
  for (const DesignPathPlot& p : paths) {
    json travel = json::array(), clearance = json::array();
    for (double v : p.tip_travel) travel.push_back(v);
    for (double v : p.clearance) clearance.push_back(std::isfinite(v) ? json(v) : json(nullptr));
    ps.push_back({{"query", p.query}, {"tip_travel", travel}, {"clearance", clearance}, {"viewer", p.viewer}});
  }
  j["paths"] = ps;
  return renderHtml(ReportKind::Design, title, j.dump());
}

}  // namespace ctr::reports
