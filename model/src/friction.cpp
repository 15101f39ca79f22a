// TEMPORARY STUB (frictionless pass-through) -- replaced by the stick-slip implementation.
#include "ctr/model/friction.hpp"

namespace ctr {

StepResult initialState(const Robot& robot, const Configuration& q, Workspace& ws, const FrictionOptions& o) {
  StepResult r;
  r.solution = solve(robot, q, ws, o.kinematics);
  r.state.q = q;
  r.state.base_twist_rate = r.solution.base_twist_rate;
  r.state.valid = r.solution.converged();
  r.summary.converged = r.solution.converged();
  return r;
}

StepResult step(const Robot& robot, const HysteresisState& from, const Configuration& q, Workspace& ws,
                const FrictionOptions& o) {
  Solution prev = solve(robot, from.q, ws, o.kinematics);
  StepResult r;
  r.solution = continueTo(robot, prev, q, ws, o.kinematics);
  r.state.q = q;
  r.state.base_twist_rate = r.solution.base_twist_rate;
  r.state.valid = r.solution.converged();
  r.summary.converged = r.solution.converged();
  return r;
}

std::vector<StepResult> replay(const Robot& robot, const std::vector<Configuration>& commands, Workspace& ws,
                               const FrictionOptions& o) {
  std::vector<StepResult> out;
  if (commands.empty()) return out;
  out.push_back(initialState(robot, commands[0], ws, o));
  for (std::size_t k = 1; k < commands.size(); ++k) out.push_back(step(robot, out.back().state, commands[k], ws, o));
  return out;
}

FrictionBand frictionBand(const Robot& robot, const Configuration& q, Workspace& ws, const FrictionBandOptions& o) {
  FrictionBand b;
  b.shapes.push_back(solve(robot, q, ws, o.kinematics));
  b.converged = b.shapes[0].converged();
  b.twist_min = b.twist_max = b.shapes[0].twist;
  return b;
}

}  // namespace ctr
