/// @file environment_yaml.hpp
/// @brief Environment description (YAML, see docs/environments.md): obstacle sources, optional "stay inside" region,
/// base pose, named starts and targets; parsing with file/line/key errors, and building into an Environment.
///
/// Paths inside a description resolve relative to the description file's folder.
#pragma once

#include <Eigen/Geometry>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "ctr/environments/environment.hpp"
#include "ctr/environments/nifti_source.hpp"
#include "ctr/environments/procedural.hpp"

namespace ctr::environments {

/// @brief One source of occupied (or, for stay_inside, free) space.
struct SourceSpec {
  enum class Kind { Nifti, Mesh, Points, OcTree, Procedural };
  Kind kind = Kind::Nifti;
  std::string path;   ///< Resolved file path (empty for procedural).
  std::string where;  ///< "FILE:LINE" of the entry, for messages.
  int line = 0;
  // NIfTI
  NiftiSelection selection;
  NiftiAffine affine = NiftiAffine::Auto;
  NiftiSampling sampling = NiftiSampling::Conservative;
  // Mesh / points: scale (from `units`) and a rigid transform applied after scaling.
  double scale = 1.0;
  Eigen::Isometry3d transform = Eigen::Isometry3d::Identity();
  bool fill = false;          ///< Mesh: solid fill (closed meshes only).
  double point_radius = 0.0;  ///< Points: occupy cells within this distance of each point (m).
  // Procedural
  ProceduralSpec procedural;
};

/// @brief A parsed environment description (nothing loaded yet).
struct EnvironmentDescription {
  std::string name;
  std::string file;          ///< The YAML file (empty when parsed from text without a file).
  double resolution = 1e-3;  ///< Octree leaf size (m).
  std::vector<SourceSpec> obstacles;
  std::optional<SourceSpec> stay_inside;
  Aabb crop;              ///< Optional `bounds:` crop of the mapped region (empty: no crop).
  double padding = 0.0;   ///< Extra free margin around the sources (m).
  bool mark_free = true;  ///< Mapped non-obstacle cells are known free (false: left unknown).
  std::optional<NamedPose> base_pose;
  std::string base_start;  ///< `base_pose: {start: NAME}`: use that named start.
  std::vector<NamedPose> starts;
  std::vector<NamedTarget> targets;
  CollisionDefaults collision;
  bool check_targets = true;  ///< Targets must lie inside the map bounds.
};

/// @brief Parses a description file. Throws ctr::io::InputError naming file, line and key for malformed YAML,
/// unknown or missing keys, bad values, missing Med-MPD start/target files, and unknown procedural types.
EnvironmentDescription loadEnvironmentDescription(const std::string& path);
/// @brief Parses description text; relative paths resolve against `base_dir`; `source` names it in messages.
EnvironmentDescription parseEnvironmentDescription(const std::string& text, const std::string& source,
                                                   const std::string& base_dir = ".");

/// @brief Options of building.
struct BuildOptions {
  std::optional<double> resolution;             ///< Overrides the description's resolution (e.g. coarser for tests).
  std::size_t max_cells = 600000000;            ///< Refuse grids larger than this.
  std::function<void(const std::string&)> log;  ///< Progress messages (optional).
};

/// @brief Loads every source and builds the octree, base pose, starts and targets. Throws ctr::io::InputError
/// for bad inputs (missing/corrupt files, empty meshes, unknown labels, a target outside the map, ...).
Environment buildEnvironment(const EnvironmentDescription& description, const BuildOptions& options = {});

/// @brief loadEnvironmentDescription + buildEnvironment.
Environment loadEnvironment(const std::string& path, const BuildOptions& options = {});

}  // namespace ctr::environments
