// Residuals, measurement model, noise estimate, RMSE and BIC.
#include "ctr/diagnosis/residuals.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

namespace ctr::diagnosis {

const char* quantityName(Quantity q) {
  switch (q) {
    case Quantity::Twist:
      return "twist";
    case Quantity::TipPosition:
      return "tip_position";
    case Quantity::TipTangent:
      return "tip_tangent";
  }
  return "?";
}

std::vector<Quantity> presentQuantities(const io::Recording& rec) {
  std::vector<Quantity> q;
  if (rec.hasTwist()) q.push_back(Quantity::Twist);
  if (rec.hasTipPosition()) q.push_back(Quantity::TipPosition);
  if (rec.hasTipTangent()) q.push_back(Quantity::TipTangent);
  return q;
}

double NoiseLevels::of(Quantity q) const {
  switch (q) {
    case Quantity::Twist:
      return twist;
    case Quantity::TipPosition:
      return tip_position;
    case Quantity::TipTangent:
      return tip_tangent;
  }
  return 0.0;
}

const Eigen::MatrixXd& Residuals::of(Quantity q) const {
  return q == Quantity::Twist ? twist : q == Quantity::TipPosition ? tip_position : tip_tangent;
}
Eigen::MatrixXd& Residuals::of(Quantity q) {
  return q == Quantity::Twist ? twist : q == Quantity::TipPosition ? tip_position : tip_tangent;
}

Residuals computeResiduals(const io::Recording& rec, const Prediction& p) {
  Residuals r;
  if (rec.hasTwist()) {
    r.twist = rec.twist - p.twist;
    for (Eigen::Index k = 0; k < r.twist.size(); ++k) {
      double& v = r.twist.data()[k];
      if (std::isfinite(v)) v = std::remainder(v, 2 * M_PI);
    }
  }
  if (rec.hasTipPosition()) r.tip_position = rec.tip_position - p.tip_position;
  if (rec.hasTipTangent()) r.tip_tangent = rec.tip_tangent - p.tip_tangent;
  return r;
}

Registration mapToSensor(const io::Recording& rec, Prediction& p, FrameMode frame, const std::vector<char>& use,
                         const NoiseLevels& noise) {
  if (frame != FrameMode::Unknown) return Registration{};
  RegistrationOptions o;
  o.position_weight = noise.tip_position > 0 ? 1.0 / (noise.tip_position * noise.tip_position) : 1.0;
  o.tangent_weight = noise.tip_tangent > 0 ? 1.0 / (noise.tip_tangent * noise.tip_tangent) : 1.0;
  if (noise.tip_position <= 0 || noise.tip_tangent <= 0) {
    // No noise estimate yet: typical sensor scales (0.5 mm, 1 deg).
    o.position_weight = 1.0 / (5e-4 * 5e-4);
    o.tangent_weight = 1.0 / (0.0175 * 0.0175);
  }
  static const Eigen::MatrixXd none;
  const Registration reg =
      fitRegistration(p.tip_position, p.tip_tangent, rec.hasTipPosition() ? rec.tip_position : none,
                      rec.hasTipTangent() ? rec.tip_tangent : none, use, o);
  applyRegistration(reg, p.tip_position, p.tip_tangent);
  return reg;
}

namespace {
double robustSpread(std::vector<double>& d) {
  if (d.size() < 3) return std::numeric_limits<double>::quiet_NaN();
  std::nth_element(d.begin(), d.begin() + static_cast<long>(d.size() / 2), d.end());
  return 1.4826 * d[d.size() / 2] / std::sqrt(2.0);
}

Eigen::MatrixXd configFeatures(const io::Recording& rec) {
  // Relative angles as (cos, sin) and translations scaled by 1/(1 cm): a metric where 1 ~ 1 rad ~ 1 cm.
  const int n = rec.tubes, rows = rec.rows();
  Eigen::MatrixXd F(rows, 3 * n);
  for (int k = 0; k < rows; ++k) {
    const Configuration& q = rec.commands[static_cast<std::size_t>(k)];
    for (int i = 0; i < n; ++i) {
      const double a = q.alpha[i] - (i > 0 ? q.alpha[0] : 0.0);
      F(k, 3 * i) = std::cos(a);
      F(k, 3 * i + 1) = std::sin(a);
      F(k, 3 * i + 2) = q.beta[i] / 0.01;
    }
  }
  return F;
}
}  // namespace

NoiseLevels estimateNoise(const io::Recording& rec, const Residuals& r) {
  NoiseLevels out;
  const int rows = rec.rows();
  const Eigen::MatrixXd F = configFeatures(rec);
  std::vector<int> nn(static_cast<std::size_t>(rows), -1);
  for (int k = 0; k < rows; ++k) {
    double best = std::numeric_limits<double>::infinity();
    for (int j = 0; j < rows; ++j) {
      if (j == k) continue;
      const double d = (F.row(k) - F.row(j)).squaredNorm();
      if (d < best) {
        best = d;
        nn[static_cast<std::size_t>(k)] = j;
      }
    }
  }
  for (Quantity q : presentQuantities(rec)) {
    const Eigen::MatrixXd& R = r.of(q);
    double s = std::numeric_limits<double>::quiet_NaN();
    if (q == Quantity::Twist) {
      // Per component: robust spread of the differences.
      std::vector<double> ds, dn;
      for (int k = 0; k < rows; ++k)
        for (Eigen::Index c = 0; c < R.cols(); ++c) {
          if (!std::isfinite(R(k, c))) continue;
          if (k > 0 && std::isfinite(R(k - 1, c))) ds.push_back(std::abs(R(k, c) - R(k - 1, c)));
          const int j = nn[static_cast<std::size_t>(k)];
          if (j >= 0 && j > k && std::isfinite(R(j, c))) dn.push_back(std::abs(R(k, c) - R(j, c)));
        }
      const double s1 = robustSpread(ds), s2 = robustSpread(dn);
      s = std::isfinite(s1) && std::isfinite(s2) ? std::min(s1, s2) : std::isfinite(s1) ? s1 : s2;
    } else {
      // Vectors: the median squared norm of the row differences against the chi-square median of the noise's
      // dimension. A position has isotropic noise in 3 components; a measured unit tangent only in the 2 directions
      // normal to it (its component along itself is second order), so pooling its 3 components as if each were
      // Gaussian under-estimates the noise. The level returned is per component, as the chi-square tests use it:
      // E|r|^2 / 3 per row.
      const double dim = q == Quantity::TipPosition ? 3.0 : 2.0;
      const double chi2_median = q == Quantity::TipPosition ? 2.365973884 : 1.386294361;  // medians of chi2(3), chi2(2)
      std::vector<double> ds, dn;
      auto finite = [&](int k) { return R.row(k).allFinite(); };
      for (int k = 0; k < rows; ++k) {
        if (!finite(k)) continue;
        if (k > 0 && finite(k - 1)) ds.push_back((R.row(k) - R.row(k - 1)).squaredNorm());
        const int j = nn[static_cast<std::size_t>(k)];
        if (j >= 0 && j > k && finite(j)) dn.push_back((R.row(k) - R.row(j)).squaredNorm());
      }
      auto level = [&](std::vector<double>& d) {
        if (d.size() < 3) return std::numeric_limits<double>::quiet_NaN();
        std::nth_element(d.begin(), d.begin() + static_cast<long>(d.size() / 2), d.end());
        const double sigma2_axis = d[d.size() / 2] / (2.0 * chi2_median);  // per noisy axis (a difference doubles it)
        return std::sqrt(sigma2_axis * dim / 3.0);
      };
      const double s1 = level(ds), s2 = level(dn);
      s = std::isfinite(s1) && std::isfinite(s2) ? std::min(s1, s2) : std::isfinite(s1) ? s1 : s2;
    }
    const double floor = q == Quantity::TipPosition ? 1e-7 : 1e-5;
    if (!std::isfinite(s) || s < floor) s = floor;
    (q == Quantity::Twist ? out.twist : q == Quantity::TipPosition ? out.tip_position : out.tip_tangent) = s;
  }
  return out;
}

SumSquares sumSquares(const Eigen::MatrixXd& r, const std::vector<char>& use) {
  SumSquares s;
  for (Eigen::Index k = 0; k < r.rows(); ++k) {
    if (k >= static_cast<Eigen::Index>(use.size()) || !use[static_cast<std::size_t>(k)]) continue;
    bool any = false;
    for (Eigen::Index c = 0; c < r.cols(); ++c)
      if (std::isfinite(r(k, c))) {
        s.ss += r(k, c) * r(k, c);
        ++s.count;
        any = true;
      }
    s.rows += any ? 1 : 0;
  }
  return s;
}

std::map<std::string, double> rmse(const io::Recording& rec, const Residuals& r, const std::vector<char>& use) {
  std::map<std::string, double> out;
  for (Quantity q : presentQuantities(rec)) {
    const SumSquares s = sumSquares(r.of(q), use);
    if (s.count == 0) continue;
    out[quantityName(q)] = q == Quantity::Twist ? std::sqrt(s.ss / s.count) : std::sqrt(s.ss / std::max(1, s.rows));
  }
  return out;
}

Eigen::VectorXd rowScores(const io::Recording& rec, const Residuals& r, const NoiseLevels& noise) {
  Eigen::VectorXd e = Eigen::VectorXd::Constant(rec.rows(), std::numeric_limits<double>::quiet_NaN());
  for (Quantity q : presentQuantities(rec)) {
    const Eigen::MatrixXd& R = r.of(q);
    const double s2 = std::max(1e-30, noise.of(q) * noise.of(q));
    for (Eigen::Index k = 0; k < R.rows(); ++k)
      for (Eigen::Index c = 0; c < R.cols(); ++c)
        if (std::isfinite(R(k, c))) e[k] = (std::isfinite(e[k]) ? e[k] : 0.0) + R(k, c) * R(k, c) / s2;
  }
  return e;
}

double finiteMean(const Eigen::VectorXd& v) {
  double s = 0.0;
  int n = 0;
  for (Eigen::Index k = 0; k < v.size(); ++k)
    if (std::isfinite(v[k])) {
      s += v[k];
      ++n;
    }
  return n ? s / n : 0.0;
}

std::array<double, 2> commonMeans(const Eigen::VectorXd& a, const Eigen::VectorXd& b) {
  double sa = 0.0, sb = 0.0;
  int n = 0;
  for (Eigen::Index k = 0; k < std::min(a.size(), b.size()); ++k)
    if (std::isfinite(a[k]) && std::isfinite(b[k])) {
      sa += a[k];
      sb += b[k];
      ++n;
    }
  return n ? std::array<double, 2>{sa / n, sb / n} : std::array<double, 2>{0.0, 0.0};
}

std::vector<char> commonRows(const Residuals& a, const Residuals& b, const std::vector<char>& use) {
  std::vector<char> u = use;
  for (Eigen::Index k = 0; k < static_cast<Eigen::Index>(u.size()); ++k) {
    if (!u[static_cast<std::size_t>(k)]) continue;
    bool any_a = false, any_b = false;
    for (Quantity q : {Quantity::Twist, Quantity::TipPosition, Quantity::TipTangent}) {
      const Eigen::MatrixXd& A = a.of(q);
      const Eigen::MatrixXd& B = b.of(q);
      if (k < A.rows()) any_a = any_a || A.row(k).array().isFinite().any();
      if (k < B.rows()) any_b = any_b || B.row(k).array().isFinite().any();
    }
    u[static_cast<std::size_t>(k)] = any_a && any_b;
  }
  return u;
}

double bic(const io::Recording& rec, const Residuals& r, const std::vector<char>& use, int parameters) {
  double b = 0.0;
  int total = 0;
  for (Quantity q : presentQuantities(rec)) {
    const SumSquares s = sumSquares(r.of(q), use);
    if (s.count == 0) continue;
    b += s.count * std::log(std::max(1e-300, s.ss / s.count));
    total += s.count;
  }
  return b + parameters * std::log(std::max(1, total));
}

}  // namespace ctr::diagnosis
