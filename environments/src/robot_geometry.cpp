#include "ctr/environments/robot_geometry.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace ctr::environments {

namespace {

/// A point of the refined backbone polyline.
struct Piece {
  double s;
  Eigen::Vector3d p;  // base frame
  double sag;         // bound of the arc's deviation from the chord ending here
  int tube;           // section tube of the chord ending here
  bool joined;        // whether a chord joins this point to the previous one
};

constexpr int kMaxPiecesPerStep = 16;

std::vector<Piece>& scratchPieces() {
  thread_local std::vector<Piece> v;
  return v;
}

/// Cubic Hermite interpolant of the step n0 -> n1 (length h) at tau in [0, 1].
Eigen::Vector3d hermitePoint(const BackbonePoint& n0, const BackbonePoint& n1, double h, double tau) {
  const double t2 = tau * tau, t3 = t2 * tau;
  return (2.0 * t3 - 3.0 * t2 + 1.0) * n0.position + ((t3 - 2.0 * t2 + tau) * h) * n0.frame.col(2) +
         (3.0 * t2 - 2.0 * t3) * n1.position + ((t3 - t2) * h) * n1.frame.col(2);
}

}  // namespace

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
  const double tol = std::max(options.chord_tolerance, 0.0);
  const double max_len = options.max_capsule_length > 0.0 ? options.max_capsule_length : 1e9;

  // Refine every integration step whose arc may leave its chord by more than half the tolerance: points of the cubic
  // Hermite interpolant of the step's end positions and tangents (the frames' third columns), which follows the arc to
  // O(h^4), so pieces of length h/k deviate from their chords by at most kappa (h/k)^2 / 8 plus the interpolation
  // error. Long steps (coarse planning integration) then give thin capsules instead of capsules inflated by the whole
  // step's sagitta kappa h^2 / 8.
  std::vector<Piece>& pieces = scratchPieces();
  pieces.clear();
  for (std::size_t m = 0; m < segs.size(); ++m) {
    const BackbonePoint& n0 = bb[segs[m].i];
    const BackbonePoint& n1 = bb[segs[m].j];
    const double h = n1.s - n0.s;
    const double k0 = n0.u0.norm(), k1 = n1.u0.norm();
    const double kappa = std::max(k0, k1);
    // |p^(4)| <= kappa^3 + 3 kappa |du/ds| (+ |u^(2)|, neglected), |du/ds| estimated by the step's change of curvature.
    const double du = (n1.u0 - n0.u0).norm() / h;
    const double h2 = h * h;
    const double hermite = h2 * h2 / 384.0 * (kappa * kappa * kappa + 3.0 * kappa * du);
    const double tau0 = n0.s < s_min ? (s_min - n0.s) / h : 0.0;
    const double len = (1.0 - tau0) * h;
    const double whole = kappa * len * len / 8.0;
    int k = 1;
    if (tol > 0.0 && whole > 0.5 * tol)
      k = static_cast<int>(std::min<double>(kMaxPiecesPerStep, std::ceil(std::sqrt(whole / (0.5 * tol)))));
    // Long steps (one step spans a straight segment) are split to the capsule length too.
    if (len > max_len) k = std::max(k, static_cast<int>(std::min(1024.0, std::ceil(len / max_len - 1e-9))));
    const bool connected = m > 0 && segs[m - 1].j == segs[m].i && segs[m - 1].tube == segs[m].tube;
    // Interpolated points (pieces, or the start clipped at s_min) add the interpolation error.
    const double piece_sag = whole / (static_cast<double>(k) * k) + (k > 1 || tau0 > 0.0 ? hermite : 0.0);
    if (!connected) {
      Eigen::Vector3d p0 = n0.position;
      if (tau0 > 0.0) p0 = hermitePoint(n0, n1, h, tau0);
      pieces.push_back({std::max(n0.s, s_min), p0, 0.0, segs[m].tube, false});
    }
    for (int l = 1; l <= k; ++l) {
      const double tau = tau0 + (1.0 - tau0) * l / k;
      const Eigen::Vector3d p = l == k ? n1.position : hermitePoint(n0, n1, h, tau);
      pieces.push_back({n0.s + tau * h, p, piece_sag, segs[m].tube, true});
    }
  }

  int section = -1;
  int prev_tube = -1;
  std::size_t a = 0;  // index of the first point of the next capsule
  while (a + 1 < pieces.size()) {
    if (!pieces[a + 1].joined) {  // a chain ends at a (a lone point is no capsule)
      ++a;
      continue;
    }
    const int tube = pieces[a + 1].tube;
    if (tube != prev_tube) {
      ++section;
      prev_tube = tube;
      if (sections) sections->push_back(Section{tube, pieces[a].s, pieces[a + 1].s, tubeRadius(robot, tube, options)});
    }
    // Grow the capsule over points a+1..b of the same tube while the chord stays within tolerance.
    const Eigen::Vector3d p0 = pieces[a].p;
    std::size_t b = a + 1;
    double dev = 0.0;
    double sag = pieces[b].sag;
    while (b + 1 < pieces.size() && pieces[b + 1].joined && pieces[b + 1].tube == tube) {
      if (pieces[b + 1].s - pieces[a].s > max_len) break;
      const Eigen::Vector3d& p1 = pieces[b + 1].p;
      double d = 0.0;
      for (std::size_t m = a + 1; m <= b; ++m) {
        const Eigen::Vector3d& pm = pieces[m].p;
        d = std::max(d, (pm - closestPointOnSegment(p0, p1, pm)).norm());
      }
      const double sg = std::max(sag, pieces[b + 1].sag);
      if (d + sg > tol) break;
      dev = d;
      sag = sg;
      ++b;
    }
    Capsule c;
    c.a = world_T_base * p0;
    c.b = world_T_base * pieces[b].p;
    c.radius = tubeRadius(robot, tube, options) + dev + sag;
    c.section = section;
    c.tube = tube;
    c.s0 = pieces[a].s;
    c.s1 = pieces[b].s;
    capsules.push_back(c);
    if (sections) sections->back().s1 = c.s1;
    a = b;
  }
}

std::vector<Capsule> robotCapsules(const Robot& robot, const Solution& solution, const Eigen::Isometry3d& world_T_base,
                                   const RobotGeometryOptions& options) {
  std::vector<Capsule> out;
  robotCapsules(robot, solution, world_T_base, options, out);
  return out;
}

}  // namespace ctr::environments
