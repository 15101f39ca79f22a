// Internal: the damped least-squares descent shared by the inverse kinematics of the equilibrium model (ik.cpp) and
// of the stateful stick-slip step (friction_ik.cpp). The two differ only in how a command is evaluated (a solve, or a
// step from a hysteresis state) and differentiated; the loop, the admissible set, the cost and the restarts are here.
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <memory>
#include <random>
#include <sstream>
#include <vector>

#include "ctr/model/friction.hpp"
#include "ctr/model/ik.hpp"
#include "ctr/model/sampling.hpp"

namespace ctr::detail {

/// The admissible actuator set as linear constraints on the step variables x = (alpha, beta / translation_scale):
/// rotation limits, the TranslationBounds box, nesting beta_{i+1} <= beta_i and ordered distal ends
/// beta_i + L_i <= beta_{i+1} + L_{i+1}.
class ActuatorSet {
 public:
  ActuatorSet(const Robot& robot, const IkOptions& options);
  int tubes() const { return n_; }
  bool feasible() const { return bounds_.feasible(); }
  double scale() const { return scale_; }
  /// An admissible configuration near q: rotations clamped to their limits, translations clamped tube by tube from
  /// the outermost to their bounds and to the interval the outer neighbour allows.
  void clamp(Configuration& q) const;
  /// Rotations outside their limits moved by whole turns into them where that is possible (the same shape: the model
  /// is 2 pi periodic in each rotation).
  void wrap(Configuration& q) const;
  /// The step of the damped least squares G dx = r (G: task rows x 2n, columns in step units) restricted to the
  /// constraints active at q that it would violate (a working set, its null space), then scaled so that no actuator
  /// moves more than max_step.
  Eigen::VectorXd step(const Configuration& q, const Eigen::MatrixXd& G, const Eigen::VectorXd& r, double lambda,
                       double max_step) const;
  /// q + t dx (dx in step units), clamped.
  Configuration move(const Configuration& q, const Eigen::VectorXd& dx, double t) const;
  /// A random admissible configuration (rotations uniform within the limits or [-pi, pi], translations uniform over
  /// the admissible set).
  Configuration sample(std::mt19937_64& rng) const;

 private:
  struct Row {  // c_i x_i + c_j x_j <= b (j < 0: one variable)
    int i = 0, j = -1;
    double ci = 1.0, cj = 0.0, b = 0.0;
  };
  const Robot* robot_;
  int n_ = 0;
  double scale_ = 0.02, min_protrusion_ = 1e-3;
  TranslationBounds bounds_;
  Eigen::VectorXd length_, rot_lo_, rot_hi_;
  std::vector<Row> rows_;
  mutable std::unique_ptr<TranslationSampler> sampler_;  // built on first use (restarts only)
};

/// Residual and errors of a tip against an IkTarget: r = (p* - p, w (d - t)) (3 or 6 rows), cost |r|^2.
struct IkMeasure {
  Eigen::VectorXd r;
  double cost = 0.0;
  double position_error = 0.0;
  double direction_error = 0.0;
};

class IkGoal {
 public:
  IkGoal(const IkTarget& target, const IkOptions& options);
  int rows() const { return direction_ ? 6 : 3; }
  IkMeasure measure(const Solution& s) const;
  bool reached(const IkMeasure& m) const;
  /// Task Jacobian G (rows x 2n, step units) from the actuation Jacobian (6 x 2n, TipJacobian::actuation) at s.
  Eigen::MatrixXd task(const Solution& s, const Eigen::MatrixXd& actuation, double scale) const;

 private:
  Eigen::Vector3d p_, d_ = Eigen::Vector3d::UnitZ();
  bool direction_ = false;
  double w_ = 0.0, tol_ = 1e-5, dir_tol_ = 0.01;
};

/// The equilibrium of a point of the descent: a solve, or a stateful step.
inline const Solution& solutionOf(const Solution& s) {
  return s;
}
inline const Solution& solutionOf(const StepResult& r) {
  return r.solution;
}

/// |stability| below which an equilibrium is taken as near a fold (the measure is 1 without tube interaction).
inline constexpr double kFoldStability = 0.05;

/// One descent from a start point. It can stop in the middle (set aside, `stopped` false) and resume where it was:
/// the loop's state is kept here.
template <class Point>
struct Descent {
  Point point;  ///< At the end (the best point of the descent).
  Configuration q;
  IkMeasure m;
  bool reached = false;
  bool stopped = false;  ///< Reached, or gave up (`message`); false while it can go on.
  int iterations = 0, evaluations = 0, jacobians = 0;
  Eigen::MatrixXd jacobian;  ///< Last actuation Jacobian computed or used, and where.
  Configuration jacobian_q;
  std::string message;  ///< Why it stopped without reaching.
  // The loop's state between iterations.
  Eigen::MatrixXd A;  // the actuation Jacobian of the next step (empty: compute it at the current point)
  bool exact = false;
  bool move_first = false;
  double mu = 0.0;
  int slow = 0;
  double reach = 1.0;
  std::vector<double> progress;  // sqrt(cost) after each accepted step
};

/// A descent from `start` (at `q0`, evaluated), before its first iteration. With `stale` (a Jacobian taken near q0)
/// the first step uses it. `move_first`: the first full step is taken even without decrease (a stateful map whose
/// value at q0 is not what any move from q0 gives: a contact that releases as soon as the tubes move); the descent
/// goes on from there.
template <class Point>
Descent<Point> beginDescent(const ActuatorSet& set, const IkGoal& goal, const IkOptions& o, Point start,
                            const Configuration& q0, const Eigen::MatrixXd* stale, bool move_first = false) {
  Descent<Point> d;
  d.point = std::move(start);
  d.q = q0;
  d.m = goal.measure(solutionOf(d.point));
  d.reached = d.stopped = goal.reached(d.m);
  d.mu = o.damping;
  d.move_first = move_first;
  if (d.reached) {
    if (stale) {
      d.jacobian = *stale;
      d.jacobian_q = q0;
    }
    return d;
  }
  // The actuation Jacobian of the step: exact at the current point, or the stale one for the first step.
  if (stale && stale->rows() == 6 && stale->cols() == 2 * set.tubes()) {
    d.A = *stale;
    d.jacobian_q = q0;
  }
  return d;
}

/// Whether a descent is slow: at the rate its residual fell over its last two steps, more than `horizon` further
/// iterations would be needed to reach zero (or it did not fall). Cold IK sets such a start aside (IkOptions).
template <class Point>
bool isSlow(const Descent<Point>& d, double horizon) {
  const std::size_t k = d.progress.size();
  if (!(horizon > 0.0) || k < 3) return false;
  const double rate = 0.5 * (d.progress[k - 3] - d.progress[k - 1]);
  return !(rate > 0.0) || d.progress[k - 1] > horizon * rate;
}

/// Damped least squares with a backtracking line search: continues `d` until it stops (reached or gave up), or until
/// `set_aside(d)` is true after a step (then it can be continued later by another call). `eval(q, from, out)` gives
/// the point at command q (from the accepted point `from`; false: refused); `differentiate(point, actuation)` its
/// 6 x 2n actuation Jacobian (false: not defined).
template <class Point, class Eval, class Differentiate, class SetAside>
void advance(Descent<Point>& d, const ActuatorSet& set, const IkGoal& goal, const IkOptions& o, Eval&& eval,
             Differentiate&& differentiate, SetAside&& set_aside) {
  if (d.stopped) return;
  Eigen::MatrixXd& A = d.A;
  // Longest fraction of the step tried first (d.reach): halved steps that succeed make the next iteration start at
  // twice the fraction that worked (near a fold, where full steps leave the branch, this saves their refused solves).
  Point trial;
  while (d.iterations < o.max_iterations) {
    if (A.size() == 0) {
      if (!differentiate(d.point, A)) {
        A.resize(0, 0);
        d.message = "the tip Jacobian is not defined here (a fold of the equilibria)";
        break;
      }
      ++d.jacobians;
      d.exact = true;
      d.jacobian_q = d.q;
    }
    ++d.iterations;
    const Eigen::MatrixXd G = goal.task(solutionOf(d.point), A, set.scale());
    const double mean_diag = std::max(G.squaredNorm() / G.rows(), 1e-300);
    bool accepted = false;
    int refused = 0;  // trials of this iteration whose evaluation was refused (not converged, unstable, snapped)
    for (bool first = true; !accepted; first = false) {
      const Eigen::VectorXd dx = set.step(d.q, G, d.m.r, d.mu * mean_diag, o.max_step);
      if (!(dx.squaredNorm() > 0.0)) break;
      // Backtracking: the step (times `reach`), then half and a quarter of it; the first decrease of the cost is taken.
      // With more damping (later rounds) the step itself is shorter: one trial each.
      for (double t = d.reach; t > (first ? 0.2 : 0.99) * d.reach && !accepted; t *= 0.5) {
        const Configuration qt = set.move(d.q, dx, t);
        ++d.evaluations;
        if (!eval(qt, d.point, trial)) {
          ++refused;
          continue;
        }
        const IkMeasure mt = goal.measure(solutionOf(trial));
        if (mt.cost < d.m.cost || (d.move_first && d.iterations == 1 && t == 1.0)) {
          d.slow = mt.cost > (1.0 - 1e-3) * d.m.cost ? d.slow + 1 : 0;
          std::swap(d.point, trial);
          d.q = qt;
          d.m = mt;
          accepted = true;
          d.reach = std::min(1.0, 2.0 * t);
        }
      }
      if (accepted || !d.exact) break;  // a stale Jacobian is replaced by the exact one before damping more
      // At the end of the branch (a fold) shorter steps only creep toward it: give up this start.
      if (refused >= 3 && std::abs(solutionOf(d.point).summary.stability) < kFoldStability) break;
      d.mu = std::max(10.0 * d.mu, o.damping);
      if (d.mu > 1e6) break;
    }
    d.jacobian = A;
    if (!accepted && !d.exact) {
      A.resize(0, 0);
      continue;
    }
    if (!accepted) {
      d.message = refused >= 3 && std::abs(solutionOf(d.point).summary.stability) < kFoldStability
                      ? "the equilibrium branch ends (a fold) between this start and the target"
                      : "no descent from the closest point found (the edge of the workspace or a local minimum)";
      break;
    }
    if (goal.reached(d.m)) {
      d.reached = d.stopped = true;
      return;
    }
    d.mu = std::max(d.mu * 0.1, 1e-12);
    A.resize(0, 0);
    d.exact = false;
    if (refused >= 3 && std::abs(solutionOf(d.point).summary.stability) < kFoldStability) {
      // Creeping along the end of the branch: steps toward the target leave it. Another start is cheaper.
      d.message = "the equilibrium branch ends (a fold) between this start and the target";
      break;
    }
    if (d.slow >= 4) {
      d.message = "the tip error stopped decreasing (the edge of the workspace or a local minimum)";
      break;
    }
    d.progress.push_back(std::sqrt(d.m.cost));
    if (d.iterations < o.max_iterations && set_aside(d)) return;
  }
  if (d.message.empty()) d.message = "iteration limit reached";
  d.stopped = true;
}

/// A whole descent (beginDescent, then advance to its end).
template <class Point, class Eval, class Differentiate>
Descent<Point> descend(const ActuatorSet& set, const IkGoal& goal, const IkOptions& o, Point start,
                       const Configuration& q0, const Eigen::MatrixXd* stale, Eval&& eval,
                       Differentiate&& differentiate, bool move_first = false) {
  Descent<Point> d = beginDescent(set, goal, o, std::move(start), q0, stale, move_first);
  advance(d, set, goal, o, eval, differentiate, [](const Descent<Point>&) { return false; });
  return d;
}

/// The summary fields of the descent `d` kept as the answer, whose equilibrium is `sol`: status, errors, closest tip,
/// stability and, when not reached, the message (`starts` > 0 names the starts tried).
template <class Point>
void summarise(const Descent<Point>& d, const Solution& sol, const IkGoal& goal, int starts, IkSummary& s) {
  s.status = d.reached ? IkStatus::Reached : IkStatus::NotReached;
  s.tip_error = d.m.position_error;
  s.direction_error = d.m.direction_error;
  s.closest = sol.tip_position;
  s.stable = sol.summary.stable;
  s.stability = sol.summary.stability;
  if (d.reached) return;
  std::ostringstream os;
  os << "not reached: the closest tip found is " << d.m.position_error * 1e3 << " mm from the target";
  if (goal.rows() == 6) os << " (direction " << d.m.direction_error << " rad off)";
  if (starts > 0) os << " after " << starts << (starts == 1 ? " start" : " starts");
  os << "; " << d.message;
  s.message = os.str();
}

/// A robot with drives: whether the answer's commands (the joints through the inverse drives) are admissible; when
/// they are not, an answer that was not failed already is marked failed with the reason.
inline bool driveCommandsAdmissible(const Robot& robot, const Configuration& q, IkSummary& s) {
  const Admissibility adm = checkAdmissible(robot, q);
  if (adm) return true;
  if (s.status != IkStatus::Failed) {
    s.status = IkStatus::Failed;
    s.message = "the commands that put the tubes there through the drives are not admissible: " + adm.message;
  }
  return false;
}

}  // namespace ctr::detail
