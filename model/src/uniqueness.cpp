// The certificate of one equilibrium per torque vector: positive definiteness of the lower bound Q of the torsional
// energy's second variation (uniqueness.hpp), discretised by linear finite elements.
#include "ctr/model/uniqueness.hpp"

#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>
#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <stdexcept>
#include <utility>
#include <vector>

namespace ctr {

const char* toString(UniquenessStatus s) {
  switch (s) {
    case UniquenessStatus::Certified:
      return "certified";
    case UniquenessStatus::Interacting:
      return "interacting";
    case UniquenessStatus::Loaded:
      return "loaded";
    case UniquenessStatus::Inadmissible:
      return "inadmissible";
  }
  return "?";
}

namespace {

constexpr double kSame = 1e-12;

/// Q = eta^T (A + P - B) eta as triplets: A of the torsional energy, P and B of the coupling terms whose lower bound
/// on an element is positive (P) or negative (B, stored with the opposite sign). A and P are kept together.
struct Discretisation {
  std::vector<Eigen::Triplet<double>> ap, b;
  int unknowns = 0;
};

/// Lower bound of b cos(theta_i - theta_j) over the element [s0, s1] for tubes i < j (b = kb_i kb_j kappa_i kappa_j /
/// K, signed).
using CouplingBound = std::function<double(int i, int j, double s0, double s1, double b)>;

Discretisation discretise(const Robot& robot, const Configuration& q, const UniquenessOptions& o,
                          const CouplingBound& bound) {
  const int n = robot.size();
  std::vector<double> base(n), disc(n), end(n);
  std::vector<double> pts{0.0};
  for (int i = 0; i < n; ++i) {
    const Tube& t = robot.tube(i);
    base[i] = q.beta[i];
    disc[i] = q.beta[i] + t.straight_length;
    end[i] = distalEnd(robot, q, i);
    pts.push_back(base[i]);
    pts.push_back(end[i]);
    if (t.curved_length > 0.0 && t.curvature != 0.0) pts.push_back(disc[i]);
  }
  std::sort(pts.begin(), pts.end());
  std::vector<double> cuts;
  for (double p : pts)
    if (cuts.empty() || p > cuts.back() + kSame) cuts.push_back(p);
  auto present = [&](int i, double s) { return s > base[i] && s < end[i]; };
  auto curvatureAt = [&](int i, double s) {
    const Tube& t = robot.tube(i);
    return s >= 0.0 && present(i, s) && s > disc[i] && t.curved_length > 0.0 ? t.curvature : 0.0;
  };
  // Nodes: every cut, and interior nodes on the pieces where two curved tubes couple.
  std::vector<double> nodes;
  for (std::size_t k = 0; k + 1 < cuts.size(); ++k) {
    const double a = cuts[k], b = cuts[k + 1], mid = 0.5 * (a + b);
    int curved = 0;
    for (int i = 0; i < n; ++i) curved += curvatureAt(i, mid) != 0.0;
    const int elements =
        curved >= 2 ? std::max(o.min_elements, static_cast<int>(std::ceil((b - a) / o.max_element - 1e-9))) : 1;
    for (int e = 0; e < elements; ++e) nodes.push_back(a + (b - a) * e / elements);
  }
  nodes.push_back(cuts.back());
  const int N = static_cast<int>(nodes.size());
  // Unknowns: tube i's twist perturbation at every node of (base_i, end_i]; zero at its proximal end.
  std::vector<std::vector<int>> dof(static_cast<std::size_t>(n), std::vector<int>(static_cast<std::size_t>(N), -1));
  int m = 0;
  for (int k = 0; k < N; ++k)
    for (int i = 0; i < n; ++i)
      if (nodes[k] > base[i] + kSame && nodes[k] <= end[i] + kSame) dof[i][k] = m++;
  Discretisation out;
  auto add = [](std::vector<Eigen::Triplet<double>>& t, int r, int c, double v) {
    if (r >= 0 && c >= 0) t.emplace_back(r, c, v);
  };
  for (int k = 0; k + 1 < N; ++k) {
    const double h = nodes[k + 1] - nodes[k], mid = 0.5 * (nodes[k] + nodes[k + 1]);
    if (!(h > 0.0)) continue;
    double K = 0.0;
    for (int i = 0; i < n; ++i)
      if (mid >= 0.0 && present(i, mid)) K += robot.tube(i).bending_stiffness;
    for (int i = 0; i < n; ++i) {
      if (!present(i, mid)) continue;
      const double kt = robot.tube(i).torsional_stiffness / h;
      const int a = dof[i][k], b = dof[i][k + 1];
      add(out.ap, a, a, kt);
      add(out.ap, b, b, kt);
      add(out.ap, a, b, -kt);
      add(out.ap, b, a, -kt);
    }
    if (!(K > 0.0)) continue;
    for (int i = 0; i < n; ++i)
      for (int j = i + 1; j < n; ++j) {
        const double b = robot.tube(i).bending_stiffness * robot.tube(j).bending_stiffness * curvatureAt(i, mid) *
                         curvatureAt(j, mid) / K;
        if (b == 0.0) continue;
        const double lower = bound(i, j, nodes[k], nodes[k + 1], b);
        if (lower == 0.0) continue;
        std::vector<Eigen::Triplet<double>>& t = lower > 0.0 ? out.ap : out.b;
        const double w = std::abs(lower);
        // Consistent mass of w (eta_i - eta_j)^2 over the element: w h / 6 [2 1; 1 2] on the difference's nodes.
        const int d[2][2] = {{dof[i][k], dof[i][k + 1]}, {dof[j][k], dof[j][k + 1]}};
        for (int p = 0; p < 2; ++p)
          for (int r = 0; r < 2; ++r) {
            const double v = w * h / 6.0 * (p == r ? 2.0 : 1.0);
            add(t, d[0][p], d[0][r], v);
            add(t, d[1][p], d[1][r], v);
            add(t, d[0][p], d[1][r], -v);
            add(t, d[1][p], d[0][r], -v);
          }
      }
  }
  out.unknowns = m;
  return out;
}

/// A + P - t B positive definite (a Cholesky factorisation succeeds with positive pivots).
bool positiveDefinite(const Discretisation& d, double t) {
  std::vector<Eigen::Triplet<double>> all = d.ap;
  all.reserve(d.ap.size() + d.b.size());
  for (const Eigen::Triplet<double>& x : d.b) all.emplace_back(x.row(), x.col(), -t * x.value());
  Eigen::SparseMatrix<double> M(d.unknowns, d.unknowns);
  M.setFromTriplets(all.begin(), all.end());
  // The unknowns are numbered node by node, so the matrix is banded (width about twice the tubes): no reordering.
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>, Eigen::Lower, Eigen::NaturalOrdering<int>> ldlt(M);
  return ldlt.info() == Eigen::Success && ldlt.vectorD().size() == d.unknowns &&
         (d.unknowns == 0 || ldlt.vectorD().minCoeff() > 0.0);
}

UniquenessCertificate certify(const Robot& robot, const Configuration& q, const UniquenessOptions& options,
                              const CouplingBound& bound) {
  UniquenessCertificate c;
  c.interaction = std::numeric_limits<double>::quiet_NaN();
  if (!checkAdmissible(robot, q)) return c;
  if (!robot.loads().empty()) {
    c.status = UniquenessStatus::Loaded;
    return c;
  }
  const Discretisation d = discretise(robot, q, options, bound);
  c.unknowns = d.unknowns;
  const double limit = 1.0 - options.margin;
  c.status = positiveDefinite(d, 1.0 / limit) ? UniquenessStatus::Certified : UniquenessStatus::Interacting;
  if (options.measure) {
    if (d.b.empty() || positiveDefinite(d, 1e12)) {
      c.interaction = 0.0;
    } else {
      // interaction = 1 / t*, t* = sup{t : A + P - t B positive definite}: bisection in log t.
      double lo = 1e-12, hi = 1e12;
      for (int it = 0; it < 8 && !positiveDefinite(d, lo); ++it) lo *= 1e-3;
      for (int it = 0; it < 80 && hi / lo > 1.0 + 1e-10; ++it) {
        const double mid = std::sqrt(lo * hi);
        (positiveDefinite(d, mid) ? lo : hi) = mid;
      }
      c.interaction = 1.0 / std::sqrt(lo * hi);
    }
  }
  return c;
}

/// Smallest and largest value of cos over [lo, hi].
std::pair<double, double> cosRange(double lo, double hi) {
  if (hi - lo >= 2 * M_PI) return {-1.0, 1.0};
  auto contains = [&](double a) {  // some a + 2 k pi in [lo, hi]
    const double k = std::ceil((lo - a) / (2 * M_PI));
    return a + 2 * M_PI * k <= hi;
  };
  const double a = std::cos(lo), b = std::cos(hi);
  return {contains(M_PI) ? -1.0 : std::min(a, b), contains(0.0) ? 1.0 : std::max(a, b)};
}

}  // namespace

UniquenessCertificate uniquenessCertificate(const Robot& robot, const Configuration& q,
                                            const UniquenessOptions& options) {
  return certify(robot, q, options, [](int, int, double, double, double b) { return -std::abs(b); });
}

UniquenessCertificate uniquenessCertificate(const Robot& robot, const FrictionBand& band,
                                            const UniquenessOptions& options) {
  if (band.shapes.empty()) throw std::invalid_argument("uniquenessCertificate: the band has no shapes");
  const int n = robot.size();
  // Every shape needs its backbone with the tubes' angles at the nodes.
  for (const Solution& sh : band.shapes) {
    bool angles = !sh.backbone.empty();
    for (const BackbonePoint& p : sh.backbone) angles = angles && p.theta.size() == n;
    if (!angles)
      throw std::invalid_argument(
          "uniquenessCertificate: the band's shapes need the tubes' angles (KinematicsOptions::record_backbone and "
          "record_tube_states)");
  }
  const Configuration& q = band.shapes[0].q;
  return certify(robot, q, options, [&](int i, int j, double s0, double s1, double b) {
    // The range of theta_i - theta_j over the element and every shape: the nodes inside it and the nearest node on
    // either side (the angles are smooth between nodes), widened by the margin.
    double lo = std::numeric_limits<double>::infinity(), hi = -lo;
    for (const Solution& sh : band.shapes) {
      const std::vector<BackbonePoint>& bb = sh.backbone;
      auto first = std::lower_bound(bb.begin(), bb.end(), s0, [](const BackbonePoint& p, double s) { return p.s < s; });
      if (first != bb.begin()) --first;
      for (auto it = first; it != bb.end(); ++it) {
        const double d = it->theta[i] - it->theta[j];
        lo = std::min(lo, d);
        hi = std::max(hi, d);
        if (it->s >= s1) break;
      }
    }
    if (!(lo <= hi)) return -std::abs(b);
    const auto [cmin, cmax] = cosRange(lo - options.angle_margin, hi + options.angle_margin);
    return b > 0.0 ? b * cmin : b * cmax;
  });
}

}  // namespace ctr
