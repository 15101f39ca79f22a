/// @file effect.hpp
/// @brief Candidate physics left out of the nominal model ("effects"): names, parameters and how each one
/// modifies the robot, the actuation or the measurement (formats.md, diagnosis effect table).
#pragma once

#include <string>
#include <vector>

#include "ctr/model/robot.hpp"

namespace ctr::diagnosis {

/// @brief Kind of a left-out effect. The JSON names are those of formats.md.
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
};

/// @brief All kinds, in the order of formats.md.
const std::vector<EffectKind>& allEffectKinds();
/// @brief JSON name of a kind (e.g. "boundary_friction").
const char* effectName(EffectKind k);
/// @brief Name of the kind's continuous parameter (e.g. "mu", "poisson_ratio", "width").
const char* parameterName(EffectKind k);
/// @brief Unit of the parameter, for reports ("", "1/m", "N m^2", "rad", "s").
const char* parameterUnit(EffectKind k);
/// @brief True for kinds that act on one tube (parameter `tube`).
bool isPerTube(EffectKind k);
/// @brief True for kinds whose output depends on the history of the actuation (friction, backlash).
bool isStateful(EffectKind k);
/// @brief Look-alike group of a kind: 1 = "lag" (the shape lags the command and depends on the direction of
/// motion: boundary/distributed friction, sensor latency, rotary/linear backlash), 2 = "shift" (the shape is that of
/// a shifted configuration: rotary/linear offsets, torsional stiffness), 0 = none. A recording may not tell the
/// members of a group apart: a candidate is tested against its rivals of the group before it is accepted, and
/// screened with the accepted members of its group refitted.
int lookAlikeGroup(EffectKind k);
/// @brief lookAlikeGroup(k) != 0.
bool isLookAlike(EffectKind k);
/// @brief Parses a JSON name; throws std::invalid_argument listing the valid names.
EffectKind parseEffectKind(const std::string& name);

/// @brief One effect with its value. `tube` is 1-based (0 when the kind is not per tube).
struct Effect {
  EffectKind kind = EffectKind::BoundaryFriction;
  int tube = 0;        ///< 1-based tube for per-tube kinds, else 0.
  double value = 0.0;  ///< The parameter (mu, poisson_ratio, curvature, bending_stiffness, width, offset, delay).
                       ///< Translation backlash and offset in metres.

  /// @brief "precurvature[tube 2]" or "boundary_friction".
  std::string label() const;
  /// @brief Same kind and tube (the value may differ).
  bool sameSlot(const Effect& o) const { return kind == o.kind && tube == o.tube; }
};

/// @brief Parses "name:key=value,key=value" (e.g. "actuator_backlash:tube=2,width=0.2" or
/// "boundary_friction:mu=0.12"); angles accept a `deg` suffix. Throws std::invalid_argument.
Effect parseEffect(const std::string& text);

/// @brief The robot with the robot-side effects applied (friction, stiffness, precurvature). Actuation and
/// measurement effects (backlash, offset, latency) leave the robot unchanged.
Robot applyToRobot(const Robot& nominal, const std::vector<Effect>& effects);

/// @brief The nominal value of an effect's parameter for the robot (0 for friction/backlash/offset/latency,
/// the description's Poisson ratio, curvature or stiffness otherwise): the "left out" value.
double nominalValue(const Robot& nominal, EffectKind kind, int tube);

}  // namespace ctr::diagnosis
