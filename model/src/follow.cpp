// The branch rule of followMove (model/follow.hpp) and the names of its values.
#include "ctr/model/follow.hpp"

namespace ctr {

const char* toString(Failure f) {
  switch (f) {
    case Failure::None:
      return "none";
    case Failure::Inadmissible:
      return "inadmissible";
    case Failure::NotConverged:
      return "not_converged";
    case Failure::NoContactSet:
      return "no_contact_set";
    case Failure::Snapped:
      return "snapped";
    case Failure::Unstable:
      return "unstable";
    case Failure::OffBranch:
      return "off_branch";
    case Failure::Collision:
      return "collision";
    case Failure::OutOfBounds:
      return "out_of_bounds";
    case Failure::Released:
      return "released";
    case Failure::NotUnique:
      return "not_unique";
    case Failure::GoalMissed:
      return "goal_missed";
  }
  return "?";
}

const char* toString(BranchChange c) {
  switch (c) {
    case BranchChange::None:
      return "none";
    case BranchChange::Lost:
      return "lost";
    case BranchChange::Ended:
      return "ended";
    case BranchChange::Jumped:
      return "jumped";
  }
  return "?";
}

BranchChange branchChange(const Eigen::VectorXd& from_twist, bool from_stable, const Solution& to,
                          double snap_threshold, bool judge_stability) {
  if (!to.converged()) return BranchChange::Lost;
  if (judge_stability && from_stable && !to.summary.stable) return BranchChange::Ended;
  if (from_twist.size() > 0 && from_twist.size() == to.twist.size() &&
      (to.twist - from_twist).cwiseAbs().maxCoeff() > snap_threshold)
    return BranchChange::Jumped;
  return BranchChange::None;
}

BranchChange branchChange(const Solution& from, const Solution& to, double snap_threshold, bool judge_stability) {
  return branchChange(from.twist, from.converged() && from.summary.stable, to, snap_threshold, judge_stability);
}

}  // namespace ctr
