/// @file replay.hpp
/// @brief Replaying a sequence of commands (a recording's rows, a planned path) through the stateful model: which
/// equilibrium branch each row is on, how the friction memory is carried, and what happens after a failed row.
/// `ctr simulate`, the diagnosis (diagnosis/forward_model.hpp) and the Python module follow this one rule.
///
/// The branch rule. A row whose commanded move from the previous row is small (tube 1's rotation, the rotation of
/// every tube relative to its outer neighbour and every translation within ReplayOptions::path_rotation_step /
/// path_translation_step) is reached by continuation along the straight joint-space move, in the stick-slip
/// sub-steps of step(): the robot followed the commanded path. A row reached by an unknown path (a larger move, as
/// between the poses of a pose set) is reached *from rest*: the tubes aligned (no relative rotation, no twist, no
/// friction torque) at the row's translations, then each tube rotated relative to tube 1 the short way (by the
/// relative angle wrapped to (-pi, pi]) to its command, with the same sub-steps (reachFromRest). The first row is the
/// robot *at rest* there (restAt): on the branch that rotation reaches, with no friction torque stored. Both are
/// quasi-static continuations from a stable state, so the replayed equilibrium is never an unstable one; a snap on
/// the way (a jump to another branch) is a prediction of the model, reported as such and not given an output.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "ctr/model/friction.hpp"

namespace ctr {

/// @brief How a replay reaches each row's equilibrium.
enum class BranchRule {
  Auto,  ///< Path for small moves from the previous row, Rest for the first row and larger moves (default).
  Path,  ///< Every row by continuation along the straight move from the previous row (the path is known).
  Rest,  ///< Every row from rest (the path between rows is unknown).
};

/// @brief "auto", "path", "rest".
const char* toString(BranchRule rule);
/// @brief Parses "auto", "path" or "rest"; throws std::invalid_argument naming the valid values.
BranchRule parseBranchRule(const std::string& text);

/// @brief How a row was reached.
enum class Reached {
  Path,     ///< Continuation from the previous evaluated row along the straight commanded move.
  Rest,     ///< From rest: the first row at rest there (restAt), later rows after an unknown path (reachFromRest).
  Restart,  ///< At rest there (restAt) because the move from the last evaluated state failed (memory lost).
};

/// @brief "path", "rest", "restart".
const char* toString(Reached r);

/// @brief Options of replay().
struct ReplayOptions {
  FrictionOptions friction;  ///< Sub-steps, snap threshold and solver options of every move.
  BranchRule branch = BranchRule::Auto;
  /// Auto: a move whose largest rotation (alpha_1, or alpha_i - alpha_{i-1}) exceeds this is an unknown path (rad;
  /// 30 deg: a log samples a moving robot much more densely, pose sets move much further).
  double path_rotation_step = 0.5235987755982988;
  /// Auto: likewise for the largest translation change (m; 10 mm).
  double path_translation_step = 0.01;
  /// Coarse sub-step (rad) tried first where the end state does not depend on the sub-steps: moves of a robot
  /// without friction (translations then use coarse_translation_step), and rotation-only moves with at most one
  /// friction site (slip at the target in the direction of motion, or stick from the start). Such a move is
  /// accepted when it converges to a stable equilibrium without a snap, else the fine sub-steps decide. 0 disables.
  double coarse_rotation_step = 0.0;
  double coarse_translation_step = 0.005;  ///< m, frictionless moves only (see coarse_rotation_step).
  /// Search, at every row reached from rest, for the other stable frictionless equilibria at the command, and follow
  /// them along the path rows after it (ReplayRow::alternatives). Costs a few continuations per such row.
  bool find_alternatives = false;
};

/// @brief Another stable equilibrium at a row's command (frictionless), which the robot may be in after an unknown
/// path.
struct Alternative {
  double tip_distance = 0.0;  ///< From the row's replayed equilibrium (m).
  Solution solution;
};

/// @brief One replayed row.
struct ReplayRow {
  StepResult result;  ///< Equilibrium, memory after the row, and the step's summary.
  bool ok = false;    ///< Admissible, converged, consistent stick/slip set, stable, no snap.
  Reached reached = Reached::Path;
  std::string reason;  ///< Why the row is not ok ("" when ok); snaps start with "snapped".
  /// With find_alternatives: every other stable frictionless equilibrium the robot may be in after an unknown path
  /// (found at rest rows, followed along path rows), nearest first.
  std::vector<Alternative> alternatives;
};

/// @brief The equilibrium reached from rest at q (see the file comment): initialState at the aligned configuration
/// with q's translations, then step() to q (the short way in every relative rotation), friction acting along the
/// way. Rotation limits are not applied along the way (they bound commands, not the model's states).
StepResult reachFromRest(const Robot& robot, const Configuration& q, Workspace& ws,
                         const FrictionOptions& options = {});

/// @brief The robot at rest at q: on the branch the rotation from the aligned tubes reaches (reachFromRest without
/// friction), every contact stuck with no friction torque (initialState on that branch). The first row of a replay.
StepResult restAt(const Robot& robot, const Configuration& q, Workspace& ws, const FrictionOptions& options = {});

/// @brief True when Auto reaches `to` from `from` by continuation (tube 1's rotation, every tube's rotation relative
/// to its outer neighbour and every translation within the options' path steps).
bool isPathMove(const Configuration& from, const Configuration& to, const ReplayOptions& options);

/// @brief What the caller knows of the path between rows that the rows themselves do not show (e.g. the full-rate
/// log behind a decimated recording). Every member is optional (empty).
struct ReplayPath {
  /// Per row: commands passed through on the way to it (e.g. the joint reversals of the full-rate log between kept
  /// rows), stepped like rows on path moves but not reported.
  std::vector<std::vector<Configuration>> via;
  /// Per row (Auto): 1 when the move to it was sampled densely (every step of the full-rate log within the path
  /// steps), 0 when not. Empty: judged from the rows (isPathMove of consecutive rows).
  std::vector<char> dense;
};

/// @brief Called with each row's index and the row as soon as it is replayed. It may take or change the row's
/// contents (the replay no longer needs them), e.g. check a shape and drop its backbone; returning false ends the
/// replay after that row.
using ReplayObserver = std::function<bool(std::size_t index, ReplayRow& row)>;

/// @brief Replays the commands in order (see the file comment for the branch rule). Failure rule: a failed row
/// (inadmissible, not converged, no consistent stick/slip set, unstable, snapped) is reported and the replay goes on
/// from the last evaluated state; when that move fails too, the row is reached from rest (Reached::Restart). A snap
/// is followed: the replay continues from the branch it landed on. Each move is one step() (sub-stepped by
/// subdivisions() of the friction options). With an observer that stops the replay, the rows replayed so far.
std::vector<ReplayRow> replay(const Robot& robot, const std::vector<Configuration>& commands, Workspace& ws,
                              const ReplayOptions& options = {}, const ReplayPath& path = {},
                              const ReplayObserver& observer = {});

}  // namespace ctr
