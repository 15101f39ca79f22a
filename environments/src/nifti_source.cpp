#include "ctr/environments/nifti_source.hpp"

#include <nifti2_io.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <memory>
#include <set>
#include <sstream>

#include "ctr/io/input_error.hpp"

namespace ctr::environments {

const char* toString(NiftiAffine affine) {
  switch (affine) {
    case NiftiAffine::Auto:
      return "auto";
    case NiftiAffine::Sform:
      return "sform";
    case NiftiAffine::Qform:
      return "qform";
  }
  return "?";
}

const char* toString(NiftiSampling sampling) {
  return sampling == NiftiSampling::Centre ? "centre" : "conservative";
}

namespace {

struct NimDeleter {
  void operator()(nifti_image* p) const { nifti_image_free(p); }
};
using NimPtr = std::unique_ptr<nifti_image, NimDeleter>;

[[noreturn]] void fail(const std::string& path, const std::string& msg) {
  throw io::InputError(path, 0, "", msg);
}

Eigen::Matrix4d toEigen(const nifti_dmat44& m) {
  Eigen::Matrix4d r;
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) r(i, j) = m.m[i][j];
  return r;
}

nifti_dmat44 toNifti(const Eigen::Matrix4d& m) {
  nifti_dmat44 r;
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) r.m[i][j] = m(i, j);
  return r;
}

template <class T>
double rawAt(const std::uint8_t* p, std::size_t v) {
  T x;
  std::memcpy(&x, p + v * sizeof(T), sizeof(T));
  return static_cast<double>(x);
}

// Calls f(value_as_double) type-dispatched for a whole volume; f returns false to stop.
template <class F>
void forEachRaw(const NiftiVolume& vol, F&& f) {
  const std::size_t n = vol.voxels();
  const std::uint8_t* p = vol.raw.get();
  auto loop = [&](auto tag) {
    using T = decltype(tag);
    for (std::size_t v = 0; v < n; ++v) {
      T x;
      std::memcpy(&x, p + v * sizeof(T), sizeof(T));
      if (!f(v, static_cast<double>(x))) return;
    }
  };
  switch (vol.datatype) {
    case DT_UINT8:
      loop(std::uint8_t{});
      break;
    case DT_INT8:
      loop(std::int8_t{});
      break;
    case DT_INT16:
      loop(std::int16_t{});
      break;
    case DT_UINT16:
      loop(std::uint16_t{});
      break;
    case DT_INT32:
      loop(std::int32_t{});
      break;
    case DT_UINT32:
      loop(std::uint32_t{});
      break;
    case DT_INT64:
      loop(std::int64_t{});
      break;
    case DT_UINT64:
      loop(std::uint64_t{});
      break;
    case DT_FLOAT32:
      loop(float{});
      break;
    case DT_FLOAT64:
      loop(double{});
      break;
    default:
      break;
  }
}

bool scaled(const NiftiVolume& v) {
  return v.scl_slope != 0.0 && !(v.scl_slope == 1.0 && v.scl_inter == 0.0);
}

const char* typeName(int dt) {
  switch (dt) {
    case DT_UINT8:
      return "uint8";
    case DT_INT8:
      return "int8";
    case DT_INT16:
      return "int16";
    case DT_UINT16:
      return "uint16";
    case DT_INT32:
      return "int32";
    case DT_UINT32:
      return "uint32";
    case DT_INT64:
      return "int64";
    case DT_UINT64:
      return "uint64";
    case DT_FLOAT32:
      return "float32";
    case DT_FLOAT64:
      return "float64";
    default:
      return nullptr;
  }
}

}  // namespace

double NiftiVolume::value(std::size_t v) const {
  const std::uint8_t* p = raw.get();
  double x = 0.0;
  switch (datatype) {
    case DT_UINT8:
      x = rawAt<std::uint8_t>(p, v);
      break;
    case DT_INT8:
      x = rawAt<std::int8_t>(p, v);
      break;
    case DT_INT16:
      x = rawAt<std::int16_t>(p, v);
      break;
    case DT_UINT16:
      x = rawAt<std::uint16_t>(p, v);
      break;
    case DT_INT32:
      x = rawAt<std::int32_t>(p, v);
      break;
    case DT_UINT32:
      x = rawAt<std::uint32_t>(p, v);
      break;
    case DT_INT64:
      x = rawAt<std::int64_t>(p, v);
      break;
    case DT_UINT64:
      x = rawAt<std::uint64_t>(p, v);
      break;
    case DT_FLOAT32:
      x = rawAt<float>(p, v);
      break;
    case DT_FLOAT64:
      x = rawAt<double>(p, v);
      break;
    default:
      break;
  }
  return scaled(*this) ? x * scl_slope + scl_inter : x;
}

std::vector<double> NiftiVolume::distinctValues(std::size_t limit) const {
  std::set<double> s;
  const bool sc = scaled(*this);
  forEachRaw(*this, [&](std::size_t, double x) {
    s.insert(sc ? x * scl_slope + scl_inter : x);
    return s.size() < limit;
  });
  return std::vector<double>(s.begin(), s.end());
}

Aabb NiftiVolume::extent() const {
  Aabb box;
  for (int c = 0; c < 8; ++c) {
    const Eigen::Vector4d ijk((c & 1) ? dims.x() - 0.5 : -0.5, (c & 2) ? dims.y() - 0.5 : -0.5,
                              (c & 4) ? dims.z() - 0.5 : -0.5, 1.0);
    box.extend(Eigen::Vector3d((ijk_to_world * ijk).head<3>()));
  }
  return box;
}

Eigen::Vector3d NiftiVolume::spacing() const {
  return ijk_to_world.topLeftCorner<3, 3>().colwise().norm().transpose();
}

NiftiVolume readNifti(const std::string& path, NiftiAffine affine) {
  {
    std::ifstream probe(path, std::ios::binary);
    if (!probe) fail(path, "cannot open the NIfTI file (missing or unreadable)");
  }
  nifti_set_debug_level(0);
  NimPtr nim(nifti_image_read(path.c_str(), 0));
  if (!nim) fail(path, "not a readable NIfTI-1/NIfTI-2 file (corrupt or unsupported header)");
  NiftiVolume vol;
  vol.path = path;
  const nifti_image& h = *nim;
  // Dimensions: 3-D, or 4-D..7-D with a single volume.
  const int ndim = static_cast<int>(h.dim[0]);
  if (ndim < 3 || ndim > 7) {
    std::ostringstream os;
    os << "the image has " << ndim << " dimension(s); a 3-D segmentation is required";
    fail(path, os.str());
  }
  for (int d = 4; d <= ndim; ++d)
    if (h.dim[d] != 1) {
      std::ostringstream os;
      os << "the image is " << ndim << "-D with dim[" << d << "] = " << h.dim[d] << "; a single 3-D volume is required";
      fail(path, os.str());
    }
  for (int d = 1; d <= 3; ++d)
    if (h.dim[d] < 1 || h.dim[d] > 100000) {
      std::ostringstream os;
      os << "invalid dimension dim[" << d << "] = " << h.dim[d];
      fail(path, os.str());
    }
  vol.dims = Eigen::Vector3i(static_cast<int>(h.dim[1]), static_cast<int>(h.dim[2]), static_cast<int>(h.dim[3]));
  if (typeName(h.datatype) == nullptr) {
    std::ostringstream os;
    os << "unsupported voxel data type " << h.datatype << " (" << nifti_datatype_string(h.datatype)
       << "); integer or float scalars are required";
    fail(path, os.str());
  }
  vol.datatype = h.datatype;
  vol.bytes_per_voxel = h.nbyper;
  vol.scl_slope = std::isfinite(h.scl_slope) ? h.scl_slope : 0.0;
  vol.scl_inter = std::isfinite(h.scl_inter) ? h.scl_inter : 0.0;
  switch (XYZT_TO_SPACE(h.xyz_units)) {
    case NIFTI_UNITS_METER:
      vol.unit_to_metre = 1.0;
      break;
    case NIFTI_UNITS_MICRON:
      vol.unit_to_metre = 1e-6;
      break;
    default:
      vol.unit_to_metre = 1e-3;
      break;  // mm, and "unknown" by convention
  }
  // Affine.
  Eigen::Matrix4d A;
  const bool has_s = h.sform_code > 0, has_q = h.qform_code > 0;
  if (affine == NiftiAffine::Sform || (affine == NiftiAffine::Auto && has_s)) {
    if (!has_s) fail(path, "key 'affine': sform requested but the file has no sform (sform_code = 0)");
    A = toEigen(h.sto_xyz);
    vol.affine_used = toString(NiftiAffine::Sform);
  } else if (affine == NiftiAffine::Qform || (affine == NiftiAffine::Auto && has_q)) {
    if (!has_q) fail(path, "key 'affine': qform requested but the file has no qform (qform_code = 0)");
    A = toEigen(h.qto_xyz);
    vol.affine_used = toString(NiftiAffine::Qform);
  } else {
    fail(path,
         "the file has no voxel-to-world affine (qform_code = sform_code = 0): world coordinates are undefined; "
         "re-save it with an orientation (e.g. from 3D Slicer)");
  }
  if (!A.allFinite() || std::abs(A.topLeftCorner<3, 3>().determinant()) < 1e-12)
    fail(path, "the " + vol.affine_used + " affine is singular or not finite");
  A.topRows<3>() *= vol.unit_to_metre;
  A.row(3) << 0, 0, 0, 1;
  vol.ijk_to_world = A;
  // Data. libnifti allocates the whole volume before reading it: bound that allocation by what the file can hold
  // (a few hundred bytes claiming 100000^3 voxels must not allocate terabytes). Deflate expands at most ~1032:1.
  {
    const std::size_t need = vol.voxels() * static_cast<std::size_t>(std::max(h.nbyper, 1));
    const char* data_file = h.iname ? h.iname : path.c_str();
    std::error_code ec;
    const auto on_disk = std::filesystem::file_size(data_file, ec);
    const bool gz = nifti_is_gzfile(data_file) != 0;
    const long double offset = h.iname_offset > 0 ? static_cast<long double>(h.iname_offset) : 0.0L;
    if (!ec && static_cast<long double>(need) + (gz ? 0.0L : offset) >
                   static_cast<long double>(on_disk) * (gz ? 1100.0L : 1.0L)) {
      std::ostringstream os;
      os << "the voxel data is shorter than the dimensions say (" << vol.dims.x() << "x" << vol.dims.y() << "x"
         << vol.dims.z() << " voxels of " << h.nbyper << " byte(s) cannot fit in a " << on_disk << "-byte file)";
      fail(path, os.str());
    }
  }
  if (nifti_image_load(nim.get()) < 0 || nim->data == nullptr)
    fail(path, "cannot read the voxel data (truncated or corrupt file)");
  const std::size_t bytes = vol.voxels() * static_cast<std::size_t>(vol.bytes_per_voxel);
  if (static_cast<std::size_t>(nim->nvox) * static_cast<std::size_t>(nim->nbyper) < bytes)
    fail(path, "the voxel data is shorter than the dimensions say");
  // Take over the library's buffer (no copy of a possibly large volume).
  vol.raw = std::shared_ptr<const std::uint8_t>(static_cast<const std::uint8_t*>(nim->data),
                                                [](const std::uint8_t* p) { std::free(const_cast<std::uint8_t*>(p)); });
  nim->data = nullptr;
  return vol;
}

std::vector<std::uint8_t> selectVoxels(const NiftiVolume& vol, const NiftiSelection& sel) {
  std::vector<std::uint8_t> mask(vol.voxels(), 0);
  const bool sc = scaled(vol);
  const double slope = vol.scl_slope, inter = vol.scl_inter;
  const bool any_nonzero = sel.labels.empty() && !sel.threshold;
  std::vector<std::size_t> hits(sel.labels.size(), 0);
  std::size_t selected = 0;
  forEachRaw(vol, [&](std::size_t v, double x) {
    const double val = sc ? x * slope + inter : x;
    bool on = false;
    if (any_nonzero) {
      on = val != 0.0;
    } else {
      if (sel.threshold && val >= *sel.threshold) on = true;
      for (std::size_t l = 0; l < sel.labels.size(); ++l)
        if (std::abs(val - sel.labels[l]) <= 1e-6) {
          on = true;
          ++hits[l];
        }
    }
    if (on) {
      mask[v] = 1;
      ++selected;
    }
    return true;
  });
  for (std::size_t l = 0; l < sel.labels.size(); ++l)
    if (hits[l] == 0) {
      std::ostringstream os;
      os << "label " << sel.labels[l] << " does not occur in the image; values present:";
      const auto vals = vol.distinctValues(20);
      for (double v : vals) os << " " << v;
      if (vals.size() >= 20) os << " ...";
      throw io::InputError(vol.path, 0, "label", os.str());
    }
  if (selected == 0) {
    std::ostringstream os;
    if (sel.threshold)
      os << "no voxel reaches the threshold " << *sel.threshold;
    else
      os << "the segmentation is empty (no non-zero voxel)";
    throw io::InputError(vol.path, 0, sel.threshold ? "threshold" : "", os.str());
  }
  return mask;
}

Aabb selectedExtent(const NiftiVolume& vol, const std::vector<std::uint8_t>& mask) {
  Eigen::Vector3i lo = vol.dims, hi = -Eigen::Vector3i::Ones();
  std::size_t v = 0;
  for (int k = 0; k < vol.dims.z(); ++k)
    for (int j = 0; j < vol.dims.y(); ++j)
      for (int i = 0; i < vol.dims.x(); ++i, ++v)
        if (mask[v]) {
          lo = lo.cwiseMin(Eigen::Vector3i(i, j, k));
          hi = hi.cwiseMax(Eigen::Vector3i(i, j, k));
        }
  Aabb box;
  if ((hi.array() < 0).any()) return box;
  for (int c = 0; c < 8; ++c) {
    const Eigen::Vector4d ijk((c & 1) ? hi.x() + 0.5 : lo.x() - 0.5, (c & 2) ? hi.y() + 0.5 : lo.y() - 0.5,
                              (c & 4) ? hi.z() + 0.5 : lo.z() - 0.5, 1.0);
    box.extend(Eigen::Vector3d((vol.ijk_to_world * ijk).head<3>()));
  }
  return box;
}

void rasterizeNifti(const NiftiVolume& vol, const std::vector<std::uint8_t>& mask, VoxelGrid& grid, std::uint8_t value,
                    NiftiSampling sampling) {
  const Eigen::Matrix3d A = vol.ijk_to_world.topLeftCorner<3, 3>();
  const Eigen::Vector3d t = vol.ijk_to_world.topRightCorner<3, 1>();
  if (sampling == NiftiSampling::Conservative) {
    const Eigen::Vector3d he = 0.5 * A.cwiseAbs().rowwise().sum();
    const double eps = 1e-4 * grid.resolution();
    std::size_t v = 0;
    for (int k = 0; k < vol.dims.z(); ++k)
      for (int j = 0; j < vol.dims.y(); ++j) {
        const Eigen::Vector3d row0 = A * Eigen::Vector3d(0, j, k) + t;
        for (int i = 0; i < vol.dims.x(); ++i, ++v) {
          if (!mask[v]) continue;
          const Eigen::Vector3d c = row0 + A.col(0) * i;
          grid.fillBox(Aabb(c - he, c + he), value, eps);
        }
      }
    return;
  }
  // Centre sampling.
  const Eigen::Matrix3d Ainv = A.inverse();
  Eigen::Vector3i lo, hi;
  if (!grid.cellRange(vol.extent(), lo, hi, 0.0)) return;
  for (int k = lo.z(); k <= hi.z(); ++k)
    for (int j = lo.y(); j <= hi.y(); ++j)
      for (int i = lo.x(); i <= hi.x(); ++i) {
        const Eigen::Vector3d ijk = Ainv * (grid.centre(i, j, k) - t);
        const long long vi = std::llround(ijk.x()), vj = std::llround(ijk.y()), vk = std::llround(ijk.z());
        if (vi < 0 || vj < 0 || vk < 0 || vi >= vol.dims.x() || vj >= vol.dims.y() || vk >= vol.dims.z()) continue;
        if (mask[(static_cast<std::size_t>(vk) * vol.dims.y() + static_cast<std::size_t>(vj)) * vol.dims.x() +
                 static_cast<std::size_t>(vi)])
          grid.set(i, j, k, value);
      }
}

void rasterizeNiftiInside(const NiftiVolume& vol, const std::vector<std::uint8_t>& mask, VoxelGrid& grid) {
  const Eigen::Matrix3d A = vol.ijk_to_world.topLeftCorner<3, 3>();
  const Eigen::Vector3d t = vol.ijk_to_world.topRightCorner<3, 1>();
  const Eigen::Matrix3d Ainv = A.inverse();
  const double h = 0.5 * grid.resolution() * (1.0 - 1e-6);
  // Half extent, in voxel index units, of a cell box mapped into index space.
  const Eigen::Vector3d hijk = h * Ainv.cwiseAbs().rowwise().sum();
  auto maskAt = [&](long long i, long long j, long long k) -> bool {
    if (i < 0 || j < 0 || k < 0 || i >= vol.dims.x() || j >= vol.dims.y() || k >= vol.dims.z()) return false;
    return mask[(static_cast<std::size_t>(k) * vol.dims.y() + static_cast<std::size_t>(j)) * vol.dims.x() +
                static_cast<std::size_t>(i)] != 0;
  };
  std::fill(grid.data().begin(), grid.data().end(), VoxelGrid::kOccupied);
  Eigen::Vector3i lo, hi;
  if (!grid.cellRange(vol.extent(), lo, hi, 0.0)) return;
  for (int k = lo.z(); k <= hi.z(); ++k)
    for (int j = lo.y(); j <= hi.y(); ++j)
      for (int i = lo.x(); i <= hi.x(); ++i) {
        const Eigen::Vector3d ijk = Ainv * (grid.centre(i, j, k) - t);
        if (!maskAt(std::llround(ijk.x()), std::llround(ijk.y()), std::llround(ijk.z()))) continue;
        // Every voxel the cell overlaps must be inside the region.
        const long long i0 = std::llround(std::floor(ijk.x() - hijk.x() + 0.5)),
                        i1 = std::llround(std::floor(ijk.x() + hijk.x() + 0.5));
        const long long j0 = std::llround(std::floor(ijk.y() - hijk.y() + 0.5)),
                        j1 = std::llround(std::floor(ijk.y() + hijk.y() + 0.5));
        const long long k0 = std::llround(std::floor(ijk.z() - hijk.z() + 0.5)),
                        k1 = std::llround(std::floor(ijk.z() + hijk.z() + 0.5));
        bool all = true;
        for (long long c = k0; c <= k1 && all; ++c)
          for (long long b = j0; b <= j1 && all; ++b)
            for (long long a = i0; a <= i1 && all; ++a)
              if (!maskAt(a, b, c)) all = false;
        if (all) grid.set(i, j, k, VoxelGrid::kFree);
      }
}

void writeNifti(const std::string& path, const Eigen::Vector3i& dims, const std::vector<float>& values,
                const Eigen::Matrix4d& ijk_to_world, int sform_code, int qform_code, bool as_uint8,
                const Eigen::Matrix4d* qform_ijk_to_world) {
  const std::size_t n = static_cast<std::size_t>(dims.x()) * dims.y() * dims.z();
  if (values.size() != n) fail(path, "writeNifti: value count does not match the dimensions");
  nifti_set_debug_level(0);
  const int64_t d[8] = {3, dims.x(), dims.y(), dims.z(), 1, 1, 1, 1};
  NimPtr nim(nifti_make_new_nim(d, as_uint8 ? DT_UINT8 : DT_FLOAT32, 1));
  if (!nim) fail(path, "writeNifti: cannot create the image");
  if (as_uint8) {
    auto* p = static_cast<std::uint8_t*>(nim->data);
    for (std::size_t v = 0; v < n; ++v) p[v] = static_cast<std::uint8_t>(std::clamp(values[v], 0.0f, 255.0f));
  } else {
    std::memcpy(nim->data, values.data(), n * sizeof(float));
  }
  Eigen::Matrix4d mm = ijk_to_world;
  mm.topRows<3>() *= 1000.0;  // metres -> millimetres
  Eigen::Matrix4d qm = qform_ijk_to_world ? *qform_ijk_to_world : ijk_to_world;
  qm.topRows<3>() *= 1000.0;
  nim->xyz_units = NIFTI_UNITS_MM;
  nim->sform_code = sform_code;
  nim->qform_code = qform_code;
  nim->sto_xyz = toNifti(mm);
  double qb, qc, qd, qx, qy, qz, dx, dy, dz, qfac;
  nifti_dmat44_to_quatern(toNifti(qm), &qb, &qc, &qd, &qx, &qy, &qz, &dx, &dy, &dz, &qfac);
  nim->quatern_b = qb;
  nim->quatern_c = qc;
  nim->quatern_d = qd;
  nim->qoffset_x = qx;
  nim->qoffset_y = qy;
  nim->qoffset_z = qz;
  nim->qfac = qfac;
  nim->dx = nim->pixdim[1] = dx;
  nim->dy = nim->pixdim[2] = dy;
  nim->dz = nim->pixdim[3] = dz;
  nim->qto_xyz = nifti_quatern_to_dmat44(qb, qc, qd, qx, qy, qz, dx, dy, dz, qfac);
  nim->nifti_type = NIFTI_FTYPE_NIFTI1_1;
  if (nifti_set_filenames(nim.get(), path.c_str(), 0, 1) != 0) fail(path, "writeNifti: bad file name");
  nifti_image_write(nim.get());
  std::ifstream check(path, std::ios::binary);
  if (!check) fail(path, "writeNifti: the file was not written");
}

}  // namespace ctr::environments
