// The warm-start history and the continuation predictor (warm_start.hpp).
#include "warm_start.hpp"

#include <algorithm>
#include <cmath>

namespace ctr::detail {

// Actuation as one vector for the warm-start history: alpha, then beta in units of 2 cm (~1 rad).
Eigen::VectorXd historyKey(const Configuration& q) {
  Eigen::VectorXd v;
  historyKey(q, v);
  return v;
}

void historyKey(const Configuration& q, Eigen::VectorXd& v) {
  historyKey(q.alpha, q.beta, v);
}

void historyKey(const Eigen::VectorXd& alpha, const Eigen::VectorXd& beta, Eigen::VectorXd& v) {
  v.resize(alpha.size() + beta.size());
  v << alpha, kHistoryBetaScale * beta;
}

// Continuation predictor: when q continues the straight line through the last solves of the chain (each step
// within 2.6 deg of the line's direction, q at most two steps ahead), the base twist rates extrapolated along it by
// the polynomial through up to four of them (Lagrange, in the arc length along the line). A higher-order term larger
// than a quarter of the secant's step (a fold ahead) falls back to the secant.
bool continuationPredictor(const WarmHistory& H, const Eigen::VectorXd& q, Eigen::VectorXd& z) {
  if (H.count < 2 || H.q[0].size() != q.size() || z.size() < H.z[0].size()) return false;
  // Scalar loops throughout: no temporaries (this runs once per solve along a path).
  const Eigen::Index dim = q.size(), nz = H.z[0].size();
  double ahead2 = 0.0;
  for (Eigen::Index c = 0; c < dim; ++c) ahead2 += (q[c] - H.q[0][c]) * (q[c] - H.q[0][c]);
  const double ahead = std::sqrt(ahead2);
  if (!(ahead > 0.0)) return false;
  double s[WarmHistory::kDepth] = {0.0};
  int points = 1;
  for (int k = 1; k < H.count; ++k) {
    if (H.q[k].size() != dim || H.z[k].size() != nz) break;
    double len2 = 0.0, dot = 0.0;  // step = q[k-1] - q[k]; along = step . (q - q[0]) / ahead
    for (Eigen::Index c = 0; c < dim; ++c) {
      const double st = H.q[k - 1][c] - H.q[k][c];
      len2 += st * st;
      dot += st * (q[c] - H.q[0][c]);
    }
    const double len = std::sqrt(len2), along = dot / ahead;
    if (!(len > 0.0) || along < 0.999 * len) break;  // not (nearly) the same direction
    s[k] = s[k - 1] - along;
    ++points;
  }
  if (points < 2 || ahead > 2.0 * -s[1]) return false;
  // Lagrange weights of the polynomial through the chain's points, at `ahead`; the secant's factor.
  double w[WarmHistory::kDepth];
  for (int i = 0; i < points; ++i) {
    w[i] = 1.0;
    for (int j = 0; j < points; ++j)
      if (j != i) w[i] *= (ahead - s[j]) / (s[i] - s[j]);
  }
  const double f = ahead / -s[1];
  auto secantAt = [&](Eigen::Index c) { return H.z[0][c] + f * (H.z[0][c] - H.z[1][c]); };
  auto polyAt = [&](Eigen::Index c) {
    double v = 0.0;
    for (int i = 0; i < points; ++i) v += w[i] * H.z[i][c];
    return v;
  };
  double secant_step = 0.0, gap = 0.0;
  bool finite = true;
  for (Eigen::Index c = 0; c < nz; ++c) {
    const double sc = secantAt(c), pc = polyAt(c);
    finite = finite && std::isfinite(pc);
    secant_step = std::max(secant_step, std::abs(sc - H.z[0][c]));
    gap = std::max(gap, std::abs(pc - sc));
  }
  const bool smooth = finite && gap <= 0.25 * secant_step;
  for (Eigen::Index c = 0; c < nz; ++c) z[c] = smooth ? polyAt(c) : secantAt(c);
  return z.allFinite();
}

void recordInChain(WarmHistory& H, bool chained, const Eigen::VectorXd& qv, const Eigen::VectorXd& z) {
  if (!chained) H.count = 0;
  for (int k = std::min(H.count, WarmHistory::kDepth - 1); k > 0; --k) {
    std::swap(H.q[k], H.q[k - 1]);
    std::swap(H.z[k], H.z[k - 1]);
  }
  H.q[0] = qv;
  H.z[0] = z;
  H.count = std::min(H.count + 1, WarmHistory::kDepth);
}

// (The loaded solver's base moments pass through a Solution in N m: the unknowns are compared to rounding.)
bool continuesChain(const WarmHistory& H, const Configuration& warm_q, const Eigen::VectorXd& q_key,
                    const Eigen::VectorXd& z) {
  if (!(H.count > 0 && warm_q.size() * 2 == q_key.size() && H.q[0].size() == q_key.size() && z.size() == H.z[0].size()))
    return false;
  const int n = warm_q.size();
  for (int i = 0; i < n; ++i)  // historyKey(warm_q) == H.q[0], without forming the key
    if (!(warm_q.alpha[i] == H.q[0][i] && kHistoryBetaScale * warm_q.beta[i] == H.q[0][n + i])) return false;
  return (z - H.z[0]).cwiseAbs().maxCoeff() <= 1e-13 * (1.0 + H.z[0].cwiseAbs().maxCoeff());
}

}  // namespace ctr::detail
