#include "ctr/planner/validity.hpp"

#include <ompl/base/SpaceInformation.h>

#include <algorithm>
#include <cmath>
#include <sstream>

#include "ctr/model/uniqueness.hpp"

namespace ob = ompl::base;

namespace ctr::planner {
namespace {

// Shapes for collision checking: the backbone geometry only (no per-tube theta / u_z at the nodes), integrated as
// every solve of the planner.
KinematicsOptions shapeOptions(const Context& ctx) {
  KinematicsOptions k = ctx.options().friction.kinematics;
  k.record_backbone = true;
  k.record_tube_states = false;
  return k;
}

// The previous band's shape with the same torques at the same sites as shape i of `cur` (FrictionBand::sites and
// torque_fractions; sites are matched by identity: their order along the backbone changes when ends cross or
// separate). -1 if the previous band has other sites.
long alignedShape(const FrictionBand& prev, const FrictionBand& cur, std::size_t i) {
  return bandShapeWith(prev, cur.sites, cur.torque_fractions[i]);
}

// Where a contact site of the previous band vanishes (an end retracting into the actuation unit, a discontinuity
// passing an end), the torque it held is released at once: the robot jumps from wherever its history put it in the
// previous band to this band. That is robust only if every shape of the previous band is within the snap threshold
// of a shape here with the same torque signs at the sites both bands share (a site that appears starts stuck, inside
// its bounds, so it does not move the robot: any sign of it will do).
// No previous band (a motion's first configuration): nothing is released.
bool releaseIsSmooth(const FrictionBand* previous, const FrictionBand& cur, double threshold) {
  if (!previous || previous->shapes.size() < 2 || cur.shapes.empty()) return true;
  const FrictionBand& prev = *previous;
  std::vector<long> to_cur(prev.sites.size(), -1);  // index in cur.sites of each previous site, -1 if it vanished
  bool vanished = false;
  for (std::size_t j = 0; j < prev.sites.size(); ++j) {
    const auto it = std::find(cur.sites.begin(), cur.sites.end(), prev.sites[j]);
    if (it == cur.sites.end()) {
      vanished = true;
    } else {
      to_cur[j] = static_cast<long>(it - cur.sites.begin());
    }
  }
  if (!vanished) return true;
  // The vertices of each band (shape 0 when the band has no others).
  const std::size_t first_cur = cur.shapes.size() == 1 ? 0 : 1;
  for (std::size_t pc = 1; pc < prev.shapes.size(); ++pc) {
    bool landed = false;
    for (std::size_t cc = first_cur; cc < cur.shapes.size() && !landed; ++cc) {
      bool same_signs = true;
      for (std::size_t j = 0; j < prev.sites.size() && same_signs; ++j)
        if (to_cur[j] >= 0)
          same_signs = prev.torque_fractions[pc][j] == cur.torque_fractions[cc][static_cast<std::size_t>(to_cur[j])];
      if (same_signs) landed = branchChange(prev.shapes[pc], cur.shapes[cc], threshold, false) != BranchChange::Jumped;
    }
    if (!landed) return false;
  }
  return true;
}

// The friction band of one robust corner at command q (ctr::frictionBand at the corner's joints, vertices only),
// followed from the band at the previous configuration of a motion: every shape converged, stable and collision-free,
// no shape leaving the branch of its counterpart in `prev` (the branch rule of followMove). Returns why not
// (Failure::None when the band is valid); `message` gets it in words.
Failure bandAt(const Context& ctx, const RobustCorner& corner, const Configuration& q, ThreadScratch& t,
               const FrictionBand* prev, FrictionBand& out, std::string& message) {
  const double thr = ctx.options().motion.snap_threshold;
  FrictionBandOptions o;
  o.interior_samples = 0;
  o.kinematics = shapeOptions(ctx);
  o.kinematics.record_tube_states = true;  // the tubes' angles, for the uniqueness certificate
  o.follow = prev && !prev->shapes.empty() ? prev : nullptr;
  Failure failure = Failure::None;
  o.check = [&](const FrictionBand& b) -> std::string {
    const std::size_t i = b.shapes.size() - 1;
    const Solution& s = b.shapes[i];
    // Followed from the same shape of the previous step; when a site appears or disappears the band changes
    // discontinuously (a new contact enters with its full bound): no branch to follow.
    const long pv = o.follow ? (i == 0 ? 0 : alignedShape(*o.follow, b, i)) : -1;
    if (pv >= 0 && branchChange(o.follow->shapes[static_cast<std::size_t>(pv)], s, thr) != BranchChange::None) {
      failure = Failure::Snapped;
      return i == 0 ? "frictionless branch snaps" : "a friction band branch snaps";
    }
    const ShapeCheck c = checkShape(ctx, s, t);
    failure = c.failure;
    if (!c.ok) return (i == 0 ? "frictionless shape: " : "friction band shape: ") + c.message;
    return "";
  };
  out = frictionBand(corner.tubes, corner.joints(q), t.ws, o);
  if (!out.converged) {
    if (out.shapes.empty() && o.follow) {
      message = "frictionless branch snaps";
      return Failure::Snapped;
    }
    if (out.shapes.empty()) {
      message = "frictionless shape: not converged";
      return Failure::NotConverged;
    }
    message = out.message;
    return failure != Failure::None ? failure : Failure::NotConverged;
  }
  if (!releaseIsSmooth(prev, out, thr)) {
    message = "a contact site vanishes and releases its friction torque (the band jumps)";
    return Failure::Released;
  }
  // The band holds every history only if no history can reach another equilibrium at the same contact torques: the
  // energy must be convex around the band (docs/planning.md, "What robust mode guarantees").
  if (!uniquenessCertificate(corner.tubes, out).certified()) {
    message =
        "the band is not certified unique: around it the tubes' bending interaction exceeds their torsional "
        "stiffness, so a history could reach another equilibrium with the same contact torques";
    return Failure::NotUnique;
  }
  return Failure::None;
}

// A command the stages cannot take (a robot with drives: the solve sees only the joints, which the drives project).
bool commandAdmissible(const Context& ctx, const Configuration& q, ConfigurationCheck& r) {
  const Admissibility adm = checkAdmissible(ctx.robot(), q);
  if (adm) return true;
  r.failure = Failure::Inadmissible;
  r.message = "inadmissible: " + adm.message;
  return false;
}

}  // namespace

ConfigurationCheck checkFrictionless(const Context& ctx, const Configuration& q, ThreadScratch& t,
                                     const Solution* warm) {
  ConfigurationCheck r;
  if (ctx.hasDrives() && !commandAdmissible(ctx, q, r)) return r;
  r.shape = solve(ctx.frictionlessRobot(), ctx.jointsAt(q), t.ws, shapeOptions(ctx), warm);
  const ShapeCheck c = checkShape(ctx, r.shape, t);
  r.ok = c.ok;
  r.failure = c.failure;
  r.message = c.message;
  return r;
}

ConfigurationCheck checkRobust(const Context& ctx, const Configuration& q, ThreadScratch& t) {
  ConfigurationCheck r;
  if (ctx.hasDrives() && !commandAdmissible(ctx, q, r)) return r;
  // Every corner's band (one without ranges and plays); the first corner's frictionless shape is the one returned.
  const std::vector<RobustCorner>& corners = ctx.robustCorners();
  for (std::size_t k = 0; k < corners.size(); ++k) {
    FrictionBand b;
    r.failure = bandAt(ctx, corners[k], q, t, nullptr, b, r.message);
    if (k == 0 && !b.shapes.empty()) r.shape = std::move(b.shapes[0]);
    if (r.failure != Failure::None) {
      if (corners.size() > 1) r.message = "corner " + std::to_string(k + 1) + " of the ranges: " + r.message;
      break;
    }
  }
  r.ok = r.failure == Failure::None;
  return r;
}

std::string robustStartOutsideBand(const Context& ctx, const Configuration& q, const Solution& replayed,
                                   ThreadScratch& t) {
  Eigen::VectorXd lo, hi;
  for (const RobustCorner& corner : ctx.robustCorners()) {
    FrictionBand b;
    std::string why;
    if (bandAt(ctx, corner, q, t, nullptr, b, why) != Failure::None) return "";  // checkRobust says why
    lo = lo.size() ? Eigen::VectorXd(lo.cwiseMin(b.twist_min)) : b.twist_min;
    hi = hi.size() ? Eigen::VectorXd(hi.cwiseMax(b.twist_max)) : b.twist_max;
  }
  if (lo.size() != replayed.twist.size()) return "";
  const double thr = ctx.options().motion.snap_threshold;
  double out = 0.0;
  for (Eigen::Index i = 0; i < lo.size(); ++i)
    out = std::max({out, lo[i] - replayed.twist[i], replayed.twist[i] - hi[i]});
  if (out <= thr) return "";
  std::ostringstream m;
  m.precision(2);
  m << std::fixed << "the start history leaves the robot on another equilibrium than the friction band of the start "
    << "configuration (a tip twist " << out << " rad beyond the band's extremes, snap threshold " << thr
    << " rad): robust mode plans from that band; exact mode follows the history";
  return m.str();
}

namespace {

// The same equilibrium, solved along a motion and cold: equal within the solver's tolerance (different equilibria of
// one configuration differ by far more: in the lung examples by 0.1-5 rad of twist and 2-70 mm at the tip).
bool sameEquilibrium(const Solution& a, const Solution& b) {
  return a.twist.size() == b.twist.size() && (a.twist - b.twist).cwiseAbs().maxCoeff() <= 1e-4 &&
         (a.tip_position - b.tip_position).norm() <= 1e-5;
}

bool sameBand(const FrictionBand& a, const FrictionBand& b) {
  if (a.shapes.size() != b.shapes.size() || !(a.sites == b.sites)) return false;
  for (std::size_t i = 0; i < a.shapes.size(); ++i)
    if (!sameEquilibrium(a.shapes[i], b.shapes[i])) return false;
  return true;
}

}  // namespace

// A geometric state (robust and frictionless modes) carries no history: it stands for the equilibrium (the band) that
// a cold solve of its configuration gives, and that is what the goal test and the validity checker see. A motion is
// followed from its start's own equilibrium; where several stable equilibria coexist, it can arrive on another one
// than the end configuration's own (the lung examples: 2-70 mm apart at the tip), and the next motion, the goal test
// and the collision checks would then be about a shape the robot is not in. So a motion is valid only as far as it
// ends on the own equilibrium of the configuration it reaches; otherwise nothing of it is valid.
double checkMotionForward(const Context& ctx, const Configuration& q0, const Configuration& q1, ThreadScratch& t,
                          std::string* message, Failure* failure) {
  const FollowOptions& fo = ctx.options().motion;
  std::string why;
  auto result = [&](const FollowSummary& f, bool own) {
    Failure kind = f.failure;
    if (kind == Failure::None && !own) {
      kind = Failure::OffBranch;
      why = "the motion arrives on another equilibrium than the configuration's own (several are stable there)";
    }
    if (kind != Failure::None && message) *message = why;
    if (failure) *failure = kind;
    if (!own) return 0.0;
    return f.completedMove() ? 1.0 : static_cast<double>(f.completed) / f.steps;
  };
  FollowSummary f;
  f.steps = subdivisions(q0, q1, fo.max_rotation_step, fo.max_translation_step);
  if (ctx.options().mode == Mode::Robust) {
    // Every corner's band followed along the motion; the motion is valid as far as the least of them.
    const std::vector<RobustCorner>& corners = ctx.robustCorners();
    double fraction = 1.0;
    for (std::size_t k = 0; k < corners.size() && fraction > 0.0; ++k) {
      const RobustCorner& corner = corners[k];
      std::string corner_why;
      Failure corner_failure = Failure::None;
      FollowSummary fk;
      fk.steps = f.steps;
      FrictionBand cur, next;
      const double done = [&]() -> double {
        fk.failure = bandAt(ctx, corner, q0, t, nullptr, cur, corner_why);
        if (fk.failure != Failure::None) return 0.0;
        fk = followMove(
            q0, q1, cur.shapes[0].twist, cur.shapes[0].converged() && cur.shapes[0].summary.stable, fo, OnSnap::Stop,
            [&](const Configuration& qk, int, int) {
              const Failure b = bandAt(ctx, corner, qk, t, &cur, next, corner_why);
              return b == Failure::None ? SubStep{&next.shapes[0], b, {}} : SubStep{nullptr, b, corner_why};
            },
            noRecovery,
            [&](int, int, SubStep&, bool) {
              std::swap(cur, next);
              return SubStep{};
            });
        if (fk.failure != Failure::None) corner_why = fk.message;
        if (fk.completed == 0) return 0.0;  // cur is the cold band at q0
        FrictionBand own;
        std::string w;
        const Configuration last = interpolate(q0, q1, static_cast<double>(fk.completed) / fk.steps);
        if (!(bandAt(ctx, corner, last, t, nullptr, own, w) == Failure::None && sameBand(cur, own))) {
          if (fk.failure == Failure::None) {
            corner_failure = Failure::OffBranch;
            corner_why =
                "the motion arrives on another equilibrium than the configuration's own (several are "
                "stable there)";
          }
          return 0.0;
        }
        return fk.completedMove() ? 1.0 : static_cast<double>(fk.completed) / fk.steps;
      }();
      if (corner_failure == Failure::None) corner_failure = fk.failure;
      if (done < fraction || (corner_failure != Failure::None && f.failure == Failure::None)) {
        fraction = std::min(fraction, done);
        f.failure = corner_failure;
        why = corners.size() > 1 && corner_failure != Failure::None
                  ? "corner " + std::to_string(k + 1) + " of the ranges: " + corner_why
                  : corner_why;
      }
    }
    if (f.failure != Failure::None && message) *message = why;
    if (failure) *failure = f.failure;
    return fraction;
  }
  ConfigurationCheck c = checkFrictionless(ctx, q0, t);
  if (!c.ok) {
    why = c.message;
    f.failure = c.failure;
    return result(f, true);
  }
  Solution cur = std::move(c.shape), next;
  f = followMove(
      q0, q1, cur.twist, cur.converged() && cur.summary.stable, fo, OnSnap::Stop,
      [&](const Configuration& qk, int, int) {
        next = solve(ctx.frictionlessRobot(), ctx.jointsAt(qk), t.ws, shapeOptions(ctx), &cur);
        return SubStep{&next, Failure::None, {}};
      },
      noRecovery,
      [&](int, int, SubStep&, bool) {
        const ShapeCheck sc = checkShape(ctx, next, t);
        if (!sc.ok) return SubStep{nullptr, sc.failure, sc.message};
        cur = std::move(next);
        return SubStep{};
      });
  why = f.message;
  if (f.completed == 0) return result(f, true);
  const Configuration last = interpolate(q0, q1, static_cast<double>(f.completed) / f.steps);
  const Solution own = solve(ctx.frictionlessRobot(), ctx.jointsAt(last), t.ws, shapeOptions(ctx));
  return result(f, own.converged() && sameEquilibrium(cur, own));
}

ValidityChecker::ValidityChecker(const ob::SpaceInformationPtr& si, std::shared_ptr<const Context> ctx)
    : ob::StateValidityChecker(si), ctx_(std::move(ctx)) {
  space_ = si->getStateSpace()->as<CtrStateSpace>();
  specs_.clearanceComputationType = ob::StateValidityCheckerSpecs::EXACT;
}

bool ValidityChecker::isValid(const ob::State* state) const {
  ThreadScratch& t = scratch();
  const auto* st = state->as<CtrStateSpace::StateType>();
  switch (ctx_->options().mode) {
    case Mode::Exact:
      if (st->cache) return st->cache->physics_ok && checkShape(*ctx_, st->cache->solution, t).ok;
      return checkFrictionless(*ctx_, space_->configuration(state), t).ok;
    case Mode::Robust:
      return checkRobust(*ctx_, space_->configuration(state), t).ok;
    case Mode::Frictionless:
      return checkFrictionless(*ctx_, space_->configuration(state), t).ok;
  }
  return false;
}

double ValidityChecker::clearance(const ob::State* state) const {
  ThreadScratch& t = scratch();
  const auto* st = state->as<CtrStateSpace::StateType>();
  Solution shape;
  if (st->cache && st->cache->solution.converged()) {
    shape = st->cache->solution;
  } else {
    shape = solve(ctx_->frictionlessRobot(), ctx_->jointsAt(space_->configuration(state)), t.ws, shapeOptions(*ctx_));
    if (!shape.converged()) return 0.0;
  }
  if (!ctx_->checker().distanceField()) return 0.0;
  return std::max(0.0, ctx_->checker().clearance(shape, t.query).clearance);
}

ForwardMotionValidator::ForwardMotionValidator(const ob::SpaceInformationPtr& si, std::shared_ptr<const Context> ctx)
    : ob::MotionValidator(si), ctx_(std::move(ctx)) {
  space_ = si->getStateSpace()->as<CtrStateSpace>();
}

bool ForwardMotionValidator::checkMotion(const ob::State* s1, const ob::State* s2) const {
  const Configuration q0 = space_->configuration(s1);
  const Configuration d = space_->difference(s1, s2);
  const Configuration q1(q0.alpha + d.alpha, q0.beta + d.beta);
  const bool ok = checkMotionForward(*ctx_, q0, q1, scratch()) >= 1.0;
  if (ok) {
    ++valid_;
  } else {
    ++invalid_;
  }
  return ok;
}

bool ForwardMotionValidator::checkMotion(const ob::State* s1, const ob::State* s2,
                                         std::pair<ob::State*, double>& lastValid) const {
  const Configuration q0 = space_->configuration(s1);
  const Configuration d = space_->difference(s1, s2);
  const Configuration q1(q0.alpha + d.alpha, q0.beta + d.beta);
  const double f = checkMotionForward(*ctx_, q0, q1, scratch());
  if (f >= 1.0) {
    ++valid_;
    return true;
  }
  ++invalid_;
  lastValid.second = f;
  if (lastValid.first) space_->interpolate(s1, s2, f, lastValid.first);
  return false;
}

}  // namespace ctr::planner
