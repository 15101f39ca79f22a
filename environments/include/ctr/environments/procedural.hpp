/// @file procedural.hpp
/// @brief Synthetic anatomies, deterministic given a seed: an intracardiac chamber (right/left atrium with a septum
/// and foramen, tricuspid valve with leaflets and chordae), a branching airway (lumen tree) and a narrow
/// transnasal skull-base passage. Every one is a "stay inside" anatomy: only the lumen is free.
///
/// Geometry is built from simple primitives with 1-Lipschitz implicit functions, so rasterisation is conservative:
/// a cell is free only if it lies entirely inside the lumen and touches no obstacle.
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "ctr/environments/aabb.hpp"
#include "ctr/environments/environment.hpp"
#include "ctr/environments/voxel_grid.hpp"

namespace ctr::environments {

/// @brief What to generate. `params` holds the type's optional numeric parameters (see proceduralParameters()).
struct ProceduralSpec {
  std::string type;                      ///< "intracardiac", "airway" or "sinus".
  std::uint64_t seed = 1;                ///< Same seed, same anatomy (bit-identical octree).
  double scale = 1.0;                    ///< Uniform scale of the anatomy about the world origin.
  std::map<std::string, double> params;  ///< Type-specific parameters, SI units.
};

/// @brief One implicit primitive (world frame, m). g(p) < 0 inside; |g| is a lower bound of the distance to the
/// surface (1-Lipschitz). Holes are subtracted.
struct Primitive {
  enum class Kind { Ellipsoid, Capsule, Cylinder, Box, Torus };
  Kind kind = Kind::Ellipsoid;
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();                          ///< Ellipsoid / box / torus centre.
  Eigen::Vector3d a = Eigen::Vector3d::Zero(), b = Eigen::Vector3d::Zero();  ///< Capsule / cylinder axis ends.
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();                    ///< world_R_local (torus axis = local z).
  Eigen::Vector3d radii = Eigen::Vector3d::Zero();                           ///< Ellipsoid radii / box half sizes.
  double radius = 0.0;        ///< Capsule / cylinder radius, torus tube radius, box edge rounding.
  double major_radius = 0.0;  ///< Torus ring radius.
  std::vector<Primitive> holes;
  std::string name;

  double g(const Eigen::Vector3d& p) const;
  Aabb bounds() const;
};

/// @brief A generated anatomy: lumen and obstacle primitives, start pose and named targets.
struct ProceduralAnatomy {
  std::string type;
  std::uint64_t seed = 0;
  std::vector<Primitive> lumen;      ///< Union of these is the free space.
  std::vector<Primitive> obstacles;  ///< Solid structures inside the lumen.
  NamedPose start;                   ///< Suggested base pose (inside the lumen, +z into the anatomy).
  std::vector<NamedTarget> targets;
  std::string description;
  /// @brief Region to map: the lumen's bounds plus a wall margin.
  Aabb extent(double wall = 3e-3) const;
};

/// @brief Known types.
std::vector<std::string> proceduralTypes();
/// @brief Parameters of a type with their defaults (SI units) and a one-line meaning each.
std::map<std::string, std::pair<double, std::string>> proceduralParameters(const std::string& type);

/// @brief Generates the anatomy. Throws std::invalid_argument for an unknown type or parameter, or a value out of
/// range.
ProceduralAnatomy makeProcedural(const ProceduralSpec& spec);

/// @brief Rasterises into `grid`: cells entirely inside the lumen and clear of every obstacle become kFree,
/// all others kOccupied.
void rasterizeProcedural(const ProceduralAnatomy& anatomy, VoxelGrid& grid);

}  // namespace ctr::environments
