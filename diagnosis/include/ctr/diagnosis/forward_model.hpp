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
#include "ctr/model/robot.hpp"

namespace ctr::diagnosis {

/// @brief Options of a prediction.
struct PredictOptions {
  /// Fine sub-steps of the stateful replay (used for a row whenever the coarse step fails or flags a snap).
  FrictionOptions friction;
  KinematicsOptions kinematics;  ///< Used by the frictionless chain of warm-started solves.
  /// Coarse rotation sub-step (rad) tried first for rotation-only rows with at most one friction site; 0 disables
  /// it. There the sub-steps only carry the equilibrium branch (the end state is slip at the target, or stick from
  /// the start), so a row whose coarse pass converges without a snap equals the fine replay (tests/diagnosis checks
  /// this to 1e-8); other rows, where the return mapping is path dependent, always use the fine sub-steps.
  double coarse_rotation_step = 0.175;  // 10 deg
  PredictOptions() {
    friction.max_rotation_step = 0.035;  // 2 deg
    friction.kinematics.record_backbone = false;
    kinematics.record_backbone = false;
  }
};

/// @brief Model output per row of a recording.
struct Prediction {
  Eigen::MatrixXd twist;         ///< rows x (n-1) (rad).
  Eigen::MatrixXd tip_position;  ///< rows x 3 (m).
  Eigen::MatrixXd tip_tangent;   ///< rows x 3 (unit).
  Eigen::VectorXd moment;        ///< Largest concentrated-moment magnitude per row (N m).
  std::vector<Configuration> actuation;  ///< The true actuation after latency/backlash/offset.
  std::vector<char> ok;          ///< Row solved (converged); failed rows repeat the previous row's output.
  int failures = 0;              ///< Rows that did not converge.
  int rows() const { return static_cast<int>(ok.size()); }
};

/// @brief Play (dead-band) operator of full width `width` applied to a sequence, starting centred on x[0].
Eigen::VectorXd playOperator(const Eigen::VectorXd& x, double width);

/// @brief The true actuation of each row: commands delayed by sensor latency (linear interpolation in `time`;
/// needs time.size() == rows, else latency is ignored), then backlash (play per tube), then offsets.
std::vector<Configuration> transformActuation(const std::vector<Configuration>& commands, const Eigen::VectorXd& time,
                                              const std::vector<Effect>& effects);

/// @brief Replays the recording's commands under the effects (stateful friction when mu > 0, otherwise a chain of
/// warm-started frictionless solves in row order) and returns the model's measurements per row.
Prediction predict(const Robot& nominal, const std::vector<Configuration>& commands, const Eigen::VectorXd& time,
                   const std::vector<Effect>& effects, Workspace& ws, const PredictOptions& options = {});

}  // namespace ctr::diagnosis
