/// @file space.hpp
/// @brief The design space of a patient-specific robot (docs/design.md): per tube the ranges of its straight and
/// curved lengths and of its precurvature and the catalogue sizes it may use, the material, the strain limit, the
/// nesting clearance and the actuation's translation rule. A candidate is a point of that space; it becomes a normal
/// robot description (ctr::Robot) by makeRobot().
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "ctr/model/configuration.hpp"
#include "ctr/model/robot.hpp"

namespace ctr::design {

/// @brief A closed interval [min, max] (min == max: fixed).
struct Range {
  double min = 0.0, max = 0.0;
  bool fixed() const { return min == max; }
  bool contains(double v, double tol = 1e-12) const { return v >= min - tol && v <= max + tol; }
};

/// @brief An available tube size (stock superelastic nitinol tubing).
struct TubeSize {
  std::string name;
  double outer_diameter = 0.0;  ///< m
  double inner_diameter = 0.0;  ///< m (outer - 2 x wall thickness)
};

/// @brief Material of every tube.
struct Material {
  double youngs_modulus = 60e9;  ///< Pa (superelastic nitinol, austenite)
  double poisson_ratio = 0.33;
  double density = 0.0;  ///< kg/m^3; 0: the robot is weightless (no linear_density written)
};

/// @brief The ranges of one tube (outermost first).
struct TubeSpace {
  std::string name;
  Range straight_length;   ///< m
  Range curved_length;     ///< m
  Range curvature;         ///< 1/m
  std::vector<int> sizes;  ///< Indices into DesignSpace::catalogue this tube may use (never empty).
  std::optional<std::array<double, 2>> rotation_limits;  ///< Kept from the robot the space was derived from.
};

/// @brief Translation limits of every tube, from its length L: [min_extension - L, min(0, max_extension - L)], i.e.
/// its distal end lies between min_extension and max_extension beyond the base (the actuation unit's front).
struct Actuation {
  double max_extension = 0.16;  ///< m
  double min_extension = 0.0;   ///< m (0: the tube can retract fully)
};

/// @brief A design space (YAML, docs/design.md; or derived from a robot by defaultSpace()).
struct DesignSpace {
  std::string file;  ///< Source, for messages ("" when derived).
  std::string name = "design";
  std::vector<TubeSize> catalogue;
  std::vector<TubeSpace> tubes;
  Material material;
  double strain_limit = 0.06;       ///< Largest precurvature x outer radius (superelastic nitinol: 6 %).
  double nesting_clearance = 5e-5;  ///< m: inner_diameter(i) - outer_diameter(i + 1) >= this.
  Actuation actuation;
  /// Each inner tube is at least this much longer than the tube around it (m; its total length, so that it can still
  /// extend when the outer tubes are retracted).
  double length_step = 0.0;
  /// Size combinations (one catalogue index per tube) that nest with the clearance, in lexicographic order.
  std::vector<std::vector<int>> size_combinations() const;
};

/// @brief One candidate design: per tube its lengths, precurvature and catalogue size.
struct Candidate {
  struct TubeDesign {
    double straight_length = 0.0, curved_length = 0.0, curvature = 0.0;
    int size = 0;  ///< Catalogue index.
  };
  std::vector<TubeDesign> tubes;
};

/// @brief Parses a design space file; throws ctr::io::InputError naming the file, line and key (unknown keys, wrong
/// types, impossible ranges, sizes that cannot nest, a space without any candidate within the constraints).
DesignSpace loadSpace(const std::string& path);
/// @brief Parses design space text (`source` names it in messages).
DesignSpace parseSpace(const std::string& text, const std::string& source);

/// @brief The space derived from a robot: the same tube count and diameters (a catalogue of the robot's own sizes,
/// each tube its own), its material (E, Poisson ratio from the first tube) and its translation rule; straight and
/// curved lengths free within +-50 %, precurvatures within [0.25, 4] x the robot's (within the strain limit); straight
/// tubes stay straight. Throws std::invalid_argument when the robot lacks diameters or its tubes do not nest.
DesignSpace defaultSpace(const Robot& robot, double strain_limit = 0.06);

/// @brief Why the candidate violates the space ("" when it does not): a value outside its range, a size not allowed,
/// strain above the limit, diameters or lengths that do not nest, no admissible translation.
std::string violation(const DesignSpace& space, const Candidate& c);

/// @brief Strain of tube i of the candidate: precurvature x outer radius.
double strain(const DesignSpace& space, const Candidate& c, int i);

/// @brief The robot of a candidate: tube names and rotation limits from the space, diameters from the catalogue,
/// stiffnesses and (with a density) linear densities from the material, translation limits from the actuation rule;
/// friction and loads from `base` (the query's robot). Throws std::invalid_argument for a candidate that violates
/// the space.
Robot makeRobot(const DesignSpace& space, const Candidate& c, const Robot& base, const std::string& name);

/// @brief The candidate of a robot within the space (sizes matched by diameters), or nullopt when the robot is not
/// a point of the space.
std::optional<Candidate> candidateOf(const DesignSpace& space, const Robot& robot);

/// @brief A start configuration for the designed robot: every tube keeps its rotation and the position of its distal
/// end (beta_i + L_i) in `start` on `base`; projected onto the admissible set when it is off by rounding only.
/// Returns false when that start is not admissible for the designed robot.
bool adaptStart(const Robot& base, const Configuration& start, const Robot& designed, Configuration& out);

/// @brief The number of continuous coordinates of a candidate in the unit cube (3 per tube).
int continuousDimension(const DesignSpace& space);
/// @brief The candidate at the unit-cube point x (each coordinate mapped linearly onto its range) with size
/// combination `combo` (an index into size_combinations()), repaired to satisfy the constraints: curvature clamped
/// to the strain limit of its size, inner tubes lengthened (straight part) to nest in length. Returns nullopt if the
/// repair cannot satisfy every constraint.
std::optional<Candidate> candidateAt(const DesignSpace& space, const std::vector<double>& x, std::size_t combo);
/// @brief The unit-cube point of a candidate (inverse of candidateAt for a candidate within the space).
std::vector<double> unitPoint(const DesignSpace& space, const Candidate& c);

/// @brief The space as YAML (loadSpace reads it back): the default space is written beside a design's result.
std::string spaceToYaml(const DesignSpace& space);

}  // namespace ctr::design
