// Replaying commands through the stateful model: the branch rule (path continuation or rest), the coarse sub-steps
// where they are exact, the failure rule and the search for other stable equilibria.
#include "ctr/model/replay.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace ctr {

const char* toString(BranchRule rule) {
  switch (rule) {
    case BranchRule::Path:
      return "path";
    case BranchRule::Rest:
      return "rest";
  }
  return "?";
}

BranchRule parseBranchRule(const std::string& text) {
  for (BranchRule r : {BranchRule::Path, BranchRule::Rest})
    if (text == toString(r)) return r;
  if (text == "auto")
    throw std::invalid_argument(
        "branch rule 'auto' (from rest after moves over 30 deg / 10 mm) is not offered: rows are in the order taken, "
        "so use 'path' (the default: continuation from the previous row) or 'rest' (the robot re-homed between "
        "rows)");
  throw std::invalid_argument("unknown branch rule '" + text + "' (known: path, rest)");
}

const char* toString(Reached r) {
  switch (r) {
    case Reached::Path:
      return "path";
    case Reached::Rest:
      return "rest";
    case Reached::Restart:
      return "restart";
  }
  return "?";
}

namespace {

bool hasFriction(const Robot& robot) {
  return robot.friction().boundary > 0.0 || robot.friction().distributed > 0.0;
}

/// The robot without rotation limits (the rest path passes through rotations outside them).
Robot withoutRotationLimits(const Robot& robot) {
  Robot r = robot;
  for (int i = 0; i < robot.size(); ++i)
    if (robot.tube(i).rotation_limits) {
      Tube t = robot.tube(i);
      t.rotation_limits.reset();
      r = r.withTube(i, t);
    }
  return r;
}

bool hasRotationLimits(const Robot& robot) {
  for (const Tube& t : robot.tubes())
    if (t.rotation_limits) return true;
  return false;
}

/// Outcome of one move: the step's result and whether it is a usable, stable, snap-free equilibrium.
struct Move {
  StepResult r;
  bool ok = false;
  Failure failure = Failure::None;
  std::string message;
};

/// Why a move's result is not a usable equilibrium (Failure::None when it is).
Failure failureOf(const Robot& robot, const StepResult& r) {
  if (r.solution.summary.status == SolveStatus::Inadmissible) return Failure::Inadmissible;
  if (!(r.summary.converged && r.state.valid))
    return r.solution.converged() ? Failure::NoContactSet : Failure::NotConverged;
  if (r.summary.snapped) return Failure::Snapped;
  if (!hasFriction(robot) && !r.solution.summary.stable) return Failure::Unstable;
  return Failure::None;
}

/// Sets the move's failure, its message (the failure in words) and ok.
void judge(const Robot& robot, Move& m) {
  const StepResult& r = m.r;
  m.failure = failureOf(robot, r);
  m.ok = m.failure == Failure::None;
  const std::string& msg = r.summary.message.empty() ? r.solution.summary.message : r.summary.message;
  switch (m.failure) {
    case Failure::Inadmissible:
      m.message = "inadmissible command: " + r.summary.message;
      break;
    case Failure::NoContactSet:
      m.message = "no consistent stick/slip contact set" + (r.summary.message.empty() ? "" : ": " + r.summary.message);
      break;
    case Failure::NotConverged:
      m.message = "did not converge" + (msg.empty() ? "" : ": " + msg);
      break;
    case Failure::Snapped:
      m.message = "snapped (the equilibrium branch ended; the quasi-static model cannot follow the jump)";
      break;
    case Failure::Unstable:
      m.message = "unstable equilibrium";
      break;
    default:
      m.message.clear();
  }
}

/// A row whose command is not admissible: no equilibrium, the reason.
Move inadmissibleMove(const Robot& robot, const Configuration& q, const Admissibility& adm) {
  Move m;
  m.r.solution.q = q;
  m.r.solution.summary.status = SolveStatus::Inadmissible;
  m.r.summary.message = adm.message;
  judge(robot, m);
  return m;
}

/// A quasi-static move of `robot` from `from` to q: the coarse sub-steps where the end state does not depend on
/// them (ReplayOptions::coarse_rotation_step), else the fine ones.
Move move(const Robot& robot, const HysteresisState& from, const Configuration& q, Workspace& ws,
          const ReplayOptions& o) {
  Move m;
  const FrictionOptions& fine = o.friction;
  const bool friction = hasFriction(robot);
  if (o.coarse_rotation_step > fine.follow.max_rotation_step &&
      (!friction || (q.beta == from.q.beta && contactSites(robot, q).size() <= 1))) {
    FrictionOptions coarse = fine;
    coarse.follow.max_rotation_step = o.coarse_rotation_step;
    if (!friction)
      coarse.follow.max_translation_step = std::max(o.coarse_translation_step, fine.follow.max_translation_step);
    // A snap is a twist jump much larger than the commanded sub-step: the detector scales with the sub-step (at most
    // 2 rad, below the ~pi jump of a real snap).
    coarse.follow.snap_threshold = std::min(2.0, fine.follow.snap_threshold * coarse.follow.max_rotation_step /
                                                     std::max(fine.follow.max_rotation_step, 1e-9));
    m.r = step(robot, from, q, ws, coarse);
    if (m.r.summary.substeps > 0 && failureOf(robot, m.r) == Failure::None) {
      m.ok = true;
      return m;
    }
  }
  m.r = step(robot, from, q, ws, fine);
  judge(robot, m);
  return m;
}

/// The aligned configuration with q's translations: every relative rotation a whole number of turns (0 after
/// wrapping), reached from q by the short way in each.
Configuration restOf(const Configuration& q) {
  Configuration home = q;
  for (int i = 1; i < q.size(); ++i) home.alpha[i] = q.alpha[i] - std::remainder(q.alpha[i] - q.alpha[0], 2 * M_PI);
  return home;
}

Move fromRest(const Robot& robot, const Configuration& home, const Configuration& q, Workspace& ws,
              const ReplayOptions& o) {
  Move m;
  const Admissibility adm = checkAdmissible(robot, q);
  if (!adm) return inadmissibleMove(robot, q, adm);
  const Robot free = hasRotationLimits(robot) ? withoutRotationLimits(robot) : robot;
  StepResult start = initialState(free, home, ws, o.friction);
  if (!(start.summary.converged && start.state.valid)) {
    m.r = std::move(start);
    m.failure = Failure::NotConverged;
    m.message = "did not converge at rest: " + m.r.summary.message;
    return m;
  }
  if (home.alpha == q.alpha) {
    m.r = std::move(start);
    judge(robot, m);
    return m;
  }
  m = move(free, start.state, q, ws, o);
  judge(robot, m);
  return m;
}

/// restAt as a Move (with the reason of a row that fails).
Move atRest(const Robot& robot, const Configuration& q, Workspace& ws, const ReplayOptions& o) {
  const Admissibility adm = checkAdmissible(robot, q);
  if (!adm) return inadmissibleMove(robot, q, adm);
  Move m;
  m.r = restAt(robot, q, ws, o.friction);
  judge(robot, m);
  return m;
}

double tipDistance(const Solution& a, const Solution& b) {
  return (a.tip_position - b.tip_position).norm();
}

/// Same equilibrium (to the solver tolerance): tips within 1 um and twists within 1e-5 rad.
bool sameEquilibrium(const Solution& a, const Solution& b) {
  if (tipDistance(a, b) > 1e-6) return false;
  return a.twist.size() != b.twist.size() || a.twist.size() == 0 || (a.twist - b.twist).cwiseAbs().maxCoeff() <= 1e-5;
}

/// True when s is none of `known` (the same equilibrium to the solver tolerance).
bool isNew(const Solution& s, const std::vector<Solution>& known) {
  for (const Solution& k : known)
    if (sameEquilibrium(s, k)) return false;
  return true;
}

/// Frictionless branches other than the replayed row's own, tracked for the alternatives.
struct Branches {
  bool active = false;
  std::vector<HysteresisState> others;
  std::vector<Solution> other_solutions;
};

/// The memory of a frictionless robot at a solved equilibrium (its branch), to follow it along a path.
HysteresisState frictionlessState(const Solution& s, const Configuration& q) {
  HysteresisState st;
  st.q = q;
  st.base_twist_rate = s.base_twist_rate;
  st.base_moment = s.base_moment;
  st.twist = s.twist;
  st.direction = Eigen::VectorXd::Zero(q.size());
  st.valid = s.converged();
  return st;
}

/// The frictionless equilibrium on the branch of a replayed row: the row's own for a robot without friction, else
/// the frictionless solve started from the row's equilibrium (the friction torques are small against the elastic
/// ones, so Newton stays on the row's branch). Not converged: an empty Solution.
Solution frictionlessTwin(const Robot& free, bool friction, const StepResult& row, Workspace& ws,
                          const ReplayOptions& o) {
  if (!friction) return row.solution;
  Solution s = solve(free, row.solution.q, ws, o.friction.kinematics, &row.solution);
  return s.converged() && s.summary.stable ? s : Solution{};
}

/// Stable frictionless equilibria at q other than `primary` (the replayed row's own branch): the one reached from
/// rest (the short way), the long way round in one relative rotation at a time, the continuation from the previous
/// row, the old warm Newton jump from it, and the cold solve.
void searchAlternatives(const Robot& free, const Configuration& q, const Solution& primary,
                        const HysteresisState* previous, Workspace& ws, const ReplayOptions& o, Branches& b) {
  std::vector<StepResult> found;
  const Configuration home = restOf(q);
  {
    Move m = fromRest(free, home, q, ws, o);
    if (m.ok) found.push_back(std::move(m.r));
  }
  for (int i = 1; i < q.size(); ++i) {
    const double wrapped = q.alpha[i] - home.alpha[i];
    if (std::abs(wrapped) < 1e-9) continue;
    Configuration other = home;
    other.alpha[i] += wrapped > 0 ? 2 * M_PI : -2 * M_PI;  // rotate the long way
    Move m = fromRest(free, other, q, ws, o);
    if (m.ok) found.push_back(std::move(m.r));
  }
  if (previous && previous->valid) {
    Move m = move(free, *previous, q, ws, o);
    if (m.ok) found.push_back(std::move(m.r));
    Solution warm;
    warm.base_twist_rate = previous->base_twist_rate;
    warm.summary.status = SolveStatus::Converged;
    StepResult jump;
    jump.solution = solve(free, q, ws, o.friction.kinematics, &warm);
    jump.summary.converged = jump.solution.converged();
    if (jump.solution.converged() && jump.solution.summary.stable) {
      jump.state = frictionlessState(jump.solution, q);
      found.push_back(std::move(jump));
    }
  }
  StepResult cold;
  cold.solution = solve(free, q, ws, o.friction.kinematics, nullptr);
  if (cold.solution.converged() && cold.solution.summary.stable) {
    cold.state = frictionlessState(cold.solution, q);
    found.push_back(std::move(cold));
  }
  for (StepResult& r : found) {
    if (!r.solution.converged() || !r.solution.summary.stable || sameEquilibrium(r.solution, primary) ||
        !isNew(r.solution, b.other_solutions))
      continue;
    b.other_solutions.push_back(r.solution);
    b.others.push_back(r.state);
  }
}

/// Follows the tracked branches along a short move to q; drops those that end (snap, no convergence, instability) or
/// merge with the replayed row's branch (`primary`) or with each other.
void followAlternatives(const Robot& free, const Configuration& q, const Solution& primary, Workspace& ws,
                        const ReplayOptions& o, Branches& b) {
  std::vector<HysteresisState> others;
  std::vector<Solution> sols;
  for (const HysteresisState& s : b.others) {
    Move m = move(free, s, q, ws, o);
    if (!m.ok || sameEquilibrium(m.r.solution, primary) || !isNew(m.r.solution, sols)) continue;
    others.push_back(m.r.state);
    sols.push_back(m.r.solution);
  }
  b.others = std::move(others);
  b.other_solutions = std::move(sols);
  b.active = !b.others.empty();
}

}  // namespace

StepResult reachFromRest(const Robot& robot, const Configuration& q, Workspace& ws, const FrictionOptions& options) {
  ReplayOptions o;
  o.friction = options;
  Move m = fromRest(robot, restOf(q), q, ws, o);
  if (!m.message.empty() && m.r.summary.message.empty()) m.r.summary.message = m.message;
  return std::move(m.r);
}

StepResult restAt(const Robot& robot, const Configuration& q, Workspace& ws, const FrictionOptions& options) {
  ReplayOptions o;
  o.friction = options;
  const Robot free = hasFriction(robot) ? robot.withFriction(FrictionCoefficients{}) : robot;
  Move m = fromRest(free, restOf(q), q, ws, o);
  if (!m.ok || !hasFriction(robot)) {
    if (!m.message.empty() && m.r.summary.message.empty()) m.r.summary.message = m.message;
    return std::move(m.r);
  }
  StepResult r = initialState(robot, q, ws, options, &m.r.solution);
  r.solution.summary.snapped = false;
  return r;
}

bool isLongMove(const Configuration& from, const Configuration& to, const ReplayOptions& o) {
  if (from.size() != to.size() || to.size() == 0) return true;
  double rot = std::abs(to.alpha[0] - from.alpha[0]);
  for (int i = 1; i < to.size(); ++i)
    rot = std::max(rot, std::abs((to.alpha[i] - to.alpha[i - 1]) - (from.alpha[i] - from.alpha[i - 1])));
  const double lin = (to.beta - from.beta).cwiseAbs().maxCoeff();
  return rot > o.alternatives_rotation_step || lin > o.alternatives_translation_step;
}

std::vector<ReplayRow> replay(const Robot& robot, const std::vector<Configuration>& commands, Workspace& ws,
                              const ReplayOptions& o, const ReplayPath& known, const ReplayObserver& observer) {
  if (hasActuation(robot)) {
    // The drives first, in the order the commands were given (the plays remember it), the passed-through commands
    // of `known` before their row; then the tubes alone replay the joints. Inadmissible commands stay as they are
    // (their rows report it) and do not move the drives.
    // Each row's state then carries its command and the plays' positions after it, as step() gives them.
    DriveState drives;
    std::vector<Configuration> joints;
    std::vector<DriveState> drives_after;
    std::vector<std::size_t> last_command;  // per row: the last admissible command so far (commands.size(): none)
    joints.reserve(commands.size());
    drives_after.reserve(commands.size());
    last_command.reserve(commands.size());
    ReplayPath joint_path;
    joint_path.via.resize(known.via.size());
    std::size_t commanded = commands.size();
    for (std::size_t k = 0; k < commands.size(); ++k) {
      if (k < known.via.size())
        for (const Configuration& v : known.via[k])
          if (v.size() == robot.size() && v.beta.size() == robot.size() && checkAdmissible(robot, v))
            joint_path.via[k].push_back(jointsOf(robot, v, drives));
      const Configuration& c = commands[k];
      const bool admissible = c.size() == robot.size() && c.beta.size() == robot.size() && checkAdmissible(robot, c);
      joints.push_back(admissible ? jointsOf(robot, c, drives) : c);
      if (admissible) commanded = k;
      drives_after.push_back(drives);
      last_command.push_back(commanded);
    }
    const ReplayObserver inner = [&](std::size_t k, ReplayRow& row) {
      if (last_command[k] < commands.size()) {
        row.result.state.command = commands[last_command[k]];
        row.result.state.drives = drives_after[k];
      }
      return !observer || observer(k, row);
    };
    return replay(robot.withoutActuation(), joints, ws, o, joint_path, inner);
  }
  std::vector<ReplayRow> out(commands.size());
  const bool friction = hasFriction(robot);
  const Robot free = friction ? robot.withFriction(FrictionCoefficients{}) : robot;
  HysteresisState good;        // the last evaluated state (invalid until the first one)
  Configuration last_command;  // the command the robot was last moved to (evaluated or not)
  bool previous_failed = false;
  Branches branches;
  for (std::size_t k = 0; k < commands.size(); ++k) {
    const Configuration& q = commands[k];
    ReplayRow& row = out[k];
    const Admissibility adm = checkAdmissible(robot, q);
    if (!adm) {
      Move m = inadmissibleMove(robot, q, adm);
      row.failure = m.failure;
      row.message = m.message;
      row.result = std::move(m.r);
      previous_failed = true;
      if (observer && !observer(k, row)) {
        out.resize(k + 1);
        break;
      }
      continue;
    }
    const bool path = good.valid && o.branch == BranchRule::Path;
    const bool long_move = o.find_alternatives && isLongMove(last_command, q, o);
    Move m;
    if (path) {
      if (k < known.via.size())
        for (const Configuration& v : known.via[k]) {
          Move mv = move(robot, good, v, ws, o);
          if (mv.r.summary.converged && mv.r.state.valid && !mv.r.summary.snapped) good = std::move(mv.r.state);
        }
      m = move(robot, good, q, ws, o);
      row.reached = Reached::Path;
      if (!(m.r.summary.converged && m.r.state.valid) && previous_failed) {
        // Two failures in a row: the memory cannot be carried on; the robot at rest here.
        Move rest = atRest(robot, q, ws, o);
        if (rest.r.summary.converged && rest.r.state.valid) {
          m = std::move(rest);
          row.reached = Reached::Restart;
        }
      }
    } else if (!good.valid) {
      m = atRest(robot, q, ws, o);  // the first row (or after rows that all failed): the robot at rest there
      row.reached = Reached::Rest;
    } else {
      m = fromRest(robot, restOf(q), q, ws, o);
      row.reached = Reached::Rest;
    }
    row.ok = m.ok;
    row.failure = m.failure;
    row.message = m.message;
    last_command = q;
    if (o.find_alternatives) {
      // The row's own frictionless branch, solved only where other branches are searched or followed.
      const bool search = row.reached != Reached::Path || long_move;
      const Solution primary =
          m.ok && (search || branches.active) ? frictionlessTwin(free, friction, m.r, ws, o) : Solution{};
      if (!primary.converged()) {
        branches = Branches{};
      } else if (search) {
        const HysteresisState* previous = good.valid ? &good : nullptr;
        branches = Branches{};
        searchAlternatives(free, q, primary, previous, ws, o, branches);
        branches.active = !branches.others.empty();
      } else {
        followAlternatives(free, q, primary, ws, o, branches);
      }
      if (m.ok && branches.active)
        for (const Solution& s : branches.other_solutions)
          row.alternatives.push_back({tipDistance(s, m.r.solution), s});
      std::sort(row.alternatives.begin(), row.alternatives.end(),
                [](const Alternative& a, const Alternative& b) { return a.tip_distance < b.tip_distance; });
    }
    // Memory is carried from converged states; never from an unstable frictionless one.
    const bool evaluated = m.r.summary.converged && m.r.state.valid && (friction || m.r.solution.summary.stable);
    if (evaluated) good = m.r.state;  // after a snap the replay goes on from the branch it landed on
    previous_failed = !evaluated;
    row.result = std::move(m.r);
    if (observer && !observer(k, row)) {
      out.resize(k + 1);
      break;
    }
  }
  return out;
}

}  // namespace ctr
