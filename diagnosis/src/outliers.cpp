// Tracker glitches: rows whose residual under the final model is far beyond the noise and beyond their neighbours'.
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>

#include "ctr/diagnosis/statistics.hpp"
#include "diagnosis_state.hpp"

namespace ctr::diagnosis::detail {

std::vector<std::pair<int, OutlierRow>> screenOutliers(const io::Recording& rec, const Residuals& r,
                                                       const NoiseLevels& noise, const std::vector<char>& use,
                                                       const std::vector<int>& origin, double alpha,
                                                       double max_fraction) {
  const int rows = rec.rows();
  std::vector<std::pair<int, OutlierRow>> out;
  if (!(alpha > 0) || rows < 20) return out;
  auto usable = [&](int k) { return k >= 0 && k < rows && use[static_cast<std::size_t>(k)]; };
  const ReplayOptions steps;
  std::map<int, OutlierRow> found;
  const std::vector<Quantity> quantities = presentQuantities(rec);
  for (Quantity q : quantities) {
    const Eigen::MatrixXd& R = r.of(q);
    const double sd = noise.of(q);
    if (!(sd > 0) || R.rows() != rows) continue;
    const double dof = rowDof(q, R.cols());
    Eigen::VectorXd z = Eigen::VectorXd::Constant(rows, std::numeric_limits<double>::quiet_NaN());
    std::vector<double> finite;
    const Eigen::MatrixXd& M = measured(rec, q);
    auto noisy = [&](const Eigen::VectorXd& e, int k) { return noisePart(q, e, M.row(k).transpose()); };
    for (int k = 0; k < rows; ++k)
      if (usable(k) && R.row(k).allFinite()) {
        z[k] = noisy(R.row(k).transpose(), k).squaredNorm() / (sd * sd);
        finite.push_back(z[k]);
      }
    if (finite.size() < 20) continue;
    // The residuals' own robust scale (model error the final model left, or a noise the estimate missed): a glitch
    // must stand out of the residuals as they are, not only out of the noise.
    std::nth_element(finite.begin(), finite.begin() + static_cast<long>(finite.size() / 2), finite.end());
    const double scale = std::max(1.0, finite[finite.size() / 2] / stats::chiSquareQuantile(0.5, dof));
    // Family-wise rate alpha over the rows and quantities (Bonferroni).
    const double p = alpha / (static_cast<double>(finite.size()) * static_cast<double>(quantities.size()));
    const double limit = scale * stats::chiSquareQuantile(1.0 - p, dof);
    auto beyond = [&](int j) { return j >= 0 && j < rows && z[j] > limit; };
    for (int k = 0; k < rows; ++k) {
      if (!(z[k] > limit)) continue;
      // A glitch stands alone: a neighbour beyond the limit too makes a stretch of model error.
      if (beyond(k - 1) || beyond(k + 1)) continue;
      // Along a densely sampled path the model error is smooth: a glitch also stands out of the mean of its two
      // neighbours (second difference, variance 1.5 sigma^2 per component for white noise).
      const bool dense =
          usable(k - 1) && usable(k + 1) && R.row(k - 1).allFinite() && R.row(k + 1).allFinite() &&
          !isLongMove(rec.commands[static_cast<std::size_t>(k - 1)], rec.commands[static_cast<std::size_t>(k)],
                      steps) &&
          !isLongMove(rec.commands[static_cast<std::size_t>(k)], rec.commands[static_cast<std::size_t>(k + 1)], steps);
      if (dense) {
        const Eigen::VectorXd d = (R.row(k) - 0.5 * (R.row(k - 1) + R.row(k + 1))).transpose();
        const double zd = noisy(d, k).squaredNorm() / (1.5 * sd * sd);
        if (!(zd > limit)) continue;
      }
      OutlierRow& o = found[k];
      o.row = origin[static_cast<std::size_t>(k)];
      o.quantities.push_back(toString(q));
      o.residual_over_noise = std::max(o.residual_over_noise, std::sqrt(z[k]));
    }
  }
  if (found.empty() || static_cast<double>(found.size()) > max_fraction * static_cast<double>(rows)) return out;
  for (auto& [k, o] : found) out.push_back({k, std::move(o)});
  return out;
}

}  // namespace ctr::diagnosis::detail
