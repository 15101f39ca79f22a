#include "ctr/planner/state_space.hpp"

#include <ompl/base/spaces/RealVectorStateSpace.h>
#include <ompl/base/spaces/SO2StateSpace.h>
#include <ompl/util/RandomNumbers.h>

#include <algorithm>
#include <cmath>

namespace ob = ompl::base;

namespace ctr::planner {

CtrStateSpace::CtrStateSpace(const Robot& robot, const TranslationSampler& sampler, double translation_weight)
    : robot_(robot), sampler_(sampler), n_(robot.size()) {
  setName("CtrStateSpace");
  for (int i = 0; i < n_; ++i) {
    const Tube& t = robot.tube(i);
    if (t.rotation_limits) {
      auto r = std::make_shared<ob::RealVectorStateSpace>(1);
      r->setBounds((*t.rotation_limits)[0], (*t.rotation_limits)[1]);
      addSubspace(r, 1.0);
      so2_.push_back(false);
    } else {
      addSubspace(std::make_shared<ob::SO2StateSpace>(), 1.0);
      so2_.push_back(true);
    }
  }
  auto tr = std::make_shared<ob::RealVectorStateSpace>(n_);
  ob::RealVectorBounds b(n_);
  for (int i = 0; i < n_; ++i) {
    b.setLow(i, sampler.lower()[i]);
    b.setHigh(i, std::max(sampler.upper()[i], sampler.lower()[i] + 1e-9));
  }
  tr->setBounds(b);
  addSubspace(tr, translation_weight);
  lock();
}

Configuration CtrStateSpace::configuration(const ob::State* s) const {
  const auto* cs = s->as<ob::CompoundState>();
  Configuration q(Eigen::VectorXd::Zero(n_), Eigen::VectorXd::Zero(n_));
  for (int i = 0; i < n_; ++i) {
    q.alpha[i] = so2_[static_cast<std::size_t>(i)] ? cs->as<ob::SO2StateSpace::StateType>(i)->value
                                                   : cs->as<ob::RealVectorStateSpace::StateType>(i)->values[0];
  }
  const auto* tr = cs->as<ob::RealVectorStateSpace::StateType>(n_);
  for (int i = 0; i < n_; ++i) q.beta[i] = tr->values[i];
  return q;
}

void CtrStateSpace::setConfiguration(ob::State* s, const Configuration& q) const {
  auto* cs = s->as<StateType>();
  for (int i = 0; i < n_; ++i) {
    if (so2_[static_cast<std::size_t>(i)]) {
      cs->as<ob::SO2StateSpace::StateType>(i)->value = std::remainder(q.alpha[i], 2.0 * M_PI);
    } else {
      cs->as<ob::RealVectorStateSpace::StateType>(i)->values[0] = q.alpha[i];
    }
  }
  auto* tr = cs->as<ob::RealVectorStateSpace::StateType>(n_);
  for (int i = 0; i < n_; ++i) tr->values[i] = q.beta[i];
  cs->cache.reset();
}

Configuration CtrStateSpace::difference(const ob::State* from, const ob::State* to) const {
  const Configuration a = configuration(from), b = configuration(to);
  Configuration d(b.alpha - a.alpha, b.beta - a.beta);
  for (int i = 0; i < n_; ++i)
    if (so2_[static_cast<std::size_t>(i)]) d.alpha[i] = std::remainder(d.alpha[i], 2.0 * M_PI);
  return d;
}

ob::State* CtrStateSpace::allocState() const {
  auto* s = new StateType();
  allocStateComponents(s);
  return s;
}

void CtrStateSpace::freeState(ob::State* state) const {
  auto* s = static_cast<StateType*>(state);
  for (unsigned int i = 0; i < componentCount_; ++i) components_[i]->freeState(s->components[i]);
  delete[] s->components;
  s->components = nullptr;
  delete s;
}

void CtrStateSpace::copyState(ob::State* destination, const ob::State* source) const {
  CompoundStateSpace::copyState(destination, source);
  destination->as<StateType>()->cache = source->as<StateType>()->cache;
}

void CtrStateSpace::interpolate(const ob::State* from, const ob::State* to, double t, ob::State* state) const {
  CompoundStateSpace::interpolate(from, to, t, state);
  state->as<StateType>()->cache.reset();
}

ob::StateSamplerPtr CtrStateSpace::allocDefaultStateSampler() const {
  return std::make_shared<CtrStateSampler>(this);
}

CtrStateSampler::CtrStateSampler(const CtrStateSpace* space)
    : ob::StateSampler(space), ctr_(space), gen_(static_cast<std::uint64_t>(rng_.uniformInt(0, 1 << 30))) {}

void CtrStateSampler::sampleUniform(ob::State* state) {
  ctr_->setConfiguration(state, sampleConfiguration(ctr_->robot(), ctr_->translationSampler(), gen_));
}

void CtrStateSampler::nearImpl(ob::State* state, const ob::State* near, double distance, bool gaussian) {
  const Configuration c = ctr_->configuration(near);
  const Robot& r = ctr_->robot();
  const TranslationSampler& ts = ctr_->translationSampler();
  for (int attempt = 0; attempt < 20; ++attempt) {
    Configuration q = c;
    for (int i = 0; i < q.size(); ++i) {
      q.alpha[i] += gaussian ? rng_.gaussian(0.0, distance) : rng_.uniformReal(-distance, distance);
      const double d = distance / 50.0;  // translation weight 50: 1 rad ~ 2 cm
      q.beta[i] += gaussian ? rng_.gaussian(0.0, d) : rng_.uniformReal(-d, d);
      q.beta[i] = std::clamp(q.beta[i], ts.lower()[i], ts.upper()[i]);
      const Tube& t = r.tube(i);
      if (t.rotation_limits) q.alpha[i] = std::clamp(q.alpha[i], (*t.rotation_limits)[0], (*t.rotation_limits)[1]);
    }
    if (checkAdmissible(r, q)) {
      ctr_->setConfiguration(state, q);
      return;
    }
  }
  ctr_->setConfiguration(state, c);
}

void CtrStateSampler::sampleUniformNear(ob::State* state, const ob::State* near, double distance) {
  nearImpl(state, near, distance, false);
}

void CtrStateSampler::sampleGaussian(ob::State* state, const ob::State* mean, double stdDev) {
  nearImpl(state, mean, stdDev, true);
}

TipProjection::TipProjection(const CtrStateSpace* space, std::shared_ptr<const Context> ctx, double cell_size)
    : ob::ProjectionEvaluator(space), ctr_(space), ctx_(std::move(ctx)), cell_(cell_size) {}

void TipProjection::defaultCellSizes() {
  cellSizes_.assign(3, cell_);
}

void TipProjection::project(const ob::State* state, Eigen::Ref<Eigen::VectorXd> projection) const {
  Eigen::Vector3d tip;
  if (!tipOf(*ctx_, *ctr_, state, tip)) tip = ctx_->basePose().translation();
  projection = tip;
}

bool tipOf(const Context& ctx, const CtrStateSpace& space, const ob::State* s, Eigen::Vector3d& tip,
           Eigen::Vector3d* tangent) {
  const auto* st = s->as<CtrStateSpace::StateType>();
  if (st->cache && st->cache->solution.converged()) {
    tip = ctx.basePose() * st->cache->solution.tip_position;
    if (tangent) *tangent = ctx.basePose().linear() * st->cache->solution.tipTangent();
    return true;
  }
  KinematicsOptions o = ctx.options().friction.kinematics;
  o.record_backbone = false;
  const Solution sol = solve(ctx.modelRobot(), ctx.jointsAt(space.configuration(s)), scratch().ws, o);
  if (!sol.converged()) return false;
  tip = ctx.basePose() * sol.tip_position;
  if (tangent) *tangent = ctx.basePose().linear() * sol.tipTangent();
  return true;
}

}  // namespace ctr::planner
