// Residuals, measurement model, noise estimate, RMSE and BIC.
#include "ctr/diagnosis/residuals.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

namespace ctr::diagnosis {

const char* toString(FrameMode mode) {
  return mode == FrameMode::Unknown ? "unknown" : "base";
}

const char* toString(Quantity q) {
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

int rowDof(Quantity q, Eigen::Index columns) {
  return q == Quantity::Twist ? static_cast<int>(columns) : q == Quantity::TipPosition ? 3 : 2;
}

double NoiseLevels::dof(Quantity q) const {
  switch (q) {
    case Quantity::Twist:
      return twist_dof;
    case Quantity::TipPosition:
      return tip_position_dof;
    case Quantity::TipTangent:
      return tip_tangent_dof;
  }
  return 0.0;
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

const Eigen::MatrixXd& measured(const io::Recording& rec, Quantity q) {
  return q == Quantity::Twist ? rec.twist : q == Quantity::TipPosition ? rec.tip_position : rec.tip_tangent;
}
const Eigen::MatrixXd& predicted(const Prediction& p, Quantity q) {
  return q == Quantity::Twist ? p.twist : q == Quantity::TipPosition ? p.tip_position : p.tip_tangent;
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

void excludeRows(Residuals& r, const std::vector<char>& rows) {
  if (rows.empty()) return;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  for (Quantity q : {Quantity::Twist, Quantity::TipPosition, Quantity::TipTangent}) {
    Eigen::MatrixXd& R = r.of(q);
    for (Eigen::Index k = 0; k < R.rows(); ++k)
      if (k >= static_cast<Eigen::Index>(rows.size()) || !rows[static_cast<std::size_t>(k)]) R.row(k).setConstant(nan);
  }
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
    out[toString(q)] = q == Quantity::Twist ? std::sqrt(s.ss / s.count) : std::sqrt(s.ss / std::max(1, s.rows));
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
    const Eigen::MatrixXd& R = r.of(q);
    const SumSquares s = sumSquares(R, use);
    if (s.count == 0) continue;
    // Independent components: a unit tangent's 3 residual components carry 2 (its noise is normal to it).
    const double n = static_cast<double>(s.count) * rowDof(q, R.cols()) / std::max<Eigen::Index>(1, R.cols());
    b += n * std::log(std::max(1e-300, s.ss / n));
    total += static_cast<int>(std::lround(n));
  }
  return b + parameters * std::log(std::max(1, total));
}

}  // namespace ctr::diagnosis
