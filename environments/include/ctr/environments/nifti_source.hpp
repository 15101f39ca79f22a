/// @file nifti_source.hpp
/// @brief NIfTI-1/NIfTI-2 segmentations (`.nii`, `.nii.gz`, through Debian's libnifti): reading, voxel-to-world
/// affine (sform or qform), voxel selection by label or threshold, and rasterisation into a VoxelGrid.
///
/// World coordinates are the file's RAS+ frame; millimetres (the usual NIfTI unit) are converted to metres.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "ctr/environments/aabb.hpp"
#include "ctr/environments/voxel_grid.hpp"

namespace ctr::environments {

/// @brief Which NIfTI transform maps voxel indices to world coordinates.
enum class NiftiAffine {
  Auto,   ///< sform when sform_code > 0, else qform when qform_code > 0, else an error (default).
  Sform,  ///< The sform (srow_x/y/z); an error if sform_code == 0.
  Qform,  ///< The qform (quaternion + offsets + qfac); an error if qform_code == 0.
};

/// @brief "auto" / "sform" / "qform" (the environment YAML's `affine`).
const char* toString(NiftiAffine affine);

/// @brief A 3-D scalar volume and its affine.
class NiftiVolume {
 public:
  std::string path;
  Eigen::Vector3i dims = Eigen::Vector3i::Zero();              ///< nx, ny, nz.
  Eigen::Matrix4d ijk_to_world = Eigen::Matrix4d::Identity();  ///< Voxel index (i, j, k, 1) -> world (m).
  std::string affine_used;                                     ///< "sform" or "qform".
  int datatype = 0;                                            ///< NIfTI DT_* code.
  double scl_slope = 0.0;                                      ///< Intensity scaling (applied when slope != 0).
  double scl_inter = 0.0;
  double unit_to_metre = 1e-3;              ///< Scale of the file's spatial unit.
  std::shared_ptr<const std::uint8_t> raw;  ///< Voxel data as stored (bytes_per_voxel each, i fastest).
  int bytes_per_voxel = 0;

  std::size_t voxels() const { return static_cast<std::size_t>(dims.x()) * dims.y() * dims.z(); }
  /// @brief Scaled value of voxel number v (i + nx * (j + ny * k)).
  double value(std::size_t v) const;
  /// @brief Distinct values present (at most `limit`; stops early), sorted.
  std::vector<double> distinctValues(std::size_t limit = 256) const;
  /// @brief World AABB of the whole image (union of the voxel boxes).
  Aabb extent() const;
  /// @brief Voxel size along i, j, k (m).
  Eigen::Vector3d spacing() const;
};

/// @brief Reads a NIfTI file (data included). Throws ctr::io::InputError naming the file for: a missing or
/// unreadable file, a corrupt header or truncated data, dimensions that are not 3-D (a 4-D file with one volume is
/// accepted), an unsupported data type, no affine (qform_code = sform_code = 0), or the requested affine missing.
NiftiVolume readNifti(const std::string& path, NiftiAffine affine = NiftiAffine::Auto);

/// @brief Which voxels count. Labels and threshold may be combined (a voxel counts if either selects it);
/// with neither, every non-zero voxel counts.
struct NiftiSelection {
  std::vector<double> labels;       ///< Voxels whose scaled value equals one of these (to 1e-6).
  std::optional<double> threshold;  ///< Voxels whose scaled value is >= threshold.
};

/// @brief Mask (one byte per voxel, 1 = selected) of the selection. Throws ctr::io::InputError if a requested
/// label does not occur in the image (the message lists the values that do) or nothing is selected.
std::vector<std::uint8_t> selectVoxels(const NiftiVolume& vol, const NiftiSelection& sel);

/// @brief World AABB of the selected voxels' boxes (empty if none).
Aabb selectedExtent(const NiftiVolume& vol, const std::vector<std::uint8_t>& mask);

/// @brief How voxels become cells.
enum class NiftiSampling {
  Conservative,  ///< A cell is set if any selected voxel's box overlaps it (never thins a structure; default).
  Centre,        ///< A cell is set if its centre falls in a selected voxel (nearest-neighbour resampling).
};

/// @brief "conservative" / "centre" (the environment YAML's `sampling`).
const char* toString(NiftiSampling sampling);

/// @brief Sets to `value` every grid cell covered by a selected voxel.
void rasterizeNifti(const NiftiVolume& vol, const std::vector<std::uint8_t>& mask, VoxelGrid& grid,
                    std::uint8_t value = VoxelGrid::kOccupied, NiftiSampling sampling = NiftiSampling::Conservative);

/// @brief "Stay inside" rasterisation: cells whose centre lies in a selected voxel and that no unselected voxel
/// overlaps become kFree; every other cell of the grid (outside the region or the image) becomes kOccupied.
void rasterizeNiftiInside(const NiftiVolume& vol, const std::vector<std::uint8_t>& mask, VoxelGrid& grid);

/// @brief Writes a NIfTI-1 file (uint8 or float32 data) with the given affine (m, converted to mm in the file),
/// stored as sform and/or qform (codes 0 omit it). For tests and tools. Throws ctr::io::InputError on failure.
void writeNifti(const std::string& path, const Eigen::Vector3i& dims, const std::vector<float>& values,
                const Eigen::Matrix4d& ijk_to_world, int sform_code = 1, int qform_code = 1, bool as_uint8 = true,
                const Eigen::Matrix4d* qform_ijk_to_world = nullptr);

}  // namespace ctr::environments
