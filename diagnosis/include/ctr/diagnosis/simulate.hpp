/// @file simulate.hpp
/// @brief Building test recordings: actuation patterns (paper sweeps, random order, random walks) and injection
/// of effects + measurement noise through the same forward model the diagnosis fits.
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include "ctr/diagnosis/effect.hpp"
#include "ctr/diagnosis/forward_model.hpp"
#include "ctr/diagnosis/registration.hpp"
#include "ctr/io/recording.hpp"

namespace ctr::diagnosis {

/// @brief Shape of a generated actuation sequence.
enum class ActuationPattern {
  Sweep,       ///< The paper's protocol: tubes 2..n rotated 0..360 deg and back in steps (tube 1 fixed).
  Random,      ///< Independent random configurations in random order (no smooth history).
  RandomWalk,  ///< Smooth random trajectory with direction reversals (like a teleoperated robot).
};

/// @brief "sweep" / "random" / "random-walk".
const char* toString(ActuationPattern pattern);

/// @brief Options of makeActuation().
struct ActuationOptions {
  ActuationPattern pattern = ActuationPattern::Sweep;
  int rows = 73;                   ///< Rows (Sweep: derived from step_deg when rows <= 0).
  double step_deg = 10.0;          ///< Sweep step (deg).
  double sweep_range_deg = 360.0;  ///< Sweep range (deg).
  bool translate = false;          ///< Also vary the innermost tube's translation within its admissible range.
  double dt = 0.1;                 ///< Time step (s) of the generated `time` column; <= 0: no time column.
  double max_speed = 1.0;          ///< RandomWalk: largest rotation speed (rad/s).
  /// Random: the fraction of poses that return to an earlier pose of the set (a pose set measured with returns).
  double returns = 0.0;
  /// Every pose logged this many times in a row (repeated frames of a tracker while the robot rests).
  int frames = 1;
  std::uint64_t seed = 1;
};

/// @brief Commanded actuation (and time when dt > 0) for the robot. Tube 1 stays at alpha = 0.
void makeActuation(const Robot& robot, const ActuationOptions& options, std::vector<Configuration>& commands,
                   Eigen::VectorXd& time);

/// @brief Measurement noise and content of a simulated recording.
struct SimulationOptions {
  double twist_sd = 0.5 * 3.14159265358979 / 180;    ///< rad
  double position_sd = 1e-4;                         ///< m, per component
  double tangent_sd = 0.2 * 3.14159265358979 / 180;  ///< per component, then renormalised
  /// Repeatability: an error drawn once per visit of a pose (consecutive rows with the same command) and added to
  /// every frame of the visit, on top of the per-row noise above (which is then the tracker's jitter).
  double repeatability_position_sd = 0.0;    ///< m, per component
  double repeatability_tangent_sd = 0.0;     ///< per component, then renormalised
  bool twist = true;                         ///< Record twist.
  bool tip_position = true;                  ///< Record tip position.
  bool tip_tangent = true;                   ///< Record tip tangent.
  std::optional<Registration> sensor_frame;  ///< Express tips in a sensor frame (for --frame unknown cases).
  std::uint64_t seed = 1;
  /// The replay; its equilibria are integrated at the library's default steps (KinematicsOptions), finer than a
  /// diagnosis replays with, so that a diagnosis of a simulated recording does not share its discretisation.
  PredictOptions predict;
  SimulationOptions() {
    const KinematicsOptions library;
    predict.replay.friction.kinematics.max_step = library.max_step;
    predict.replay.friction.kinematics.max_bending_per_step = library.max_bending_per_step;
  }
};

/// @brief A recording of the robot with the effects present (the same forward model as the fit), plus noise.
/// `time` may be empty. Throws std::runtime_error if more than 10 % of rows fail to solve.
io::Recording simulateRecording(const Robot& nominal, const std::vector<Configuration>& commands,
                                const Eigen::VectorXd& time, const std::vector<Effect>& effects,
                                const SimulationOptions& options = {});

}  // namespace ctr::diagnosis
