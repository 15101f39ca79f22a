// Procedural anatomies: determinism for a seed, variety across seeds, free start poses and targets, parameters.
#include <gtest/gtest.h>
#include <octomap/OcTree.h>

#include <fstream>
#include <sstream>

#include "ctr/environments/environment_yaml.hpp"
#include "ctr/environments/procedural.hpp"
#include "env_test_util.hpp"

namespace ctr::environments {
namespace {

// Every leaf: key, depth and log-odds, in traversal order.
std::string bytesOf(const octomap::OcTree& t) {
  std::ostringstream os;
  os.precision(9);
  for (auto it = t.begin_leafs(), end = t.end_leafs(); it != end; ++it)
    os << it.getKey()[0] << ' ' << it.getKey()[1] << ' ' << it.getKey()[2] << ' ' << it.getDepth() << ' '
       << it->getLogOdds() << '\n';
  return os.str();
}

Environment build(const std::string& type, std::uint64_t seed, double res, const std::string& extra = "") {
  std::ostringstream y;
  y << "resolution: " << res << "\nprocedural: {type: " << type << ", seed: " << seed << extra << "}\n";
  return buildEnvironment(parseEnvironmentDescription(y.str(), "<test>"));
}

class ProceduralTypes : public ::testing::TestWithParam<std::string> {};

TEST_P(ProceduralTypes, SameSeedSameTreeDifferentSeedDifferentTree) {
  const std::string type = GetParam();
  const double res = type == "sinus" ? 0.0005 : 0.001;
  const Environment a = build(type, 7, res), b = build(type, 7, res), c = build(type, 8, res);
  const std::string ba = bytesOf(a.tree()), bb = bytesOf(b.tree()), bc = bytesOf(c.tree());
  EXPECT_EQ(ba, bb);
  EXPECT_NE(ba, bc);
  ASSERT_EQ(a.targets().size(), b.targets().size());
  for (std::size_t i = 0; i < a.targets().size(); ++i) EXPECT_EQ(a.targets()[i].position, b.targets()[i].position);
  // The start pose and every target lie in free space, inside the map.
  ASSERT_FALSE(a.starts().empty());
  EXPECT_EQ(a.occupancy(a.basePose().translation()), Occupancy::Free);
  EXPECT_GE(a.targets().size(), 3u);
  for (const auto& t : a.targets()) EXPECT_EQ(a.occupancy(t.position), Occupancy::Free) << type << " " << t.name;
  // A stay-inside anatomy: mostly walls, some lumen, no unknown inside the map.
  const OccupancyStats st = a.stats();
  EXPECT_GT(st.free_volume, 0.0);
  EXPECT_GT(st.occupied_volume, st.free_volume);
  EXPECT_LT(a.buildSeconds(), 5.0);
}

INSTANTIATE_TEST_SUITE_P(All, ProceduralTypes, ::testing::Values("intracardiac", "airway", "sinus"));

TEST(Procedural, IntracardiacStructure) {
  const ProceduralAnatomy h = makeProcedural({"intracardiac", 1, 1.0, {}});
  EXPECT_EQ(h.type, "intracardiac");
  std::vector<std::string> names;
  for (const auto& o : h.obstacles) names.push_back(o.name);
  for (const char* n : {"interatrial_septum", "tricuspid_annulus", "leaflet_1", "leaflet_2", "leaflet_3", "chorda_1"})
    EXPECT_NE(std::find(names.begin(), names.end(), n), names.end()) << n;
  // The foramen target is in the septum's hole: inside the septum box, but outside the holed septum.
  const Primitive* septum = nullptr;
  for (const auto& o : h.obstacles)
    if (o.name == "interatrial_septum") septum = &o;
  ASSERT_NE(septum, nullptr);
  Eigen::Vector3d fo;
  for (const auto& t : h.targets)
    if (t.name == "foramen") fo = t.position;
  EXPECT_GT(septum->g(fo), 0.0);
  Primitive solid = *septum;
  solid.holes.clear();
  EXPECT_LT(solid.g(fo), 0.0);
  // Quick to build at 1 mm (the README demo); ASan + UBSan builds (scripts/run-sanitizers.sh) are ~5-10x slower.
  const Environment e = build("intracardiac", 1, 0.001);
#ifdef CTR_SANITIZED
  EXPECT_LT(e.buildSeconds(), 10.0);
#else
  EXPECT_LT(e.buildSeconds(), 1.0);
#endif
}

TEST(Procedural, PrimitivesAreLipschitzAndSigned) {
  Primitive e;
  e.kind = Primitive::Kind::Ellipsoid;
  e.radii = Eigen::Vector3d(0.01, 0.02, 0.03);
  EXPECT_LT(e.g(Eigen::Vector3d::Zero()), 0.0);
  EXPECT_NEAR(e.g(Eigen::Vector3d(0.01, 0, 0)), 0.0, 1e-12);
  // |g| never exceeds the true distance (conservative rasterisation relies on it): sample pairs.
  Primitive t;
  t.kind = Primitive::Kind::Torus;
  t.major_radius = 0.01;
  t.radius = 0.002;
  Primitive b;
  b.kind = Primitive::Kind::Box;
  b.radii = Eigen::Vector3d(0.01, 0.005, 0.002);
  b.radius = 0.001;
  b.holes.push_back(t);
  for (const Primitive* p : {&e, &t, &b}) {
    for (int i = 0; i < 2000; ++i) {
      const Eigen::Vector3d x = Eigen::Vector3d::Random() * 0.04, y = x + Eigen::Vector3d::Random() * 0.003;
      EXPECT_LE(std::abs(p->g(x) - p->g(y)), (x - y).norm() * (1 + 1e-9) + 1e-15);
    }
  }
}

TEST(Procedural, Parameters) {
  EXPECT_THROW(makeProcedural({"kidney", 1, 1.0, {}}), std::invalid_argument);
  EXPECT_THROW(makeProcedural({"airway", 1, 1.0, {{"generations", 9}}}), std::invalid_argument);
  EXPECT_THROW(makeProcedural({"sinus", 1, 1.0, {{"width", 0.004}}}), std::invalid_argument);
  const ProceduralAnatomy a2 = makeProcedural({"airway", 3, 1.0, {{"generations", 2}}});
  const ProceduralAnatomy a3 = makeProcedural({"airway", 3, 1.0, {{"generations", 3}}});
  auto leaves = [](const ProceduralAnatomy& a) {
    return std::count_if(a.targets.begin(), a.targets.end(),
                         [](const NamedTarget& t) { return t.name.rfind("leaf_", 0) == 0; });
  };
  EXPECT_EQ(leaves(a2), 4);
  EXPECT_EQ(leaves(a3), 8);
  // Scale multiplies every length.
  const ProceduralAnatomy s1 = makeProcedural({"intracardiac", 2, 1.0, {}});
  const ProceduralAnatomy s2 = makeProcedural({"intracardiac", 2, 2.0, {}});
  EXPECT_TRUE((s2.targets[0].position).isApprox(2.0 * s1.targets[0].position));
  EXPECT_FALSE(proceduralParameters("airway").empty());
}

}  // namespace
}  // namespace ctr::environments
