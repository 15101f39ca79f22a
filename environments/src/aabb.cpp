#include "ctr/environments/aabb.hpp"

namespace ctr::environments {

double distance(const Aabb& box, const Eigen::Vector3d& p) {
  if (box.empty()) return std::numeric_limits<double>::infinity();
  const Eigen::Vector3d d = (box.min - p).cwiseMax(p - box.max).cwiseMax(Eigen::Vector3d::Zero());
  return d.norm();
}

}  // namespace ctr::environments
