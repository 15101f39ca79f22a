#include "ctr/planner/propagator.hpp"

#include <ompl/control/spaces/RealVectorControlSpace.h>

#include <cmath>

namespace ob = ompl::base;
namespace oc = ompl::control;

namespace ctr::plan {
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
    c->why = "model not converged: " + r.summary.message;
  } else if (r.summary.snapped) {
    c->why = "snap";
  } else if (!r.solution.summary.stable) {
    c->why = "unstable";
  }
  return c;
}

}  // namespace

std::shared_ptr<const StateCache> startCache(const Context& ctx, const Configuration& q, const StartHistory& h) {
  Workspace& ws = scratch().ws;
  const FrictionOptions fo = stepOptions(ctx);
  const Robot& r = ctx.robot();
  std::vector<Configuration> path;
  switch (h.kind) {
    case StartHistory::Kind::Rest: break;
    case StartHistory::Kind::Positive:
    case StartHistory::Kind::Negative: {
      Configuration from = q;
      from.alpha.array() -= (h.kind == StartHistory::Kind::Positive ? 1.0 : -1.0) * h.approach;
      path.push_back(from);
      break;
    }
    case StartHistory::Kind::Path: path = h.path; break;
  }
  StepResult cur = initialState(r, path.empty() ? q : path.front(), ws, fo);
  for (std::size_t k = 1; k < path.size() && cur.state.valid; ++k) cur = step(r, cur.state, path[k], ws, fo);
  if (!path.empty() && cur.state.valid) cur = step(r, cur.state, q, ws, fo);
  return fromStep(cur, false);
}

std::shared_ptr<const StateCache> propagateCache(const Context& ctx, const StateCache& from, const Configuration& to) {
  if (!from.hysteresis.valid) {
    auto c = std::make_shared<StateCache>();
    c->why = "no valid memory to propagate from";
    return c;
  }
  const Admissibility adm = checkAdmissible(ctx.robot(), to);
  if (!adm) {
    auto c = std::make_shared<StateCache>();
    c->hysteresis = from.hysteresis;
    c->solution.q = to;
    c->solution.summary.status = SolveStatus::Inadmissible;
    c->why = "inadmissible: " + adm.message;
    return c;
  }
  // Walk forward in sub-steps of the motion-checking resolution; every intermediate equilibrium must be valid
  // (converged, stable, no snap, collision-free), so that the replay at that resolution sees only checked states.
  ThreadScratch& t = scratch();
  const Configuration& q0 = from.hysteresis.q;
  const double da = (to.alpha - q0.alpha).cwiseAbs().maxCoeff(), db = (to.beta - q0.beta).cwiseAbs().maxCoeff();
  const int sub = std::max(1, static_cast<int>(std::ceil(std::max(da / ctx.options().rotation_resolution,
                                                                  db / ctx.options().translation_resolution) -
                                                         1e-9)));
  FrictionOptions fo = stepOptions(ctx);
  HysteresisState h = from.hysteresis;
  for (int k = 1; k <= sub; ++k) {
    const double s = static_cast<double>(k) / sub;
    const Configuration qk = k == sub ? to
                                      : Configuration(q0.alpha + s * (to.alpha - q0.alpha),
                                                      q0.beta + s * (to.beta - q0.beta));
    const StepResult r = step(ctx.robot(), h, qk, t.ws, fo);
    if (k == sub) return fromStep(r, false);
    auto c = fromStep(r, false);
    if (!c->physics_ok) return c;
    const ShapeCheck sc = checkShape(ctx, r.solution, t);
    if (!sc.ok) {
      auto bad = std::make_shared<StateCache>(*c);
      bad->physics_ok = false;
      bad->why = "intermediate state: " + sc.reason;
      return bad;
    }
    h = r.state;
  }
  return nullptr;  // not reached
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
  Configuration q = from->hysteresis.valid ? from->hysteresis.q : space_->configuration(state);
  for (int i = 0; i < n; ++i) {
    q.alpha[i] += u[i] * duration;
    q.beta[i] += u[n + i] * duration;
  }
  std::shared_ptr<const StateCache> next = propagateCache(*ctx_, *from, q);
  space_->setConfiguration(result, q);
  result->as<CtrStateSpace::StateType>()->cache = std::move(next);
}

bool FrictionPropagator::steer(const ob::State* from, const ob::State* to, oc::Control* result, double& duration) const {
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

}  // namespace ctr::plan
