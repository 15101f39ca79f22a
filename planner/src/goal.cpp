#include "ctr/planner/goal.hpp"

#include <ompl/base/SpaceInformation.h>

#include "ctr/planner/stopwatch.hpp"

#include <Eigen/Cholesky>
#include <chrono>
#include <cmath>
#include <limits>

namespace ob = ompl::base;

namespace ctr::plan {
namespace {

// Projects translations onto the admissible chain (and the sampler's box).
void projectTranslations(const Context& ctx, Configuration& q) {
  const TranslationSampler& s = ctx.translationSampler();
  const Robot& r = ctx.robot();
  for (int i = 0; i < q.size(); ++i) {
    double lo = s.lower()[i], hi = s.upper()[i];
    if (i > 0) {
      lo = std::max(lo, q.beta[i - 1] + r.tube(i - 1).length() - r.tube(i).length());
      hi = std::min(hi, q.beta[i - 1]);
    }
    q.beta[i] = std::clamp(q.beta[i], lo, std::max(lo, hi));
    const Tube& t = r.tube(i);
    if (t.rotation_limits) q.alpha[i] = std::clamp(q.alpha[i], (*t.rotation_limits)[0], (*t.rotation_limits)[1]);
  }
}

}  // namespace

double inverseKinematics(const Context& ctx, const Eigen::Vector3d& target, Configuration& q, int iterations) {
  Workspace& ws = scratch().ws;
  KinematicsOptions o;
  o.record_backbone = false;
  const Robot& r = ctx.frictionlessRobot();
  const Eigen::Vector3d tb = ctx.basePose().inverse() * target;
  const int n = q.size();
  projectTranslations(ctx, q);
  Solution cur = solve(r, q, ws, o);
  if (!cur.converged()) return std::numeric_limits<double>::infinity();
  double err = (tb - cur.tip_position).norm();
  double lambda = 1e-3;
  for (int it = 0; it < iterations && err > 1e-5; ++it) {
    Eigen::MatrixXd J(3, 2 * n);
    const double scale_b = 0.02;  // 1 unit of the scaled translation = 2 cm
    for (int j = 0; j < 2 * n; ++j) {
      Configuration qj = q;
      const double h = 1e-5;
      if (j < n) {
        qj.alpha[j] += h;
      } else {
        qj.beta[j - n] += h * scale_b;
      }
      const Solution sj = solve(r, qj, ws, o, &cur);
      if (!sj.converged()) return err;
      J.col(j) = (sj.tip_position - cur.tip_position) / h;
    }
    const Eigen::Vector3d e = tb - cur.tip_position;
    const Eigen::Matrix3d A = J * J.transpose() + lambda * Eigen::Matrix3d::Identity();
    Eigen::VectorXd dx = J.transpose() * A.ldlt().solve(e);
    const double big = dx.cwiseAbs().maxCoeff();
    if (big > 0.3) dx *= 0.3 / big;
    Configuration qn = q;
    for (int j = 0; j < n; ++j) {
      qn.alpha[j] += dx[j];
      qn.beta[j] += dx[n + j] * scale_b;
    }
    projectTranslations(ctx, qn);
    const Solution sn = solve(r, qn, ws, o, &cur);
    const double en = sn.converged() ? (tb - sn.tip_position).norm() : std::numeric_limits<double>::infinity();
    if (en < err) {
      q = qn;
      cur = sn;
      err = en;
      lambda = std::max(1e-6, lambda * 0.3);
    } else {
      lambda *= 10.0;
      if (lambda > 1e3) break;
    }
  }
  return err;
}

TipGoal::TipGoal(const ob::SpaceInformationPtr& si, std::shared_ptr<const Context> ctx, TipGoalSpec spec)
    : ob::GoalSampleableRegion(si), ctx_(std::move(ctx)), spec_(std::move(spec)) {
  space_ = si->getStateSpace()->as<CtrStateSpace>();
  setThreshold(spec_.tolerance);
}

std::pair<double, double> TipGoal::errors(const Solution& sol) const {
  const Eigen::Vector3d tip = ctx_->basePose() * sol.tip_position;
  double ang = 0.0;
  if (spec_.direction) {
    const Eigen::Vector3d t = ctx_->basePose().linear() * sol.tipTangent();
    ang = std::acos(std::clamp(t.dot(spec_.direction->normalized()), -1.0, 1.0));
  }
  return {(tip - spec_.position).norm(), ang};
}

double TipGoal::distanceGoal(const ob::State* st) const {
  Eigen::Vector3d tip, tangent;
  if (!tipOf(*ctx_, *space_, st, tip, &tangent)) return std::numeric_limits<double>::infinity();
  double d = (tip - spec_.position).norm();
  if (spec_.direction) {
    const double ang = std::acos(std::clamp(tangent.dot(spec_.direction->normalized()), -1.0, 1.0));
    d += 0.05 * std::max(0.0, ang - spec_.cone_angle);
  }
  return d;
}

void TipGoal::sampleGoal(ob::State* st) const {
  std::lock_guard<std::mutex> lock(mutex_);
  if (pool_.empty()) return;
  const Configuration& q = pool_[static_cast<std::size_t>(rng_.uniformInt(0, static_cast<int>(pool_.size()) - 1))];
  space_->setConfiguration(st, q);
}

unsigned int TipGoal::maxSampleCount() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return static_cast<unsigned int>(pool_.size());
}

std::size_t TipGoal::fillPool(std::size_t count, double seconds, std::uint64_t seed, bool cpu_clock) {
  std::mt19937_64 gen(seed);
  const Stopwatch watch(cpu_clock);
  ob::State* st = si_->allocState();
  while (true) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (pool_.size() >= count) break;
    }
    if (watch.seconds() > seconds) break;
    Configuration q = sampleConfiguration(ctx_->robot(), ctx_->translationSampler(), gen);
    const double err = inverseKinematics(*ctx_, spec_.position, q);
    if (!(err < 0.5 * spec_.tolerance)) continue;
    space_->setConfiguration(st, q);
    if (!si_->isValid(st) || distanceGoal(st) > spec_.tolerance) continue;
    std::lock_guard<std::mutex> lock(mutex_);
    pool_.push_back(space_->configuration(st));
  }
  si_->freeState(st);
  std::lock_guard<std::mutex> lock(mutex_);
  return pool_.size();
}

}  // namespace ctr::plan
