#include "ctr/model/sampling.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace ctr {

TranslationBounds translationBounds(const Robot& robot, double min_protrusion) {
  const int n = robot.size();
  TranslationBounds b;
  b.lower.resize(n);
  b.upper.resize(n);
  Eigen::VectorXd len(n);
  for (int i = 0; i < n; ++i) {
    const Tube& t = robot.tube(i);
    len[i] = t.length();
    b.lower[i] = t.translation_limits ? (*t.translation_limits)[0] : -t.length();
    b.upper[i] = t.translation_limits ? std::min(0.0, (*t.translation_limits)[1]) : 0.0;
  }
  if (n == 0) return b;
  // Chain bounds: beta_{i+1} in [beta_i + L_i - L_{i+1}, beta_i]; the innermost protrudes.
  b.lower[n - 1] = std::max(b.lower[n - 1], min_protrusion - len[n - 1]);
  // Tighten the box by propagating the chain both ways (a few sweeps suffice for a chain).
  for (int sweep = 0; sweep < 2 * n; ++sweep) {
    for (int i = 0; i + 1 < n; ++i) {
      b.upper[i + 1] = std::min(b.upper[i + 1], b.upper[i]);
      b.lower[i + 1] = std::max(b.lower[i + 1], b.lower[i] + len[i] - len[i + 1]);
      b.lower[i] = std::max(b.lower[i], b.lower[i + 1]);
      b.upper[i] = std::min(b.upper[i], b.upper[i + 1] + len[i + 1] - len[i]);
    }
  }
  return b;
}

TranslationSampler::TranslationSampler(const Robot& robot, double min_protrusion, int grid) : n_(robot.size()) {
  if (grid < 16) throw std::invalid_argument("TranslationSampler: grid must be >= 16");
  len_.resize(n_);
  for (int i = 0; i < n_; ++i) len_[i] = robot.tube(i).length();
  const TranslationBounds b = translationBounds(robot, min_protrusion);
  lo_ = b.lower;
  hi_ = b.upper;
  feasible_ = b.feasible();
  if (!feasible_) return;
  vol_.assign(static_cast<std::size_t>(n_), std::vector<double>(static_cast<std::size_t>(grid), 1.0));
  // V_{n-1} = 1; V_i(b) = integral over beta_{i+1} in [max(lo, b + L_i - L_{i+1}), min(hi, b)] of V_{i+1}.
  for (int i = n_ - 2; i >= 0; --i) {
    auto& V = vol_[static_cast<std::size_t>(i)];
    for (int g = 0; g < grid; ++g) {
      const double b = lo_[i] + (hi_[i] - lo_[i]) * g / (grid - 1);
      const double a0 = std::max(lo_[i + 1], b + len_[i] - len_[i + 1]), a1 = std::min(hi_[i + 1], b);
      double acc = 0.0;
      if (a1 > a0) {
        const int m = 64;  // Simpson-free trapezoid on a fine sub-grid of the interpolated table
        const double h = (a1 - a0) / m;
        for (int k = 0; k <= m; ++k) acc += (k == 0 || k == m ? 0.5 : 1.0) * volumeAt(i + 1, a0 + k * h);
        acc *= h;
      }
      V[static_cast<std::size_t>(g)] = acc;
    }
  }
}

double TranslationSampler::volumeAt(int i, double b) const {
  if (i == n_ - 1) return 1.0;
  const auto& V = vol_[static_cast<std::size_t>(i)];
  if (hi_[i] <= lo_[i]) return V[0];
  const double x = (b - lo_[i]) / (hi_[i] - lo_[i]) * (static_cast<double>(V.size()) - 1);
  if (x <= 0) return V.front();
  if (x >= static_cast<double>(V.size()) - 1) return V.back();
  const std::size_t k = static_cast<std::size_t>(x);
  const double t = x - static_cast<double>(k);
  return (1 - t) * V[k] + t * V[k + 1];
}

// Draws beta_i in [a, b] with density proportional to volumeAt(i, .), by inverse CDF on a fine sub-grid.
double TranslationSampler::drawFromConditional(int i, double a, double b, std::mt19937_64& rng) const {
  std::uniform_real_distribution<double> U(0.0, 1.0);
  if (!(b > a)) return a;
  if (i == n_ - 1) return a + (b - a) * U(rng);
  const int m = 256;
  std::vector<double> cdf(m + 1, 0.0);
  const double h = (b - a) / m;
  for (int k = 1; k <= m; ++k)
    cdf[static_cast<std::size_t>(k)] =
        cdf[static_cast<std::size_t>(k - 1)] + 0.5 * h * (volumeAt(i, a + (k - 1) * h) + volumeAt(i, a + k * h));
  const double u = U(rng);
  // Tubes of equal length nest with equal translations: the admissible set is thinner than the grid (zero volume
  // everywhere). Then uniform in the interval (the set's own, lower-dimensional measure) rather than its lower end.
  if (!(cdf.back() > 0.0)) return a + (b - a) * u;
  const double target = u * cdf.back();
  const auto it = std::lower_bound(cdf.begin(), cdf.end(), target);
  const int k = std::clamp(static_cast<int>(it - cdf.begin()), 1, m);
  // Linear density within the cell: solve the quadratic for the position (here: linear interpolation of the CDF).
  const double c0 = cdf[static_cast<std::size_t>(k - 1)], c1 = cdf[static_cast<std::size_t>(k)];
  const double t = c1 > c0 ? (target - c0) / (c1 - c0) : 0.5;
  return a + (k - 1 + t) * h;
}

Eigen::VectorXd TranslationSampler::sample(std::mt19937_64& rng) const {
  if (!feasible_) throw std::logic_error("TranslationSampler: the admissible translation set is empty");
  Eigen::VectorXd beta(n_);
  beta[0] = drawFromConditional(0, lo_[0], hi_[0], rng);
  for (int i = 1; i < n_; ++i) {
    const double a = std::max(lo_[i], beta[i - 1] + len_[i - 1] - len_[i]), b = std::min(hi_[i], beta[i - 1]);
    beta[i] = drawFromConditional(i, a, std::max(a, b), rng);
  }
  return beta;
}

Configuration sampleConfiguration(const Robot& robot, const TranslationSampler& sampler, std::mt19937_64& rng) {
  const int n = robot.size();
  Configuration q(Eigen::VectorXd(n), sampler.sample(rng));
  for (int i = 0; i < n; ++i) {
    const Tube& t = robot.tube(i);
    const double lo = t.rotation_limits ? (*t.rotation_limits)[0] : -M_PI;
    const double hi = t.rotation_limits ? (*t.rotation_limits)[1] : M_PI;
    q.alpha[i] = std::uniform_real_distribution<double>(lo, hi)(rng);
  }
  return q;
}

}  // namespace ctr
