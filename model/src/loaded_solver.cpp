// The loaded (Cosserat-rod) equilibrium: shooting on the base twist rates, the base moment and the contact unknowns
// with the Newton core (exact dual-number Jacobians, Broyden updates between them), warm starts along paths, and the
// cold start from the load-free equilibrium by continuation in the load.
#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "access.hpp"
#include "contact_events.hpp"
#include "loaded_map.hpp"
#include "newton.hpp"
#include "solvers.hpp"
#include "workspace_impl.hpp"

namespace ctr::detail {
namespace {

// The loaded map as a system of the Newton core. Value evaluations record the outputs when `record` (Jacobian
// evaluations do not); recordedAt(z) tells whether W.out belongs to z (the point of the last recording is kept in
// W.recorded_z).
class LoadedSystem final : public NewtonSystem {
 public:
  LoadedSystem(LoadedWork& W, const KinematicsOptions& opt, bool record)
      : W_(W), record_(record), nodes_(record && opt.record_backbone), tubes_(opt.record_tube_states) {}
  void evaluate(const Eigen::VectorXd& z, bool jacobian) override {
    if (jacobian) {
      evalJacobian(W_, z);
      return;
    }
    evalValue(W_, z, record_ ? &W_.out : nullptr, nodes_, tubes_);
    if (record_) {
      W_.recorded_z = z;
      recorded_ = true;
    }
  }
  const Eigen::VectorXd& residual() const override { return W_.r; }
  Eigen::MatrixXd& jacobian() override { return W_.J; }
  double stability() const override { return loadedStability(W_.L, W_.J); }
  bool recordedAt(const Eigen::VectorXd& z) const { return recorded_ && W_.recorded_z == z; }

 private:
  LoadedWork& W_;
  bool record_, nodes_, tubes_;
  bool recorded_ = false;
};

// The model key of the Jacobian cache: the robot's kb, kt, kappa, densities and the (scaled) loads.
void modelKey(const LoadedProblem& L, Eigen::VectorXd& k) {
  const Problem& P = L.P;
  k.resize(4 * P.n + 9);
  k << P.kb, P.kt, P.kappa, L.rho, L.g, L.F, L.M;
}

Solution packageLoaded(LoadedWork& W, const Configuration& q, const Eigen::VectorXd& z, bool ok, int iterations,
                       double res_norm, const std::string& why, const KinematicsOptions& opt, double stability,
                       bool recorded) {
  const LoadedProblem& L = W.L;
  const Problem& P = L.P;
  const int n = P.n;
  // The outputs (twist, moments, contacts, backbone) of an evaluation at the returned point.
  if (!recorded) evalValue(W, z, &W.out, opt.record_backbone, opt.record_tube_states);
  Solution sol;
  sol.q = q;
  sol.loaded = true;
  sol.summary.status = ok ? SolveStatus::Converged : SolveStatus::NotConverged;
  sol.summary.iterations = iterations;
  sol.summary.residual_norm = ok ? res_norm : maxAbs(W.r);
  sol.summary.message = ok ? "" : why;
  sol.summary.stability = stability;
  sol.summary.stable = ok && stability > 0.0;
  sol.base_twist_rate.resize(n);
  double msum = 0.0;
  for (int i = 0; i + 1 < n; ++i) {
    sol.base_twist_rate[i] = z[i];
    msum += P.kt[i] * z[i];
  }
  sol.base_moment = L.K0 * z.segment(n - 1, 3);
  sol.base_twist_rate[n - 1] = (sol.base_moment.z() - msum) / P.kt[n - 1];
  sol.theta0 = P.alpha - P.beta.cwiseProduct(sol.base_twist_rate);
  double C = 0.0;
  for (int i = 0; i < n; ++i) C += L.rho[i] * std::max(0.0, P.end[i]);
  sol.base_force = L.F + L.g * C;
  SolutionAccess::contactUnknowns(sol) = z.tail(L.m - n - 2);
  sol.twist = W.out.twist;
  if (sol.twist.size() != n - 1) sol.twist = Eigen::VectorXd::Zero(n - 1);
  sol.tip_position = W.tip_p;
  sol.tip_frame = W.tip_R;
  sol.moments = W.out.moments;
  if (opt.record_backbone) sol.backbone = W.out.backbone;
  sol.contacts = contactResults(P, W.out.contacts_relative_twist, W.out.contacts_moment, z, n + 2);
  return sol;
}

}  // namespace

bool newtonLoaded(LoadedWork& W, Eigen::VectorXd& z, const KinematicsOptions& opt, int& iterations, double& res_norm,
                  std::string& why, bool record, bool* recorded) {
  JacobianCache& C = W.cache;
  const LoadedProblem& L = W.L;
  const Problem& P = L.P;
  LoadedSystem S(W, opt, record);
  NewtonJacobian jac;
  historyKey(P.alpha, P.beta, W.q_key);
  modelKey(L, W.model_key);
  // Solves under contact laws (stick-slip steps) never start from the workspace's Jacobian: a step stays a function of
  // its state and command alone, bit for bit (the planner's exact-mode replay recomputes its checked states).
  if (P.contacts.empty() && C.usable(W.q_key, W.model_key, z)) {
    W.J = C.J;
    jac.from_cache = true;
    jac.updates = C.updates;
  }
  const bool ok =
      newton(S, z, newtonSettings(opt, P.s_tip, L.m, JacobianReuse::Broyden), W.newton, jac, iterations, res_norm, why);
  if (ok) C.store(W.J, W.q_key, W.model_key, z, std::numeric_limits<double>::quiet_NaN(), jac.updates);
  if (recorded) *recorded = S.recordedAt(z);
  return ok;
}

Solution solveLoaded(const Robot& robot, const Configuration& q, const std::vector<ContactCondition>* conditions,
                     Workspace& ws, const KinematicsOptions& opt, const Solution* warm) {
  const Admissibility adm = checkAdmissible(robot, q);
  if (!adm) return inadmissibleSolution(q, adm.message, robot.size(), true);
  LoadedWork& W = WorkspaceAccess::impl(ws).loaded;
  LoadedProblem& L = W.L;
  setupLoaded(L, robot, q, conditions, opt, 1.0);
  int iters = 0;
  double rn = 0.0;
  std::string why;
  Eigen::VectorXd z;
  bool ok = false, recorded = false;
  const bool have_warm = warm && warm->base_twist_rate.size() == robot.size() && warm->base_twist_rate.allFinite();
  const Eigen::VectorXd qv = historyKey(q);
  bool chained = false;
  if (have_warm) {
    z = unknownsFrom(L, *warm);
    // Only frictionless solves follow the workspace's chain (a stick-slip step depends on its state alone).
    chained = L.P.contacts.empty() && continuesChain(W.history, warm->q, qv, z);
    if (opt.extrapolate_warm_start && chained && W.history.count >= 2) {
      // Following a path: Newton from the extrapolation of the chain (the torsion-only solver's predictor).
      Eigen::VectorXd zp = z;
      if (continuationPredictor(W.history, qv, zp)) {
        ok = newtonLoaded(W, zp, opt, iters, rn, why, true, &recorded);
        if (ok) z = zp;
      }
    }
    if (!ok) ok = newtonLoaded(W, z, opt, iters, rn, why, true, &recorded);
  }
  if (!ok) {
    // From the load-free equilibrium (its own cold-start fallbacks; the warm branch when given), then continuation
    // in the load scale from 0 to 1 when the full load is too far for Newton.
    KinematicsOptions o = opt;
    o.record_backbone = false;
    o.loaded_model = false;
    const Solution free = solveTorsionOnly(robot, q, conditions, ws, o, have_warm ? warm : nullptr);
    iters += free.summary.iterations;
    if (!free.converged()) {
      const Eigen::VectorXd z0 = z.size() == L.m ? z : Eigen::VectorXd::Zero(L.m);
      evalJacobian(W, z0);
      return packageLoaded(
          W, q, z0, false, iters, maxAbs(W.r),
          "the load-free equilibrium (start of the load continuation) did not converge: " + free.summary.message, opt,
          loadedStability(L, W.J), false);
    }
    // Quasi-static loading from the load-free shape: the load scale goes from 0 to 1 (first in one step); a step is
    // taken when Newton converges and the tip moved little (tangent turned by less than follow.snap_threshold, position
    // by less than a tenth of the robot's length), otherwise it is halved. So a cold solve returns the equilibrium
    // reached by applying the load gradually, never another equilibrium that Newton happens to find under the full
    // load.
    Eigen::VectorXd zc = unknownsFrom(L, free);
    std::string w;
    Eigen::Vector3d tip_p = free.tip_position, tip_t = free.tipTangent();
    double t = 0.0, dt = 1.0;
    int steps = 0;
    bool found = true;
    while (t < 1.0) {
      const double tn = std::min(1.0, t + dt);
      setLoadScale(L, robot, tn);
      Eigen::VectorXd zt = zc;
      double r2 = 0.0;
      ++steps;
      if (newtonLoaded(W, zt, opt, iters, r2, w)) {
        evalValue(W, zt, nullptr, false, false);  // tip of the converged point
        const Eigen::Vector3d np = W.tip_p, nt = W.tip_R.col(2);
        const double turn = std::acos(std::clamp(tip_t.dot(nt), -1.0, 1.0));
        if ((turn > opt.follow.snap_threshold || (np - tip_p).norm() > 0.1 * L.P.s_tip) && dt > 1e-3) {
          dt *= 0.5;
        } else {
          zc = zt;
          t = tn;
          tip_p = np;
          tip_t = nt;
          dt = std::min(1.0, 2.0 * dt);
        }
      } else {
        dt *= 0.5;
      }
      if (dt < 1e-4 || steps > 400) {
        found = false;
        why = (why.empty() ? std::string() : why + "; ") +
              "load continuation from the load-free equilibrium stopped at " + std::to_string(t) + " of the load: " + w;
        break;
      }
    }
    setLoadScale(L, robot, 1.0);
    if (found) found = newtonLoaded(W, zc, opt, iters, rn, w, true, &recorded);
    if (found) {
      z = zc;
      ok = true;
    } else {
      if (why.empty()) why = w;
      if (z.size() != L.m) z = zc;
      evalJacobian(W, z);
      rn = maxAbs(W.r);
      recorded = false;
    }
  }
  double stability = loadedStability(L, W.J);
  if (ok && opt.refine_below_stability > 0.0 && std::abs(stability) < opt.refine_below_stability) {
    // Near a fold the twist is ill-conditioned (error ~ discretisation / stability): re-solve with a quarter of the
    // step from the converged point (same branch), as the torsion-only solver does. Exact Jacobians throughout.
    setupLoaded(L, robot, q, conditions, opt, 0.25);
    W.cache.valid = false;
    Eigen::VectorXd zr = z;
    double rn2 = 0.0;
    std::string w2;
    bool rec2 = false;
    if (newtonLoaded(W, zr, opt, iters, rn2, w2, true, &rec2)) {
      z = zr;
      rn = rn2;
      recorded = rec2;
    } else {
      setupLoaded(L, robot, q, conditions, opt, 1.0);
      W.cache.valid = false;
      evalJacobian(W, z);
      recorded = false;
    }
    stability = loadedStability(L, W.J);
  }
  if (ok && L.P.contacts.empty())
    recordInChain(W.history, chained, qv, z);
  else
    W.history.count = 0;
  return packageLoaded(W, q, z, ok, iters, rn, why, opt, stability, recorded);
}

}  // namespace ctr::detail
