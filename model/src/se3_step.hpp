// Internal: one SE(3) exponential step of the backbone pose with a body twist (w = (wx, wy, 0), v = (0, 0, a)),
// used by the 4th-order commutator-free Lie-group integrator of the backbone.
#pragma once

#include <Eigen/Core>
#include <cmath>

namespace ctr::detail {

/// (R, p) <- (R, p) * exp(xi), exact (Rodrigues + SE(3) left Jacobian), with series near zero rotation.
inline void se3Step(Eigen::Matrix3d& R, Eigen::Vector3d& p, const Eigen::Vector2d& w, double a) {
  const double th2 = w.squaredNorm();
  double A, B, C;  // sin(t)/t, (1-cos t)/t^2, (t - sin t)/t^3
  if (th2 < 1e-8) {
    A = 1.0 - th2 / 6.0 * (1.0 - th2 / 20.0);
    B = 0.5 - th2 / 24.0 * (1.0 - th2 / 30.0);
    C = 1.0 / 6.0 - th2 / 120.0 * (1.0 - th2 / 42.0);
  } else {
    const double th = std::sqrt(th2);
    A = std::sin(th) / th;
    B = (1.0 - std::cos(th)) / th2;
    C = (th - std::sin(th)) / (th2 * th);
  }
  Eigen::Matrix3d W;
  W << 0, 0, w.y(), 0, 0, -w.x(), -w.y(), w.x(), 0;
  const Eigen::Matrix3d W2 = W * W;
  const Eigen::Matrix3d E = Eigen::Matrix3d::Identity() + A * W + B * W2;
  const Eigen::Vector3d t = a * (Eigen::Vector3d::UnitZ() + B * W.col(2) + C * W2.col(2));  // V e_z a
  p += R * t;
  R = R * E;
}

}  // namespace ctr::detail
