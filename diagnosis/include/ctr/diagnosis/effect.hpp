/// @file effect.hpp
/// @brief Candidate physics left out of the nominal model ("effects"): names, parameters and how each one
/// modifies the robot, the actuation or the measurement (docs/formats.md "Diagnosis", effect table).
#pragma once

#include <Eigen/Core>
#include <array>
#include <string>
#include <vector>

#include "ctr/model/robot.hpp"

namespace ctr::diagnosis {

/// @brief Kind of a left-out effect. The JSON names are those of docs/formats.md ("Diagnosis").
enum class EffectKind {
  BoundaryFriction,     ///< `boundary_friction`: stick-slip Coulomb torque mu' |m| at concentrated moments.
  DistributedFriction,  ///< `distributed_friction`: Coulomb friction of the distributed contact forces.
  TorsionalStiffness,   ///< `torsional_stiffness`: Poisson ratio (G J = E I / (1 + nu)), all tubes.
  Precurvature,         ///< `precurvature`: one tube's precurvature (1/m).
  BendingStiffness,     ///< `bending_stiffness`: one tube's E I (N m^2); only ratios are observable.
  ActuatorBacklash,     ///< `actuator_backlash`: dead band (play) of full width w in one tube's rotation drive.
  ActuatorOffset,       ///< `actuator_offset`: constant offset between commanded and true rotation of one tube.
  SensorLatency,        ///< `sensor_latency`: measurement at time t shows the robot commanded at t - delay.
  TranslationBacklash,  ///< `translation_backlash`: dead band (play) of full width w (m) in one tube's linear stage.
  TranslationOffset,    ///< `translation_offset`: constant offset (m) between commanded and true translation.
  /// `gravity`: the robot's own weight. Parameters `scale` and `direction` (unit vector, base frame): the gravity
  /// vector is kStandardGravity * scale * direction, acting on each tube's linear density -- the description's, or,
  /// when no tube of the description has one, kNitinolDensity times the tube's cross-section from its diameters (an
  /// assumption, reported; tubes without diameters stay weightless). Replaces the description's gravity. Fitted as
  /// the 3-vector scale * direction (Effect::vec), so the direction is always fitted.
  Gravity,
  /// `tip_load`: a constant external force at the tip, `force` (N, base frame; Effect::vec). Replaces the
  /// description's tip force (its tip moment is kept).
  TipLoad,
  // Generic models of physics outside the library (isGeneric): never named in a verdict; they describe a remainder.
  /// `drive_ratio`: a ratio error of one rotation drive, delta alpha = c0 alpha (Effect::coef): the tube turns
  /// 1 + c0 times the commanded angle from the drive's zero.
  DriveRatio,
  /// `drive_periodic`: a periodic transmission error of one rotation drive, one and two cycles per turn of the
  /// drive's own angle: delta alpha = c0 cos alpha + c1 sin alpha + c2 cos 2 alpha + c3 sin 2 alpha (Effect::coef).
  DrivePeriodic,
  /// `stage_error`: a smooth error of one translation stage, delta beta = c0 u + c1 u^2 + c2 u^3 with u the stage's
  /// command scaled to [-1, 1] over the recording (Effect::coef, Effect::ref = centre and half-range).
  StageError,
  /// `tracker_drift`: the measured tip positions drift linearly with time from the start of the recording,
  /// delta p = d (t - t0) / T (a 3-vector, base frame; t0 and T = the first time and the duration, Effect::ref;
  /// Effect::coef = d, the drift over the whole recording).
  TrackerDrift,
};

/// @brief Standard gravity (m/s^2): the `gravity` effect's scale 1.
constexpr double kStandardGravity = 9.81;
/// @brief Density of nitinol (kg/m^3): the weight the `gravity` effect assumes when the description gives no tube a
/// linear density (superelastic NiTi, 6,450 kg/m^3).
constexpr double kNitinolDensity = 6450.0;

/// @brief All kinds of the library (docs/formats.md), in its order; the generic kinds are not among them.
const std::vector<EffectKind>& allEffectKinds();
/// @brief The generic kinds (drive_ratio, drive_periodic, stage_error, tracker_drift).
const std::vector<EffectKind>& genericEffectKinds();
/// @brief True for the generic models of physics outside the library.
bool isGeneric(EffectKind k);
/// @brief JSON name of a kind (e.g. "boundary_friction").
const char* toString(EffectKind k);
/// @brief Name of the kind's (first) continuous parameter (e.g. "mu", "poisson_ratio", "width"; "scale" for
/// gravity, "force" for tip_load).
const char* parameterName(EffectKind k);
/// @brief Unit of the parameter, for reports ("", "1/m", "N m^2", "rad", "s", "N").
const char* parameterUnit(EffectKind k);
/// @brief Number of fitted coordinates of a kind: 1 (Effect::value), 3 for the vector kinds gravity and tip_load
/// (Effect::vec), 1, 4, 3 and 3 for the generic kinds (Effect::coef). A model's parameter count (BIC) is the sum over
/// its effects.
int parameterCount(EffectKind k);
/// @brief True for kinds that act on one tube (parameter `tube`).
bool isPerTube(EffectKind k);
/// @brief True for kinds whose output depends on the history of the actuation (friction, backlash).
bool isStateful(EffectKind k);
/// @brief Look-alike group of a kind: 1 = "lag" (the shape lags the command and depends on the direction of
/// motion: boundary/distributed friction, sensor latency, rotary/linear backlash), 2 = "shift" (the shape is that of
/// a shifted configuration: rotary/linear offsets, torsional stiffness), 3 = "load" (external loads: gravity,
/// tip_load), 0 = none. A recording may not tell look-alikes apart: a candidate is tested against its rival
/// look-alikes before it is accepted, and screened with its accepted look-alikes refitted (areLookAlikes).
int lookAlikeGroup(EffectKind k);
/// @brief True when a recording may not tell a and b apart: the same non-zero group, or a load (group 3) and a
/// bending shape parameter (precurvature, bending_stiffness), which bend the robot like a load does. Precurvature
/// and bending stiffness are not look-alikes of each other.
bool areLookAlikes(EffectKind a, EffectKind b);
/// @brief True when the kind has a look-alike (areLookAlikes with some kind).
bool isLookAlike(EffectKind k);
/// @brief The physics a kind stands for, in a sentence for reports (what it is and how it shows in a recording).
std::string describePhysics(EffectKind k);
/// @brief Parses a JSON name; throws std::invalid_argument listing the valid names.
EffectKind parseEffectKind(const std::string& name);

/// @brief One effect with its value. `tube` is 1-based (0 when the kind is not per tube).
struct Effect {
  EffectKind kind = EffectKind::BoundaryFriction;
  int tube = 0;        ///< 1-based tube for per-tube kinds, else 0.
  double value = 0.0;  ///< The parameter (mu, poisson_ratio, curvature, bending_stiffness, width, offset, delay).
                       ///< Translation backlash and offset in metres. Unused (0) by the vector kinds.
  /// Vector kinds (parameterCount(kind) == 3), base frame: tip_load's force (N); gravity's scale * direction
  /// (the gravity vector over kStandardGravity). Zero for the other kinds.
  Eigen::Vector3d vec = Eigen::Vector3d::Zero();
  /// Generic kinds: their coefficients (parameterCount of them used); zero otherwise.
  Eigen::Matrix<double, 6, 1> coef = Eigen::Matrix<double, 6, 1>::Zero();
  /// Generic kinds: the reference of their variable (drive_ratio: the drive's zero, 0; stage_error: centre and
  /// half-range of the command; tracker_drift: the first time and the duration).
  Eigen::Vector2d ref = Eigen::Vector2d(0.0, 1.0);

  /// @brief "precurvature[tube 2]" or "boundary_friction".
  std::string label() const;
  /// @brief Same kind and tube (the value may differ).
  bool sameSlot(const Effect& o) const { return kind == o.kind && tube == o.tube; }
  /// @brief Fitted coordinate i (0 <= i < parameterCount(kind)): value, or vec[i].
  double coordinate(int i) const;
  /// @brief Sets fitted coordinate i.
  void setCoordinate(int i, double v);
  /// @brief gravity: the scale |vec| (1 = the standard gravity).
  double gravityScale() const { return vec.norm(); }
  /// @brief gravity: the unit direction vec / |vec| in the base frame (-z when the scale is 0).
  Eigen::Vector3d gravityDirection() const;
  /// @brief The parameters in words, e.g. "mu = 0.118", "force = (0.05, 0, -0.1) N",
  /// "scale = 1.02, direction = (0, -1, 0)".
  std::string valueText() const;
  /// @brief Generic kinds: the correction at a value of their variable (drive_*: delta alpha (rad) at alpha;
  /// stage_error: delta beta (m) at beta; tracker_drift: the x, y or z (`axis`) drift at time x).
  double genericAt(double x, int axis = 0) const;
};

/// @brief Parses "name:key=value,key=value" (e.g. "actuator_backlash:tube=2,width=0.2" or
/// "boundary_friction:mu=0.12"); angles accept a `deg` suffix. Vector parameters take three comma-separated
/// numbers: "tip_load:force=0.05,0,-0.1" (N, base frame), "gravity:scale=1,direction=0,-1,0" (direction
/// normalised; scale defaults to 1). Throws std::invalid_argument.
Effect parseEffect(const std::string& text);

/// @brief Uncertainty of an effect's fitted coordinates: 95 % interval of each coordinate and their covariance
/// (coordinate units), from which the intervals of derived parameters (gravity scale and direction) follow.
/// Empty when not computed (or the effect was held in the fit).
struct EffectUncertainty {
  std::vector<std::array<double, 2>> interval95;  ///< Per coordinate.
  Eigen::MatrixXd covariance;                     ///< Coordinates x coordinates.
  bool empty() const { return interval95.empty(); }
};

/// @brief A reported parameter of an effect: one number (`mu`, `scale`, `tube`) or a 3-vector (`force`,
/// `direction`), with its 95 % intervals (one per component; empty when unknown).
struct NamedParameter {
  std::string name;
  std::vector<double> value;
  std::vector<std::array<double, 2>> interval95;
};

/// @brief The parameters of an effect as reported (docs/formats.md effect table): `tube` (per-tube kinds), then the
/// kind's parameter(s): gravity -> `scale`, `direction`; tip_load -> `force`. Intervals from `u` when given (gravity:
/// scale and direction by the delta method from the covariance of scale * direction).
std::vector<NamedParameter> namedParameters(const Effect& e, const EffectUncertainty* u = nullptr);

/// @brief The robot with the robot-side effects applied (friction, stiffness, precurvature, loads: gravity and
/// tip_load replace the description's gravity / tip force, the other loads are kept). Actuation and measurement
/// effects (backlash, offset, latency) leave the robot unchanged.
Robot applyToRobot(const Robot& nominal, const std::vector<Effect>& effects);

/// @brief Puts a drive effect (actuator_backlash, actuator_offset, translation_backlash, translation_offset,
/// drive_ratio, drive_periodic, stage_error) into the drives of its tube: plays, offsets, ratio errors and periodic /
/// stage coefficients are added to what the drives hold (exact for plays and offsets, which compose by adding; first
/// order for the transmission errors), the references set. Returns false (drives unchanged) for the other kinds.
bool addDriveEffect(const Effect& e, Drive& rotation, Drive& translation);

/// @brief The robot as a description can carry it: applyToRobot, and the drive effects in its tubes' drives
/// (addDriveEffect: on top of the description's own drives). Measurement effects (sensor_latency, tracker_drift) are
/// not the robot's and leave it unchanged. Throws std::invalid_argument for a tube out of range or a drive value the
/// description refuses (e.g. a play wider than a turn).
Robot robotWithEffects(const Robot& nominal, const std::vector<Effect>& effects);

/// @brief The nominal value of an effect's parameter for the robot (0 for friction/backlash/offset/latency,
/// the description's Poisson ratio, curvature or stiffness otherwise): the "left out" value. Vector kinds: 0 (use
/// nominalEffect).
double nominalValue(const Robot& nominal, EffectKind kind, int tube);
/// @brief The effect at its nominal value for the robot: applyToRobot(nominal, {nominalEffect(...)}) is the nominal
/// model. gravity: the description's gravity / kStandardGravity when some tube has a linear density, else 0 (a
/// weightless description); tip_load: the description's tip force.
Effect nominalEffect(const Robot& nominal, EffectKind kind, int tube);
/// @brief Why the robot cannot carry a `gravity` effect ("" when it can): no tube has a linear density and none
/// has diameters to compute one.
std::string gravityUnavailable(const Robot& nominal);

}  // namespace ctr::diagnosis
