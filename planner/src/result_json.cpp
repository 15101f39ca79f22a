#include "ctr/planner/result_json.hpp"

#include <cmath>
#include <nlohmann/json.hpp>

namespace ctr::planner {

std::string resultJson(const Query& q, const PlanResult& r, int indent) {
  nlohmann::json j;
  j["query"] = q.name;
  j["solved"] = r.solved;
  j["planner_solved"] = r.planner_solved;
  j["mode"] = toString(r.mode);
  j["planner"] = r.planner;
  j["planning_time"] = r.planning_time;
  j["planning_wall_time"] = r.planning_wall_time;
  j["time_limit_clock"] = q.cpu_time_limit ? "cpu" : "wall";
  j["replay_time"] = r.replay_time;
  j["path_length"] = r.path_length;
  j["waypoints"] = r.path.size();
  j["goal_pool"] = r.goal_pool;
  if (r.final_approach) {
    const auto list = [](const Eigen::VectorXd& v) { return std::vector<double>(v.data(), v.data() + v.size()); };
    j["final_approach"] = {{"alpha", list(r.final_approach->alpha)}, {"beta", list(r.final_approach->beta)}};
  }
  j["replay"] = nlohmann::json::parse(replayJson(r));
  if (r.range_replay) {
    const RangeReplay& rr = *r.range_replay;
    auto number = [](double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); };
    nlohmann::json points = nlohmann::json::array();
    for (const RangeReplay::Point& p : rr.points) {
      nlohmann::json values;
      for (std::size_t i = 0; i < rr.names.size(); ++i) values[rr.names[i]] = p.values[i];
      points.push_back({{"values", values},
                        {"corner", p.corner},
                        {"ok", p.ok},
                        {"min_clearance", number(p.min_clearance)},
                        {"tip_error", number(p.tip_error)},
                        {"failure", toString(p.failure)},
                        {"message", p.message}});
    }
    j["range_replay"] = {{"ranges", rr.names},
                         {"corners", rr.corners},
                         {"samples", rr.samples},
                         {"clean", rr.clean},
                         {"worst_clearance", number(rr.worst_clearance)},
                         {"worst", rr.points.empty() ? nlohmann::json(nullptr) : nlohmann::json(rr.worst)},
                         {"points", points}};
  }
  if (!r.message.empty()) j["message"] = r.message;
  return j.dump(indent);
}

std::string replayJson(const PlanResult& r) {
  auto number = [](double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); };
  const nlohmann::json j = {{"completed", r.replay.completed},
                            {"collision_free", r.replay.collision_free},
                            {"stable", r.replay.stable},
                            {"goal_reached", r.replay.goal_reached},
                            {"tip_error", number(r.replay.tip_error)},
                            {"direction_error", number(r.replay.direction_error)},
                            {"min_clearance", number(r.replay.min_clearance)},
                            {"steps", r.replay.steps},
                            {"collisions", r.replay.collisions},
                            {"snaps", r.replay.snaps},
                            {"failure", toString(r.replay.failure)},
                            {"first_failure", r.replay.message}};
  return j.dump();
}

}  // namespace ctr::planner
