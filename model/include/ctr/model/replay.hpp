/// @file replay.hpp
/// @brief Replaying a sequence of commands (a recording's rows, a planned path) through the stateful model: which
/// equilibrium branch each row is on, how the friction memory is carried, and what happens after a failed row.
/// `ctr simulate`, the diagnosis (diagnosis/forward_model.hpp) and the Python module follow this one rule.
///
/// The branch rule. Rows are in the order taken: between two rows the robot moved. By default (BranchRule::Path) every
/// row after the first is reached by continuation along the straight joint-space move from the previous row, in the
/// stick-slip sub-steps of step(), whatever the move's size: the friction memory is carried and a snap on the way is
/// the model's prediction. With BranchRule::Rest every row after the first is reached *from rest*: the tubes aligned
/// (no relative rotation, no twist, no friction torque) at the row's translations, then each tube rotated relative to
/// tube 1 the short way (by the relative angle wrapped to (-pi, pi]) to its command, with the same sub-steps
/// (reachFromRest) -- what a caller states who knows the robot was re-homed between rows. The first row is the robot
/// *at rest* there (restAt): on the branch that rotation reaches, with no friction torque stored. Both are
/// quasi-static continuations from a stable state, so the replayed equilibrium is never an unstable one; a snap on
/// the way (a jump to another branch) is a prediction of the model, reported as such and not given an output.
///
/// A long move (ReplayOptions::alternatives_rotation_step / alternatives_translation_step) can pass another
/// equilibrium, and the path between two rows of a pose set is not known: with ReplayOptions::find_alternatives the
/// other stable equilibria at the row's command (among them the one reached from rest) are found after every long
/// move and followed along the short moves after it (ReplayRow::alternatives), so a caller can tell which rows the
/// robot may have reached on another branch.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "ctr/model/friction.hpp"

namespace ctr {

/// @brief How a replay reaches each row's equilibrium.
enum class BranchRule {
  Path,  ///< Every row by continuation along the straight move from the previous row (rows in the order taken).
  Rest,  ///< Every row from rest (the robot re-homed between rows).
};

/// @brief "path", "rest".
const char* toString(BranchRule rule);
/// @brief Parses "path" or "rest"; throws std::invalid_argument naming the valid values (and, for "auto", that a rule
/// by move size is not offered).
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
  BranchRule branch = BranchRule::Path;
  /// With find_alternatives: a move whose largest rotation (alpha_1, or alpha_i - alpha_{i-1}) exceeds this (rad;
  /// 30 deg) is long enough to pass another equilibrium; the other stable equilibria are searched after it.
  double alternatives_rotation_step = 0.5235987755982988;
  /// Likewise for the largest translation change (m; 10 mm).
  double alternatives_translation_step = 0.01;
  /// Coarse sub-step (rad) tried first where the end state does not depend on the sub-steps: moves of a robot
  /// without friction (translations then use coarse_translation_step), and rotation-only moves with at most one
  /// friction site (slip at the target in the direction of motion, or stick from the start). Such a move is
  /// accepted when it converges to a stable equilibrium without a snap, else the fine sub-steps decide. 0 disables.
  double coarse_rotation_step = 0.0;
  double coarse_translation_step = 0.005;  ///< m, frictionless moves only (see coarse_rotation_step).
  /// Search, at the first row, at every row reached from rest and after every long move, for the other stable
  /// frictionless equilibria at the command (the one reached from rest among them), and follow them along the short
  /// moves after it (ReplayRow::alternatives). Costs a few continuations per such row.
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
  Failure failure = Failure::None;  ///< Why the row is not ok (None when ok).
  std::string message;              ///< The same in words ("" when ok).
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

/// @brief True when the move from `from` to `to` is long enough to pass another equilibrium: tube 1's rotation, a
/// tube's rotation relative to its outer neighbour or a translation beyond the options' alternatives steps (or the
/// sizes differ).
bool isLongMove(const Configuration& from, const Configuration& to, const ReplayOptions& options);

/// @brief What the caller knows of the path between rows that the rows themselves do not show (e.g. the full-rate
/// log behind a decimated recording). Every member is optional (empty).
struct ReplayPath {
  /// Per row: commands passed through on the way to it (e.g. the joint reversals of the full-rate log between kept
  /// rows), stepped like rows on path moves but not reported.
  std::vector<std::vector<Configuration>> via;
};

/// @brief Called with each row's index and the row as soon as it is replayed. It may take or change the row's
/// contents (the replay no longer needs them), e.g. check a shape and drop its backbone; returning false ends the
/// replay after that row.
using ReplayObserver = std::function<bool(std::size_t index, ReplayRow& row)>;

/// @brief Replays the commands in order (see the file comment for the branch rule; with BranchRule::Path the commands
/// in `path.via` are passed through on the way to each row). Failure rule: a failed row
/// (inadmissible, not converged, no consistent stick/slip set, unstable, snapped) is reported and the replay goes on
/// from the last evaluated state; when that move fails too, the row is reached from rest (Reached::Restart). A snap
/// is followed: the replay continues from the branch it landed on. Each move is one step() (sub-stepped by
/// subdivisions() of the friction options). With an observer that stops the replay, the rows replayed so far.
/// A robot with actuation (hasActuation): the commands go through its drives first, in order (jointsOf; the plays
/// remember the order, `path.via` included), and the tubes replay the joints: the rows' solutions and states are
/// in joint space, and each row's state also carries its command and the plays' positions after it
/// (HysteresisState::command, drives; as step() gives them).
std::vector<ReplayRow> replay(const Robot& robot, const std::vector<Configuration>& commands, Workspace& ws,
                              const ReplayOptions& options = {}, const ReplayPath& path = {},
                              const ReplayObserver& observer = {});

}  // namespace ctr
