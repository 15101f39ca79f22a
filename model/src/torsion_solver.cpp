// The torsion-only equilibrium (Lock & Dupont 2011 §II.A, §II.D): shooting on the base twist rates (and the contact
// unknowns) with the Newton core, warm starts along paths, and the cold-start fallbacks (continuation in the
// precurvatures, then in the relative rotations).
#include <cmath>
#include <functional>
#include <string>

#include "access.hpp"
#include "contact_events.hpp"
#include "newton.hpp"
#include "solvers.hpp"
#include "workspace_impl.hpp"

namespace ctr::detail {
namespace {

// The torsion-only map as a system of the Newton core; with `record` every evaluation records the backbone (so that it
// is at hand for the returned point without another pass).
class TorsionSystem final : public NewtonSystem {
 public:
  TorsionSystem(const Problem& P, Evaluator& E, Outputs& out, bool record) : P_(P), E_(E), out_(out), record_(record) {}
  void evaluate(const Eigen::VectorXd& z, bool jacobian) override { E_.evaluate(P_, z, jacobian, record_, out_); }
  const Eigen::VectorXd& residual() const override { return E_.r; }
  Eigen::MatrixXd& jacobian() override { return E_.J; }
  double stability() const override { return out_.stability; }

 private:
  const Problem& P_;
  Evaluator& E_;
  Outputs& out_;
  bool record_;
};

// Newton from z (exact Jacobians with the values far from the solution, chord steps near it). The outputs are those
// of the last evaluated point.
bool newtonTorsion(const Problem& P, WorkspaceImpl& W, Eigen::VectorXd& z, const KinematicsOptions& opt,
                   int& iterations, double& res_norm, std::string& why, bool record) {
  TorsionSystem S(P, W.eval, W.out, record);
  NewtonSettings s = newtonSettings(opt, P.s_tip, P.n, JacobianReuse::Chord);
  s.jacobian_at_trials = true;
  NewtonJacobian jac;
  return newton(S, z, s, W.newton, jac, iterations, res_norm, why);
}

Solution package(const Configuration& q, const Problem& P, const Outputs& out, const Eigen::VectorXd& z, bool ok,
                 int iterations, double res_norm, const std::string& why, const KinematicsOptions& opt) {
  Solution sol;
  sol.q = q;
  sol.summary.status = ok ? SolveStatus::Converged : SolveStatus::NotConverged;
  sol.summary.iterations = iterations;
  sol.summary.residual_norm = res_norm;
  sol.summary.message = ok ? "" : why;
  sol.summary.stability = out.stability;
  sol.summary.stable = ok && out.stability > 0.0;
  const int n = P.n;
  sol.base_twist_rate = z.head(n);
  sol.theta0.resize(n);
  for (int i = 0; i < n; ++i) sol.theta0[i] = P.alpha[i] - P.beta[i] * z[i];
  SolutionAccess::contactUnknowns(sol) = z.tail(P.m - n);
  sol.twist = out.twist;
  if (sol.twist.size() != n - 1) sol.twist = Eigen::VectorXd::Zero(n - 1);
  sol.tip_position = out.tip_position;
  sol.tip_frame = out.tip_frame;
  sol.moments = out.moments;
  if (opt.record_backbone) {
    // The last evaluation was at (P, z) with recording on (see solveTorsionOnly).
    if (opt.record_tube_states) {
      sol.backbone = out.backbone;
    } else {
      sol.backbone.resize(out.backbone.size());
      for (std::size_t k = 0; k < out.backbone.size(); ++k) {
        const BackbonePoint& a = out.backbone[k];
        BackbonePoint& b = sol.backbone[k];
        b.s = a.s;
        b.position = a.position;
        b.frame = a.frame;
        b.u0 = a.u0;
        b.outermost = a.outermost;
        b.segment_start = a.segment_start;
      }
    }
  }
  sol.contacts = contactResults(P, out.contacts_relative_twist, out.contacts_moment, z, n);
  return sol;
}

Eigen::VectorXd initialGuess(const Problem& P, const Solution* warm) {
  Eigen::VectorXd z = Eigen::VectorXd::Zero(P.m);
  if (warm && warm->base_twist_rate.size() == P.n && warm->base_twist_rate.allFinite()) {
    z.head(P.n) = warm->base_twist_rate;
    contactUnknownsFrom(P, warm->contacts, z, P.n);
  }
  return z;
}

// Adaptive continuation in a parameter t from 0 (where z is a solution) to 1. `setAt(t)` sets the problem up.
bool continuation(const std::function<void(double)>& setAt, const Problem& P, WorkspaceImpl& W, Eigen::VectorXd& z,
                  const KinematicsOptions& opt, int& iterations, int& steps, std::string& why) {
  double t = 0.0, dt = 1.0 / std::max(1, opt.homotopy_steps);
  KinematicsOptions o = opt;
  o.max_iterations = std::min(opt.max_iterations, 12);  // short Newton runs; shrink the step instead
  while (t < 1.0) {
    const double tn = std::min(1.0, t + dt);
    setAt(tn);
    Eigen::VectorXd zt = z;
    double rn = 0;
    std::string w;
    ++steps;
    const bool ok = newtonTorsion(P, W, zt, o, iterations, rn, w, false);
    if (ok) {
      z = zt;
      t = tn;
      dt = std::min(0.5, 1.5 * dt);
    } else {
      dt *= 0.5;
      if (dt < 1e-4) {
        why = w;
        return false;
      }
    }
    if (steps > 400) {
      why = "continuation took too many steps";
      return false;
    }
  }
  return true;
}

// The model key of the chord cache: the robot's kb, kt, kappa.
void modelKey(const Problem& P, Eigen::VectorXd& k) {
  const int n = P.n;
  k.resize(3 * n);
  k.head(n) = P.kb;
  k.segment(n, n) = P.kt;
  k.tail(n) = P.kappa;
}

}  // namespace

Solution solveTorsionOnly(const Robot& robot, const Configuration& q, const std::vector<ContactCondition>* conditions,
                          Workspace& ws, const KinematicsOptions& opt, const Solution* warm) {
  const Admissibility adm = checkAdmissible(robot, q);
  if (!adm) return inadmissibleSolution(q, adm.message, robot.size(), false);
  WorkspaceImpl& W = WorkspaceAccess::impl(ws);
  Problem& P = W.problem;
  P.setup(robot, q, conditions, opt);
  Eigen::VectorXd z = initialGuess(P, warm);
  int iters = 0;
  double rn = 0.0;
  std::string why;
  // Every path below ends with an evaluation at the returned (P, z) with recording on: the backbone (and the
  // stability) package() returns are that evaluation's.
  const bool rec = opt.record_backbone;
  const bool frictionless = conditions == nullptr;
  // Following a path: a frictionless solve warm-started from this workspace's last frictionless solve. (Solves under
  // contact laws never use the workspace's history: a stick-slip step is a function of its state and command, so
  // that a planner's checked states are what a replay of its path computes.)
  WarmHistory& H = W.history;
  JacobianCache& CC = W.chain_chord;
  Eigen::VectorXd& qv = W.key;  // the workspace's scratch vectors: no allocation per solve
  historyKey(q, qv);
  // Quasi-Newton steps from the cached Jacobian; its stability is the solution's unless small (then evaluated).
  TorsionSystem chord_system(P, W.eval, W.out, rec);
  auto chord = [&](Eigen::VectorXd& zc, int max_steps, int& iterations) {
    modelKey(P, W.model_key);
    if (!CC.usable(qv, W.model_key, zc)) return false;
    W.out.stability = CC.stability;
    return chordSolve(chord_system, zc, CC, max_steps, opt.tolerance, exactStabilityBelow(opt), W.newton, iterations,
                      rn);
  };
  const bool chained = frictionless && warm && continuesChain(H, warm->q, qv, z);
  bool ok = false;
  const long jacobians_before = W.eval.jacobian_evaluations;
  if (opt.extrapolate_warm_start && chained && H.count >= 2) {
    Eigen::VectorXd& zp = W.z_predicted;
    zp = z;
    if (continuationPredictor(H, qv, zp)) {
      int it_p = 0;
      Eigen::VectorXd& zc = W.z_chord;
      zc = zp;
      ok = chord(zc, 2, it_p);
      if (ok) {
        z = zc;
      } else {
        ok = newtonTorsion(P, W, zp, opt, it_p, rn, why, rec);
        if (ok) z = zp;
      }
      iters += it_p;
    }
  }
  if (!ok && opt.extrapolate_warm_start && chained) {
    // A path-following solve without a usable prediction: quasi-Newton steps from the warm start.
    Eigen::VectorXd& zc = W.z_chord;
    zc = z;
    ok = chord(zc, 4, iters);
    if (ok) z = zc;
  }
  if (!ok) ok = newtonTorsion(P, W, z, opt, iters, rn, why, rec);
  bool plain = ok;  // converged on the first attempt at the actual problem (no fallback, no refinement)
  const bool cold = (warm == nullptr);
  int cont_steps = 0;
  if ((!ok || (cold && W.out.stability <= 0.0)) && opt.homotopy) {
    plain = false;
    const Eigen::VectorXd z_first = z;
    const bool ok_first = ok;
    auto finish = [&](Eigen::VectorXd& zc) {
      P.setup(robot, q, conditions, opt);
      return newtonTorsion(P, W, zc, opt, iters, rn, why, rec) && W.out.stability > 0.0;
    };
    // Fallback 1: continuation in the precurvatures from the interaction-free robot (unique, stable solution).
    Eigen::VectorXd zh = Eigen::VectorXd::Zero(P.m);
    std::string hwhy;
    bool found = continuation([&](double lam) { P.setup(robot, q, conditions, opt, lam); }, P, W, zh, opt, iters,
                              cont_steps, hwhy) &&
                 finish(zh);
    // Fallback 2: continuation in rotation from the aligned configuration (relative angles zero: untwisted
    // solution exact), along the shortest relative rotations (the model is 2 pi periodic in them).
    if (!found) {
      Configuration qa = q;
      Eigen::VectorXd rel(q.size());
      for (int i = 0; i < q.size(); ++i) {
        rel[i] = std::remainder(q.alpha[i] - q.alpha[0], 2.0 * M_PI);
        qa.alpha[i] = q.alpha[0];
      }
      zh.setZero(P.m);
      std::string rwhy;
      found = continuation(
                  [&](double t) {
                    Configuration qt = qa;
                    qt.alpha = qa.alpha + t * rel;
                    P.setup(robot, qt, conditions, opt);
                  },
                  P, W, zh, opt, iters, cont_steps, rwhy) &&
              finish(zh);
      if (!found) hwhy += "; rotation continuation from the aligned configuration: " + rwhy;
    }
    if (found) {
      z = zh;
      ok = true;
    } else {
      z = z_first;
      ok = ok_first;
      P.setup(robot, q, conditions, opt);
      if (!ok) why += "; homotopy from zero precurvature: " + hwhy;
      W.eval.evaluate(P, z, true, rec, W.out);  // outputs of the returned point
      rn = maxAbs(W.eval.r);
    }
  }
  if (ok && opt.refine_below_stability > 0.0 && std::abs(W.out.stability) < opt.refine_below_stability) {
    plain = false;
    // Ill-conditioned twist near a fold: refine the discretisation (warm start, same branch).
    Eigen::VectorXd zr = z;
    int it2 = 0;
    double rn2 = 0;
    std::string w2;
    P.setup(robot, q, conditions, opt, 1.0, 0.25);
    if (newtonTorsion(P, W, zr, opt, it2, rn2, w2, rec)) {
      z = zr;
      rn = rn2;
    } else {
      P.setup(robot, q, conditions, opt);
      W.eval.evaluate(P, z, true, rec, W.out);
    }
    iters += it2;
  }
  W.eval.finish(P, W.out);
  Solution sol = package(q, P, W.out, z, ok, iters, rn, why, opt);
  sol.summary.continuation_steps = cont_steps;
  if (frictionless && ok)
    recordInChain(H, chained, qv, z);
  else if (frictionless)
    H.count = 0;
  if (frictionless && plain && W.eval.jacobian_evaluations > jacobians_before && W.eval.J.rows() == P.m) {
    // An exact Jacobian of this solve (at its last Newton iterate): the chord matrix of the next nearby solves.
    modelKey(P, W.model_key);
    CC.store(W.eval.J, qv, W.model_key, z, W.out.stability, 0);
  }
  return sol;
}

}  // namespace ctr::detail
