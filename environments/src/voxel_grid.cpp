#include "ctr/environments/voxel_grid.hpp"

#include <octomap/OcTree.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <sstream>
#include <stdexcept>

#include "tree_builder.hpp"

namespace ctr::environments {

namespace {
constexpr int kKeyOffset = 32768;
constexpr int kMaxKey = 65535;
constexpr int kDepth = 16;
}  // namespace

int coordToKey(double c, double resolution) {
  return static_cast<int>(std::floor((1.0 / resolution) * c)) + kKeyOffset;
}

double keyToCoord(int key, double resolution) {
  return (static_cast<double>(key - kKeyOffset) + 0.5) * resolution;
}

VoxelGrid::VoxelGrid(double resolution, const Aabb& region, std::uint8_t fill, std::size_t max_cells)
    : res_(resolution) {
  if (!(resolution > 0.0) || !std::isfinite(resolution))
    throw std::invalid_argument("resolution must be a positive number of metres");
  if (region.empty() || !region.min.allFinite() || !region.max.allFinite())
    throw std::invalid_argument("the region to map is empty");
  Eigen::Vector3i lo, hi;
  for (int a = 0; a < 3; ++a) {
    const double fl = std::floor(region.min[a] / resolution) + kKeyOffset;
    const double fh = std::floor(region.max[a] / resolution) + kKeyOffset;
    if (fl < 0 || fh > kMaxKey) {
      std::ostringstream os;
      os << "the region [" << region.min.transpose() << "] - [" << region.max.transpose()
         << "] m exceeds OctoMap's key range at resolution " << resolution << " m (+-" << kKeyOffset * resolution
         << " m around the origin)";
      throw std::invalid_argument(os.str());
    }
    lo[a] = static_cast<int>(fl);
    hi[a] = static_cast<int>(fh);
  }
  origin_ = lo;
  dims_ = hi - lo + Eigen::Vector3i::Ones();
  const double n = static_cast<double>(dims_.x()) * dims_.y() * dims_.z();
  if (n > static_cast<double>(max_cells)) {
    std::ostringstream os;
    os << "the map would need " << dims_.x() << " x " << dims_.y() << " x " << dims_.z() << " = "
       << static_cast<long long>(n) << " cells at resolution " << resolution << " m (limit " << max_cells
       << "); choose a coarser resolution or smaller bounds";
    throw std::invalid_argument(os.str());
  }
  data_.assign(static_cast<std::size_t>(n), fill);
}

Aabb VoxelGrid::bounds() const {
  Eigen::Vector3d lo, hi;
  for (int a = 0; a < 3; ++a) {
    lo[a] = static_cast<double>(origin_[a] - kKeyOffset) * res_;
    hi[a] = static_cast<double>(origin_[a] + dims_[a] - kKeyOffset) * res_;
  }
  return Aabb(lo, hi);
}

Eigen::Vector3i VoxelGrid::cellOf(const Eigen::Vector3d& p) const {
  Eigen::Vector3i c;
  for (int a = 0; a < 3; ++a) {
    const double k = std::floor((1.0 / res_) * p[a]);
    c[a] = static_cast<int>(std::clamp(k, -1e9, 1e9)) + kKeyOffset - origin_[a];
  }
  return c;
}

Eigen::Vector3d VoxelGrid::centre(int i, int j, int k) const {
  return Eigen::Vector3d(keyToCoord(origin_.x() + i, res_), keyToCoord(origin_.y() + j, res_),
                         keyToCoord(origin_.z() + k, res_));
}

bool VoxelGrid::cellRange(const Aabb& box, Eigen::Vector3i& lo, Eigen::Vector3i& hi, double eps) const {
  if (box.empty() || data_.empty()) return false;
  for (int a = 0; a < 3; ++a) {
    const double extent = box.max[a] - box.min[a];
    long long l, h;
    if (extent < 2.0 * eps || extent <= 0.0) {
      const double c = 0.5 * (box.min[a] + box.max[a]);
      l = h = static_cast<long long>(std::floor(c / res_)) + kKeyOffset - origin_[a];
    } else {
      const double vlo = (box.min[a] + eps) / res_;
      const double vhi = (box.max[a] - eps) / res_;
      if (!std::isfinite(vlo) || !std::isfinite(vhi)) return false;
      l = static_cast<long long>(std::floor(vlo)) + kKeyOffset - origin_[a];
      h = static_cast<long long>(std::ceil(vhi)) - 1 + kKeyOffset - origin_[a];
    }
    l = std::max<long long>(l, 0);
    h = std::min<long long>(h, dims_[a] - 1);
    if (l > h) return false;
    lo[a] = static_cast<int>(l);
    hi[a] = static_cast<int>(h);
  }
  return true;
}

void VoxelGrid::fillBox(const Aabb& box, std::uint8_t v, double eps) {
  Eigen::Vector3i lo, hi;
  if (!cellRange(box, lo, hi, eps)) return;
  for (int k = lo.z(); k <= hi.z(); ++k)
    for (int j = lo.y(); j <= hi.y(); ++j) {
      std::uint8_t* row = &data_[index(0, j, k)];
      std::fill(row + lo.x(), row + hi.x() + 1, v);
    }
}

std::size_t VoxelGrid::count(std::uint8_t v) const {
  return static_cast<std::size_t>(std::count(data_.begin(), data_.end(), v));
}

void VoxelGrid::paint(const VoxelGrid& other, std::uint8_t where, std::uint8_t v) {
  if (std::abs(other.res_ - res_) > 1e-12 * res_) throw std::invalid_argument("VoxelGrid::paint: resolutions differ");
  const Eigen::Vector3i off = other.origin_ - origin_;
  for (int k = 0; k < other.dims_.z(); ++k) {
    const int kk = k + off.z();
    if (kk < 0 || kk >= dims_.z()) continue;
    for (int j = 0; j < other.dims_.y(); ++j) {
      const int jj = j + off.y();
      if (jj < 0 || jj >= dims_.y()) continue;
      const std::uint8_t* src = &other.data_[other.index(0, j, k)];
      for (int i = 0; i < other.dims_.x(); ++i) {
        if (src[i] != where) continue;
        const int ii = i + off.x();
        if (ii < 0 || ii >= dims_.x()) continue;
        data_[index(ii, jj, kk)] = v;
      }
    }
  }
}

// ---------------------------------------------------------------------------------------------------------------
// Grid -> octree through a pyramid of block codes.

namespace {

constexpr std::uint8_t kCodeFree = 0, kCodeOcc = 1, kCodeUnknown = 2, kCodeMixed = 3;

struct Level {
  Eigen::Vector3i lo = Eigen::Vector3i::Zero();  // block coordinates (key >> level) of element 0
  Eigen::Vector3i n = Eigen::Vector3i::Zero();
  std::vector<std::uint8_t> code;
  std::uint8_t get(int x, int y, int z) const {
    x -= lo.x();
    y -= lo.y();
    z -= lo.z();
    if (x < 0 || y < 0 || z < 0 || x >= n.x() || y >= n.y() || z >= n.z()) return kCodeUnknown;
    return code[(static_cast<std::size_t>(z) * n.y() + y) * n.x() + x];
  }
};

class Pyramid {
 public:
  Pyramid(const VoxelGrid& g, bool free_as_known) : grid_(g), free_known_(free_as_known) {
    levels_.resize(kDepth + 1);
    for (int l = 1; l <= kDepth; ++l) {
      Level& L = levels_[l];
      for (int a = 0; a < 3; ++a) {
        L.lo[a] = g.originKey()[a] >> l;
        const int hi = (g.originKey()[a] + g.dims()[a] - 1) >> l;
        L.n[a] = hi - L.lo[a] + 1;
      }
      L.code.assign(static_cast<std::size_t>(L.n.x()) * L.n.y() * L.n.z(), kCodeUnknown);
      for (int z = 0; z < L.n.z(); ++z)
        for (int y = 0; y < L.n.y(); ++y)
          for (int x = 0; x < L.n.x(); ++x) {
            const int bx = L.lo.x() + x, by = L.lo.y() + y, bz = L.lo.z() + z;
            std::uint8_t c = get(l - 1, 2 * bx, 2 * by, 2 * bz);
            for (int i = 1; i < 8 && c != kCodeMixed; ++i) {
              const std::uint8_t ci = get(l - 1, 2 * bx + (i & 1), 2 * by + ((i >> 1) & 1), 2 * bz + ((i >> 2) & 1));
              if (ci != c) c = kCodeMixed;
            }
            L.code[(static_cast<std::size_t>(z) * L.n.y() + y) * L.n.x() + x] = c;
          }
    }
  }

  std::uint8_t get(int level, int x, int y, int z) const {
    if (level == 0) {
      const int i = x - grid_.originKey().x(), j = y - grid_.originKey().y(), k = z - grid_.originKey().z();
      if (!grid_.inside(i, j, k)) return kCodeUnknown;
      const std::uint8_t v = grid_.at(i, j, k);
      if (v == VoxelGrid::kOccupied) return kCodeOcc;
      if (v == VoxelGrid::kFree) return free_known_ ? kCodeFree : kCodeUnknown;
      return kCodeUnknown;
    }
    return levels_[static_cast<std::size_t>(level)].get(x, y, z);
  }

 private:
  const VoxelGrid& grid_;
  bool free_known_;
  std::vector<Level> levels_;
};

void buildFromPyramid(detail::TreeBuilder& tree, octomap::OcTreeNode* node, const Pyramid& pyr, int level, int x, int y,
                      int z, float occ, float fre) {
  for (unsigned i = 0; i < 8; ++i) {
    const int cx = 2 * x + static_cast<int>(i & 1u), cy = 2 * y + static_cast<int>((i >> 1) & 1u),
              cz = 2 * z + static_cast<int>((i >> 2) & 1u);
    const std::uint8_t c = pyr.get(level - 1, cx, cy, cz);
    if (c == kCodeUnknown) continue;
    octomap::OcTreeNode* child = tree.createNodeChild(node, i);
    if (c == kCodeOcc) {
      child->setLogOdds(occ);
    } else if (c == kCodeFree) {
      child->setLogOdds(fre);
    } else {
      buildFromPyramid(tree, child, pyr, level - 1, cx, cy, cz, occ, fre);
    }
  }
}

}  // namespace

std::shared_ptr<octomap::OcTree> gridToOcTree(const VoxelGrid& grid, bool free_as_known) {
  auto tree = std::make_shared<detail::TreeBuilder>(grid.resolution());
  if (grid.cells() == 0) return tree;
  const Pyramid pyr(grid, free_as_known);
  const float occ = tree->getClampingThresMaxLog();
  const float fre = tree->getClampingThresMinLog();
  const std::uint8_t rc = pyr.get(kDepth, 0, 0, 0);
  if (rc == kCodeUnknown) return tree;
  octomap::OcTreeNode* root = tree->makeRoot();
  if (rc == kCodeOcc) {
    root->setLogOdds(occ);
  } else if (rc == kCodeFree) {
    root->setLogOdds(fre);
  } else {
    buildFromPyramid(*tree, root, pyr, kDepth, 0, 0, 0, occ, fre);
  }
  tree->updateInnerOccupancy();
  return tree;
}

void rasterizeOcTree(const octomap::OcTree& tree, VoxelGrid& grid, bool mark_free) {
  if (grid.cells() == 0 || tree.getRoot() == nullptr) return;
  const Aabb gb = grid.bounds();
  const double eps = 1e-6 * grid.resolution();
  const octomap::point3d bmin(static_cast<float>(gb.min.x()), static_cast<float>(gb.min.y()),
                              static_cast<float>(gb.min.z()));
  const octomap::point3d bmax(static_cast<float>(gb.max.x()), static_cast<float>(gb.max.y()),
                              static_cast<float>(gb.max.z()));
  // Free leaves first so that occupied leaves win where a coarse free leaf and an occupied one share a cell.
  for (int pass = mark_free ? 0 : 1; pass < 2; ++pass) {
    for (auto it = tree.begin_leafs_bbx(bmin, bmax), end = tree.end_leafs_bbx(); it != end; ++it) {
      const bool occ = tree.isNodeOccupied(*it);
      if ((pass == 0) == occ) continue;
      // Exact key-space box of the leaf (avoids float rounding of getCoordinate()).
      const octomap::OcTreeKey key = it.getIndexKey();
      const unsigned depth = it.getDepth();
      const int span = 1 << (tree.getTreeDepth() - depth);
      Aabb box;
      for (int a = 0; a < 3; ++a) {
        box.min[a] = static_cast<double>(static_cast<int>(key[a]) - kKeyOffset) * tree.getResolution();
        box.max[a] = box.min[a] + span * tree.getResolution();
      }
      grid.fillBox(box, occ ? VoxelGrid::kOccupied : VoxelGrid::kFree, eps);
    }
  }
}

// ---------------------------------------------------------------------------------------------------------------
// Unknown -> occupied inside bounds.

namespace {

struct KeyBox {
  std::array<int, 3> lo{}, hi{};
};

// 0: block outside, 1: block fully inside, 2: partial.
int classify(const KeyBox& kb, int level, int x, int y, int z) {
  const int b[3] = {x, y, z};
  bool full = true;
  for (int a = 0; a < 3; ++a) {
    const long long lo = static_cast<long long>(b[a]) << level;
    const long long hi = lo + (1LL << level) - 1;
    if (hi < kb.lo[static_cast<std::size_t>(a)] || lo > kb.hi[static_cast<std::size_t>(a)]) return 0;
    if (lo < kb.lo[static_cast<std::size_t>(a)] || hi > kb.hi[static_cast<std::size_t>(a)]) full = false;
  }
  return full ? 1 : 2;
}

void fillRec(const octomap::OcTree& src, const octomap::OcTreeNode* s, detail::TreeBuilder& dst, octomap::OcTreeNode* d,
             const KeyBox& kb, int level, int x, int y, int z, float occ) {
  if (s != nullptr && !src.nodeHasChildren(s)) {
    d->setLogOdds(s->getLogOdds());
    return;
  }
  if (s == nullptr && classify(kb, level, x, y, z) == 1) {
    d->setLogOdds(occ);
    return;
  }
  for (unsigned i = 0; i < 8; ++i) {
    const int cx = 2 * x + static_cast<int>(i & 1u), cy = 2 * y + static_cast<int>((i >> 1) & 1u),
              cz = 2 * z + static_cast<int>((i >> 2) & 1u);
    const octomap::OcTreeNode* sc = (s != nullptr && src.nodeChildExists(s, i)) ? src.getNodeChild(s, i) : nullptr;
    if (sc == nullptr && classify(kb, level - 1, cx, cy, cz) == 0) continue;
    octomap::OcTreeNode* dc = dst.createNodeChild(d, i);
    fillRec(src, sc, dst, dc, kb, level - 1, cx, cy, cz, occ);
  }
}

}  // namespace

std::shared_ptr<octomap::OcTree> fillUnknown(const octomap::OcTree& tree, const Aabb& bounds) {
  auto out = std::make_shared<detail::TreeBuilder>(tree.getResolution());
  out->setOccupancyThres(tree.getOccupancyThres());
  out->setClampingThresMax(tree.getClampingThresMax());
  out->setClampingThresMin(tree.getClampingThresMin());
  out->setProbHit(tree.getProbHit());
  out->setProbMiss(tree.getProbMiss());
  const double res = tree.getResolution();
  KeyBox kb;
  bool any = !bounds.empty();
  for (int a = 0; a < 3 && any; ++a) {
    kb.lo[static_cast<std::size_t>(a)] = std::max(0, coordToKey(bounds.min[a], res));
    kb.hi[static_cast<std::size_t>(a)] = std::min(kMaxKey, coordToKey(bounds.max[a], res));
    if (kb.lo[static_cast<std::size_t>(a)] > kb.hi[static_cast<std::size_t>(a)]) any = false;
  }
  const octomap::OcTreeNode* sroot = tree.getRoot();
  if (sroot == nullptr && !any) return out;
  KeyBox use = kb;
  if (!any) {  // nothing to fill: an impossible key box
    use.lo = {1 << 20, 1 << 20, 1 << 20};
    use.hi = {-1, -1, -1};
  }
  octomap::OcTreeNode* droot = out->makeRoot();
  fillRec(tree, sroot, *out, droot, use, kDepth, 0, 0, 0, out->getClampingThresMaxLog());
  out->updateInnerOccupancy();
  return out;
}

}  // namespace ctr::environments
