// Frictionless quasi-static continuation (continueTo): followMove along the straight line in actuation space, each
// sub-step warm-started from the last; where the branch ends, the robot snaps to a stable equilibrium found cold.
#include "ctr/model/configuration.hpp"
#include "ctr/model/follow.hpp"
#include "ctr/model/kinematics.hpp"
#include "solvers.hpp"

namespace ctr {

Solution continueTo(const Robot& robot, const Solution& from, const Configuration& q, Workspace& ws,
                    const KinematicsOptions& options) {
  const Admissibility adm = checkAdmissible(robot, q);
  if (!adm) return detail::inadmissibleSolution(q, adm.message, robot.size(), false);
  if (!from.converged() || from.q.size() != q.size()) return solve(robot, q, ws, options, nullptr);
  KinematicsOptions inner = options;
  Solution cur = from, next, cold;
  int iters = 0;
  auto at = [&](int k, int steps) -> const KinematicsOptions& {
    inner.record_backbone = k == steps && options.record_backbone;
    return inner;
  };
  const FollowSummary f = followMove(
      from.q, q, from.twist, from.summary.stable, options.follow, OnSnap::Continue,
      [&](const Configuration& qk, int k, int steps) {
        next = solve(robot, qk, ws, at(k, steps), &cur);
        iters += next.summary.iterations;
        return SubStep{&next, Failure::None, {}};
      },
      [&](const Configuration& qk, int k, int steps) {
        cold = solve(robot, qk, ws, at(k, steps), nullptr);
        iters += cold.summary.iterations;
        return SubStep{&cold, Failure::None, {}};
      },
      [&](int, int, SubStep& s, bool) {
        cur = std::move(*s.solution);
        return SubStep{};
      });
  if (f.failure != Failure::None) {
    next.summary.message = "continuation lost the equilibrium: " + next.summary.message;
    next.summary.iterations = iters;
    next.summary.continuation_steps = f.completed + 1;
    return next;
  }
  cur.summary.snapped = f.snapped;
  cur.summary.iterations = iters;
  cur.summary.continuation_steps = f.steps;
  return cur;
}

}  // namespace ctr
