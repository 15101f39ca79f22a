// The Newton core of the shooting solvers (newton.hpp).
#include "newton.hpp"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <sstream>

namespace ctr::detail {

double exactStabilityBelow(const KinematicsOptions& opt) {
  return std::max(0.25, 2.0 * opt.refine_below_stability);
}

NewtonSettings newtonSettings(const KinematicsOptions& opt, double s_tip, int capped, JacobianReuse reuse) {
  NewtonSettings s;
  s.max_iterations = opt.max_iterations;
  s.line_search_steps = std::max(1, opt.line_search_steps);
  s.tolerance = opt.tolerance;
  s.step_cap = 4.0 * M_PI / std::max(s_tip, 1e-3);  // a base twist rate changes by at most 4 pi over the robot (1/m)
  s.capped = capped;
  s.reuse = reuse;
  s.exact_stability_below = exactStabilityBelow(opt);
  return s;
}

void broydenUpdate(Eigen::MatrixXd& J, const Eigen::VectorXd& step, const Eigen::VectorXd& dr, Eigen::VectorXd& tmp) {
  const double ss = step.squaredNorm();
  if (!(ss > 0.0)) return;
  tmp = dr;
  tmp.noalias() -= J * step;
  J.noalias() += tmp * (step.transpose() / ss);
}

bool newton(NewtonSystem& S, Eigen::VectorXd& z, const NewtonSettings& s, NewtonScratch& w, NewtonJacobian& jac,
            int& iterations, double& res_norm, std::string& why) {
  const bool chord_reuse = s.reuse == JacobianReuse::Chord;
  bool exact = !jac.from_cache;  // jacobian() is the exact Jacobian at z
  S.evaluate(z, exact);
  if (exact) jac.updates = 0;
  bool chord = false;  // Chord: the last value-only step contracted the residual 10x; the next reuses its factorisation
  double nr = maxAbs(S.residual());
  double merit = S.residual().squaredNorm();  // Newton directions descend on the 2-norm (not on the max-norm)
  Eigen::VectorXd& dz = w.dz;
  Eigen::VectorXd& zt = w.zt;
  auto fail = [&](const char* message) {
    why = message;
    res_norm = nr;
    jac.exact = exact;
    return false;
  };
  for (int it = 0;; ++it) {
    if (!S.residual().allFinite()) return fail("non-finite residual");
    if (nr < s.tolerance) {
      if (!exact && (jac.updates > s.max_updates || !(std::abs(S.stability()) > s.exact_stability_below))) {
        S.evaluate(z, true);
        exact = true;
      }
      if (exact) jac.updates = 0;
      jac.exact = exact;
      res_norm = nr;
      return true;
    }
    if (it >= s.max_iterations) break;
    if (chord_reuse && !exact && !chord) {  // a value-only step that did not converge after all: the Jacobian at z
      S.evaluate(z, true);
      exact = true;
    }
    ++iterations;
    const bool factorise = exact || !chord_reuse;
    if (factorise) w.lu.compute(S.jacobian());
    dz.noalias() = w.lu.solve(-S.residual());
    if (factorise && (!dz.allFinite() || std::abs(w.lu.determinant()) < 1e-300)) {
      // Singular Jacobian (at a fold): regularised step.
      const Eigen::MatrixXd& J = S.jacobian();
      const Eigen::MatrixXd JtJ = J.transpose() * J + 1e-8 * Eigen::MatrixXd::Identity(J.rows(), J.cols());
      dz = JtJ.ldlt().solve(-J.transpose() * S.residual());
      if (!dz.allFinite()) return fail("singular Jacobian");
    }
    const Eigen::Index capped = s.capped > 0 ? std::min<Eigen::Index>(s.capped, dz.size()) : dz.size();
    const double big = capped > 0 ? dz.head(capped).cwiseAbs().maxCoeff() : 0.0;
    if (big > s.step_cap) dz *= s.step_cap / big;
    // Chord: Newton's quadratic convergence (residual ~ K nr^2 after the step, K 0.002-0.03 median on the example
    // robots) predicts the step converges: the trial points are evaluated without the Jacobian. Measured over 26 k
    // Newton steps of the example robots (cold, warm, stick-slip; tolerance 1e-10 and 1e-8): 90 % of such trials
    // converge; the others cost one evaluation more (the Jacobian at z next).
    const bool value_only = !s.jacobian_at_trials || chord || nr * nr < 1000.0 * s.tolerance;
    const double nr_before = nr;
    if (!chord_reuse) w.r_old = S.residual();
    double t = 1.0;
    bool accepted = false;
    int ls = 0;
    for (; ls < s.line_search_steps; ++ls) {
      zt = z + t * dz;
      S.evaluate(zt, !value_only);
      const double mt = S.residual().squaredNorm();
      if (S.residual().allFinite() && mt < (1.0 - 1e-4 * t) * merit) {
        accepted = true;
        break;
      }
      t *= 0.5;
    }
    if (!accepted) {
      if (S.residual().allFinite() && maxAbs(S.residual()) < s.tolerance) {  // converged within roundoff of the test
        z = zt;
        nr = maxAbs(S.residual());
        merit = S.residual().squaredNorm();
        exact = !value_only;
        chord = false;
        continue;
      }
      if (!exact) {  // a step of a reused Jacobian that found no descent: retry from z with the Jacobian at z
        S.evaluate(z, true);
        exact = true;
        jac.updates = 0;
        chord = false;
        nr = maxAbs(S.residual());
        merit = S.residual().squaredNorm();
        continue;
      }
      S.evaluate(z, true);
      nr = maxAbs(S.residual());
      return fail("line search failed (no descent direction)");
    }
    const double nr_new = maxAbs(S.residual());
    if (chord_reuse) {
      exact = !value_only;
      chord = value_only && nr_new < 0.1 * nr_before;
    } else if (ls > 0 || nr_new > 0.25 * nr) {
      S.evaluate(zt, true);  // poor progress: the exact Jacobian
      exact = true;
      jac.updates = 0;
    } else {
      w.r_old = S.residual() - w.r_old;  // the change of r along the step
      broydenUpdate(S.jacobian(), zt - z, w.r_old, dz);
      exact = false;
      ++jac.updates;
    }
    z = zt;
    nr = nr_new;
    merit = S.residual().squaredNorm();
  }
  std::ostringstream os;
  os << "no convergence in " << s.max_iterations << " Newton iterations (residual " << nr << ")";
  why = os.str();
  res_norm = nr;
  jac.exact = exact;
  return false;
}

bool JacobianCache::usable(const Eigen::VectorXd& q_key, const Eigen::VectorXd& model_key,
                           const Eigen::VectorXd& z_now) const {
  return valid && J.rows() == z_now.size() && z.size() == z_now.size() && q.size() == q_key.size() &&
         (q - q_key).cwiseAbs().maxCoeff() <= 0.1 && model.size() == model_key.size() && model == model_key &&
         (z - z_now).cwiseAbs().maxCoeff() <= 0.1 * (1.0 + z.cwiseAbs().maxCoeff());
}

void JacobianCache::store(const Eigen::MatrixXd& J_kept, const Eigen::VectorXd& q_key, const Eigen::VectorXd& model_key,
                          const Eigen::VectorXd& z_now, double stab, int broyden_updates) {
  J = J_kept;
  q = q_key;
  model = model_key;
  z = z_now;
  stability = stab;
  updates = broyden_updates;
  valid = true;
}

bool chordSolve(NewtonSystem& S, Eigen::VectorXd& z, const JacobianCache& C, int max_steps, double tolerance,
                double exact_stability_below, NewtonScratch& w, int& iterations, double& res_norm) {
  S.evaluate(z, false);
  if (!S.residual().allFinite()) return false;
  double nr = maxAbs(S.residual());
  Eigen::MatrixXd& J = w.J;
  Eigen::VectorXd& step = w.dz;
  J = C.J;
  for (int it = 0; it < max_steps && !(nr < tolerance); ++it) {
    ++iterations;
    w.lu.compute(J);
    step.noalias() = w.lu.solve(-S.residual());
    w.r_old = S.residual();
    z += step;
    S.evaluate(z, false);
    const double nn = maxAbs(S.residual());
    if (!S.residual().allFinite() || !(nn < 0.25 * nr)) return false;
    nr = nn;
    w.r_old = S.residual() - w.r_old;
    broydenUpdate(J, step, w.r_old, w.zt);
  }
  if (!(nr < tolerance)) return false;
  res_norm = nr;
  if (!(std::abs(C.stability) > exact_stability_below)) S.evaluate(z, true);
  return true;
}

}  // namespace ctr::detail
