#include "ctr/planner/goal.hpp"

#include <ompl/base/SpaceInformation.h>

#include "ctr/model/ik.hpp"
#include "ctr/planner/stopwatch.hpp"
#include "ctr/planner/validity.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <iomanip>
#include <limits>
#include <sstream>

namespace ob = ompl::base;

namespace ctr::planner {

double inverseKinematics(const Context& ctx, const Eigen::Vector3d& target, Configuration& q, int iterations) {
  // The library's inverse kinematics (ctr/model/ik.hpp) with the planner's discretisation and protrusion, warm from q,
  // without restarts: the goal pool draws its own random starts.
  IkOptions o;
  o.kinematics = ctx.options().friction.kinematics;
  o.kinematics.record_backbone = false;
  o.max_iterations = iterations;
  o.restarts = 0;
  o.min_protrusion = ctx.options().min_protrusion;
  o.check_branch = false;  // the pool solves every candidate cold itself (and rejects one off the goal)
  const IkResult r =
      ctr::inverseKinematics(ctx.frictionlessRobot(), IkTarget(ctx.basePose().inverse() * target), q, scratch().ws, o);
  if (r.summary.status == IkStatus::Failed) return std::numeric_limits<double>::infinity();
  q = r.q;
  return r.summary.tip_error;
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

double TipGoal::goalDistance(const Eigen::Vector3d& tip, const Eigen::Vector3d& tangent) const {
  double d = (tip - spec_.position).norm();
  if (spec_.direction) {
    const double ang = std::acos(std::clamp(tangent.dot(spec_.direction->normalized()), -1.0, 1.0));
    d += 0.05 * std::max(0.0, ang - spec_.cone_angle);
  }
  return d;
}

double TipGoal::bandDistance(const Configuration& q, Eigen::Vector3d* center) const {
  FrictionBandOptions o;
  o.interior_samples = 0;
  o.kinematics = ctx_->options().friction.kinematics;
  o.kinematics.record_backbone = false;
  // Every shape of every robust corner's band (the ranges' corners; one without ranges and plays).
  double d = 0.0;
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
  for (const RobustCorner& corner : ctx_->robustCorners()) {
    const FrictionBand band = frictionBand(corner.tubes, corner.joints(q), scratch().ws, o);
    if (!band.converged) return std::numeric_limits<double>::infinity();
    for (const Solution& s : band.shapes) {
      const Eigen::Vector3d tip = ctx_->basePose() * s.tip_position;
      d = std::max(d, goalDistance(tip, ctx_->basePose().linear() * s.tipTangent()));
      lo = lo.cwiseMin(tip);
      hi = hi.cwiseMax(tip);
    }
  }
  if (center) *center = 0.5 * (lo + hi);
  return d;
}

double TipGoal::distanceGoal(const ob::State* st) const {
  Eigen::Vector3d tip, tangent;
  if (!tipOf(*ctx_, *space_, st, tip, &tangent)) return std::numeric_limits<double>::infinity();
  const double d = goalDistance(tip, tangent);
  // Robust mode: the goal must be reached whatever the history, i.e. by every shape of the friction band. The
  // frictionless shape is one of them, so its distance is a lower bound: the band is only computed near the goal.
  if (ctx_->options().mode != Mode::Robust || d > spec_.tolerance) return d;
  return std::max(d, bandDistance(space_->configuration(st)));
}

void TipGoal::sampleGoal(ob::State* st) const {
  // While the pool is below its target size, every other call first tries one more IK candidate (outside the lock):
  // the pool keeps growing during planning, so a planner is not stuck with goals it cannot reach.
  bool grow = false;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    grow = pool_.size() < target_ && rng_.uniform01() < 0.5;
  }
  if (grow) tryCandidate();
  std::lock_guard<std::mutex> lock(mutex_);
  if (pool_.empty()) return;
  const Configuration& q = pool_[static_cast<std::size_t>(rng_.uniformInt(0, static_cast<int>(pool_.size()) - 1))];
  space_->setConfiguration(st, q);
}

unsigned int TipGoal::maxSampleCount() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return static_cast<unsigned int>(pool_.size());
}

bool TipGoal::tryCandidate() const {
  Configuration q;  // joints (the inverse kinematics solves the tubes); the pool keeps their commands
  {
    std::lock_guard<std::mutex> lock(mutex_);
    q = sampleConfiguration(ctx_->robot(), ctx_->translationSampler(), gen_);
  }
  double err = inverseKinematics(*ctx_, spec_.position, q);
  if (!(err < 0.5 * spec_.tolerance)) return false;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    ++ik_reached_;
  }
  const bool robust = ctx_->options().mode == Mode::Robust;
  double band = 0.0;
  if (robust) {
    // Centre the friction band's tips on the target: aim the frictionless tip at the target minus the offset of the
    // band's centre from it (a few fixed-point iterations).
    Eigen::Vector3d aim = spec_.position, centre;
    band = bandDistance(ctx_->commandAt(q), &centre);
    for (int it = 0; it < 3 && band > spec_.tolerance; ++it) {
      aim += spec_.position - centre;
      err = inverseKinematics(*ctx_, aim, q);
      if (!(err < 0.5 * spec_.tolerance)) break;
      band = bandDistance(ctx_->commandAt(q), &centre);
    }
    std::lock_guard<std::mutex> lock(mutex_);
    best_band_ = std::min(best_band_, band);
    band_reached_ += band <= spec_.tolerance;
  }
  q = ctx_->commandAt(q);
  if (!q.alpha.allFinite() || !q.beta.allFinite()) return false;  // the drives cannot be inverted there
  ob::State* st = si_->allocState();
  space_->setConfiguration(st, q);
  q = space_->configuration(st);  // as the state space stores it (rotations wrapped)
  si_->freeState(st);
  bool ok = false;
  // Why a goal configuration on the target was rejected (for the one-line reason of an empty pool; under the lock).
  auto countRejected = [&](Failure f) {
    if (f == Failure::Collision)
      ++rejected_collision_;
    else if (f == Failure::Unstable)
      ++rejected_unstable_;
    else if (f == Failure::NotUnique)
      ++rejected_not_unique_;
  };
  if (robust) {
    if (band <= spec_.tolerance) {
      const ConfigurationCheck c = checkRobust(*ctx_, q, scratch());
      ok = c.ok;
      std::lock_guard<std::mutex> lock(mutex_);
      countRejected(c.failure);
    }
  } else {
    // One cold solve serves the goal test and the validity check (exact and frictionless modes check a goal
    // configuration on the frictionless shape, as ValidityChecker::isValid does for a state without history).
    const ConfigurationCheck c = checkFrictionless(*ctx_, q, scratch());
    const bool on_target =
        c.shape.converged() && goalDistance(ctx_->basePose() * c.shape.tip_position,
                                            ctx_->basePose().linear() * c.shape.tipTangent()) <= spec_.tolerance;
    ok = on_target && c.ok;
    std::lock_guard<std::mutex> lock(mutex_);
    if (!on_target) {
      ++rejected_goal_;
    } else if (!ok) {
      countRejected(c.failure);
    }
  }
  if (!ok) return false;
  std::lock_guard<std::mutex> lock(mutex_);
  if (pool_.size() >= target_) return false;
  pool_.push_back(std::move(q));
  return true;
}

std::size_t TipGoal::fillPool(std::size_t count, double seconds, std::uint64_t seed, bool cpu_clock,
                              std::size_t target) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!seeded_) gen_.seed(seed);  // later calls continue the sequence (new candidates)
    seeded_ = true;
    target_ = std::max({count, target, target_});
  }
  const Stopwatch watch(cpu_clock);
  while (maxSampleCount() < count && watch.seconds() <= seconds) tryCandidate();
  return maxSampleCount();
}

std::string TipGoal::emptyPoolReason() const {
  std::lock_guard<std::mutex> lock(mutex_);
  if (!pool_.empty()) return "";
  auto mm = [](double v) {
    std::ostringstream o;
    o << std::fixed << std::setprecision(2) << v * 1e3 << " mm";
    return o.str();
  };
  if (ik_reached_ == 0) return "no configuration found by inverse kinematics puts the tip on the target";
  const std::string n = std::to_string(ik_reached_) + " inverse-kinematics solution" + (ik_reached_ > 1 ? "s" : "");
  if (ctx_->options().mode == Mode::Robust && band_reached_ == 0)
    return "robust mode: " + n +
           " put the frictionless tip on the target, but no friction band reaches it as a "
           "whole (closest: every band tip within " +
           mm(best_band_) + ", tolerance " + mm(spec_.tolerance) + ")";
  if (ctx_->options().mode == Mode::Robust) {
    const std::size_t other =
        band_reached_ - std::min(band_reached_, rejected_collision_ + rejected_unstable_ + rejected_not_unique_);
    return "robust mode: " + std::to_string(band_reached_) + " of " + n +
           " reach the target with their whole friction band, but none is valid: in " +
           std::to_string(rejected_collision_) + " a band shape collides with the anatomy, in " +
           std::to_string(rejected_unstable_) + " one is elastically unstable, in " +
           std::to_string(rejected_not_unique_) + " the band is not certified unique, in " + std::to_string(other) +
           " one does not converge, snaps or is released";
  }
  const std::size_t in_goal = ik_reached_ - std::min(ik_reached_, rejected_goal_);
  const std::size_t other = in_goal - std::min(in_goal, rejected_collision_ + rejected_unstable_);
  std::string why = "no valid goal configuration for this design: " + n + " put the tip on the target";
  if (rejected_goal_ > 0) why += ", " + std::to_string(rejected_goal_) + " of them outside the goal's direction cone";
  why += "; of the " + std::to_string(in_goal) + " in the goal region " + std::to_string(rejected_collision_) +
         " collide with the anatomy";
  if (rejected_unstable_ > 0) why += ", " + std::to_string(rejected_unstable_) + " are elastically unstable";
  if (other > 0) why += ", " + std::to_string(other) + " are invalid otherwise (not converged)";
  return why;
}

}  // namespace ctr::planner
