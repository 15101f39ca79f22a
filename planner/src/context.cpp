#include "ctr/planner/context.hpp"

#include <cstdio>
#include <stdexcept>

namespace ctr::planner {

const char* toString(Mode m) {
  switch (m) {
    case Mode::Exact:
      return "exact";
    case Mode::Robust:
      return "robust";
    case Mode::Frictionless:
      return "frictionless";
  }
  return "?";
}

Mode parseMode(const std::string& s) {
  if (s == "exact") return Mode::Exact;
  if (s == "robust") return Mode::Robust;
  if (s == "frictionless") return Mode::Frictionless;
  throw std::invalid_argument("unknown mode '" + s + "' (exact, robust, frictionless)");
}

KinematicsOptions planningKinematicsOptions() {
  KinematicsOptions o;
  o.max_step = 0.04;
  o.max_bending_per_step = 0.3;
  // The bending limit per segment (the library default): longer steps where only less curved tubes bend. The collision
  // capsules follow the arcs of long steps (robotCapsules refines them), so the steps' length does not fatten them.
  o.tolerance = 1e-8;  // scaled residual: ~1e-10 m at the tip, far below the 1 µm the steps allow
  o.extrapolate_warm_start = true;
  return o;
}

FrictionOptions planningFrictionOptions() {
  FrictionOptions f;
  f.kinematics = planningKinematicsOptions();
  return f;
}

std::string geometricDriveLimit(const Robot& robot) {
  for (int i = 0; i < robot.size(); ++i) {
    const Tube& t = robot.tube(i);
    const std::string tube = "tube " + std::to_string(i + 1);
    if (t.rotation_drive.play > 0.0) return tube + "'s rotation drive has a play (its position is history)";
    if (t.translation_drive.play > 0.0) return tube + "'s translation drive has a play (its position is history)";
  }
  return unwrappedCommandDependence(robot);
}

Context::Context(Robot robot, std::shared_ptr<const environments::Environment> env, ContextOptions options,
                 environments::CollisionOptions collision)
    : robot_(std::move(robot)),
      tubes_(robot_.withoutActuation()),
      frictionless_(tubes_.withFriction({0.0, 0.0})),
      drives_(hasActuation(robot_)),
      env_(std::move(env)),
      options_(options),
      sampler_(robot_, options.min_protrusion) {
  if (!env_) throw std::invalid_argument("planning context: no environment");
  if (!options_.ranges.empty()) {
    if (options_.mode != Mode::Robust)
      throw std::invalid_argument(std::string("ranges of the robot's values are planned for in robust mode, not ") +
                                  toString(options_.mode));
    checkRanges(robot_, options_.ranges);
  }
  if (drives_ && options_.mode == Mode::Frictionless) {
    const std::string why = geometricDriveLimit(robot_);
    if (!why.empty())
      throw std::invalid_argument("robot '" + robot_.name() + "': " + why +
                                  "; frictionless mode plans without history: plan in exact mode, whose states carry "
                                  "the drives, or in robust mode, which covers every position of a play");
  }
  if (options_.mode == Mode::Robust) {
    try {
      corners_ = planner::robustCorners(robot_, options_.ranges);
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument("robot '" + robot_.name() + "': " + e.what() +
                                  "; robust mode keeps rotations within a turn: plan in exact mode");
    }
  }
  if (!sampler_.feasible()) throw std::invalid_argument("robot '" + robot_.name() + "' has no admissible translation");
  checker_ = std::make_shared<environments::CollisionChecker>(env_, robot_, collision);
}

Configuration Context::jointsAt(const Configuration& command) const {
  if (!drives_) return command;
  DriveState none;
  return jointsOf(robot_, command, none);
}

Configuration Context::commandAt(const Configuration& joints) const {
  if (!drives_) return joints;
  return commandsFor(robot_, joints, DriveState{});
}

ThreadScratch& scratch() {
  thread_local ThreadScratch t;
  return t;
}

ShapeCheck checkShape(const Context& ctx, const Solution& sol, ThreadScratch& t) {
  ShapeCheck c;
  if (!sol.converged()) {
    c.failure = sol.summary.status == SolveStatus::Inadmissible ? Failure::Inadmissible : Failure::NotConverged;
    c.message = sol.summary.status == SolveStatus::Inadmissible ? "inadmissible: " + sol.summary.message
                                                                : "model not converged: " + sol.summary.message;
    return c;
  }
  if (!sol.summary.stable) {
    c.failure = Failure::Unstable;
    c.message = "elastically unstable equilibrium";
    return c;
  }
  const environments::CollisionResult r = ctx.checker().check(sol, t.query);
  if (r.collision) {
    // %g: the same text as an ostream's default formatting, without constructing a stream per check.
    char buf[128];
    std::snprintf(buf, sizeof buf, "collision (tube %d, s %g-%g m%s)", r.tube + 1, r.s0, r.s1,
                  r.outside_map ? ", outside the map" : "");
    c.failure = Failure::Collision;
    c.message = buf;
    return c;
  }
  c.ok = true;
  return c;
}

}  // namespace ctr::planner
