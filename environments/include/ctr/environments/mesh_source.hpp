/// @file mesh_source.hpp
/// @brief Triangle meshes (STL, OBJ, PLY, ... through assimp): loading, closedness check, surface voxelisation
/// (exact triangle/box overlap) and optional solid fill of closed meshes.
#pragma once

#include <Eigen/Geometry>
#include <array>
#include <string>
#include <vector>

#include "ctr/environments/aabb.hpp"
#include "ctr/environments/voxel_grid.hpp"

namespace ctr::environments {

/// @brief An indexed triangle mesh in the world frame (m). Vertices with identical coordinates are welded.
struct TriangleMesh {
  std::vector<Eigen::Vector3d> vertices;
  std::vector<std::array<int, 3>> triangles;

  /// @brief World AABB of the vertices.
  Aabb extent() const;
  /// @brief Number of edges used by exactly one triangle, or by more than two (0 for a closed 2-manifold).
  std::size_t openEdges() const;
  /// @brief Whether every edge is shared by exactly two triangles.
  bool closed() const { return openEdges() == 0; }
};

/// @brief Reads a mesh with assimp and applies `scale` (e.g. 1e-3 for millimetres) then `transform`.
/// Throws ctr::io::InputError for a missing/unreadable file, an unsupported format or a mesh without triangles.
TriangleMesh loadMesh(const std::string& path, double scale = 1.0,
                      const Eigen::Isometry3d& transform = Eigen::Isometry3d::Identity());

/// @brief Sets to `value` every grid cell whose box intersects a triangle (exact separating-axis test, with the
/// cell grown by `grow` metres to stay conservative under rounding).
void voxelizeSurface(const TriangleMesh& mesh, VoxelGrid& grid, std::uint8_t value = VoxelGrid::kOccupied,
                     double grow = 1e-9);

/// @brief Solid voxelisation of a closed mesh: surface cells plus every cell enclosed by them (flood fill from the
/// outside). When `interior_only` is set, sets only the enclosed cells that do not touch the surface. Throws
/// ctr::io::InputError (naming `source`) if the mesh is not closed.
void voxelizeSolid(const TriangleMesh& mesh, VoxelGrid& grid, std::uint8_t value = VoxelGrid::kOccupied,
                   bool interior_only = false, const std::string& source = "mesh");

/// @brief Writes an ASCII STL (for tests and tools).
void writeStl(const std::string& path, const TriangleMesh& mesh);

}  // namespace ctr::environments
