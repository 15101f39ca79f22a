/// @file forward_model.hpp
/// @brief The forward model of a recording under a set of effects: nominal robot modified by the effects,
/// actuation transformed (latency, backlash, offset), replayed in order through the (friction) model.
/// The same code path injects effects (simulate.hpp) and fits them (fit.hpp).
#pragma once

#include <Eigen/Core>
#include <vector>

#include "ctr/diagnosis/effect.hpp"
#include "ctr/model/configuration.hpp"
#include "ctr/model/friction.hpp"
#include "ctr/model/kinematics.hpp"
#include "ctr/model/replay.hpp"
#include "ctr/model/robot.hpp"

namespace ctr::diagnosis {

/// @brief The full-rate command log behind a decimated recording: the actuation effects (latency, backlash,
/// offsets) act on it, and each recording row takes the transformed command of its own log row.
struct CommandHistory {
  std::vector<Configuration> commands;  ///< Every logged command.
  Eigen::VectorXd time;                 ///< Their times (may be empty: no latency).
  std::vector<int> rows;                ///< Log row of each recording row.
};

/// @brief Longest integration step (m) of the replays' equilibria (KinematicsOptions::max_step; library default 10 mm).
constexpr double kReplayMaxStep = 0.03;
/// @brief Largest bending per integration step (rad) of the replays' equilibria (library default 0.12 rad).
constexpr double kReplayMaxBending = 0.25;

/// @brief Options of a prediction.
struct PredictOptions {
  /// Full-rate commands of a decimated recording (nullptr: the recording's own rows are the whole log). Owned by
  /// the caller and alive during the prediction.
  const CommandHistory* history = nullptr;
  /// The replay (replay.hpp): the branch rule, the fine sub-steps of every move (2 deg / 1 mm here) and the coarse
  /// sub-step tried first where the end state does not depend on the sub-steps (10 deg here; tests/diagnosis checks
  /// the replay equals the fine one to 1e-8). The equilibria are integrated with steps of at most kReplayMaxStep and
  /// kReplayMaxBending (about half the cost of the library's default steps, tip error below 2 um on the example
  /// robots); diagnose() checks this error against the noise on every recording (DiagnosisReport::discretisation).
  ReplayOptions replay;
  /// Keep each row's equilibrium (Prediction::solutions), e.g. to linearise the model around it (load screen).
  bool keep_solutions = false;
  PredictOptions() {
    replay.friction.follow.max_rotation_step = 0.035;  // 2 deg
    replay.friction.kinematics.record_backbone = false;
    replay.friction.kinematics.max_step = kReplayMaxStep;
    replay.friction.kinematics.max_bending_per_step = kReplayMaxBending;
    replay.coarse_rotation_step = 0.175;  // 10 deg
  }
};

/// @brief Model output per row of a recording.
///
/// A row the model cannot evaluate (command inadmissible beyond the tolerance, not converged, snapped, unstable, no
/// consistent stick/slip set) has ok = 0, its failure and message, and NaN outputs: no row ever carries another row's
/// output. The replay (replay.hpp) continues past it from the last evaluated state (one quasi-static move to the next
/// row, so the friction and backlash memory is kept); only if that move fails too is the row reached from rest and
/// `restarts` counts it.
struct Prediction {
  Eigen::MatrixXd twist;                 ///< rows x (n-1) (rad); NaN on failed rows.
  Eigen::MatrixXd tip_position;          ///< rows x 3 (m); NaN on failed rows.
  Eigen::MatrixXd tip_tangent;           ///< rows x 3 (unit); NaN on failed rows.
  Eigen::VectorXd moment;                ///< Largest concentrated-moment magnitude per row (N m); NaN on failed rows.
  std::vector<Configuration> actuation;  ///< The true actuation after latency/backlash/offset.
  std::vector<char> ok;                  ///< Row evaluated (admissible, converged, no snap).
  std::vector<Failure> failure;          ///< Why a row failed (Failure::None when ok).
  std::vector<std::string> message;      ///< The same in words ("" when ok).
  int failures = 0;                      ///< Rows with ok = 0.
  int restarts = 0;                      ///< Rows reached from rest after a failure (memory lost).
  std::vector<Reached> reached;          ///< How each row was reached (path, rest, restart).
  /// With PredictOptions::replay.find_alternatives: per row, the other stable equilibria the robot may be in after an
  /// unknown path (replay.hpp; base frame); empty for the other rows.
  std::vector<std::vector<Alternative>> alternatives;
  /// Each row's equilibrium (with its contact laws) when PredictOptions::keep_solutions; an unconverged Solution on
  /// failed rows. Empty otherwise.
  std::vector<Solution> solutions;
  int rows() const { return static_cast<int>(ok.size()); }
};

/// @brief Play (dead-band) operator of full width `width` applied to a sequence, starting centred on x[0].
Eigen::VectorXd playOperator(const Eigen::VectorXd& x, double width);

/// @brief The true actuation of each row: commands delayed by sensor latency (linear interpolation in `time`;
/// needs time.size() == rows, else latency is ignored), then backlash (play per tube, rotation and translation),
/// then offsets (rotation and translation). Translation effects can move a tube past the nesting constraints; the
/// result is then projected onto the admissible set (an inner tube retracted behind an outer tube's end is taken at
/// that end), which needs the robot: pass it, or the translations are left as computed.
std::vector<Configuration> transformActuation(const std::vector<Configuration>& commands, const Eigen::VectorXd& time,
                                              const std::vector<Effect>& effects, const Robot* robot = nullptr);

/// @brief Replays the recording's commands under the effects (ctr::replay: the branch rule, the stateful friction
/// model, the failure rule) and returns the model's measurements per row. Commands that violate the nesting
/// constraints by no more than kAdmissibilityTolerance are projected first; rows beyond it fail ("inadmissible
/// command: ...") and are skipped.
Prediction predict(const Robot& nominal, const std::vector<Configuration>& commands, const Eigen::VectorXd& time,
                   const std::vector<Effect>& effects, Workspace& ws, const PredictOptions& options = {});

}  // namespace ctr::diagnosis
