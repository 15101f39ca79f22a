#include "ctr/environments/environment_json.hpp"

#include <nlohmann/json.hpp>

namespace ctr::environments {
namespace {

using Json = nlohmann::json;

Json vec(const Eigen::Vector3d& v) {
  return Json::array({v.x(), v.y(), v.z()});
}

Json poseJson(const Eigen::Isometry3d& T) {
  Json m = Json::array();
  for (int r = 0; r < 4; ++r) {
    Json row = Json::array();
    for (int c = 0; c < 4; ++c) row.push_back(T.matrix()(r, c));
    m.push_back(row);
  }
  return {{"position", vec(T.translation())}, {"direction", vec(T.linear().col(2))}, {"matrix", m}};
}

}  // namespace

std::string infoJson(const Environment& e, int indent) {
  const OccupancyStats st = e.stats();
  Json j;
  j["name"] = e.name();
  j["resolution"] = e.resolution();
  j["bounds"] = {{"min", vec(e.bounds().min)}, {"max", vec(e.bounds().max)}, {"size", vec(e.bounds().size())}};
  j["nodes"] = st.nodes;
  j["occupied_leaves"] = st.occupied_leaves;
  j["free_leaves"] = st.free_leaves;
  j["occupied_volume"] = st.occupied_volume;
  j["free_volume"] = st.free_volume;
  j["memory_bytes"] = st.memory_bytes;
  j["build_seconds"] = e.buildSeconds();
  j["base_pose"] = poseJson(e.basePose());
  j["base_pose"]["source"] = e.basePoseSource();
  j["base_pose"]["occupancy"] = toString(e.occupancy(e.basePose().translation()));
  Json starts = Json::array();
  for (const auto& s : e.starts()) {
    Json p = poseJson(s.pose);
    p["name"] = s.name;
    p["source"] = s.source;
    starts.push_back(p);
  }
  j["starts"] = starts;
  Json targets = Json::array();
  for (const auto& t : e.targets())
    targets.push_back({{"name", t.name},
                       {"position", vec(t.position)},
                       {"occupancy", toString(e.occupancy(t.position))},
                       {"distance_from_base", (t.position - e.basePose().translation()).norm()},
                       {"source", t.source}});
  j["targets"] = targets;
  j["sources"] = e.sources();
  j["collision"] = {{"safety_margin", e.collisionDefaults().safety_margin},
                    {"unknown_space", toString(e.collisionDefaults().unknown_space)},
                    {"exclude_proximal", e.collisionDefaults().exclude_proximal}};
  return j.dump(indent);
}

}  // namespace ctr::environments
