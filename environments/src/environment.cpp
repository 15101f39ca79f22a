#include "ctr/environments/environment.hpp"

#include <octomap/AbstractOcTree.h>
#include <octomap/OcTree.h>

#include <fcntl.h>
#include <unistd.h>
#include <Eigen/SVD>
#include <cmath>

#include <cstdio>
#include <sstream>
#include <stdexcept>

#include "ctr/environments/voxel_grid.hpp"
#include "ctr/io/input_error.hpp"

namespace ctr::environments {

const char* toString(UnknownSpace u) {
  return u == UnknownSpace::Free ? "free" : "occupied";
}

const char* toString(Occupancy o) {
  switch (o) {
    case Occupancy::Free:
      return "free";
    case Occupancy::Occupied:
      return "occupied";
    case Occupancy::Unknown:
      return "unknown";
  }
  return "unknown";
}

UnknownSpace parseUnknownSpace(const std::string& text) {
  if (text == toString(UnknownSpace::Free)) return UnknownSpace::Free;
  if (text == toString(UnknownSpace::Occupied)) return UnknownSpace::Occupied;
  throw std::invalid_argument("unknown space must be 'free' or 'occupied', not '" + text + "'");
}

namespace {

Aabb treeBounds(const octomap::OcTree& tree) {
  if (tree.getRoot() == nullptr || tree.size() == 0) return {};
  double x0, y0, z0, x1, y1, z1;
  tree.getMetricMin(x0, y0, z0);
  tree.getMetricMax(x1, y1, z1);
  return Aabb(Eigen::Vector3d(x0, y0, z0), Eigen::Vector3d(x1, y1, z1));
}

template <class T>
std::string nameList(const std::vector<T>& v) {
  std::string s;
  for (const auto& x : v) s += (s.empty() ? "" : ", ") + x.name;
  return s.empty() ? "(none)" : s;
}

bool inKeyRange(const octomap::OcTree& tree, const Eigen::Vector3d& p) {
  for (int a = 0; a < 3; ++a) {
    if (!std::isfinite(p[a])) return false;
    const int k = coordToKey(p[a], tree.getResolution());
    if (k < 0 || k > 65535) return false;
  }
  return true;
}

}  // namespace

Environment::Environment(std::string name, std::shared_ptr<const octomap::OcTree> tree, Aabb bounds)
    : name_(std::move(name)), tree_(std::move(tree)), bounds_(bounds) {
  if (!tree_) throw std::invalid_argument("Environment: null octree");
  // The bounds always contain every node of the tree (collision checking relies on "nothing beyond the bounds").
  bounds_.extend(treeBounds(*tree_));
}

double Environment::resolution() const {
  return tree_->getResolution();
}

void Environment::setBasePose(const Eigen::Isometry3d& world_T_base, std::string source) {
  base_pose_ = world_T_base;
  base_pose_source_ = source.empty() ? "set" : std::move(source);
}

void Environment::addStart(NamedPose p) {
  for (auto& s : starts_)
    if (s.name == p.name) {
      s = std::move(p);
      return;
    }
  starts_.push_back(std::move(p));
}

const NamedPose& Environment::start(const std::string& name) const {
  for (const auto& s : starts_)
    if (s.name == name) return s;
  throw std::invalid_argument("environment '" + name_ + "' has no start pose '" + name +
                              "' (known: " + nameList(starts_) + ")");
}

void Environment::useStart(const std::string& name) {
  const NamedPose& s = start(name);
  setBasePose(s.pose, name);
}

void Environment::addTarget(NamedTarget t) {
  for (auto& s : targets_)
    if (s.name == t.name) {
      s = std::move(t);
      return;
    }
  targets_.push_back(std::move(t));
}

const NamedTarget& Environment::target(const std::string& name) const {
  for (const auto& t : targets_)
    if (t.name == name) return t;
  throw std::invalid_argument("environment '" + name_ + "' has no target '" + name + "' (known: " + nameList(targets_) +
                              ")");
}

Occupancy Environment::occupancy(const Eigen::Vector3d& p) const {
  if (!inKeyRange(*tree_, p)) return Occupancy::Unknown;
  const octomap::OcTreeNode* n = tree_->search(p.x(), p.y(), p.z());
  if (n == nullptr) return Occupancy::Unknown;
  return tree_->isNodeOccupied(n) ? Occupancy::Occupied : Occupancy::Free;
}

bool Environment::isObstacle(const Eigen::Vector3d& p, UnknownSpace unknown) const {
  const Occupancy o = occupancy(p);
  if (o == Occupancy::Unknown) return unknown == UnknownSpace::Occupied;
  return o == Occupancy::Occupied;
}

OccupancyStats Environment::stats() const {
  OccupancyStats st;
  st.nodes = tree_->size();
  st.memory_bytes = static_cast<double>(tree_->memoryUsage());
  if (tree_->getRoot() == nullptr) return st;
  for (auto it = tree_->begin_leafs(), end = tree_->end_leafs(); it != end; ++it) {
    const double sz = it.getSize();
    if (tree_->isNodeOccupied(*it)) {
      ++st.occupied_leaves;
      st.occupied_volume += sz * sz * sz;
    } else {
      ++st.free_leaves;
      st.free_volume += sz * sz * sz;
    }
  }
  return st;
}

void Environment::write(const std::string& path) const {
  writeOcTree(*tree_, path);
}

void writeOcTree(const octomap::OcTree& tree, const std::string& path) {
  auto endsWith = [&](const char* ext) {
    const std::string e(ext);
    return path.size() >= e.size() && path.compare(path.size() - e.size(), e.size(), e) == 0;
  };
  const bool bt = endsWith(".bt"), ot = endsWith(".ot");
  if (!bt && !ot) throw io::InputError(path, 0, "", "octree output must end in .bt (binary) or .ot (full)");
  const std::string tmp = path + ".tmp";
  bool ok = false;
  // OctoMap prints progress (" done.") on the stderr file descriptor while writing: silence it.
  std::fflush(stderr);
  const int saved = ::dup(2);
  const int devnull = ::open("/dev/null", O_WRONLY);
  if (saved >= 0 && devnull >= 0) ::dup2(devnull, 2);
  try {
    ok = bt ? tree.writeBinaryConst(tmp) : tree.write(tmp);
  } catch (const std::exception&) {
    ok = false;
  }
  std::fflush(stderr);
  if (saved >= 0) {
    ::dup2(saved, 2);
    ::close(saved);
  }
  if (devnull >= 0) ::close(devnull);
  if (!ok) {
    std::remove(tmp.c_str());
    throw io::InputError(path, 0, "", "cannot write the octree (is the folder writable?)");
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    std::remove(tmp.c_str());
    throw io::InputError(path, 0, "", "cannot rename " + tmp + " to the output file");
  }
}

Eigen::Isometry3d poseFromDirection(const Eigen::Vector3d& position, const Eigen::Vector3d& direction,
                                    const Eigen::Vector3d* x_hint) {
  const double n = direction.norm();
  if (!(n > 1e-12) || !direction.allFinite())
    throw std::invalid_argument("insertion direction must be a non-zero finite vector");
  if (!position.allFinite()) throw std::invalid_argument("position must be finite");
  const Eigen::Vector3d z = direction / n;
  Eigen::Vector3d hint;
  bool have_hint = false;
  if (x_hint != nullptr && x_hint->allFinite()) {
    const Eigen::Vector3d h = *x_hint - x_hint->dot(z) * z;
    if (h.norm() > 1e-6 * std::max(1.0, x_hint->norm())) {
      hint = h.normalized();
      have_hint = true;
    }
  }
  if (!have_hint) {
    int axis = 0;
    z.cwiseAbs().minCoeff(&axis);
    Eigen::Vector3d e = Eigen::Vector3d::Zero();
    e[axis] = 1.0;
    hint = (e - e.dot(z) * z).normalized();
  }
  Eigen::Matrix3d R;
  R.col(0) = hint;
  R.col(1) = z.cross(hint);
  R.col(2) = z;
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = R;
  T.translation() = position;
  return T;
}

Eigen::Isometry3d poseFromMatrix(const Eigen::Matrix4d& m, double tolerance) {
  if (!m.allFinite()) throw std::invalid_argument("pose matrix has non-finite entries");
  if (std::abs(m(3, 0)) > 1e-9 || std::abs(m(3, 1)) > 1e-9 || std::abs(m(3, 2)) > 1e-9 ||
      std::abs(m(3, 3) - 1.0) > 1e-9)
    throw std::invalid_argument("pose matrix: the last row must be [0 0 0 1]");
  const Eigen::Matrix3d A = m.topLeftCorner<3, 3>();
  const double err = (A.transpose() * A - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  if (err > tolerance || A.determinant() <= 0.0) {
    std::ostringstream os;
    os << "pose matrix: the rotation block is not a proper rotation (|R^T R - I| = " << err
       << ", det = " << A.determinant() << ")";
    throw std::invalid_argument(os.str());
  }
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(A, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d R = svd.matrixU() * svd.matrixV().transpose();
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = R;
  T.translation() = m.topRightCorner<3, 1>();
  return T;
}

}  // namespace ctr::environments
