// Inverse kinematics of the equilibrium model (frictionless, or with the robot's external loads): damped least
// squares on the exact tip Jacobian from a warm start, a previous result or random admissible configurations.
#include "ctr/model/ik.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <stdexcept>

#include "ctr/model/follow.hpp"
#include "ctr/model/jacobian.hpp"
#include "ik_solver.hpp"

namespace ctr {

const char* toString(IkStatus s) {
  switch (s) {
    case IkStatus::Reached:
      return "reached";
    case IkStatus::NotReached:
      return "not reached";
    case IkStatus::Failed:
      return "failed";
  }
  return "unknown";
}

namespace {

using detail::ActuatorSet;
using detail::Descent;
using detail::IkGoal;

// Trial points of the Newton line search of a trial solve and of a candidate's coarse cold solve
// (KinematicsOptions::line_search_steps). A trial past a fold has no solution near its warm start: its Newton steps
// find no descent, and the solver's 12 halvings (each point with its Jacobian) made such a refused trial cost 5-15
// accepted ones, most of the time of a start whose branch ends before the target. With 4 the descents are the same
// (the same iterations for the 600 cold IKs of the medmpd robots in bench_ik) and the refusals cheap.
constexpr int kTrialLineSearch = 4;

// Evaluation and differentiation of the equilibrium map for the descent.
struct EquilibriumMap {
  const Robot& robot;
  Workspace& ws;
  const IkOptions& o;
  // Trial solves start from the accepted point's equilibrium: one that does not converge from there within a few
  // Newton iterations is refused (the line search then tries a shorter step), so neither a long Newton run nor the
  // solver's fallback continuation from scratch (milliseconds, and another branch if it succeeds) is spent on it.
  KinematicsOptions trial = [this] {
    KinematicsOptions k = o.kinematics;
    k.homotopy = false;
    k.max_iterations = std::min(k.max_iterations, 12);
    k.line_search_steps = std::min(k.line_search_steps, kTrialLineSearch);
    return k;
  }();

  // A trial is refused when it does not converge, is unstable (if required) or left the branch of `from`: the solver
  // fell back to a continuation from scratch, or the twist jumped by more than the snap threshold beyond the change
  // of the base rotations.
  bool acceptable(const Solution& s, const Solution* from) const {
    if (!s.converged()) return false;
    if (o.require_stable && !s.summary.stable) return false;
    if (from && s.summary.continuation_steps > 0) return false;
    if (from && from->q.size() == s.q.size()) {
      // The branch rule of followMove, its threshold widened by twice the largest change of a base rotation.
      const double turned = (s.q.alpha - from->q.alpha).cwiseAbs().maxCoeff();
      if (branchChange(*from, s, o.kinematics.follow.snap_threshold + 2.0 * turned, false) != BranchChange::None)
        return false;
    }
    return true;
  }
  bool operator()(const Configuration& q, const Solution& from, Solution& out) const {
    out = solve(robot, q, ws, trial, &from);
    return acceptable(out, &from);
  }
  bool differentiate(const Solution& s, Eigen::MatrixXd& A) const {
    const TipJacobian tj = tipJacobian(robot, s, ws, o.kinematics, false, false);
    if (!tj.ok) return false;
    A = tj.actuation;
    return true;
  }
};

void checkStart(const Robot& robot, const Configuration& q) {
  if (q.alpha.size() != robot.size() || q.beta.size() != robot.size())
    throw std::invalid_argument("inverseKinematics: the start has " + std::to_string(q.alpha.size()) +
                                " rotations and " + std::to_string(q.beta.size()) + " translations, robot '" +
                                robot.name() + "' has " + std::to_string(robot.size()) + " tubes");
  if (!q.alpha.allFinite() || !q.beta.allFinite())
    throw std::invalid_argument("inverseKinematics: the start is not finite");
}

class Run {
 public:
  Run(const Robot& robot, const IkTarget& target, Workspace& ws, const IkOptions& o)
      : robot_(robot), target_(target), o_(o), set_(robot, o), goal_(target, o), map_{robot, ws, o} {
    if (!set_.feasible())
      throw std::invalid_argument("inverseKinematics: robot '" + robot.name() +
                                  "' has no admissible translations (limits, nesting, min_protrusion)");
  }

  // One descent from an evaluated start. `may_set_aside`: a slow descent (IkOptions::slow_start_horizon) stops in
  // the middle and is kept for resumeSetAside().
  void descend(Solution start, const Configuration& q0, const Eigen::MatrixXd* stale, bool may_set_aside = false) {
    ++summary_.starts;
    advance(detail::beginDescent(set_, goal_, o_, std::move(start), q0, stale),
            may_set_aside ? o_.slow_start_horizon : 0.0);
  }

  // Continues the set-aside descents, the smallest error first, until one reaches with a cold-solve-consistent
  // equilibrium.
  void resumeSetAside() {
    std::stable_sort(aside_.begin(), aside_.end(),
                     [](const Descent<Solution>& a, const Descent<Solution>& b) { return a.m.cost < b.m.cost; });
    std::vector<Descent<Solution>> aside = std::move(aside_);
    aside_.clear();
    for (Descent<Solution>& d : aside) {
      if (done(true)) break;
      advance(std::move(d), 0.0);
    }
  }

  /// Check reached answers against a cold solve (cold and warm-from-configuration IK; not warm updates).
  void checkBranch(bool on) { check_branch_ = on; }

  // A cold solve of q; false if it is not a usable start.
  bool evaluate(const Configuration& q, Solution& out) {
    ++summary_.evaluations;
    out = solve(robot_, q, map_.ws, o_.kinematics);
    return map_.acceptable(out, nullptr);
  }

  // Descents from random admissible configurations until one reaches; a slow one (IkOptions::slow_start_horizon) is
  // set aside for the next start and resumed only if none reaches. Turning every tube by the same angle turns
  // the load-free robot rigidly about the base axis: each candidate is first turned so that its tip has the target's
  // azimuth (within the rotation limits), and the candidates are tried in the order of the distance left in the
  // (radius, height) half-plane, the part of the error this turn cannot remove; while none is within near_start of the
  // target there, more are drawn (up to max_cold_candidates). (The model is 2 pi periodic in each
  // rotation: a turned rotation beyond its limit is brought back by whole turns where the limits allow.)
  void restarts(int count) {
    if (count <= 0 || done(true)) return;
    std::mt19937_64 rng(o_.seed);
    struct Candidate {
      Solution s;
      double distance;
    };
    const Eigen::Vector3d& p = target_.position;
    const double target_radius = p.head<2>().norm(), target_azimuth = std::atan2(p.y(), p.x());
    // The candidates only rank the starts: solved with coarse steps (the planner's 40 mm / 0.3 rad: tips within a few
    // um, about half the cost); the chosen ones are solved again at the options' discretisation below.
    // Without the cold solve's continuation (homotopy) fallback: a configuration whose cold Newton fails or ends on an
    // unstable equilibrium is replaced by another draw (the continuation took about half of the candidates' time on
    // the medmpd robots; the starts per target did not grow without those configurations).
    KinematicsOptions coarse = o_.kinematics;
    coarse.max_step = std::max(coarse.max_step, 0.04);
    coarse.max_bending_per_step = std::max(coarse.max_bending_per_step, 0.3);
    coarse.tolerance = std::max(coarse.tolerance, 1e-8);
    coarse.homotopy = false;
    coarse.line_search_steps = std::min(coarse.line_search_steps, kTrialLineSearch);
    std::vector<Candidate> c;
    const int wanted = std::max(o_.cold_candidates, count);
    const int most = std::max(wanted, o_.max_cold_candidates);
    double nearest = std::numeric_limits<double>::infinity();
    for (int k = 0;; ++k) {
      const int have = static_cast<int>(c.size());
      const int goal = have >= wanted && o_.near_start > 0 && nearest > o_.near_start ? most : wanted;
      if (have >= goal || k >= 2 * goal) break;  // at most twice as many drawn as kept
      Candidate cand;
      ++summary_.evaluations;
      cand.s = solve(robot_, set_.sample(rng), map_.ws, coarse);
      if (!map_.acceptable(cand.s, nullptr)) continue;
      const Eigen::Vector3d& t = cand.s.tip_position;
      cand.distance = std::hypot(t.head<2>().norm() - target_radius, t.z() - p.z());
      nearest = std::min(nearest, cand.distance);
      c.push_back(std::move(cand));
    }
    std::stable_sort(c.begin(), c.end(),
                     [](const Candidate& a, const Candidate& b) { return a.distance < b.distance; });
    for (std::size_t k = 0; k < c.size() && static_cast<int>(k) < count && !done(true); ++k) {
      const Eigen::Vector3d& t = c[k].s.tip_position;
      Configuration q = c[k].s.q;
      if (t.head<2>().norm() > 1e-9 * (1.0 + t.norm()) && target_radius > 1e-9 * (1.0 + p.norm())) {
        q.alpha.array() += std::remainder(target_azimuth - std::atan2(t.y(), t.x()), 2.0 * M_PI);
        set_.wrap(q);
        set_.clamp(q);
      }
      ++summary_.evaluations;
      Solution start = solve(robot_, q, map_.ws, o_.kinematics, &c[k].s);
      if (map_.acceptable(start, nullptr)) descend(std::move(start), q, nullptr, true);
    }
    if (!done(true)) resumeSetAside();
  }

  // Reached; with `clean`, by an equilibrium a cold solve also gives.
  bool done(bool clean) const { return best_ && rank_ <= (clean ? 0 : 1); }

  IkResult result(const Configuration& fallback, const std::string& failure) {
    IkResult r;
    r.summary = summary_;
    if (!best_) {
      r.q = fallback;
      r.summary.status = IkStatus::Failed;
      r.summary.message = failure;
      return r;
    }
    r.q = best_->q;
    r.solution = std::move(best_->point);
    r.jacobian = std::move(best_->jacobian);
    r.jacobian_q = best_->jacobian_q;
    detail::summarise(*best_, r.solution, goal_, summary_.starts, r.summary);
    r.summary.branch_dependent = rank_ == 1;
    if (rank_ == 1 && best_->reached)
      r.summary.message =
          "reached on an equilibrium branch that a cold solve of the configuration does not give (several stable "
          "equilibria coexist there): the robot gets there only along a continuous path from the start";
    return r;
  }

  ActuatorSet& set() { return set_; }

 private:
  // A slow descent whose tip is where another descent stalled (set aside as slow, or ended without reaching): the
  // same local minimum, reached from another start (on a workspace edge many starts end in one); continuing it would
  // only repeat the other's last iterations.
  bool stalledWhereAnotherStalled(const Descent<Solution>& d) const {
    const double radius = std::max(10.0 * o_.tolerance, 0.02 * d.m.position_error);
    const Eigen::Vector3d& tip = d.point.tip_position;
    for (const Eigen::Vector3d& t : stalled_)
      if ((tip - t).norm() <= radius) return true;
    for (const Descent<Solution>& a : aside_)
      if ((tip - a.point.tip_position).norm() <= radius) return true;
    return false;
  }

  // Continues a descent; a stopped one is ranked (with the branch check, a descent that reaches is checked by a cold
  // solve of its configuration, what forward kinematics gives without history: another equilibrium there ranks the
  // answer below one whose cold solve agrees), a slow one (with a horizon > 0, IkOptions::slow_start_horizon) is set
  // aside, or stopped when it stalled where another descent stalled (stalledWhereAnotherStalled).
  void advance(Descent<Solution> d, double horizon) {
    const int iterations = d.iterations, evaluations = d.evaluations, jacobians = d.jacobians;
    detail::advance(
        d, set_, goal_, o_, map_, [this](const Solution& s, Eigen::MatrixXd& A) { return map_.differentiate(s, A); },
        [this, horizon](const Descent<Solution>& x) {
          return detail::isSlow(x, horizon) ||
                 (detail::isSlow(x, o_.slow_start_horizon) && stalledWhereAnotherStalled(x));
        });
    summary_.iterations += d.iterations - iterations;
    summary_.evaluations += d.evaluations - evaluations;
    summary_.jacobians += d.jacobians - jacobians;
    if (!d.stopped && stalledWhereAnotherStalled(d)) {
      d.stopped = true;
      d.message = "the tip error stopped decreasing where another start's descent had stalled (a local minimum)";
    }
    if (!d.stopped) {
      aside_.push_back(std::move(d));
      return;
    }
    if (!d.reached) stalled_.push_back(d.point.tip_position);
    int rank = d.reached ? 0 : 2;
    if (d.reached && check_branch_) {
      ++summary_.evaluations;
      const Solution cold = solve(robot_, d.q, map_.ws, o_.kinematics);
      if (!cold.converged() || !goal_.reached(goal_.measure(cold))) rank = 1;
    }
    if (!best_ || rank < rank_ || (rank == rank_ && d.m.cost < best_->m.cost)) {
      best_ = std::move(d);
      rank_ = rank;
    }
  }

  const Robot& robot_;
  const IkTarget& target_;
  const IkOptions& o_;
  ActuatorSet set_;
  IkGoal goal_;
  EquilibriumMap map_;
  IkSummary summary_;
  std::optional<Descent<Solution>> best_;
  std::vector<Descent<Solution>> aside_;  // slow descents set aside (cold start and restarts)
  std::vector<Eigen::Vector3d> stalled_;  // tips where descents ended without reaching
  int rank_ = 3;                          // 0 reached (cold solve agrees), 1 reached on another branch, 2 not reached
  bool check_branch_ = false;
};

const char* kNoStart = "the model did not converge at any start configuration";

/// The joints of a command through a robot's drives without history (plays centred on it).
Configuration jointsCentred(const Robot& robot, const Configuration& command) {
  DriveState fresh;
  return jointsOf(robot, command, fresh);
}

/// A robot with drives: `r` is the inverse kinematics of its tubes (joints); its configuration becomes the commands
/// that put them there without history (plays centred: only the transmission errors and offsets are compensated).
IkResult throughDrives(const Robot& robot, IkResult r) {
  if (r.q.size() != robot.size()) return r;
  r.q = commandsFor(robot, r.q, DriveState{});
  detail::driveCommandsAdmissible(robot, r.q, r.summary);
  return r;
}

}  // namespace

IkResult inverseKinematics(const Robot& robot, const IkTarget& target, Workspace& ws, const IkOptions& o) {
  if (hasActuation(robot)) return throughDrives(robot, inverseKinematics(robot.withoutActuation(), target, ws, o));
  Run run(robot, target, ws, o);
  run.checkBranch(o.check_branch);
  run.restarts(1 + std::max(0, o.restarts));
  return run.result(defaultConfiguration(robot), kNoStart);
}

IkResult inverseKinematics(const Robot& robot, const IkTarget& target, const Configuration& start, Workspace& ws,
                           const IkOptions& o) {
  checkStart(robot, start);
  if (hasActuation(robot))
    return throughDrives(robot,
                         inverseKinematics(robot.withoutActuation(), target, jointsCentred(robot, start), ws, o));
  Run run(robot, target, ws, o);
  run.checkBranch(o.check_branch);
  Configuration q0 = start;
  run.set().clamp(q0);
  Solution s0;
  if (run.evaluate(q0, s0)) run.descend(std::move(s0), q0, nullptr);
  if (!run.done(false)) run.restarts(o.restarts);
  return run.result(q0, kNoStart);
}

IkResult inverseKinematics(const Robot& robot, const IkTarget& target, const IkResult& previous, Workspace& ws,
                           const IkOptions& o) {
  if (hasActuation(robot) && previous.q.size() == robot.size()) {
    IkResult tubes = previous;  // continued in joint space: where the previous result put the tubes
    tubes.q = previous.solution.converged() && previous.solution.q.size() == robot.size()
                  ? previous.solution.q
                  : jointsCentred(robot, previous.q);
    return throughDrives(robot, inverseKinematics(robot.withoutActuation(), target, tubes, ws, o));
  }
  if (!previous.solution.converged() || previous.q.size() != robot.size()) {
    IkOptions once = o;
    once.restarts = 0;
    return inverseKinematics(robot, target, previous.q.size() ? previous.q : defaultConfiguration(robot), ws, once);
  }
  checkStart(robot, previous.q);
  Run run(robot, target, ws, o);
  const bool usable = previous.jacobian.rows() == 6 && previous.jacobian.cols() == 2 * robot.size();
  run.descend(previous.solution, previous.q, usable ? &previous.jacobian : nullptr);
  return run.result(previous.q, kNoStart);
}

std::vector<IkResult> inverseKinematicsPath(const Robot& robot, const std::vector<IkTarget>& targets,
                                            const Configuration* start, Workspace& ws, const IkOptions& o) {
  std::vector<IkResult> out;
  out.reserve(targets.size());
  for (const IkTarget& t : targets) {
    if (!out.empty() && out.back().summary.status != IkStatus::Failed)
      out.push_back(inverseKinematics(robot, t, out.back(), ws, o));
    else
      out.push_back(start ? inverseKinematics(robot, t, *start, ws, o) : inverseKinematics(robot, t, ws, o));
  }
  return out;
}

}  // namespace ctr
