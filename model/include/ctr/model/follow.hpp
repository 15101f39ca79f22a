/// @file follow.hpp
/// @brief Following an equilibrium along a straight move in actuator space: the sub-steps, the branch rule that says
/// when the followed equilibrium snapped, and the kinds of failure of a solve, step, motion or replayed row.
///
/// One routine (followMove) follows every equilibrium the library follows: the frictionless continuation
/// (continueTo), the stick-slip step (step), the planner's motion check and its propagator. The branch rule
/// (branchChange) is also the one that IK trials and the loaded solver's load continuation apply to their own steps.
#pragma once

#include <string>
#include <utility>

#include "ctr/model/configuration.hpp"
#include "ctr/model/kinematics.hpp"

namespace ctr {

/// @brief Why a solve, step, motion or replayed row failed (None: it did not). Carried in results and JSON
/// (`"failure"`) next to the human-readable `message`; callers branch on this value, never on the message.
enum class Failure {
  None,          ///< No failure.
  Inadmissible,  ///< The command violates the nesting, ordering or limits of the tubes.
  NotConverged,  ///< The equilibrium solve did not converge (the followed equilibrium was lost).
  NoContactSet,  ///< The solve converged but no stick/slip contact set is consistent with Coulomb's law.
  Snapped,       ///< The followed equilibrium branch ended (a fold) or jumped to another one.
  Unstable,      ///< The equilibrium is elastically unstable.
  OffBranch,     ///< The motion arrives on another stable equilibrium than the configuration's own.
  Collision,     ///< The shape collides with the environment.
  OutOfBounds,   ///< The shape leaves the workspace bounds.
  Released,      ///< A contact site vanishes and releases its friction torque (the friction band jumps).
  GoalMissed,    ///< A replayed plan ends off its goal.
  /// A friction band not certified unique (uniqueness.hpp): a history could reach another equilibrium with the same
  /// contact torques.
  NotUnique,
};

/// @brief "none", "inadmissible", "not_converged", "no_contact_set", "snapped", "unstable", "off_branch",
/// "collision", "out_of_bounds", "released", "goal_missed", "not_unique".
const char* toString(Failure f);

/// @brief How the equilibrium changed over one sub-step (branchChange).
enum class BranchChange {
  None,   ///< Still the followed equilibrium.
  Lost,   ///< The solve warm-started from the followed equilibrium did not converge.
  Ended,  ///< The followed equilibrium was stable and the new one is not: the branch ended at a fold.
  Jumped  ///< Some tube's tip twist changed by more than the snap threshold: another equilibrium.
};

/// @brief "none" / "lost" / "ended" / "jumped".
const char* toString(BranchChange c);

/// @brief The branch rule: how `to`, solved warm-started from `from` one sub-step (or one trial step) later, relates
/// to `from`'s equilibrium. Lost if `to` did not converge; Ended if `from` is stable and `to` is not (only with
/// `judge_stability`); Jumped if a tip twist changed by more than `snap_threshold`; else None. `from` without twist
/// (not yet solved) is never jumped from.
BranchChange branchChange(const Solution& from, const Solution& to, double snap_threshold, bool judge_stability = true);

/// @brief branchChange from an equilibrium known by its tip twist and whether it is (converged and) stable.
BranchChange branchChange(const Eigen::VectorXd& from_twist, bool from_stable, const Solution& to,
                          double snap_threshold, bool judge_stability = true);

/// @brief What a follow did: how far it got, whether it snapped on the way, and why it stopped.
struct FollowSummary {
  int steps = 0;                    ///< Sub-steps of the move.
  int completed = 0;                ///< Sub-steps accepted (steps when the whole move was followed).
  bool snapped = false;             ///< A sub-step snapped (and the follow went on: OnSnap::Continue).
  Failure failure = Failure::None;  ///< Why it stopped before the end (None when it did not).
  std::string message;              ///< The reason in words, when it stopped.
  bool completedMove() const { return failure == Failure::None && completed == steps; }
};

/// @brief What followMove does when a sub-step snaps.
enum class OnSnap {
  Continue,  ///< Take the new equilibrium and go on (the robot jumps; summary.snapped is set).
  Stop,      ///< Stop before the sub-step (failure Snapped): a motion that snaps is not followed.
};

/// @brief One sub-step's outcome, as the caller's `advance` and `recover` return it.
struct SubStep {
  /// The equilibrium reached (owned by the caller; commit may move it from there); nullptr on failure.
  Solution* solution = nullptr;
  Failure failure = Failure::None;  ///< The caller's own failure (not converged, no contact set, ...).
  std::string message;              ///< Its reason in words.
};

/// @brief Follows an equilibrium along the straight move from q0 to q1 in subdivisions(q0, q1, ...) equal sub-steps:
/// the one routine behind continueTo, step, the planner's motion check and its propagator.
///
/// For k = 1..steps: `advance(qk, k, steps)` solves the sub-step from the caller's current equilibrium (warm start)
/// and returns a SubStep; a failure it reports stops the follow there. The branch rule judges the new equilibrium
/// against the last accepted one (first the start: its tip twist and whether it is converged and stable): when the
/// branch was Lost or Ended and `recover` is given, `recover(qk, k, steps)` finds another equilibrium (a cold solve)
/// and the sub-step snapped (if the last one was stable) onto it; a Lost branch that cannot be recovered stops the
/// follow (NotConverged). A snap (Ended or Jumped) stops the follow (OnSnap::Stop, failure Snapped) or is taken
/// (OnSnap::Continue, summary.snapped). `commit(k, steps, sub, snapped)` then accepts the sub-step (the caller moves
/// its state on; `snapped` says whether this sub-step snapped) or refuses it with a failure (a collision, ...) that
/// stops the follow before it. q0 and q1 are read at every sub-step: they must not be (part of) state that the
/// callbacks change.
template <class Advance, class Recover, class Commit>
FollowSummary followMove(const Configuration& q0, const Configuration& q1, const Eigen::VectorXd& start_twist,
                         bool start_stable, const FollowOptions& o, OnSnap on_snap, Advance&& advance,
                         Recover&& recover, Commit&& commit) {
  FollowSummary f;
  f.steps = subdivisions(q0, q1, o.max_rotation_step, o.max_translation_step);
  Eigen::VectorXd twist = start_twist;
  bool stable = start_stable;
  auto stop = [&f](Failure why, std::string message) {
    f.failure = why;
    f.message = std::move(message);
    return f;
  };
  for (int k = 1; k <= f.steps; ++k) {
    const Configuration qk = interpolate(q0, q1, static_cast<double>(k) / f.steps);
    SubStep s = advance(qk, k, f.steps);
    if (s.failure != Failure::None || !s.solution) return stop(s.failure, std::move(s.message));
    BranchChange c = branchChange(twist, stable, *s.solution, o.snap_threshold, o.judge_stability);
    bool snapped = false;
    if (c == BranchChange::Lost || c == BranchChange::Ended) {
      SubStep r = recover(qk, k, f.steps);
      if (r.failure == Failure::None && r.solution && r.solution->converged()) {
        s = std::move(r);
        snapped = stable;
        c = BranchChange::None;
      } else if (c == BranchChange::Lost) {
        return stop(Failure::NotConverged, "the followed equilibrium is lost at sub-step " + std::to_string(k) + "/" +
                                               std::to_string(f.steps) + ": " +
                                               (s.message.empty() ? s.solution->summary.message : s.message));
      }
    }
    if (c != BranchChange::None) snapped = true;
    if (snapped && on_snap == OnSnap::Stop)
      return stop(Failure::Snapped, std::string("the equilibrium branch snaps (") +
                                        (c == BranchChange::Jumped ? "jumps" : "ends") + ") at sub-step " +
                                        std::to_string(k) + "/" + std::to_string(f.steps));
    f.snapped = f.snapped || snapped;
    twist = s.solution->twist;
    stable = s.solution->converged() && s.solution->summary.stable;
    SubStep done = commit(k, f.steps, s, snapped);
    if (done.failure != Failure::None) return stop(done.failure, std::move(done.message));
    f.completed = k;
  }
  return f;
}

/// @brief A `recover` for followMove that finds nothing (the follow then stops where the branch is lost).
inline SubStep noRecovery(const Configuration&, int, int) {
  return {nullptr, Failure::NotConverged, {}};
}

}  // namespace ctr
