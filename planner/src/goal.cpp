#include "ctr/planner/goal.hpp"

#include <ompl/base/SpaceInformation.h>

#include "ctr/model/friction.hpp"
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

namespace {

// The goal's friction bands: vertices only, with the planner's kinematics, no backbone.
FrictionBandOptions vertexBandOptions(const Context& ctx) {
  FrictionBandOptions o;
  o.interior_samples = 0;
  o.kinematics = ctx.options().friction.kinematics;
  o.kinematics.record_backbone = false;
  return o;
}

}  // namespace

double TipGoal::bandDistance(const Configuration& q, Eigen::Vector3d* center) const {
  const FrictionBandOptions o = vertexBandOptions(*ctx_);
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

long TipGoal::approachEntry(const Configuration& q) const {
  for (std::size_t k = 0; k < pool_.size(); ++k)
    if (approach_[k].size() > 0 && pool_[k].alpha == q.alpha && pool_[k].beta == q.beta) return static_cast<long>(k);
  return -1;
}

Configuration TipGoal::stored(const Configuration& q) const {
  ob::State* st = si_->allocState();
  space_->setConfiguration(st, q);
  const Configuration out = space_->configuration(st);
  si_->freeState(st);
  return out;
}

std::optional<Configuration> TipGoal::approachMove(const ob::State* st) const {
  if (ctx_->options().mode != Mode::Robust) return std::nullopt;
  const Configuration q = space_->configuration(st);
  std::lock_guard<std::mutex> lock(mutex_);
  const long k = approachEntry(q);
  if (k < 0) return std::nullopt;
  return approach_[static_cast<std::size_t>(k)];
}

double TipGoal::approachDistance(const Configuration& q, const Configuration& move, bool vertices,
                                 Eigen::Vector3d* centre) const {
  constexpr double kInf = std::numeric_limits<double>::infinity();
  FrictionOptions fo = ctx_->options().friction;
  fo.kinematics.record_backbone = false;
  const FrictionBandOptions bo = vertexBandOptions(*ctx_);
  const Configuration to(q.alpha + move.alpha, q.beta + move.beta);
  // The corners carry friction at the upper end of its range; the end of an approach also depends on the lower end.
  double lower = -1.0;
  for (const RangeDimension& d : ctx_->options().ranges)
    if (d.kind == RangeDimension::Kind::BoundaryFriction && d.lo < d.hi) lower = d.lo;
  ThreadScratch& t = scratch();
  double dist = 0.0;
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(kInf), hi = -lo;
  for (const RobustCorner& corner : ctx_->robustCorners()) {
    std::vector<Robot> robots{corner.tubes};
    if (lower >= 0.0) robots.push_back(corner.tubes.withFriction({lower, corner.tubes.friction().distributed}));
    const Configuration a = corner.joints(q), b = corner.joints(to);
    for (const Robot& robot : robots) {
      std::vector<HysteresisState> starts;
      if (vertices) {
        const FrictionBand band = frictionBand(robot, a, t.ws, bo);
        if (!band.converged) return kInf;
        for (const Solution& shape : band.shapes) starts.push_back(stuckStateAt(robot, shape));
      } else {
        const StepResult rest = initialState(robot, a, t.ws, fo);
        if (!rest.summary.converged) return kInf;
        starts.push_back(rest.state);
      }
      for (const HysteresisState& from : starts) {
        const StepResult r = step(robot, from, b, t.ws, fo);
        if (!r.summary.converged || r.summary.snapped) return kInf;
        const Eigen::Vector3d tip = ctx_->basePose() * r.solution.tip_position;
        dist = std::max(dist, goalDistance(tip, ctx_->basePose().linear() * r.solution.tipTangent()));
        lo = lo.cwiseMin(tip);
        hi = hi.cwiseMax(tip);
      }
    }
  }
  if (centre) *centre = 0.5 * (lo + hi);
  return dist;
}

bool TipGoal::tryApproach(const Configuration& q0, Configuration& start, Configuration& move, double& distance) const {
  const int n = q0.size();
  if (n < 2 || ctx_->robustCorners().empty()) return false;
  // How far a contact can stick: the widest range of relative twist at a contact site over the band at the goal.
  const RobustCorner& corner = ctx_->robustCorners().front();
  const FrictionBandOptions bo = vertexBandOptions(*ctx_);
  const Configuration goal0 = ctx_->commandAt(q0);
  if (!goal0.alpha.allFinite() || !goal0.beta.allFinite()) return false;
  const FrictionBand band = frictionBand(corner.tubes, corner.joints(goal0), scratch().ws, bo);
  if (!band.converged) return false;
  double width = 0.0;
  for (std::size_t c = 0; c < band.sites.size(); ++c) {
    double lo = std::numeric_limits<double>::infinity(), hi = -lo;
    for (const Solution& s : band.shapes) {
      if (c >= s.contacts.size()) return false;
      lo = std::min(lo, s.contacts[c].relative_twist);
      hi = std::max(hi, s.contacts[c].relative_twist);
    }
    width = std::max(width, hi - lo);
  }
  double sense = 1.0;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    sense = (gen_() & 1u) ? 1.0 : -1.0;
  }
  // Moves of growing length in one sense, then in the other: a longer move slips more contacts (a narrower band at
  // its end) but sweeps the robot further; the first that holds the target and is valid is kept.
  bool tried = false, held = false, valid = false;
  Failure rejected = Failure::None;
  double best = std::numeric_limits<double>::infinity();
  for (int attempt = 0; attempt < 6; ++attempt) {
    const double s = attempt < 3 ? sense : -sense;
    const double relative = std::clamp((2.0 / (1 << (attempt % 3))) * width + 0.05, 0.1, 1.5);
    // Neighbours turned against each other by `relative` (rad); the whole turned so that the mean of the rotations
    // weighted by each tube's bending stiffness times precurvature stays (the robot turns as a whole as little as it
    // can).
    move = Configuration(Eigen::VectorXd::Zero(n), Eigen::VectorXd::Zero(n));
    double weight = 0.0, mean = 0.0;
    for (int i = 0; i < n; ++i) {
      move.alpha[i] = s * relative * (0.5 * (n - 1) - i);
      const double w = corner.tubes.tube(i).bending_stiffness * std::abs(corner.tubes.tube(i).curvature);
      weight += w;
      mean += w * move.alpha[i];
    }
    if (weight > 0.0) move.alpha.array() -= mean / weight;
    // Aim the frictionless tip so that where the approach ends (estimated from the frictionless start) is on the
    // target.
    Configuration q = q0;
    Eigen::Vector3d aim = spec_.position, centre;
    bool aimed = true;
    for (int it = 0;; ++it) {
      const Configuration goal = ctx_->commandAt(q);
      aimed = goal.alpha.allFinite() && goal.beta.allFinite();
      if (!aimed) break;
      start = Configuration(goal.alpha - move.alpha, goal.beta - move.beta);
      const double d = approachDistance(start, move, false, &centre);
      aimed = std::isfinite(d);
      if (!aimed || d <= 0.25 * spec_.tolerance || it == 3) break;
      aim += spec_.position - centre;
      aimed = inverseKinematics(*ctx_, aim, q) < 0.5 * spec_.tolerance;
      if (!aimed) break;
    }
    if (!aimed) continue;
    // Every history: every shape of the band at the start.
    tried = true;
    distance = approachDistance(start, move, true);
    best = std::min(best, distance);
    if (!(distance <= spec_.tolerance)) continue;
    held = true;
    start = stored(start);
    // Valid: the band at the start, and the approach itself (every band branch followed along it, as the motion
    // validity of a path's last motion).
    ConfigurationCheck c = checkRobust(*ctx_, start, scratch());
    if (c.ok) {
      const Configuration to(start.alpha + move.alpha, start.beta + move.beta);
      c.ok = checkMotionForward(*ctx_, start, to, scratch(), nullptr, &c.failure) >= 1.0;
    }
    valid = c.ok;
    if (valid) break;
    rejected = c.failure;
  }
  std::lock_guard<std::mutex> lock(mutex_);
  approach_tried_ += tried;
  best_approach_ = std::min(best_approach_, best);
  band_reached_ += held;
  if (held && !valid) countRejected(rejected);
  return valid;
}

double TipGoal::distanceGoal(const ob::State* st) const {
  // An approach goal's start: the goal holds after its final approach (every history's end is within the distance
  // found when it was accepted).
  if (ctx_->options().mode == Mode::Robust) {
    const Configuration q = space_->configuration(st);
    std::lock_guard<std::mutex> lock(mutex_);
    const long k = approachEntry(q);
    if (k >= 0) return approach_distance_[static_cast<std::size_t>(k)];
  }
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
  const Configuration on_target = q;  // the frictionless tip on the target
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
  // Robust mode, no band on the target: a final approach move may still bring every history's end onto it.
  Configuration move;  // the approach goal's move (size 0: none)
  double approach_distance = 0.0;
  if (robust && band > spec_.tolerance) {
    if (!spec_.final_approach) return false;
    // An approach costs a stick-slip move from every band shape: only while no band holds the target directly.
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (std::count_if(approach_.begin(), approach_.end(), [](const Configuration& m) { return m.size() == 0; }) > 0)
        return false;
    }
    Configuration start;
    if (!tryApproach(on_target, start, move, approach_distance)) return false;
    q = start;  // wrapped as the state space stores it, and valid
  } else {
    q = ctx_->commandAt(q);
  }
  if (!q.alpha.allFinite() || !q.beta.allFinite()) return false;  // the drives cannot be inverted there
  q = stored(q);
  bool ok = false;
  if (move.size() > 0) {
    ok = true;  // tryApproach checked it
  } else if (robust) {
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
  approach_.push_back(std::move(move));
  approach_distance_.push_back(approach_distance);
  return true;
}

void TipGoal::countRejected(Failure f) const {
  if (f == Failure::Collision)
    ++rejected_collision_;
  else if (f == Failure::Unstable)
    ++rejected_unstable_;
  else if (f == Failure::NotUnique)
    ++rejected_not_unique_;
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
  if (ctx_->options().mode == Mode::Robust && band_reached_ == 0) {
    std::string approach;
    if (spec_.final_approach)
      approach = ", nor does one after a final approach move (" +
                 (approach_tried_ == 0
                      ? std::string("none could be aimed at it: a stick-slip step did not converge or snapped")
                      : std::to_string(approach_tried_) + " tried, closest: every end within " + mm(best_approach_)) +
                 ")";
    return "robust mode: " + n +
           " put the frictionless tip on the target, but no friction band reaches it as a whole (closest: every band "
           "tip within " +
           mm(best_band_) + ", tolerance " + mm(spec_.tolerance) + ")" + approach;
  }
  if (ctx_->options().mode == Mode::Robust) {
    const std::size_t other =
        band_reached_ - std::min(band_reached_, rejected_collision_ + rejected_unstable_ + rejected_not_unique_);
    return "robust mode: " + std::to_string(band_reached_) + " of " + n +
           " reach the target with their whole friction band (directly or after a final approach move), but none is "
           "valid: in " +
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
