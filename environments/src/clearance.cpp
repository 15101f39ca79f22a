#include "ctr/environments/clearance.hpp"

#include <dynamicEDT3D/dynamicEDT3D.h>
#include <octomap/OcTree.h>

#include <chrono>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>

#include "ctr/environments/voxel_grid.hpp"

namespace ctr::environments {

DistanceField::DistanceField(const octomap::OcTree& tree, const Aabb& region, const DistanceFieldOptions& options)
    : res_(tree.getResolution()), max_distance_(options.max_distance) {
  const auto t0 = std::chrono::steady_clock::now();
  if (region.empty()) throw std::invalid_argument("distance field: empty region");
  if (!(options.max_distance > 0.0)) throw std::invalid_argument("distance field: max_distance must be > 0");
  // Occupancy of the region's cells (unknown cells stay kUnknown).
  VoxelGrid grid;
  try {
    grid = VoxelGrid(res_, region, VoxelGrid::kUnknown, options.max_cells);
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(std::string("distance field: ") + e.what() +
                                " (set a smaller field region or disable the distance field)");
  }
  rasterizeOcTree(tree, grid, true);
  region_ = grid.bounds();
  origin_key_ = grid.originKey();
  dims_ = grid.dims();
  const bool unknown_occ = options.unknown_space == UnknownSpace::Occupied;
  // dynamicEDT3D takes ownership of a bool*** map allocated with new[].
  const int sx = dims_.x(), sy = dims_.y(), sz = dims_.z();
  bool*** map = new bool**[static_cast<std::size_t>(sx)];
  for (int x = 0; x < sx; ++x) {
    map[x] = new bool*[static_cast<std::size_t>(sy)];
    for (int y = 0; y < sy; ++y) {
      map[x][y] = new bool[static_cast<std::size_t>(sz)];
      for (int z = 0; z < sz; ++z) {
        const std::uint8_t v = grid.at(x, y, z);
        const bool occ = v == VoxelGrid::kOccupied || (unknown_occ && v == VoxelGrid::kUnknown);
        map[x][y][z] = occ;
        occupied_ += occ ? 1u : 0u;
      }
    }
  }
  const int maxcells = static_cast<int>(std::ceil(options.max_distance / res_)) + 1;
  if (maxcells > 127) {
    for (int x = 0; x < sx; ++x) {
      for (int y = 0; y < sy; ++y) delete[] map[x][y];
      delete[] map[x];
    }
    delete[] map;
    throw std::invalid_argument("distance field: max_distance is more than 126 cells; use a smaller max_distance");
  }
  {
    DynamicEDT3D edt(maxcells * maxcells);
    edt.initializeMap(sx, sy, sz, map);  // takes ownership of map
    edt.update(false);                   // squared cell distances are enough
    // Compact copy: squared distance in cells and the offset to the nearest occupied cell.
    const std::size_t n = cells();
    sq_.assign(n, static_cast<std::uint16_t>(maxcells * maxcells));
    near_.assign(n, {-128, -128, -128});
    for (int z = 0; z < sz; ++z)
      for (int y = 0; y < sy; ++y)
        for (int x = 0; x < sx; ++x) {
          const int sq = edt.getSQCellDistance(x, y, z);
          const std::size_t id = index(x, y, z);
          if (sq < 0 || sq >= maxcells * maxcells) continue;
          const INTPOINT3D o = edt.getClosestObstacle(x, y, z);
          if (o.x == DynamicEDT3D::invalidObstData) continue;
          sq_[id] = static_cast<std::uint16_t>(sq);
          near_[id] = {static_cast<std::int8_t>(o.x - x), static_cast<std::int8_t>(o.y - y),
                       static_cast<std::int8_t>(o.z - z)};
        }
  }
  // Saturation in metres (the transform caps at maxcells cells).
  max_distance_ = std::min(options.max_distance, static_cast<double>(maxcells) * res_);
  build_seconds_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

DistanceField::~DistanceField() = default;

namespace {

// Lattice bound: for a cell c and any cell B whose centre is at squared distance >= n cells^2 from c's centre, the
// distance from c's centre to B's box (in cells) is at least sqrt(boxBound()[n]). It is the minimum of
// sum_i max(|d_i| - 1/2, 0)^2 over integer offsets d with |d|^2 >= n: much tighter than sqrt(n) - sqrt(3)/2 at the
// small distances where the collision pre-filter has to decide.
const std::vector<float>& boxBound() {
  static const std::vector<float> table = [] {
    constexpr int kMax = 128;  // offsets up to the largest supported field distance (127 cells)
    const int nmax = 3 * kMax * kMax;
    std::vector<float> best(static_cast<std::size_t>(nmax) + 1, std::numeric_limits<float>::infinity());
    for (int a = 0; a <= kMax; ++a)
      for (int b = 0; b <= a; ++b)
        for (int c = 0; c <= b; ++c) {
          const int n = a * a + b * b + c * c;
          auto term = [](int d) { return d > 0 ? (d - 0.5) * (d - 0.5) : 0.0; };
          const float v = static_cast<float>(term(a) + term(b) + term(c));
          if (v < best[static_cast<std::size_t>(n)]) best[static_cast<std::size_t>(n)] = v;
        }
    for (int n = nmax - 1; n >= 0; --n)  // suffix minimum: any offset with |d|^2 >= n
      best[static_cast<std::size_t>(n)] =
          std::min(best[static_cast<std::size_t>(n)], best[static_cast<std::size_t>(n) + 1]);
    return best;
  }();
  return table;
}

}  // namespace

std::size_t DistanceField::cells() const {
  return static_cast<std::size_t>(dims_.x()) * static_cast<std::size_t>(dims_.y()) *
         static_cast<std::size_t>(dims_.z());
}

bool DistanceField::cellOf(const Eigen::Vector3d& p, int& x, int& y, int& z) const {
  const double inv = 1.0 / res_;
  const double fx = std::floor(inv * p.x()), fy = std::floor(inv * p.y()), fz = std::floor(inv * p.z());
  if (!std::isfinite(fx) || !std::isfinite(fy) || !std::isfinite(fz)) return false;
  x = static_cast<int>(fx) + 32768 - origin_key_.x();
  y = static_cast<int>(fy) + 32768 - origin_key_.y();
  z = static_cast<int>(fz) + 32768 - origin_key_.z();
  return x >= 0 && y >= 0 && z >= 0 && x < dims_.x() && y < dims_.y() && z < dims_.z();
}

Eigen::Vector3d DistanceField::centreOf(int x, int y, int z) const {
  return Eigen::Vector3d(keyToCoord(origin_key_.x() + x, res_), keyToCoord(origin_key_.y() + y, res_),
                         keyToCoord(origin_key_.z() + z, res_));
}

bool DistanceField::contains(const Eigen::Vector3d& p) const {
  int x, y, z;
  return cellOf(p, x, y, z);
}

double DistanceField::cellDistance(const Eigen::Vector3d& p) const {
  int x, y, z;
  if (!cellOf(p, x, y, z)) return -1.0;
  return std::min(std::sqrt(static_cast<double>(sq_[index(x, y, z)])) * res_, max_distance_);
}

bool DistanceField::occupied(const Eigen::Vector3d& p) const {
  int x, y, z;
  if (!cellOf(p, x, y, z)) return false;
  return sq_[index(x, y, z)] == 0;
}

bool DistanceField::nearestObstacle(const Eigen::Vector3d& p, Eigen::Vector3d& obstacle_centre) const {
  int x, y, z;
  if (!cellOf(p, x, y, z)) return false;
  const auto& o = near_[index(x, y, z)];
  if (o[0] == -128) return false;
  obstacle_centre = centreOf(x + o[0], y + o[1], z + o[2]);
  return true;
}

double DistanceField::pointDistance(const Eigen::Vector3d& p, Eigen::Vector3d* obstacle_centre) const {
  int x, y, z;
  if (!cellOf(p, x, y, z)) return -1.0;
  const auto& o = near_[index(x, y, z)];
  if (o[0] == -128) return max_distance_;
  const Eigen::Vector3d c = centreOf(x + o[0], y + o[1], z + o[2]);
  if (obstacle_centre) *obstacle_centre = c;
  const double h = 0.5 * res_;
  return std::min(distance(Aabb(c.array() - h, c.array() + h), p), max_distance_);
}

bool DistanceField::probe(const Eigen::Vector3d& p, double& lower_bound, bool& is_occupied) const {
  int x, y, z;
  if (!cellOf(p, x, y, z)) return false;
  const std::uint16_t sq = sq_[index(x, y, z)];
  is_occupied = sq == 0;
  if (is_occupied) {
    lower_bound = 0.0;
    return true;
  }
  // Distance from p's cell centre to the nearest occupied box (lattice bound, see boxBound()), minus |p - centre|
  // for the query point, minus a tenth of a cell of slack for the propagation error of the transform (the nearest
  // obstacle found by neighbour propagation could be marginally farther than the true nearest one; none was seen
  // against brute force, the slack is a safety margin). Saturated cells only know that the distance is beyond
  // the cap.
  const double to_box = std::sqrt(static_cast<double>(boxBound()[sq])) * res_;
  const double off = (p - centreOf(x, y, z)).norm();
  lower_bound = std::max(0.0, std::min(to_box, max_distance_ - 0.5 * std::sqrt(3.0) * res_) - off - 0.1 * res_);
  return true;
}

double DistanceField::lowerBound(const Eigen::Vector3d& p) const {
  double lb = -1.0;
  bool occ = false;
  return probe(p, lb, occ) ? lb : -1.0;
}

}  // namespace ctr::environments
