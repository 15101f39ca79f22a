#include "ik_solver.hpp"

#include <Eigen/Cholesky>
#include <Eigen/QR>
#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace ctr::detail {

namespace {
constexpr double kActive = 1e-9;  // a constraint with less slack (step units) than this is active
}  // namespace

ActuatorSet::ActuatorSet(const Robot& robot, const IkOptions& o)
    : robot_(&robot),
      n_(robot.size()),
      scale_(o.translation_scale),
      min_protrusion_(o.min_protrusion),
      bounds_(translationBounds(robot, o.min_protrusion)) {
  auto positive = [](double v, const char* what) {
    if (!(v > 0.0) || !std::isfinite(v))
      throw std::invalid_argument(std::string("IkOptions::") + what + " must be positive and finite");
  };
  positive(scale_, "translation_scale");
  positive(o.max_step, "max_step");
  positive(o.damping, "damping");
  positive(o.tolerance, "tolerance");
  if (!(o.direction_tolerance >= 0.0))
    throw std::invalid_argument("IkOptions::direction_tolerance must not be negative");
  if (!(o.min_protrusion >= 0.0) || !std::isfinite(o.min_protrusion))
    throw std::invalid_argument("IkOptions::min_protrusion must be finite and not negative");
  if (o.max_iterations < 0 || o.restarts < 0 || o.cold_candidates < 0)
    throw std::invalid_argument("IkOptions: max_iterations, restarts and cold_candidates must not be negative");
  if (!(o.slow_start_horizon >= 0.0)) throw std::invalid_argument("IkOptions::slow_start_horizon must not be negative");
  length_.resize(n_);
  rot_lo_ = Eigen::VectorXd::Constant(n_, -std::numeric_limits<double>::infinity());
  rot_hi_ = Eigen::VectorXd::Constant(n_, std::numeric_limits<double>::infinity());
  for (int i = 0; i < n_; ++i) {
    const Tube& t = robot.tube(i);
    length_[i] = t.length();
    if (t.rotation_limits) {
      rot_lo_[i] = (*t.rotation_limits)[0];
      rot_hi_[i] = (*t.rotation_limits)[1];
      rows_.push_back({i, -1, 1.0, 0.0, rot_hi_[i]});
      rows_.push_back({i, -1, -1.0, 0.0, -rot_lo_[i]});
    }
    rows_.push_back({n_ + i, -1, 1.0, 0.0, bounds_.upper[i] / scale_});
    rows_.push_back({n_ + i, -1, -1.0, 0.0, -bounds_.lower[i] / scale_});
  }
  for (int i = 0; i + 1 < n_; ++i) {
    rows_.push_back({n_ + i + 1, n_ + i, 1.0, -1.0, 0.0});                                     // beta_{i+1} <= beta_i
    rows_.push_back({n_ + i, n_ + i + 1, 1.0, -1.0, (length_[i + 1] - length_[i]) / scale_});  // ordered ends
  }
}

void ActuatorSet::clamp(Configuration& q) const {
  for (int i = 0; i < n_; ++i) q.alpha[i] = std::min(std::max(q.alpha[i], rot_lo_[i]), rot_hi_[i]);
  for (int i = 0; i < n_; ++i) {
    double lo = bounds_.lower[i], hi = bounds_.upper[i];
    if (i > 0) {
      hi = std::min(hi, q.beta[i - 1]);
      // The distal end at or beyond the outer one's exactly as checkAdmissible computes them (beta_{i-1} + L_{i-1} -
      // L_i alone can leave it an ulp behind; equal lengths: equal translations).
      const double end = q.beta[i - 1] + length_[i - 1];
      double need = length_[i] == length_[i - 1] ? q.beta[i - 1] : end - length_[i];
      for (int k = 0; k < 64 && need + length_[i] < end; ++k)
        need = std::nextafter(need, std::numeric_limits<double>::infinity());
      lo = std::max(lo, need);
    }
    // The bounds are consistent along the chain, so lo <= hi up to rounding.
    q.beta[i] = std::max(lo, std::min(q.beta[i], hi));
  }
}

void ActuatorSet::wrap(Configuration& q) const {
  const double turn = 2.0 * M_PI;
  for (int i = 0; i < n_; ++i) {
    if (q.alpha[i] > rot_hi_[i]) q.alpha[i] -= turn * std::ceil((q.alpha[i] - rot_hi_[i]) / turn);
    if (q.alpha[i] < rot_lo_[i]) q.alpha[i] += turn * std::ceil((rot_lo_[i] - q.alpha[i]) / turn);
    // Overshot the other limit (limits narrower than a turn): leave it to the clamp.
  }
}

Eigen::VectorXd ActuatorSet::step(const Configuration& q, const Eigen::MatrixXd& G, const Eigen::VectorXd& r,
                                  double lambda, double max_step) const {
  const int m = 2 * n_;
  Eigen::VectorXd x(m);
  x << q.alpha, q.beta / scale_;
  auto dot = [](const Row& c, const Eigen::VectorXd& v) { return c.ci * v[c.i] + (c.j >= 0 ? c.cj * v[c.j] : 0.0); };
  std::vector<char> in_set(rows_.size(), 0);
  std::vector<std::size_t> working;
  Eigen::MatrixXd N = Eigen::MatrixXd::Identity(m, m);  // orthonormal basis of the directions the working set allows
  Eigen::VectorXd dx = Eigen::VectorXd::Zero(m);
  for (std::size_t pass = 0; pass <= rows_.size(); ++pass) {
    const Eigen::MatrixXd GN = G * N;
    Eigen::MatrixXd M = GN * GN.transpose();
    M.diagonal().array() += lambda;
    dx = N * (GN.transpose() * M.ldlt().solve(r));
    // The active constraint this step violates most joins the working set.
    std::size_t worst = rows_.size();
    double worst_rate = 0.0;
    for (std::size_t k = 0; k < rows_.size(); ++k) {
      if (in_set[k] || rows_[k].b - dot(rows_[k], x) > kActive) continue;
      const double rate = dot(rows_[k], dx);
      if (rate > worst_rate * (1.0 + 1e-12) + 1e-15) {
        worst = k;
        worst_rate = rate;
      }
    }
    if (worst == rows_.size()) break;
    in_set[worst] = 1;
    working.push_back(worst);
    Eigen::MatrixXd At = Eigen::MatrixXd::Zero(m, static_cast<Eigen::Index>(working.size()));
    for (std::size_t w = 0; w < working.size(); ++w) {
      const Row& c = rows_[working[w]];
      At(c.i, static_cast<Eigen::Index>(w)) = c.ci;
      if (c.j >= 0) At(c.j, static_cast<Eigen::Index>(w)) = c.cj;
    }
    const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(At);
    const Eigen::Index rank = qr.rank();
    if (rank >= m) return Eigen::VectorXd::Zero(m);
    const Eigen::MatrixXd Q = qr.householderQ();
    N = Q.rightCols(m - rank);
  }
  const double big = dx.cwiseAbs().maxCoeff();
  if (big > max_step) dx *= max_step / big;
  return dx;
}

Configuration ActuatorSet::move(const Configuration& q, const Eigen::VectorXd& dx, double t) const {
  Configuration out(q.alpha + t * dx.head(n_), q.beta + (t * scale_) * dx.tail(n_));
  clamp(out);
  return out;
}

Configuration ActuatorSet::sample(std::mt19937_64& rng) const {
  if (!sampler_) sampler_ = std::make_unique<TranslationSampler>(*robot_, min_protrusion_, 128);
  Configuration q = sampleConfiguration(*robot_, *sampler_, rng);
  clamp(q);  // the sampler's rotations are within [-pi, pi] or the limits; this only fixes rounding
  return q;
}

IkGoal::IkGoal(const IkTarget& t, const IkOptions& o)
    : p_(t.position), direction_(t.direction.has_value()), tol_(o.tolerance), dir_tol_(o.direction_tolerance) {
  if (!p_.allFinite()) throw std::invalid_argument("IK target: the position is not finite");
  if (direction_) {
    const double norm = t.direction->norm();
    if (!std::isfinite(norm) || !(norm > 0.0))
      throw std::invalid_argument("IK target: the direction must be a finite, non-zero vector");
    if (!(t.direction_weight >= 0.0) || !std::isfinite(t.direction_weight))
      throw std::invalid_argument("IK target: the direction weight must be finite and not negative");
    d_ = *t.direction / norm;
    w_ = t.direction_weight;
  }
}

IkMeasure IkGoal::measure(const Solution& s) const {
  IkMeasure m;
  m.r.resize(rows());
  m.r.head<3>() = p_ - s.tip_position;
  m.position_error = m.r.head<3>().norm();
  if (direction_) {
    const Eigen::Vector3d t = s.tipTangent();
    m.r.tail<3>() = w_ * (d_ - t);
    m.direction_error = std::acos(std::clamp(t.dot(d_), -1.0, 1.0));
  }
  m.cost = m.r.squaredNorm();
  if (!std::isfinite(m.cost)) m.cost = std::numeric_limits<double>::infinity();
  return m;
}

bool IkGoal::reached(const IkMeasure& m) const {
  return m.position_error <= tol_ && (!direction_ || m.direction_error <= dir_tol_);
}

Eigen::MatrixXd IkGoal::task(const Solution& s, const Eigen::MatrixXd& A, double scale) const {
  const Eigen::Index n = A.cols() / 2;
  Eigen::MatrixXd G(rows(), A.cols());
  G.topRows<3>() = A.topRows<3>();
  if (direction_) {
    // dt = dw x t = -[t]x dw.
    const Eigen::Vector3d t = s.tipTangent();
    Eigen::Matrix3d tx;
    tx << 0, -t.z(), t.y(), t.z(), 0, -t.x(), -t.y(), t.x(), 0;
    G.bottomRows<3>() = -w_ * tx * A.bottomRows<3>();
  }
  G.rightCols(n) *= scale;
  return G;
}

}  // namespace ctr::detail
