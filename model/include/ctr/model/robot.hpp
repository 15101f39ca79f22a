/// @file robot.hpp
/// @brief Constant description of a concentric tube robot (tubes, stiffnesses, friction coefficients).
#pragma once

#include <array>
#include <optional>
#include <string>
#include <vector>

#include "ctr/model/actuation.hpp"
#include "ctr/model/loads.hpp"

namespace ctr {

/// @brief One precurved tube: a straight proximal part followed by a constant-curvature distal part.
///
/// Units are SI (m, 1/m, N m^2). Tubes are numbered 1..n from the outermost (docs/formats.md).
struct Tube {
  std::string name;                  ///< Human-readable name (used in error messages).
  double straight_length = 0.0;      ///< Proximal straight length (m).
  double curved_length = 0.0;        ///< Distal precurved length (m).
  double curvature = 0.0;            ///< Precurvature of the curved part (1/m); bends toward tube-frame +x.
  double bending_stiffness = 0.0;    ///< E*I (N m^2).
  double torsional_stiffness = 0.0;  ///< G*J (N m^2).
  std::optional<double> poisson_ratio;  ///< Kept when the description gave it (G*J = E*I / (1 + nu)).
  double outer_diameter = 0.0;       ///< Outer diameter (m); 0 if unknown.
  double inner_diameter = 0.0;       ///< Inner diameter (m); 0 if unknown.
  double linear_density = 0.0;       ///< Mass per unit length (kg/m) for gravity; 0 if unknown (weightless).
  std::optional<std::array<double, 2>> rotation_limits;     ///< [min, max] of alpha (rad).
  std::optional<std::array<double, 2>> translation_limits;  ///< [min, max] of beta (m).
  Drive rotation_drive;     ///< Between the rotation command and alpha (ideal by default; actuation.hpp).
  Drive translation_drive;  ///< Between the translation command and beta (ideal by default).

  /// @brief Total length straight + curved (m).
  double length() const { return straight_length + curved_length; }
};

/// @brief Friction coefficients of the robot (docs/formats.md `friction:` block). Zero means frictionless.
struct FrictionCoefficients {
  double boundary = 0.0;     ///< Lumped coefficient mu' of the concentrated-moment friction (paper eq. 34-35).
  double distributed = 0.0;  ///< Coulomb coefficient mu of the distributed contact friction (paper eq. 15-21).
};

/// @brief An immutable, validated robot description. Share it between threads freely.
class Robot {
public:
  /// @brief Builds and validates a robot. Throws std::invalid_argument naming the tube and key on bad values.
  Robot(std::string name, std::vector<Tube> tubes, FrictionCoefficients friction = {}, Loads loads = {});

  const std::string& name() const { return name_; }
  /// @brief Number of tubes n.
  int size() const { return static_cast<int>(tubes_.size()); }
  /// @brief Tube i, 0-based (tube 1 of the paper is tube(0)).
  const Tube& tube(int i) const { return tubes_.at(static_cast<std::size_t>(i)); }
  const std::vector<Tube>& tubes() const { return tubes_; }
  const FrictionCoefficients& friction() const { return friction_; }
  /// @brief External loads (base frame); empty() for the load-free (torsion-only) model.
  const Loads& loads() const { return loads_; }
  /// @brief True when some tube has a linear density, i.e. gravity acts on the robot.
  bool hasWeight() const;

  /// @brief A copy with other friction coefficients.
  Robot withFriction(FrictionCoefficients f) const;
  /// @brief A copy with other external loads (validated again).
  Robot withLoads(const Loads& loads) const;
  /// @brief A copy whose drives are all ideal (the physics of the tubes alone: commands are joints).
  Robot withoutActuation() const;
  /// @brief A copy with one tube replaced (validated again).
  Robot withTube(int i, const Tube& t) const;

private:
  std::string name_;
  std::vector<Tube> tubes_;
  FrictionCoefficients friction_;
  Loads loads_;
};

/// @brief Validates a tube; returns an empty string or "tube 'name' (k): key 'x': what is wrong".
std::string validateTube(const Tube& t, int index);

}  // namespace ctr
