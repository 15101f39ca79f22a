#include "ctr/model/configuration.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>

namespace ctr {

Configuration Configuration::zeros(int n) {
  return Configuration(Eigen::VectorXd::Zero(n), Eigen::VectorXd::Zero(n));
}

int subdivisions(const Configuration& from, const Configuration& to, double max_rotation_step,
                 double max_translation_step) {
  if (from.alpha.size() != to.alpha.size() || from.beta.size() != to.beta.size())
    throw std::invalid_argument("subdivisions: the configurations have different numbers of tubes");
  if (!(max_rotation_step > 0.0) || !(max_translation_step > 0.0))
    throw std::invalid_argument("subdivisions: the step sizes must be positive");
  const double da = to.alpha.size() ? (to.alpha - from.alpha).cwiseAbs().maxCoeff() : 0.0;
  const double db = to.beta.size() ? (to.beta - from.beta).cwiseAbs().maxCoeff() : 0.0;
  const double steps = std::ceil(std::max(da / max_rotation_step, db / max_translation_step) - kSubdivisionSlack);
  if (!std::isfinite(da) || !std::isfinite(db) || !(steps < static_cast<double>(std::numeric_limits<int>::max())))
    throw std::invalid_argument("subdivisions: the move is not finite or needs too many steps");
  return std::max(1, static_cast<int>(steps));
}

Configuration interpolate(const Configuration& from, const Configuration& to, double t) {
  if (t == 0.0) return from;
  if (t == 1.0) return to;
  return Configuration(from.alpha + t * (to.alpha - from.alpha), from.beta + t * (to.beta - from.beta));
}

Admissibility checkAdmissible(const Robot& robot, const Configuration& q, double tol) {
  const int n = robot.size();
  // The message is formatted only on failure (a stream per call cost ~3 % of a warm planning solve).
  using A = Admissibility::Actuator;
  auto fail = [](A actuator, int tube, const auto&... parts) {
    std::ostringstream os;
    (os << ... << parts);
    return Admissibility{false, actuator, tube, os.str()};
  };
  if (q.alpha.size() != n || q.beta.size() != n)
    return fail(A::None, 0, "configuration has ", q.alpha.size(), " rotations and ", q.beta.size(),
                " translations, robot '", robot.name(), "' has ", n, " tubes");
  for (int i = 0; i < n; ++i) {
    if (!std::isfinite(q.alpha[i])) {
      return fail(A::Rotation, i + 1, "alpha_", i + 1, " is not finite");
    }
    if (!std::isfinite(q.beta[i])) {
      return fail(A::Translation, i + 1, "beta_", i + 1, " is not finite");
    }
  }
  for (int i = 0; i < n; ++i) {
    if (q.beta[i] > tol) {
      return fail(A::Translation, i + 1, "beta_", i + 1, " = ", q.beta[i],
                  " m > 0: tubes start inside the actuation unit (beta <= 0)");
    }
  }
  for (int i = 0; i + 1 < n; ++i) {
    if (q.beta[i + 1] > q.beta[i] + tol) {
      return fail(A::Translation, i + 2, "beta_", i + 2, " = ", q.beta[i + 1], " m > beta_", i + 1, " = ", q.beta[i],
                  " m: inner tubes must start at or behind outer tubes (beta_n <= ... <= beta_1)");
    }
    const double e0 = distalEnd(robot, q, i), e1 = distalEnd(robot, q, i + 1);
    if (e1 < e0 - tol) {
      return fail(A::Translation, i + 2, "distal end of tube ", i + 2, " (beta_", i + 2, " + L_", i + 2, " = ", e1,
                  " m) is behind the end of tube ", i + 1, " (", e0,
                  " m): inner tubes must extend at least as far (beta_1 + L_1 <= ... <= beta_n + L_n)");
    }
  }
  if (distalEnd(robot, q, n - 1) <= 0.0) {
    return fail(A::Translation, n, "the innermost tube does not leave the actuation unit (beta_", n, " + L_", n,
                " <= 0)");
  }
  for (int i = 0; i < n; ++i) {
    const Tube& t = robot.tube(i);
    if (t.rotation_limits) {
      auto [lo, hi] = *t.rotation_limits;
      if (q.alpha[i] < lo - tol || q.alpha[i] > hi + tol) {
        return fail(A::Rotation, i + 1, "alpha_", i + 1, " = ", q.alpha[i], " rad is outside rotation_limits [", lo,
                    ", ", hi, "] of tube '", t.name, "'");
      }
    }
    if (t.translation_limits) {
      auto [lo, hi] = *t.translation_limits;
      if (q.beta[i] < lo - tol || q.beta[i] > hi + tol) {
        return fail(A::Translation, i + 1, "beta_", i + 1, " = ", q.beta[i], " m is outside translation_limits [", lo,
                    ", ", hi, "] of tube '", t.name, "'");
      }
    }
  }
  return {};
}

Admissibility projectAdmissible(const Robot& robot, Configuration& q, double tolerance) {
  // Sizes and finiteness first: nothing to project there.
  const int n = robot.size();
  if (q.alpha.size() != n || q.beta.size() != n) return checkAdmissible(robot, q);
  if (!q.alpha.allFinite() || !q.beta.allFinite()) return checkAdmissible(robot, q);
  // Admissible as it is (checkAdmissible's default, rounding-level tolerance): q is left unchanged bit for bit, so
  // every configuration accepted before the projection existed gives the same results.
  if (checkAdmissible(robot, q)) return {};
  Configuration p = q;
  for (int i = 0; i < n; ++i) {
    const Tube& t = robot.tube(i);
    if (t.rotation_limits) p.alpha[i] = std::clamp(p.alpha[i], (*t.rotation_limits)[0], (*t.rotation_limits)[1]);
    if (i == 0) {
      p.beta[0] = std::min(p.beta[0], 0.0);
    } else {
      p.beta[i] = std::min(p.beta[i], p.beta[i - 1]);
      // Coincident distal ends, exactly in floating point: distalEnd(i) >= distalEnd(i - 1) as checkAdmissible
      // computes them (beta_{i-1} + L_{i-1} - L_i alone can leave the inner end an ulp behind).
      const double L = t.length(), end = distalEnd(robot, p, i - 1);
      if (p.beta[i] + L < end) {
        // Equal lengths: equal translations; else the nearest value that puts the end at or beyond `end`.
        double b = L == robot.tube(i - 1).length() ? p.beta[i - 1] : end - L;
        for (int k = 0; k < 64 && b + L < end; ++k) b = std::nextafter(b, std::numeric_limits<double>::infinity());
        p.beta[i] = b;
      }
    }
    if (t.translation_limits) p.beta[i] = std::clamp(p.beta[i], (*t.translation_limits)[0], (*t.translation_limits)[1]);
  }
  const double moved = std::max((p.alpha - q.alpha).cwiseAbs().maxCoeff(), (p.beta - q.beta).cwiseAbs().maxCoeff());
  // The projection may not fix every constraint (limits that contradict the nesting, an inner tube shorter than the
  // tube around it, the innermost tube inside the actuation unit): check the result.
  if (moved <= tolerance * (1.0 + 1e-9) && checkAdmissible(robot, p)) {
    q = p;
    return {};
  }
  // Refused, q unchanged: name the first constraint violated by more than the tolerance ...
  Admissibility a = checkAdmissible(robot, q, tolerance);
  if (!a) return a;
  // ... or, when every constraint alone is within the tolerance but the projection needs a larger move (violations
  // that add up along the tubes) or cannot satisfy them jointly, the first violated constraint and why.
  a = checkAdmissible(robot, q);
  std::ostringstream os;
  os << a.message << " (every constraint is within the admissibility tolerance " << tolerance
     << ", but projecting them together ";
  if (moved > tolerance * (1.0 + 1e-9))
    os << "moves a value by " << moved << ")";
  else
    os << "does not give an admissible configuration)";
  a.message = os.str();
  return a;
}

Configuration defaultConfiguration(const Robot& robot) {
  const int n = robot.size();
  Configuration q = Configuration::zeros(n);
  for (int i = 0; i < n; ++i) q.beta[i] = -robot.tube(i).straight_length;
  for (int i = 1; i < n; ++i) q.beta[i] = std::min(q.beta[i], q.beta[i - 1]);
  for (int i = 1; i < n; ++i) {
    const double need = q.beta[i - 1] + robot.tube(i - 1).length() - robot.tube(i).length();
    if (q.beta[i] < need) q.beta[i] = std::min(need, q.beta[i - 1]);
  }
  return q;
}

}  // namespace ctr
