// Internal: the Newton core of the shooting solvers (torsion-only, loaded, distributed friction): damped Newton steps
// with a step cap and a backtracking line search, quasi-Newton reuse of Jacobians (chord or Broyden), the quasi-Newton
// solve from a cached Jacobian, and the cache with its reuse rule.
//
// Failure messages (the SolveSummary::message of a failed solve names one of them, after what was being solved):
//   "non-finite residual"                          the residual at the current iterate is NaN or infinite;
//   "singular Jacobian"                            neither the Newton step nor the regularised one is finite;
//   "line search failed (no descent direction)"    12 halvings of the step found no decrease of |r|^2;
//   "no convergence in N Newton iterations (residual x)".
#pragma once

#include <Eigen/Core>
#include <Eigen/LU>
#include <limits>
#include <string>

#include "ctr/model/kinematics.hpp"

namespace ctr::detail {

/// Max-norm of a vector (0 when empty).
inline double maxAbs(const Eigen::VectorXd& v) {
  return v.size() ? v.cwiseAbs().maxCoeff() : 0.0;
}

/// A square system r(z) = 0 as the Newton core sees it.
class NewtonSystem {
 public:
  virtual ~NewtonSystem() = default;
  /// r(z) into residual(); with `jacobian` also dr/dz into jacobian().
  virtual void evaluate(const Eigen::VectorXd& z, bool jacobian) = 0;
  virtual const Eigen::VectorXd& residual() const = 0;
  /// The Jacobian of the last evaluation with it, or its quasi-Newton update.
  virtual Eigen::MatrixXd& jacobian() = 0;
  /// Stability measure of jacobian() (its sign tells stable from unstable equilibria).
  virtual double stability() const = 0;
};

/// How Newton reuses a Jacobian between exact evaluations.
enum class JacobianReuse {
  /// Value-only steps reuse the factorised Jacobian while each contracts the residual 10x; otherwise the Jacobian is
  /// evaluated at the iterate. For maps whose Jacobian comes with the value at a few times its cost.
  Chord,
  /// Broyden updates along steps that cut the residual 4x at the full step; after a poorer step the exact Jacobian at
  /// the new iterate. For maps whose Jacobian costs many values.
  Broyden,
};

struct NewtonSettings {
  int max_iterations = 40;
  /// Trial points of the backtracking line search of one iteration (the step, then halved each time) before the
  /// solve gives up (no descent direction).
  int line_search_steps = 12;
  double tolerance = 1e-10;  ///< On the max-norm of the residual.
  /// Largest max-norm change of the first `capped` unknowns in one step (0 capped: all).
  double step_cap = std::numeric_limits<double>::infinity();
  int capped = 0;
  JacobianReuse reuse = JacobianReuse::Chord;
  /// Chord: evaluate trial points with the Jacobian unless the step is expected to converge (quadratic convergence
  /// predicts it when nr^2 < 1000 tolerance).
  bool jacobian_at_trials = false;
  /// Converged on a reused or updated Jacobian: the exact one at the solution when |stability| <= this (near a fold,
  /// where its sign matters) or after more than max_updates Broyden updates.
  double exact_stability_below = 0.25;
  int max_updates = 30;
};

/// Settings of the model's solvers from their options: iterations, tolerance, the base twist-rate step cap 4 pi / tip
/// arc length on the first `capped` unknowns, and the stability limit of exactStabilityBelow().
NewtonSettings newtonSettings(const KinematicsOptions& opt, double s_tip, int capped, JacobianReuse reuse);

/// Below this |stability| a solve converged on a reused Jacobian evaluates the exact one at the solution: 0.25, or
/// twice KinematicsOptions::refine_below_stability (so that the refinement test uses an exact stability).
double exactStabilityBelow(const KinematicsOptions& opt);

/// Storage reused between solves (no allocation per solve).
struct NewtonScratch {
  Eigen::PartialPivLU<Eigen::MatrixXd> lu;
  Eigen::VectorXd dz, zt, r_old;
  Eigen::MatrixXd J;
};

/// In/out state of the Jacobian: `from_cache` (in) the system's jacobian() already holds a usable Jacobian taken near
/// z (the first evaluation is then value-only); `updates` Broyden updates since it was exact (in with from_cache,
/// out); `exact` (out) the returned jacobian() is the exact one at z.
struct NewtonJacobian {
  bool from_cache = false;
  int updates = 0;
  bool exact = false;
};

/// Damped Newton from z. Returns true on convergence (residual max-norm below tolerance). On return z is the last
/// iterate and the system was last evaluated there (with the Jacobian after a failed line search); res_norm is its
/// residual's max-norm and `why` (on failure) one of the messages above. `iterations` is incremented per step.
bool newton(NewtonSystem& S, Eigen::VectorXd& z, const NewtonSettings& s, NewtonScratch& w, NewtonJacobian& jac,
            int& iterations, double& res_norm, std::string& why);

/// J += (dr - J step) step^T / |step|^2 (Broyden's update along a step).
void broydenUpdate(Eigen::MatrixXd& J, const Eigen::VectorXd& step, const Eigen::VectorXd& dr, Eigen::VectorXd& tmp);

/// A Jacobian kept from a recent solve for the quasi-Newton steps of the next nearby ones: where it was taken
/// (history key of the actuation, unknowns), of which model (its parameters), its stability (NaN when not kept: then
/// chordSolve evaluates the exact Jacobian at its solution) and its Broyden updates since it was exact.
struct JacobianCache {
  bool valid = false;
  Eigen::MatrixXd J;
  Eigen::VectorXd q, model, z;
  double stability = 0.0;
  int updates = 0;
  /// The reuse rule: the same model and number of unknowns, the actuation within 0.1 in history-key units (0.1 rad,
  /// 2 mm) and the unknowns within 0.1 (1 + |z|) of where it was taken.
  bool usable(const Eigen::VectorXd& q_key, const Eigen::VectorXd& model_key, const Eigen::VectorXd& z_now) const;
  void store(const Eigen::MatrixXd& J_kept, const Eigen::VectorXd& q_key, const Eigen::VectorXd& model_key,
             const Eigen::VectorXd& z_now, double stab, int broyden_updates);
};

/// Quasi-Newton from a good start (a predicted z, a warm start) with a cached Jacobian C.J and Broyden updates, no
/// line search: succeeds when the residual converges within max_steps steps, each cutting it by at least 4 (the
/// caller falls back to newton() otherwise). Evaluations are value-only, except the last when |C.stability| <=
/// exact_stability_below (the Jacobian at the solution then).
bool chordSolve(NewtonSystem& S, Eigen::VectorXd& z, const JacobianCache& C, int max_steps, double tolerance,
                double exact_stability_below, NewtonScratch& w, int& iterations, double& res_norm);

}  // namespace ctr::detail
