#include "ctr/model/configuration.hpp"

#include <cmath>
#include <sstream>

namespace ctr {

Configuration Configuration::zeros(int n) {
  return Configuration(Eigen::VectorXd::Zero(n), Eigen::VectorXd::Zero(n));
}

Admissibility checkAdmissible(const Robot& robot, const Configuration& q, double tol) {
  const int n = robot.size();
  std::ostringstream os;
  auto fail = [&](const std::string& m) { return Admissibility{false, m}; };
  if (q.alpha.size() != n || q.beta.size() != n) {
    os << "configuration has " << q.alpha.size() << " rotations and " << q.beta.size()
       << " translations, robot '" << robot.name() << "' has " << n << " tubes";
    return fail(os.str());
  }
  for (int i = 0; i < n; ++i) {
    if (!std::isfinite(q.alpha[i])) {
      os << "alpha_" << i + 1 << " is not finite";
      return fail(os.str());
    }
    if (!std::isfinite(q.beta[i])) {
      os << "beta_" << i + 1 << " is not finite";
      return fail(os.str());
    }
  }
  for (int i = 0; i < n; ++i) {
    if (q.beta[i] > tol) {
      os << "beta_" << i + 1 << " = " << q.beta[i] << " m > 0: tubes start inside the actuation unit (beta <= 0)";
      return fail(os.str());
    }
  }
  for (int i = 0; i + 1 < n; ++i) {
    if (q.beta[i + 1] > q.beta[i] + tol) {
      os << "beta_" << i + 2 << " = " << q.beta[i + 1] << " m > beta_" << i + 1 << " = " << q.beta[i]
         << " m: inner tubes must start at or behind outer tubes (beta_n <= ... <= beta_1)";
      return fail(os.str());
    }
    const double e0 = distalEnd(robot, q, i), e1 = distalEnd(robot, q, i + 1);
    if (e1 < e0 - tol) {
      os << "distal end of tube " << i + 2 << " (beta_" << i + 2 << " + L_" << i + 2 << " = " << e1
         << " m) is behind the end of tube " << i + 1 << " (" << e0
         << " m): inner tubes must extend at least as far (beta_1 + L_1 <= ... <= beta_n + L_n)";
      return fail(os.str());
    }
  }
  if (distalEnd(robot, q, n - 1) <= 0.0) {
    os << "the innermost tube does not leave the actuation unit (beta_" << n << " + L_" << n << " <= 0)";
    return fail(os.str());
  }
  for (int i = 0; i < n; ++i) {
    const Tube& t = robot.tube(i);
    if (t.rotation_limits) {
      auto [lo, hi] = *t.rotation_limits;
      if (q.alpha[i] < lo - tol || q.alpha[i] > hi + tol) {
        os << "alpha_" << i + 1 << " = " << q.alpha[i] << " rad is outside rotation_limits [" << lo << ", " << hi
           << "] of tube '" << t.name << "'";
        return fail(os.str());
      }
    }
    if (t.translation_limits) {
      auto [lo, hi] = *t.translation_limits;
      if (q.beta[i] < lo - tol || q.beta[i] > hi + tol) {
        os << "beta_" << i + 1 << " = " << q.beta[i] << " m is outside translation_limits [" << lo << ", " << hi
           << "] of tube '" << t.name << "'";
        return fail(os.str());
      }
    }
  }
  return {};
}

}  // namespace ctr
