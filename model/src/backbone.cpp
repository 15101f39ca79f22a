#include "ctr/model/backbone.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace ctr {

std::vector<BackbonePoint> resampleBackbone(const Solution& sol, double ds) {
  if (!(ds > 0.0)) throw std::invalid_argument("resampleBackbone: ds must be > 0");
  const auto& nodes = sol.backbone;
  if (nodes.size() < 2) return nodes;
  std::vector<BackbonePoint> out;
  const double s0 = nodes.front().s, s1 = nodes.back().s;
  const int count = std::max(1, static_cast<int>(std::ceil((s1 - s0) / ds - 1e-9)));
  std::size_t k = 0;
  for (int i = 0; i <= count; ++i) {
    const double s = (i == count) ? s1 : s0 + (s1 - s0) * i / count;
    while (k + 2 < nodes.size() && nodes[k + 1].s <= s) ++k;
    const BackbonePoint& a = nodes[k];
    const BackbonePoint& b = nodes[k + 1];
    const double h = b.s - a.s;
    BackbonePoint p = a;
    p.s = s;
    if (h > 0.0) {
      const double t = std::clamp((s - a.s) / h, 0.0, 1.0);
      // Cubic Hermite on position with the tangents (exact to O(h^4) like the integrator).
      const double h00 = 2 * t * t * t - 3 * t * t + 1, h10 = t * t * t - 2 * t * t + t;
      const double h01 = -2 * t * t * t + 3 * t * t, h11 = t * t * t - t * t;
      p.position = h00 * a.position + h10 * h * a.frame.col(2) + h01 * b.position + h11 * h * b.frame.col(2);
      const Eigen::Quaterniond qa(a.frame), qb(b.frame);
      p.frame = qa.slerp(t, qb).toRotationMatrix();
      p.theta = (1 - t) * a.theta + t * b.theta;
      p.uz = (1 - t) * a.uz + t * b.uz;
      p.u0 = (1 - t) * a.u0 + t * b.u0;
    }
    out.push_back(std::move(p));
  }
  return out;
}

Eigen::Matrix2Xd tubeBendingMoments(const Robot& robot, const Configuration& q, const BackbonePoint& p) {
  const int n = robot.size();
  if (p.theta.size() < n)
    throw std::invalid_argument("tubeBendingMoments: the backbone point has no tube states (record_tube_states)");
  Eigen::Matrix2Xd m = Eigen::Matrix2Xd::Zero(2, n);
  for (int i = 0; i < n; ++i) {
    const Tube& t = robot.tube(i);
    // At a segment boundary the s- node still has the state before its events, the s+ node after them.
    const double end = q.beta[i] + t.length(), disc = q.beta[i] + t.straight_length;
    const bool at_end = std::abs(end - p.s) < 1e-12, at_disc = std::abs(disc - p.s) < 1e-12;
    if (end < p.s || (at_end && p.segment_start)) continue;  // ended
    const bool curved = t.curved_length > 0.0 && (at_disc ? p.segment_start || disc <= 0.0 : p.s > disc);
    Eigen::Vector2d pre = Eigen::Vector2d::Zero();
    if (curved) pre = t.curvature * Eigen::Vector2d(-std::sin(p.theta[i]), std::cos(p.theta[i]));
    m.col(i) = t.bending_stiffness * (p.u0 - pre);
  }
  return m;
}

}  // namespace ctr
