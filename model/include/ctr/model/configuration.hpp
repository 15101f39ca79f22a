/// @file configuration.hpp
/// @brief Actuator configuration (rotations alpha, translations beta) and its admissibility.
#pragma once

#include <Eigen/Core>
#include <string>

#include "ctr/model/actuation.hpp"
#include "ctr/model/robot.hpp"

namespace ctr {

/// @brief Actuator values of all tubes: rotations alpha_i (rad) and translations beta_i (m, <= 0).
struct Configuration {
  Eigen::VectorXd alpha;  ///< Rotation of each tube's proximal end about +z (rad).
  Eigen::VectorXd beta;   ///< Translation: tube i occupies s in [beta_i, beta_i + L_i] (m).

  Configuration() = default;
  Configuration(Eigen::VectorXd a, Eigen::VectorXd b) : alpha(std::move(a)), beta(std::move(b)) {}
  /// @brief n tubes with every rotation and every translation zero (all proximal ends at s = 0). Not admissible in
  /// general (checkAdmissible); defaultConfiguration(robot) gives the admissible default of a robot.
  static Configuration zeros(int n);
  int size() const { return static_cast<int>(alpha.size()); }
};

/// @brief Result of an admissibility check: ok, or which constraint is violated (its actuator as a value, and a
/// message in words).
struct Admissibility {
  /// The kind of actuator a violated constraint is about (None: sizes or values that are not numbers of a tube).
  enum class Actuator { None, Rotation, Translation };
  bool ok = true;
  Actuator actuator = Actuator::None;  ///< Rotation (alpha) or translation (beta) of `tube`.
  int tube = 0;                        ///< 1-based tube whose actuator the constraint names first (0: none).
  std::string message;
  explicit operator bool() const { return ok; }
};

/// @brief Checks sizes, finiteness, beta_n <= ... <= beta_1 <= 0, ordered distal ends
/// beta_1 + L_1 <= ... <= beta_n + L_n (docs/formats.md), the innermost tube protruding (beta_n + L_n > 0),
/// and the per-tube limits of the robot description.
Admissibility checkAdmissible(const Robot& robot, const Configuration& q, double tolerance = 1e-12);

/// @brief Tolerance (m for translations, rad for rotations) within which a configuration read from a file may
/// violate the nesting/ordering constraints and the per-tube limits and still be taken as admissible: it is then
/// projected onto the admissible set (docs/formats.md "Admissibility tolerance"). 1 um / 1e-6 rad: logged values
/// rounded to 1 um (6 decimals in metres, 3 in millimetres) put a constraint between two of them up to 1 um off,
/// while moving a tube end by 1 um moves the tip by less than 1 um, far below any tracker's noise. Larger
/// violations are errors.
inline constexpr double kAdmissibilityTolerance = 1e-6;

/// @brief Projects q onto the admissible set when it violates the constraints by no more than `tolerance`:
/// beta_1 <= 0, then for i = 2..n beta_i = min(beta_i, beta_{i-1}) and max(beta_i, beta_{i-1} + L_{i-1} - L_i)
/// (coincident distal ends, ordered exactly in floating point), and rotations/translations clamped to the tube
/// limits. Returns ok (q projected, every value moved by at most `tolerance`, checkAdmissible(robot, q) holds) or
/// the violated constraint of the unprojected q (q unchanged). A q that checkAdmissible already accepts is left
/// unchanged bit for bit.
Admissibility projectAdmissible(const Robot& robot, Configuration& q, double tolerance = kAdmissibilityTolerance);

/// @brief True when some tube's rotation or translation drive is not ideal (Tube::rotation_drive, translation_drive).
bool hasActuation(const Robot& robot);

/// @brief The tubes' joint values for a command through their drives (actuation.hpp): plays (updating `state`; a
/// drive without history takes its play as centred on this command), transmission errors, offsets; translations
/// then projected onto the admissible set (a stage cannot push a tube through the nesting order). The command
/// itself for a robot without actuation. Throws std::invalid_argument for a command of another size.
Configuration jointsOf(const Robot& robot, const Configuration& command, DriveState& state);

/// @brief The commands that put the tubes at `joints` from the drives' `state` (Drive::command per tube and joint:
/// plays taken up on the side of each move, transmission errors and offsets inverted): jointsOf(robot,
/// commandsFor(robot, joints, state), state) gives `joints` back (without translations projected by jointsOf). NaN
/// where a transmission cannot be inverted. Throws std::invalid_argument for joints of another size.
Configuration commandsFor(const Robot& robot, const Configuration& joints, const DriveState& state);

/// @brief The default configuration of the command line and the Python module: rotations 0, each tube's straight
/// part retracted (beta_i = -straight length), then made admissible (beta_{i+1} <= beta_i, ordered distal ends).
Configuration defaultConfiguration(const Robot& robot);

/// @brief Number of equal sub-steps of the straight move from `from` to `to` (both with the same number of tubes)
/// in which no rotation changes by more than max_rotation_step (rad) and no translation by more than
/// max_translation_step (m): ceil(max(max_i |d alpha_i| / max_rotation_step, max_i |d beta_i| / max_translation_step)),
/// at least 1 (also for no move). Rotations are the unwrapped commands: a move by 2 pi is a full turn, not none.
/// A move within kSubdivisionSlack of a step above a whole number of steps (the rounding of a move that is an exact
/// multiple of the step) takes that whole number. Every motion discretisation of the library uses this count with
/// interpolate(): the friction sub-steps of step(), continueTo(), the planner's motion checks and replay.
/// Throws std::invalid_argument for different sizes, a step size that is not positive, or a move that is not finite.
int subdivisions(const Configuration& from, const Configuration& to, double max_rotation_step,
                 double max_translation_step);

/// @brief Rounding allowance of subdivisions() (in steps).
inline constexpr double kSubdivisionSlack = 1e-9;

/// @brief The configuration a fraction t of the way along the straight move from `from` to `to`:
/// from + t (to - from) in every rotation and translation (unwrapped). t = 0 gives `from` and t = 1 gives `to`
/// exactly (bit for bit); sub-step k of n is interpolate(from, to, double(k) / n).
Configuration interpolate(const Configuration& from, const Configuration& to, double t);

/// @brief Distal end s_i = beta_i + L_i of tube i (0-based).
inline double distalEnd(const Robot& robot, const Configuration& q, int i) {
  return q.beta[i] + robot.tube(i).length();
}

}  // namespace ctr
