#include "ctr/environments/robot_geometry.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace ctr::env {

Eigen::Vector3d closestPointOnSegment(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& p) {
  const Eigen::Vector3d ab = b - a;
  const double L2 = ab.squaredNorm();
  if (L2 <= 0.0) return a;
  const double t = std::clamp((p - a).dot(ab) / L2, 0.0, 1.0);
  return a + t * ab;
}

double tubeRadius(const Robot& robot, int tube, const RobotGeometryOptions& options) {
  const double od = robot.tube(tube).outer_diameter;
  return 0.5 * (od > 0.0 ? od : options.default_outer_diameter) + options.safety_margin;
}

void robotCapsules(const Robot& robot, const Solution& sol, const Eigen::Isometry3d& world_T_base,
                   const RobotGeometryOptions& options, std::vector<Capsule>& capsules,
                   std::vector<Section>* sections) {
  capsules.clear();
  if (sections) sections->clear();
  const auto& bb = sol.backbone;
  if (bb.empty())
    throw std::invalid_argument("robotCapsules: the solution has no backbone (solve with record_backbone = true)");
  const int n = robot.size();
  // Distal ends from the configuration (when it matches the robot): the outermost tube at s is the first tube
  // whose end lies beyond s. Combined with BackbonePoint::outermost, taking the outer (larger) of the two.
  const bool have_q = sol.q.beta.size() == n;
  auto outermostAt = [&](double s, int node_value) {
    int t = std::clamp(node_value, 0, n - 1);
    if (have_q) {
      int tq = n - 1;
      for (int i = 0; i < n; ++i)
        if (sol.q.beta[i] + robot.tube(i).length() > s) {
          tq = i;
          break;
        }
      t = std::min(t, tq);
    }
    return t;
  };

  // Backbone nodes with s >= s_min, and the section (outermost tube) of every segment between consecutive nodes.
  const double s_min = std::max(0.0, options.exclude_proximal);
  std::size_t first = 0;
  while (first + 1 < bb.size() && bb[first + 1].s <= s_min) ++first;
  struct Seg {
    std::size_t i, j;
    int tube;
  };
  std::vector<Seg> segs;
  segs.reserve(bb.size());
  for (std::size_t k = first; k + 1 < bb.size(); ++k) {
    const double s0 = std::max(bb[k].s, s_min), s1 = bb[k + 1].s;
    if (!(s1 > s0)) continue;
    segs.push_back({k, k + 1, outermostAt(0.5 * (s0 + s1), bb[k + 1].outermost)});
  }
  // Position of node k, clipped to s = s_min for a segment that starts in the excluded part.
  auto pos = [&](std::size_t k) -> Eigen::Vector3d {
    if (bb[k].s < s_min && k + 1 < bb.size() && bb[k + 1].s > s_min) {
      const double t = (s_min - bb[k].s) / (bb[k + 1].s - bb[k].s);
      return (1.0 - t) * bb[k].position + t * bb[k + 1].position;
    }
    return bb[k].position;
  };
  const double tol = std::max(options.chord_tolerance, 0.0);
  const double max_len = options.max_capsule_length > 0.0 ? options.max_capsule_length : 1e9;
  int section = -1;
  int prev_tube = -1;
  std::size_t a = 0;
  while (a < segs.size()) {
    const int tube = segs[a].tube;
    if (tube != prev_tube) {
      ++section;
      prev_tube = tube;
      if (sections) sections->push_back(Section{tube, std::max(bb[segs[a].i].s, s_min), bb[segs[a].j].s,
                                                tubeRadius(robot, tube, options)});
    }
    // Grow the capsule over segments a..b of the same tube while the chord stays within tolerance.
    const std::size_t i0 = segs[a].i;
    const Eigen::Vector3d p0 = pos(i0);
    std::size_t b = a;
    double dev = 0.0;
    auto sagitta = [&](std::size_t k) {
      const double h = bb[segs[k].j].s - bb[segs[k].i].s;
      const double kappa = std::max(bb[segs[k].i].u0.norm(), bb[segs[k].j].u0.norm());
      return kappa * h * h / 8.0;
    };
    double sag = sagitta(a);
    while (b + 1 < segs.size() && segs[b + 1].tube == tube && segs[b + 1].i == segs[b].j) {
      const std::size_t jn = segs[b + 1].j;
      if (bb[jn].s - std::max(bb[i0].s, s_min) > max_len) break;
      const Eigen::Vector3d p1 = bb[jn].position;
      double d = 0.0;
      for (std::size_t m = a; m <= b; ++m) {
        const Eigen::Vector3d& pm = bb[segs[m].j].position;
        d = std::max(d, (pm - closestPointOnSegment(p0, p1, pm)).norm());
      }
      const double sg = std::max(sag, sagitta(b + 1));
      if (d + sg > tol) break;
      dev = d;
      sag = sg;
      ++b;
    }
    Capsule c;
    c.a = world_T_base * p0;
    c.b = world_T_base * bb[segs[b].j].position;
    c.radius = tubeRadius(robot, tube, options) + dev + sag;
    c.section = section;
    c.tube = tube;
    c.s0 = std::max(bb[i0].s, s_min);
    c.s1 = bb[segs[b].j].s;
    capsules.push_back(c);
    if (sections) sections->back().s1 = c.s1;
    a = b + 1;
  }
}

std::vector<Capsule> robotCapsules(const Robot& robot, const Solution& solution, const Eigen::Isometry3d& world_T_base,
                                   const RobotGeometryOptions& options) {
  std::vector<Capsule> out;
  robotCapsules(robot, solution, world_T_base, options, out);
  return out;
}

}  // namespace ctr::env
