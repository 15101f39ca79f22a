// The planning viewer's data: anatomy surface voxels, per-waypoint robot shapes, collisions and friction bands.
#include <octomap/OcTree.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <nlohmann/json.hpp>
#include <set>
#include <stdexcept>
#include <tuple>

#include "ctr/model/backbone.hpp"
#include "ctr/model/friction.hpp"
#include "ctr/planner/context.hpp"
#include "ctr/reports/reports.hpp"

namespace ctr::reports {
namespace {
using nlohmann::json;

// 10 micrometre resolution keeps the embedded JSON small.
double r5(double v) {
  return std::isfinite(v) ? std::round(v * 1e5) / 1e5 : 0.0;
}

// Backbone of a solved shape as `m` world points (flat x, y, z) and its tip arc length.
json shapePoints(const Solution& sol, const Eigen::Isometry3d& world_T_base, int m, double& length) {
  json a = json::array();
  length = sol.tipArcLength();
  if (sol.backbone.empty() || !(length > 0)) return a;
  const std::vector<BackbonePoint> pts = resampleBackbone(sol, length / std::max(1, m - 1));
  for (const BackbonePoint& b : pts) {
    const Eigen::Vector3d p = world_T_base * b.position;
    a.push_back(r5(p.x()));
    a.push_back(r5(p.y()));
    a.push_back(r5(p.z()));
  }
  return a;
}

// Occupied leaves with a non-occupied 6-neighbour, coarsened until at most max_voxels remain: flat x, y, z, size.
json surfaceVoxels(const environments::Environment& env, const Eigen::Vector3d& lo, const Eigen::Vector3d& hi,
                   bool crop, int max_voxels, json& meta) {
  const octomap::OcTree& tree = env.tree();
  std::vector<std::array<double, 4>> surf;
  std::size_t occupied = 0;
  for (auto it = tree.begin_leafs(), end = tree.end_leafs(); it != end; ++it) {
    if (!tree.isNodeOccupied(*it)) continue;
    const octomap::point3d c = it.getCoordinate();
    const Eigen::Vector3d p(c.x(), c.y(), c.z());
    if (crop && ((p.array() < lo.array()).any() || (p.array() > hi.array()).any())) continue;
    ++occupied;
    const double h = it.getSize();
    bool surface = false;
    for (int d = 0; d < 3 && !surface; ++d)
      for (int sgn = -1; sgn <= 1 && !surface; sgn += 2) {
        Eigen::Vector3d q = p;
        q[d] += sgn * h;
        if (env.occupancy(q) != environments::Occupancy::Occupied) surface = true;
      }
    if (surface) surf.push_back({p.x(), p.y(), p.z(), h});
  }
  meta["occupied_leaves"] = occupied;
  meta["surface_leaves"] = surf.size();
  int factor = 1;
  const double res = env.resolution();
  while (static_cast<int>(surf.size()) > max_voxels && factor < 1024) {
    factor *= 2;
    const double cell = res * factor;
    std::set<std::tuple<long, long, long>> seen;
    std::vector<std::array<double, 4>> out;
    for (const auto& v : surf) {
      const auto key =
          std::make_tuple(static_cast<long>(std::floor(v[0] / cell)), static_cast<long>(std::floor(v[1] / cell)),
                          static_cast<long>(std::floor(v[2] / cell)));
      if (!seen.insert(key).second) continue;
      out.push_back({(std::get<0>(key) + 0.5) * cell, (std::get<1>(key) + 0.5) * cell, (std::get<2>(key) + 0.5) * cell,
                     std::max(cell, v[3])});
    }
    surf.swap(out);
  }
  meta["coarsening"] = factor;
  meta["drawn"] = surf.size();
  json a = json::array();
  for (const auto& v : surf)
    for (double x : v) a.push_back(r5(x));
  return a;
}
}  // namespace

std::string planningHtml(const planner::Context& ctx, const std::vector<Configuration>& waypoints,
                         const std::optional<ViewGoal>& goal, const PlanningViewOptions& o) {
  if (waypoints.empty()) throw std::invalid_argument("the path has no waypoints");
  const auto t0 = std::chrono::steady_clock::now();
  const Robot& robot = ctx.robot();
  const int n = robot.size();
  const Eigen::Isometry3d& T = ctx.basePose();
  const int m = std::max(8, o.max_shape_points);
  json j;
  j["kind"] = "planning";
  j["title"] = o.title;
  j["robot"] = robot.name();
  j["environment"] = ctx.environment().name();
  j["mode"] = planner::toString(ctx.options().mode);
  j["friction"] = {{"boundary", robot.friction().boundary}, {"distributed", robot.friction().distributed}};
  json tubes = json::array();
  for (int i = 0; i < n; ++i) {
    const double od = robot.tube(i).outer_diameter > 0 ? robot.tube(i).outer_diameter : 1e-3 * (n - i);
    tubes.push_back({{"outer_diameter", od}, {"length", robot.tube(i).length()}});
  }
  j["tubes"] = tubes;
  const Eigen::Vector3d bo = T.translation(), bz = T.linear().col(2);
  j["base"] = {{"origin", {bo.x(), bo.y(), bo.z()}}, {"z", {bz.x(), bz.y(), bz.z()}}};

  // Shapes by a quasi-static replay through the friction model.
  FrictionOptions fo = ctx.options().friction;
  fo.kinematics.record_backbone = true;
  planner::ThreadScratch& scratch = planner::scratch();
  Workspace& ws = scratch.ws;
  json shapes = json::array(), lengths = json::array(), ends = json::array(), valid = json::array(),
       conv = json::array(), reasons = json::object(), config = json::array();
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e9), hi = Eigen::Vector3d::Constant(-1e9);
  StepResult cur;
  int collisions = 0, failures = 0;
  json last_pts = json::array();
  double last_len = 0;
  for (std::size_t k = 0; k < waypoints.size(); ++k) {
    const Configuration& q = waypoints[k];
    if (q.size() != n) throw std::invalid_argument("waypoint " + std::to_string(k) + " has the wrong number of tubes");
    try {
      if (k == 0 && o.start && o.start->valid && o.start->q.size() == n)
        cur = step(robot, *o.start, q, ws, fo);  // from the history the robot arrived with
      else
        cur = (k == 0 || !cur.state.valid) ? initialState(robot, q, ws, fo) : step(robot, cur.state, q, ws, fo);
    } catch (const std::exception& e) {
      cur = StepResult{};
      cur.solution.summary.message = e.what();
    }
    const Solution& s = cur.solution;
    const bool ok = s.converged();
    double len = 0;
    json pts = ok ? shapePoints(s, T, m, len) : json::array();
    if (pts.empty()) {
      pts = last_pts;
      len = last_len;
    }
    std::string reason;
    if (ok) {
      const planner::ShapeCheck sc = planner::checkShape(ctx, s, scratch);
      if (!sc.ok) reason = sc.message;
      if (sc.failure == Failure::Collision) ++collisions;
    } else {
      reason = "not converged" + (s.summary.message.empty() ? std::string() : ": " + s.summary.message);
      ++failures;
    }
    if (!reason.empty()) reasons[std::to_string(k)] = reason;
    for (std::size_t c = 0; c + 2 < pts.size(); c += 3)
      for (int d = 0; d < 3; ++d) {
        lo[d] = std::min(lo[d], pts[c + d].get<double>());
        hi[d] = std::max(hi[d], pts[c + d].get<double>());
      }
    json e = json::array();
    for (int i = 0; i < n; ++i) e.push_back(r5(std::min(len, distalEnd(robot, q, i))));
    json cq = json::array();
    for (int i = 0; i < n; ++i) cq.push_back(std::round(q.alpha[i] * 1e6) / 1e6);
    for (int i = 0; i < n; ++i) cq.push_back(std::round(q.beta[i] * 1e7) / 1e7);
    shapes.push_back(pts);
    lengths.push_back(r5(len));
    ends.push_back(e);
    valid.push_back(reason.empty() ? 1 : 0);
    conv.push_back(ok ? 1 : 0);
    config.push_back(cq);
    last_pts = pts;
    last_len = len;
  }
  j["waypoints"] = waypoints.size();
  j["shapes"] = shapes;
  j["lengths"] = lengths;
  j["ends"] = ends;
  j["valid"] = valid;
  j["converged"] = conv;
  j["reasons"] = reasons;
  j["configurations"] = config;
  j["collisions"] = collisions;
  j["failures"] = failures;

  // Friction bands at evenly spaced waypoints.
  json bands = json::array();
  const bool friction = robot.friction().boundary > 0;
  if (friction && o.band_waypoints > 0) {
    const int nb = std::min<int>(o.band_waypoints, static_cast<int>(waypoints.size()));
    FrictionBandOptions bo2;
    bo2.interior_samples = o.band_samples;
    bo2.kinematics.record_backbone = true;
    std::set<std::size_t> done;
    for (int b = 0; b < nb; ++b) {
      const std::size_t k = nb == 1
                                ? waypoints.size() - 1
                                : static_cast<std::size_t>(std::llround(double(b) * (waypoints.size() - 1) / (nb - 1)));
      if (!done.insert(k).second) continue;
      try {
        const FrictionBand fb = frictionBand(robot, waypoints[k], ws, bo2);
        if (!fb.converged) continue;
        json gs = json::array();
        for (const Solution& s : fb.shapes) {
          if (!s.converged()) continue;
          double len = 0;
          json p = shapePoints(s, T, std::max(8, o.band_shape_points), len);
          if (!p.empty()) gs.push_back(p);
        }
        bands.push_back({{"waypoint", k}, {"shapes", gs}, {"tip_spread", r5(fb.tip_spread)}});
      } catch (const std::exception&) {
        // No band where the model cannot compute one (e.g. distributed friction).
      }
    }
  }
  j["bands"] = bands;

  if (goal) {
    j["goal"] = {{"position", {goal->position[0], goal->position[1], goal->position[2]}},
                 {"tolerance", goal->tolerance},
                 {"name", goal->name}};
    for (int d = 0; d < 3; ++d) {
      lo[d] = std::min(lo[d], goal->position[d]);
      hi[d] = std::max(hi[d], goal->position[d]);
    }
  }
  j["bounds"] = {{"lo", {lo.x(), lo.y(), lo.z()}}, {"hi", {hi.x(), hi.y(), hi.z()}}};
  json meta;
  const Eigen::Vector3d margin = Eigen::Vector3d::Constant(o.crop_margin);
  j["voxels"] =
      surfaceVoxels(ctx.environment(), lo - margin, hi + margin, o.crop_margin > 0, std::max(1000, o.max_voxels), meta);
  meta["resolution"] = ctx.environment().resolution();
  j["voxel_info"] = meta;
  if (!o.info_json.empty()) {
    try {
      j["info"] = json::parse(o.info_json);
    } catch (const std::exception&) {
      j["info"] = o.info_json;
    }
  }
  j["compute_seconds"] = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return renderHtml(ReportKind::Planning, o.title, j.dump());
}

}  // namespace ctr::reports
