// VoxelGrid key math, grid -> octree conversion, octree rasterisation, unknown filling, atomic writing.
#include <gtest/gtest.h>
#include <octomap/OcTree.h>

#include <random>

#include "ctr/environments/environment.hpp"
#include "ctr/environments/octomap_source.hpp"
#include "ctr/environments/voxel_grid.hpp"
#include "env_test_util.hpp"

namespace ctr::environments {
namespace {

TEST(VoxelGrid, KeysMatchOctoMap) {
  octomap::OcTree tree(0.001);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-2.0, 2.0);
  for (int i = 0; i < 1000; ++i) {
    const double c = u(rng);
    EXPECT_EQ(coordToKey(c, 0.001), tree.coordToKey(c));
    const int k = coordToKey(c, 0.001);
    EXPECT_NEAR(keyToCoord(k, 0.001), tree.keyToCoord(static_cast<octomap::key_type>(k)), 1e-12);
  }
}

TEST(VoxelGrid, CellRangeAndFillBox) {
  VoxelGrid g(0.001, Aabb(Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(0.0099, 0.0099, 0.0099)));
  EXPECT_EQ(g.dims(), Eigen::Vector3i(10, 10, 10));
  // A box spanning cells 2..4 on x (touching the faces of 1 and 5 does not count).
  g.fillBox(Aabb(Eigen::Vector3d(0.002, 0.002, 0.002), Eigen::Vector3d(0.005, 0.003, 0.003)), VoxelGrid::kOccupied);
  EXPECT_EQ(g.count(VoxelGrid::kOccupied), 3u);
  EXPECT_EQ(g.at(2, 2, 2), VoxelGrid::kOccupied);
  EXPECT_EQ(g.at(4, 2, 2), VoxelGrid::kOccupied);
  EXPECT_EQ(g.at(5, 2, 2), VoxelGrid::kFree);
  // A point box occupies the cell containing it.
  g.fillBox(Aabb(Eigen::Vector3d(0.0075, 0.0075, 0.0075), Eigen::Vector3d(0.0075, 0.0075, 0.0075)),
            VoxelGrid::kOccupied);
  EXPECT_EQ(g.at(7, 7, 7), VoxelGrid::kOccupied);
  EXPECT_THROW(VoxelGrid(0.001, Aabb()), std::invalid_argument);
  EXPECT_THROW(VoxelGrid(1e-3, Aabb(Eigen::Vector3d::Zero(), Eigen::Vector3d::Constant(1.0)), 0, 1000),
               std::invalid_argument);
}

TEST(VoxelGrid, GridToOcTreeMatchesCells) {
  // Random blobs in an unaligned grid; every cell must read back with the same occupancy, outside is unknown.
  VoxelGrid g(0.002, Aabb(Eigen::Vector3d(-0.0131, 0.0047, -0.051), Eigen::Vector3d(0.0213, 0.0405, -0.0102)));
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> ux(-0.0131, 0.0213), uy(0.0047, 0.0405), uz(-0.051, -0.0102);
  for (int b = 0; b < 12; ++b) {
    const Eigen::Vector3d c(ux(rng), uy(rng), uz(rng));
    g.fillBox(Aabb(c.array() - 0.004, c.array() + 0.004), VoxelGrid::kOccupied);
  }
  auto tree = gridToOcTree(g, true);
  std::size_t occ = 0;
  for (int k = 0; k < g.dims().z(); ++k)
    for (int j = 0; j < g.dims().y(); ++j)
      for (int i = 0; i < g.dims().x(); ++i) {
        const Eigen::Vector3d c = g.centre(i, j, k);
        const octomap::OcTreeNode* n = tree->search(c.x(), c.y(), c.z());
        ASSERT_NE(n, nullptr);
        EXPECT_EQ(tree->isNodeOccupied(n), g.at(i, j, k) == VoxelGrid::kOccupied);
        occ += g.at(i, j, k) == VoxelGrid::kOccupied;
      }
  const Eigen::Vector3d out = g.bounds().max + Eigen::Vector3d::Constant(0.003);
  EXPECT_EQ(tree->search(out.x(), out.y(), out.z()), nullptr);
  // Uniform blocks are pruned: far fewer leaves than cells.
  EXPECT_LT(tree->getNumLeafNodes(), g.cells());
  // Inner nodes hold the max of their children (FCL relies on it).
  std::size_t checked = 0;
  for (auto it = tree->begin_tree(), end = tree->end_tree(); it != end; ++it) {
    if (!tree->nodeHasChildren(&*it)) continue;
    float mx = -1e9f;
    for (unsigned i = 0; i < 8; ++i)
      if (tree->nodeChildExists(&*it, i)) mx = std::max(mx, tree->getNodeChild(&*it, i)->getLogOdds());
    EXPECT_FLOAT_EQ(it->getLogOdds(), mx);
    ++checked;
  }
  EXPECT_GT(checked, 0u);
  // Same as inserting cell by cell.
  octomap::OcTree ref(0.002);
  for (int k = 0; k < g.dims().z(); ++k)
    for (int j = 0; j < g.dims().y(); ++j)
      for (int i = 0; i < g.dims().x(); ++i) {
        const Eigen::Vector3d c = g.centre(i, j, k);
        ref.updateNode(c.x(), c.y(), c.z(), g.at(i, j, k) == VoxelGrid::kOccupied, true);
      }
  std::size_t ref_occ = 0;
  for (auto it = ref.begin_leafs(), end = ref.end_leafs(); it != end; ++it)
    if (ref.isNodeOccupied(*it)) ref_occ += static_cast<std::size_t>(std::lround(std::pow(it.getSize() / 0.002, 3)));
  EXPECT_EQ(ref_occ, occ);

  // Without known free space only occupied cells exist.
  auto sparse = gridToOcTree(g, false);
  for (auto it = sparse->begin_leafs(), end = sparse->end_leafs(); it != end; ++it)
    EXPECT_TRUE(sparse->isNodeOccupied(*it));
}

TEST(VoxelGrid, RasterizeAndFillUnknown) {
  VoxelGrid g(0.001, Aabb(Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(0.0199, 0.0199, 0.0199)));
  g.fillBox(Aabb(Eigen::Vector3d(0.004, 0.004, 0.004), Eigen::Vector3d(0.008, 0.012, 0.006)), VoxelGrid::kOccupied);
  auto tree = gridToOcTree(g, false);  // free space unknown
  VoxelGrid back(0.001, g.bounds().inflated(-1e-4), VoxelGrid::kFree);
  rasterizeOcTree(*tree, back);
  EXPECT_EQ(back.data(), g.data());
  // Fill unknown inside a box: everything there becomes occupied, outside stays unknown.
  const Aabb box(Eigen::Vector3d(0.0, 0.0, 0.0), Eigen::Vector3d(0.0099, 0.0099, 0.0099));
  auto filled = fillUnknown(*tree, box);
  const octomap::OcTreeNode* n = filled->search(0.0015, 0.0015, 0.0015);
  ASSERT_NE(n, nullptr);
  EXPECT_TRUE(filled->isNodeOccupied(n));
  EXPECT_EQ(filled->search(0.0155, 0.0155, 0.0155), nullptr);
  n = filled->search(0.0055, 0.0055, 0.0055);  // originally occupied
  ASSERT_NE(n, nullptr);
  EXPECT_TRUE(filled->isNodeOccupied(n));
}

TEST(Environment, WriteIsAtomicAndReadable) {
  test::TempDir dir;
  VoxelGrid g(0.001, Aabb(Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(0.0099, 0.0099, 0.0099)));
  g.fillBox(Aabb(Eigen::Vector3d(0.002, 0.002, 0.002), Eigen::Vector3d(0.006, 0.006, 0.006)), VoxelGrid::kOccupied);
  Environment env("box", gridToOcTree(g));
  const std::string bt = dir.file("box.bt"), ot = dir.file("box.ot");
  env.write(bt);
  env.write(ot);
  EXPECT_FALSE(std::filesystem::exists(bt + ".tmp"));
  auto t1 = loadOcTreeFile(bt);
  auto t2 = loadOcTreeFile(ot);
  EXPECT_EQ(t1->getNumLeafNodes(), env.tree().getNumLeafNodes());
  EXPECT_EQ(t2->getNumLeafNodes(), env.tree().getNumLeafNodes());
  EXPECT_THROW(env.write(dir.file("box.txt")), io::InputError);
  EXPECT_THROW(env.write(dir.file("no/such/folder/box.bt")), io::InputError);
  EXPECT_FALSE(std::filesystem::exists(dir.file("no/such/folder/box.bt.tmp")));
  EXPECT_NEAR(env.stats().occupied_volume, 64e-9, 1e-15);
}

TEST(Environment, PosesAndNames) {
  const Eigen::Vector3d dir(1, 1, 0);
  const Eigen::Isometry3d T = poseFromDirection(Eigen::Vector3d(1, 2, 3), dir);
  EXPECT_TRUE(T.linear().col(2).isApprox(dir.normalized()));
  EXPECT_NEAR((T.linear().transpose() * T.linear() - Eigen::Matrix3d::Identity()).norm(), 0.0, 1e-12);
  EXPECT_NEAR(T.linear().determinant(), 1.0, 1e-12);
  const Eigen::Vector3d hint(0, 0, 1);
  const Eigen::Isometry3d T2 = poseFromDirection(Eigen::Vector3d::Zero(), dir, &hint);
  EXPECT_TRUE(T2.linear().col(0).isApprox(hint));
  EXPECT_THROW(poseFromDirection(Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()), std::invalid_argument);
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m(0, 1) = 0.5;
  EXPECT_THROW(poseFromMatrix(m), std::invalid_argument);

  VoxelGrid g(0.001, Aabb(Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(0.0099, 0.0099, 0.0099)));
  Environment env("e", gridToOcTree(g));
  env.addStart({"a", T, "x"});
  env.addTarget({"t", Eigen::Vector3d(0.001, 0.001, 0.001), "x"});
  env.useStart("a");
  EXPECT_TRUE(env.basePose().isApprox(T));
  EXPECT_THROW(env.useStart("b"), std::invalid_argument);
  try {
    env.target("nope");
    ADD_FAILURE();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("known: t"), std::string::npos);
  }
  EXPECT_EQ(env.occupancy(Eigen::Vector3d(0.005, 0.005, 0.005)), Occupancy::Free);
  EXPECT_EQ(env.occupancy(Eigen::Vector3d(0.5, 0.5, 0.5)), Occupancy::Unknown);
  EXPECT_EQ(env.occupancy(Eigen::Vector3d(1e6, 0, 0)), Occupancy::Unknown);
  EXPECT_TRUE(env.isObstacle(Eigen::Vector3d(0.5, 0.5, 0.5), UnknownSpace::Occupied));
  EXPECT_FALSE(env.isObstacle(Eigen::Vector3d(0.5, 0.5, 0.5), UnknownSpace::Free));
}

}  // namespace
}  // namespace ctr::environments
