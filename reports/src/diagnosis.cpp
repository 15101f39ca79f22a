// The diagnosis report's data: the diagnosis JSON and the plot data, unchanged, side by side.
#include <cmath>
#include <nlohmann/json.hpp>

#include "ctr/diagnosis/diagnose.hpp"
#include "ctr/reports/reports.hpp"

namespace ctr::reports {

std::string diagnosisHtml(const diagnosis::DiagnosisReport& report, const io::Recording& rec,
                          const std::string& title) {
  nlohmann::json j;
  j["kind"] = "diagnosis";
  j["report"] = nlohmann::json::parse(diagnosis::reportToJson(report));
  j["plot"] = nlohmann::json::parse(diagnosis::plotDataJson(report, rec));
  j["recording_rows"] = rec.rows();
  // Every row of the recording (the diagnosis may use every k-th row only): measured values vs configuration.
  auto r6 = [](double v) {
    return std::isfinite(v) ? nlohmann::json(std::round(v * 1e6) / 1e6) : nlohmann::json(nullptr);
  };
  auto matrix = [&](const Eigen::MatrixXd& M) {
    nlohmann::json a = nlohmann::json::array();
    for (Eigen::Index r = 0; r < M.rows(); ++r) {
      nlohmann::json row = nlohmann::json::array();
      for (Eigen::Index c = 0; c < M.cols(); ++c) row.push_back(r6(M(r, c)));
      a.push_back(row);
    }
    return a;
  };
  nlohmann::json full;
  nlohmann::json vars = nlohmann::json::array();
  for (const diagnosis::ConfigVariable& v : diagnosis::configVariables(rec)) {
    nlohmann::json val = nlohmann::json::array();
    for (Eigen::Index k = 0; k < v.value.size(); ++k) val.push_back(r6(v.value[k]));
    vars.push_back({{"name", v.name}, {"angle", v.angle}, {"value", val}});
  }
  full["variables"] = vars;
  if (rec.hasTime()) {
    nlohmann::json t = nlohmann::json::array();
    for (Eigen::Index k = 0; k < rec.time.size(); ++k) t.push_back(r6(rec.time[k]));
    full["time"] = t;
  }
  if (rec.hasTwist()) full["twist"] = matrix(rec.twist);
  if (rec.hasTipPosition()) full["tip_position"] = matrix(rec.tip_position);
  j["recording"] = full;
  j["tubes"] = rec.tubes;
  return renderHtml(ReportKind::Diagnosis, title, j.dump());
}

}  // namespace ctr::reports
