// The sweep report's data.
#include <cmath>
#include <nlohmann/json.hpp>

#include "ctr/reports/reports.hpp"

namespace ctr::reports {
namespace {
nlohmann::json num(double v) {
  return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr);
}
}  // namespace

std::string sweepHtml(const SweepPlot& s, const std::string& title) {
  using nlohmann::json;
  json j;
  j["kind"] = "sweep";
  j["robot"] = s.robot;
  j["tube"] = s.tube;
  j["tubes"] = s.tubes;
  j["friction"] = {
      {"boundary", s.boundary_friction}, {"distributed", s.distributed_friction}, {"mode", s.friction_mode}};
  json angle = json::array(), dir = json::array(), conv = json::array(), stab = json::array(), stable = json::array(),
       snap = json::array(), tip = json::array(), twist = json::array();
  for (int i = 0; i + 1 < s.tubes; ++i) twist.push_back(json::array());
  for (int d = 0; d < 3; ++d) tip.push_back(json::array());
  for (const SweepRow& r : s.rows) {
    angle.push_back(r.angle);
    dir.push_back(r.direction);
    conv.push_back(r.converged ? 1 : 0);
    stable.push_back(r.stable ? 1 : 0);
    snap.push_back(r.snapped ? 1 : 0);
    stab.push_back(r.converged ? num(r.stability) : json(nullptr));
    for (int i = 0; i + 1 < s.tubes; ++i)
      twist[i].push_back(r.converged && i < static_cast<int>(r.twist.size()) ? num(r.twist[i]) : json(nullptr));
    for (int d = 0; d < 3; ++d) tip[d].push_back(r.converged ? num(r.tip[d]) : json(nullptr));
  }
  j["angle"] = angle;
  j["direction"] = dir;
  j["converged"] = conv;
  j["stable"] = stable;
  j["snapped"] = snap;
  j["stability"] = stab;
  j["twist"] = twist;
  j["tip"] = tip;
  json band = json::array();
  for (const SweepBand& b : s.band) {
    json mn = json::array(), mx = json::array();
    for (double v : b.twist_min) mn.push_back(num(v));
    for (double v : b.twist_max) mx.push_back(num(v));
    band.push_back({{"angle", b.angle}, {"twist_min", mn}, {"twist_max", mx}, {"tip_spread", num(b.tip_spread)}});
  }
  j["band"] = band;
  return renderHtml(ReportKind::Sweep, title, j.dump());
}

}  // namespace ctr::reports
