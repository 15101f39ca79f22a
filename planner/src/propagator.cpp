#include "ctr/planner/propagator.hpp"

#include <ompl/control/spaces/RealVectorControlSpace.h>

#include <cmath>

namespace ob = ompl::base;
namespace oc = ompl::control;

namespace ctr::planner {
namespace {

FrictionOptions stepOptions(const Context& ctx) {
  FrictionOptions o = ctx.options().friction;
  o.kinematics.record_backbone = true;
  return o;
}

std::shared_ptr<StateCache> fromStep(const StepResult& r, bool snapped_before) {
  auto c = std::make_shared<StateCache>();
  c->hysteresis = r.state;
  c->solution = r.solution;
  c->physics_ok = r.summary.converged && r.solution.converged() && r.solution.summary.stable && !r.summary.snapped &&
                  !snapped_before;
  if (!r.summary.converged || !r.solution.converged()) {
    c->failure = r.summary.failure != Failure::None ? r.summary.failure : Failure::NotConverged;
    c->message = "model not converged: " + r.summary.message;
  } else if (r.summary.snapped || snapped_before) {
    c->failure = Failure::Snapped;
    c->message = "snap";
  } else if (!r.solution.summary.stable) {
    c->failure = Failure::Unstable;
    c->message = "unstable";
  }
  return c;
}

}  // namespace

const char* toString(StartHistory::Kind kind) {
  switch (kind) {
    case StartHistory::Kind::Rest:
      return "rest";
    case StartHistory::Kind::Positive:
      return "positive";
    case StartHistory::Kind::Negative:
      return "negative";
    case StartHistory::Kind::Path:
      return "path";
  }
  return "?";
}

std::vector<Configuration> startCommands(const Configuration& q, const StartHistory& h) {
  std::vector<Configuration> commands;
  switch (h.kind) {
    case StartHistory::Kind::Rest:
      break;
    case StartHistory::Kind::Positive:
    case StartHistory::Kind::Negative: {
      Configuration from = q;
      from.alpha.array() -= (h.kind == StartHistory::Kind::Positive ? 1.0 : -1.0) * h.approach;
      commands.push_back(from);
      break;
    }
    case StartHistory::Kind::Path:
      commands = h.path;
      break;
  }
  commands.push_back(q);
  return commands;
}

ReplayOptions replayOptions(const Context& ctx) {
  ReplayOptions o;
  o.friction = stepOptions(ctx);
  o.branch = BranchRule::Path;
  o.coarse_rotation_step = 0.0;
  return o;
}

std::string historyFailure(std::size_t index, const ReplayRow& row) {
  if (row.result.summary.converged && row.result.state.valid && row.reached != Reached::Restart) return "";
  return "start history, command " + std::to_string(index + 1) + ": " + row.message;
}

std::shared_ptr<const StateCache> startCache(const Context& ctx, const Configuration& q, const StartHistory& h) {
  const std::vector<ReplayRow> rows = replay(ctx.robot(), startCommands(q, h), scratch().ws, replayOptions(ctx));
  for (std::size_t k = 0; k + 1 < rows.size(); ++k) {
    const std::string why = historyFailure(k, rows[k]);
    if (why.empty()) continue;
    auto c = std::make_shared<StateCache>();
    c->failure = rows[k].failure;
    c->message = why;
    return c;
  }
  return fromStep(rows.back().result, false);
}

std::shared_ptr<const StateCache> propagateCache(const Context& ctx, const StateCache& from, const Configuration& to) {
  if (!from.hysteresis.valid) {
    auto c = std::make_shared<StateCache>();
    c->failure = Failure::NotConverged;
    c->message = "no valid memory to propagate from";
    return c;
  }
  const Admissibility adm = checkAdmissible(ctx.robot(), to);
  if (!adm) {
    auto c = std::make_shared<StateCache>();
    c->hysteresis = from.hysteresis;
    c->solution.q = to;
    c->solution.summary.status = SolveStatus::Inadmissible;
    c->failure = Failure::Inadmissible;
    c->message = "inadmissible: " + adm.message;
    return c;
  }
  // Follow the motion in sub-steps of the motion-checking resolution; every intermediate equilibrium must be valid
  // (converged, stable, no snap, collision-free), so that the replay at that resolution sees only checked states.
  ThreadScratch& t = scratch();
  const FrictionOptions fo = stepOptions(ctx);
  FollowOptions motion = ctx.options().motion;
  motion.judge_stability = fo.follow.judge_stability;  // stick-slip equilibria: judged by their twist jumps
  HysteresisState h = from.hysteresis;
  StepResult r;
  std::shared_ptr<StateCache> out;
  followMove(
      from.hysteresis.lastCommand(), to, h.twist, false, motion, OnSnap::Continue,
      [&](const Configuration& qk, int, int) {
        out.reset();
        r = step(ctx.robot(), h, qk, t.ws, fo);
        if (r.summary.converged && r.solution.converged()) return SubStep{&r.solution, Failure::None, {}};
        return SubStep{nullptr, Failure::NotConverged, r.summary.message};
      },
      noRecovery,
      [&](int k, int steps, SubStep&, bool snapped) {
        out = fromStep(r, snapped);
        if (k == steps) return SubStep{};
        if (!out->physics_ok) return SubStep{nullptr, out->failure, out->message};
        const ShapeCheck sc = checkShape(ctx, r.solution, t);
        if (!sc.ok) {
          out->physics_ok = false;
          out->failure = sc.failure;
          out->message = "intermediate state: " + sc.message;
          return SubStep{nullptr, sc.failure, out->message};
        }
        h = r.state;
        return SubStep{};
      });
  return out ? out : fromStep(r, false);
}

FrictionPropagator::FrictionPropagator(oc::SpaceInformation* si, std::shared_ptr<const Context> ctx,
                                       double rotation_rate, double translation_rate)
    : oc::StatePropagator(si), ctx_(std::move(ctx)), rot_rate_(rotation_rate), trans_rate_(translation_rate) {
  space_ = si->getStateSpace()->as<CtrStateSpace>();
}

void FrictionPropagator::propagate(const ob::State* state, const oc::Control* control, double duration,
                                   ob::State* result) const {
  const int n = space_->tubes();
  const double* u = control->as<oc::RealVectorControlSpace::ControlType>()->values;
  const auto* st = state->as<CtrStateSpace::StateType>();
  std::shared_ptr<const StateCache> from = st->cache;
  if (!from) from = startCache(*ctx_, space_->configuration(state), StartHistory{});
  // Unwrapped rotations: continue from the memory's own (unwrapped) command.
  Configuration q = from->hysteresis.valid ? from->hysteresis.lastCommand() : space_->configuration(state);
  for (int i = 0; i < n; ++i) {
    q.alpha[i] += u[i] * duration;
    q.beta[i] += u[n + i] * duration;
  }
  std::shared_ptr<const StateCache> next = propagateCache(*ctx_, *from, q);
  space_->setConfiguration(result, q);
  result->as<CtrStateSpace::StateType>()->cache = std::move(next);
}

bool FrictionPropagator::steer(const ob::State* from, const ob::State* to, oc::Control* result,
                               double& duration) const {
  const int n = space_->tubes();
  const Configuration d = space_->difference(from, to);
  double T = 0.0;
  for (int i = 0; i < n; ++i) {
    T = std::max(T, std::abs(d.alpha[i]) / rot_rate_);
    T = std::max(T, std::abs(d.beta[i]) / trans_rate_);
  }
  if (!(T > 0.0)) return false;
  double* u = result->as<oc::RealVectorControlSpace::ControlType>()->values;
  for (int i = 0; i < n; ++i) {
    u[i] = d.alpha[i] / T;
    u[n + i] = d.beta[i] / T;
  }
  // Extend toward the target by at most the longest control duration (an RRT "range").
  duration = std::min(T, si_->getMaxControlDuration() * si_->getPropagationStepSize());
  return true;
}

}  // namespace ctr::planner
