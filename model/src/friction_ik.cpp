// Friction-aware inverse kinematics: the stateful stick-slip step inverted by the damped least squares of
// ik_solver.hpp, each evaluation a step from the given HysteresisState; and the friction-blind comparison.
#include "ctr/model/friction_ik.hpp"
#include "ctr/model/replay.hpp"

#include <algorithm>
#include <cmath>
#include <optional>
#include <stdexcept>

#include "ctr/model/jacobian.hpp"
#include "ik_solver.hpp"

namespace ctr {
namespace {

using detail::Descent;

// Evaluation (a step from `state`) and differentiation (contact laws held) of the stateful map.
struct StatefulMap {
  const Robot& robot;
  const HysteresisState& state;
  Workspace& ws;
  const FrictionIkOptions& o;

  bool acceptable(const StepResult& r) const {
    return r.summary.converged && r.solution.converged() && !r.summary.snapped &&
           (!o.ik.require_stable || r.solution.summary.stable);
  }
  bool operator()(const Configuration& q, const StepResult& /*from*/, StepResult& out) const {
    out = step(robot, state, q, ws, o.friction);
    return acceptable(out);
  }
  bool differentiate(const StepResult& r, Eigen::MatrixXd& A) const {
    const TipJacobian tj = tipJacobian(robot, r.solution, ws, o.friction.kinematics, false, false);
    if (!tj.ok) return false;
    A = tj.actuation;
    return true;
  }
};

// Fills the FrictionCost of a result from the friction-blind command and its stateful step.
void blindCost(FrictionCost& c, const IkResult& blind, const StepResult& blind_step, const IkTarget& target) {
  c.blind_q = blind.q;
  c.blind_reached = blind.summary.reached();
  if (blind_step.summary.converged && blind_step.solution.converged()) {
    c.blind_tip = blind_step.solution.tip_position;
    c.blind_tip_error = (c.blind_tip - target.position).norm();
  }
}

}  // namespace

std::vector<FrictionIkResult> frictionInverseKinematicsPath(const Robot& robot, const HysteresisState& start,
                                                            const std::vector<IkTarget>& targets, Workspace& ws,
                                                            const FrictionIkOptions& o) {
  if (hasActuation(robot) && start.valid && start.q.size() == robot.size()) {
    // The joints on the tubes alone (the state's q are the joints), then the commands through the drives.
    std::vector<FrictionIkResult> out = frictionInverseKinematicsPath(robot.withoutActuation(), start, targets, ws, o);
    HysteresisState state = start;
    for (FrictionIkResult& r : out) {
      const Configuration joints = r.q;
      r.q = commandsFor(robot, joints, state.drives);
      if (r.cost.blind_q.size() == robot.size()) r.cost.blind_q = commandsFor(robot, r.cost.blind_q, state.drives);
      r.cost.drive_alpha_difference = (r.q.alpha - joints.alpha).cwiseAbs().maxCoeff();
      r.cost.drive_beta_difference = (r.q.beta - joints.beta).cwiseAbs().maxCoeff();
      const bool failed_before = r.summary.status == IkStatus::Failed;
      if (!detail::driveCommandsAdmissible(robot, r.q, r.summary) && !failed_before) continue;
      r.step = step(robot, state, r.q, ws, o.friction);  // the same joints from the same state, plays carried
      if (r.step.state.valid) state = r.step.state;
    }
    return out;
  }
  if (!start.valid)
    throw std::invalid_argument("frictionInverseKinematics: the hysteresis state is not initialised (initialState)");
  if (start.q.size() != robot.size())
    throw std::invalid_argument("frictionInverseKinematics: the state and the robot have different tube counts");
  const detail::ActuatorSet set(robot, o.ik);
  if (!set.feasible())
    throw std::invalid_argument("frictionInverseKinematics: robot '" + robot.name() +
                                "' has no admissible translations (limits, nesting, min_protrusion)");
  std::vector<detail::IkGoal> goals;
  goals.reserve(targets.size());
  for (const IkTarget& t : targets) goals.emplace_back(t, o.ik);

  std::vector<FrictionIkResult> out;
  out.reserve(targets.size());
  HysteresisState state = start, blind_state = start;
  IkResult blind;
  IkOptions update = o.ik;
  update.restarts = 0;
  for (std::size_t k = 0; k < targets.size(); ++k) {
    const IkTarget& target = targets[k];
    const detail::IkGoal& goal = goals[k];
    FrictionIkResult res;
    // The friction-blind command: frictionless inverse kinematics (warm from the start's command, then updates).
    const bool with_blind = k == 0 || o.compare_blind;
    std::optional<StepResult> blind_step;
    if (with_blind) {
      blind = k == 0 || !blind.solution.converged() ? inverseKinematics(robot, target, start.q, ws, o.ik)
                                                    : inverseKinematics(robot, target, blind, ws, update);
      blind_step = step(robot, blind_state, blind.q, ws, o.friction);
      if (blind_step->state.valid) blind_state = blind_step->state;
      blindCost(res.cost, blind, *blind_step, target);
    }

    const StatefulMap map{robot, state, ws, o};
    auto differentiate = [&map](const StepResult& r, Eigen::MatrixXd& A) { return map.differentiate(r, A); };
    std::optional<Descent<StepResult>> best;
    auto descend = [&](StepResult s0, const Configuration& q0, const Eigen::MatrixXd* stale, bool move_first) {
      Descent<StepResult> d =
          detail::descend(set, goal, o.ik, std::move(s0), q0, stale, map, differentiate, move_first);
      ++res.summary.starts;
      res.summary.iterations += d.iterations;
      res.summary.evaluations += d.evaluations;
      res.summary.jacobians += d.jacobians;
      if (!best || d.m.cost < best->m.cost) best = std::move(d);
    };
    auto from = [&](const Configuration& q) {
      ++res.summary.evaluations;
      StepResult s = step(robot, state, q, ws, o.friction);
      if (map.acceptable(s)) descend(std::move(s), q, nullptr, false);
    };
    if (k == 0) {
      // The friction-blind command from the start state is both the first guess and the blind evaluation.
      ++res.summary.evaluations;
      if (map.acceptable(*blind_step)) descend(*blind_step, blind.q, nullptr, false);
      if (!(best && best->reached) && blind.q.size() &&
          (blind.q.alpha != state.q.alpha || blind.q.beta != state.q.beta))
        from(state.q);
    } else {
      // The previous equilibrium is where the tubes rest, but not necessarily what the next move gives: a contact
      // site at the edge of the actuation unit releases its torque as soon as they move. So its first step is taken.
      const FrictionIkResult& prev = out.back();
      if (prev.step.summary.converged && prev.step.solution.converged())
        descend(prev.step, prev.q, prev.jacobian.size() ? &prev.jacobian : nullptr, true);
      else
        from(state.q);
    }

    if (!best) {
      res.q = state.q;
      res.step = step(robot, state, state.q, ws, o.friction);
      res.summary.status = IkStatus::Failed;
      res.summary.message = "the stateful model did not converge at any start command";
    } else {
      res.q = best->q;
      res.step = std::move(best->point);
      res.jacobian = std::move(best->jacobian);
      res.jacobian_q = best->jacobian_q;
      detail::summarise(*best, res.step.solution, goal, 0, res.summary);
    }
    if (res.cost.blind_q.size() == res.q.size() && res.q.size() > 0) {
      res.cost.alpha_difference = (res.q.alpha - res.cost.blind_q.alpha).cwiseAbs().maxCoeff();
      res.cost.beta_difference = (res.q.beta - res.cost.blind_q.beta).cwiseAbs().maxCoeff();
    }
    if (res.step.state.valid) state = res.step.state;
    out.push_back(std::move(res));
  }
  return out;
}

FrictionIkResult frictionInverseKinematics(const Robot& robot, const HysteresisState& state, const IkTarget& target,
                                           Workspace& ws, const FrictionIkOptions& o) {
  return std::move(frictionInverseKinematicsPath(robot, state, {target}, ws, o).front());
}

const char* toString(Approach approach) {
  switch (approach) {
    case Approach::Rest:
      return "rest";
    case Approach::Positive:
      return "positive";
    case Approach::Negative:
      return "negative";
  }
  return "?";
}

Configuration approachStart(const Robot& robot, const Configuration& q, Approach approach, double angle) {
  if (!std::isfinite(angle)) throw std::invalid_argument("approachStart: the angle is not finite");
  Configuration from = q;
  if (approach == Approach::Rest) return from;
  const double s = approach == Approach::Positive ? 1.0 : -1.0;
  for (int k = 0; k < q.size() && k < robot.size(); ++k) {
    from.alpha[k] -= s * k * angle;
    if (const auto& lim = robot.tube(k).rotation_limits)
      from.alpha[k] = std::clamp(from.alpha[k], (*lim)[0], (*lim)[1]);
  }
  return from;
}

StepResult approachState(const Robot& robot, const Configuration& q, Approach approach, double angle, Workspace& ws,
                         const FrictionOptions& o) {
  const Configuration from = approachStart(robot, q, approach, angle);
  const StepResult r = restAt(robot, from, ws, o);  // as the first row of a replay (replay.hpp)
  if (approach == Approach::Rest || !r.state.valid) return r;
  return step(robot, r.state, q, ws, o);
}

}  // namespace ctr
