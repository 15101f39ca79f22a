// Helpers shared by the environment tests: temporary folders, small files, brute-force geometry.
#pragma once

#include <gtest/gtest.h>
#include <octomap/OcTree.h>

#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <string>
#include <vector>

#include "ctr/environments/aabb.hpp"
#include "ctr/environments/robot_geometry.hpp"
#include "ctr/io/input_error.hpp"

namespace ctr::environments::test {

/// A fresh folder under the system temp dir, removed at the end of the test.
class TempDir {
 public:
  TempDir() {
    static int counter = 0;
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    std::string name = std::string("ctr_env_") + (info ? info->name() : "x") + "_" + std::to_string(::getpid()) + "_" +
                       std::to_string(counter++);
    for (char& c : name)
      if (c == '/') c = '_';
    path_ = std::filesystem::temp_directory_path() / name;
    std::filesystem::remove_all(path_);
    std::filesystem::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  std::string file(const std::string& name) const { return (path_ / name).string(); }
  std::string write(const std::string& name, const std::string& content) const {
    std::ofstream(file(name), std::ios::binary) << content;
    return file(name);
  }
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
};

/// Occupied leaf boxes of a tree.
inline std::vector<Aabb> occupiedBoxes(const octomap::OcTree& tree) {
  std::vector<Aabb> out;
  if (!tree.getRoot()) return out;
  for (auto it = tree.begin_leafs(), end = tree.end_leafs(); it != end; ++it) {
    if (!tree.isNodeOccupied(*it)) continue;
    const double h = 0.5 * it.getSize();
    const Eigen::Vector3d c(it.getX(), it.getY(), it.getZ());
    out.emplace_back(c.array() - h, c.array() + h);
  }
  return out;
}

/// Smallest distance between the axis of the capsule (sampled every `step`) and the boxes, minus the radius.
/// Exact up to step / 2.
inline double bruteClearance(const Capsule& c, const std::vector<Aabb>& boxes, double step) {
  const double L = (c.b - c.a).norm();
  const int n = std::max(1, static_cast<int>(std::ceil(L / step)));
  Aabb near;
  near.extend(c.a);
  near.extend(c.b);
  near = near.inflated(c.radius + 0.05);
  double best = std::numeric_limits<double>::infinity();
  for (const Aabb& b : boxes) {
    if (!near.intersects(b)) continue;
    for (int i = 0; i <= n; ++i) best = std::min(best, distance(b, c.a + (c.b - c.a) * (double(i) / n)));
  }
  return best - c.radius;
}

/// Expects `f` to throw ctr::io::InputError whose what() contains every fragment.
template <class F>
void expectInputError(F&& f, const std::vector<std::string>& fragments) {
  try {
    f();
    ADD_FAILURE() << "expected ctr::io::InputError";
  } catch (const ctr::io::InputError& e) {
    const std::string w = e.what();
    for (const auto& s : fragments) EXPECT_NE(w.find(s), std::string::npos) << "'" << s << "' not in: " << w;
  } catch (const std::exception& e) {
    ADD_FAILURE() << "expected ctr::io::InputError, got: " << e.what();
  }
}

}  // namespace ctr::environments::test
