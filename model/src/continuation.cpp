// Frictionless quasi-static continuation (continueTo): small steps along the straight line in actuation space, each
// warm-started from the last, following the equilibrium branch and detecting snaps.
#include "ctr/model/configuration.hpp"
#include "ctr/model/kinematics.hpp"
#include "solvers.hpp"

namespace ctr {

Solution continueTo(const Robot& robot, const Solution& from, const Configuration& q, Workspace& ws,
                    const KinematicsOptions& options) {
  const Admissibility adm = checkAdmissible(robot, q);
  if (!adm) return detail::inadmissibleSolution(q, adm.message, robot.size(), false);
  if (!from.converged() || from.q.size() != q.size()) {
    Solution s = solve(robot, q, ws, options, nullptr);
    return s;
  }
  const int steps = subdivisions(from.q, q, options.max_rotation_step, options.max_translation_step);
  KinematicsOptions inner = options;
  inner.record_backbone = false;
  Solution cur = from;
  bool snapped = false;
  int iters = 0;
  for (int k = 1; k <= steps; ++k) {
    const Configuration qk = interpolate(from.q, q, static_cast<double>(k) / steps);
    if (k == steps) inner.record_backbone = options.record_backbone;
    Solution next = solve(robot, qk, ws, inner, &cur);
    iters += next.summary.iterations;
    if (!next.converged() || (cur.summary.stable && !next.summary.stable)) {
      // The branch we followed ended (fold) or was lost: find a stable equilibrium from scratch.
      Solution cold = solve(robot, qk, ws, inner, nullptr);
      iters += cold.summary.iterations;
      if (cold.converged()) {
        snapped = snapped || cur.summary.stable;
        next = cold;
      } else if (!next.converged()) {
        next.summary.message = "continuation lost the equilibrium: " + next.summary.message;
        next.summary.iterations = iters;
        next.summary.continuation_steps = k;
        return next;
      }
    } else if (next.twist.size() && cur.twist.size() == next.twist.size() &&
               (next.twist - cur.twist).cwiseAbs().maxCoeff() > options.snap_threshold) {
      snapped = true;
    }
    cur = std::move(next);
  }
  cur.summary.snapped = snapped;
  cur.summary.iterations = iters;
  cur.summary.continuation_steps = steps;
  return cur;
}

}  // namespace ctr
