// Environment descriptions: every source type together, stay-inside regions, base poses (Med-MPD start files,
// matrices, position + direction), targets, and bad inputs with their messages.
#include <gtest/gtest.h>
#include <octomap/OcTree.h>

#include "ctr/environments/environment_yaml.hpp"
#include "ctr/environments/medmpd.hpp"
#include "ctr/environments/mesh_source.hpp"
#include "ctr/environments/nifti_source.hpp"
#include "ctr/environments/pointcloud_source.hpp"
#include "env_test_util.hpp"

namespace ctr::environments {
namespace {

using test::expectInputError;
using test::TempDir;

// A 20 mm cube of 1 mm voxels (voxel i spans [i, i + 1] mm) with label 2 in [5, 8) mm on every axis.
std::string writeVolume(const TempDir& dir, const std::string& name) {
  std::vector<float> vals(20 * 20 * 20, 0.0f);
  for (int k = 5; k < 8; ++k)
    for (int j = 5; j < 8; ++j)
      for (int i = 5; i < 8; ++i) vals[i + 20 * (j + 20 * k)] = 2.0f;
  Eigen::Matrix4d A = Eigen::Matrix4d::Identity();
  A.topLeftCorner<3, 3>() *= 0.001;
  A.topRightCorner<3, 1>().setConstant(0.0005);
  writeNifti(dir.file(name), Eigen::Vector3i(20, 20, 20), vals, A);
  return dir.file(name);
}

TriangleMesh box(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi) {
  TriangleMesh m;
  for (int c = 0; c < 8; ++c)
    m.vertices.emplace_back((c & 1) ? hi.x() : lo.x(), (c & 2) ? hi.y() : lo.y(), (c & 4) ? hi.z() : lo.z());
  const int f[12][3] = {{0, 2, 1}, {1, 2, 3}, {4, 5, 6}, {5, 7, 6}, {0, 1, 4}, {1, 5, 4},
                        {2, 6, 3}, {3, 6, 7}, {0, 4, 2}, {2, 4, 6}, {1, 3, 5}, {3, 7, 5}};
  for (const auto& t : f) m.triangles.push_back({t[0], t[1], t[2]});
  return m;
}

const char* kStart =
    "-5.248765888557394010e-01 5.107049987509495459e-01 6.809441759219001522e-01 4.305291433190915029e+00\n"
    "5.639258054610066795e-01 -3.905890173074297311e-01 7.276179667201541079e-01 1.488654564382930232e+01\n"
    "6.375674492995373477e-01 7.659116292429624107e-01 -8.298869672475249482e-02 1.226848388671875000e+01\n"
    "0.000000000000000000e+00 0.000000000000000000e+00 0.000000000000000000e+00 1.000000000000000000e+00\n";

TEST(MedMpd, StartAndTargetFiles) {
  TempDir dir;
  const Eigen::Isometry3d T = readMedMpdStart(dir.write("start1.txt", kStart));
  // Translation mm -> m; the rotation's z column is the insertion direction.
  EXPECT_TRUE(
      T.translation().isApprox(Eigen::Vector3d(0.004305291433190915, 0.01488654564382930, 0.01226848388671875)));
  EXPECT_TRUE(T.linear().col(2).isApprox(Eigen::Vector3d(0.6809441759219, 0.7276179667201, -0.0829886967248), 1e-9));
  EXPECT_NEAR(T.linear().determinant(), 1.0, 1e-12);
  EXPECT_TRUE(readMedMpdTarget(dir.write("t.txt", "6.48e+01\n2.01e+02\n1.21e+03\n"))
                  .isApprox(Eigen::Vector3d(0.0648, 0.201, 1.21)));
  expectInputError([&] { readMedMpdStart(dir.write("bad.txt", "1 0 0 0\n0 1 0 0\n0 0 1 0\n")); },
                   {"bad.txt:3", "16 numbers", "found 12"});
  expectInputError([&] { readMedMpdStart(dir.write("skew.txt", "1 0.5 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n")); },
                   {"skew.txt", "not a proper rotation"});
  expectInputError([&] { readMedMpdTarget(dir.write("word.txt", "1\nabc\n3\n")); }, {"word.txt:2", "abc"});
  expectInputError([&] { readMedMpdTarget(dir.file("nope.txt")); }, {"nope.txt", "cannot open"});
}

TEST(EnvironmentYaml, AllSourcesTogether) {
  TempDir dir;
  writeVolume(dir, "seg.nii.gz");
  writeStl(dir.file("box.stl"), box(Eigen::Vector3d(12.5, 12.5, 12.5), Eigen::Vector3d(14.5, 14.5, 14.5)));  // mm
  writeXyz(dir.file("pts.xyz"), {Eigen::Vector3d(0.0025, 0.0175, 0.0025)});
  octomap::OcTree t(0.001);
  t.updateNode(0.0165, 0.0025, 0.0025, true);
  t.writeBinary(dir.file("extra.bt"));
  dir.write("start.txt", kStart);
  const std::string yaml = R"(
name: all
resolution: 0.001
obstacles:
  - nifti: seg.nii.gz
    label: 2
  - mesh: box.stl
    units: mm
    fill: true
  - points: pts.xyz
  - octomap: extra.bt
starts:
  bronchus: {medmpd_start: start.txt}
  side: {position: [1, 2, 3], direction: [0, 0, 1], units: mm}
base_pose: {start: side}
targets:
  a: [0.010, 0.010, 0.010]
  b: {position: [2.5, 2.5, 2.5], units: mm}
collision: {safety_margin: 0.0002, unknown_space: occupied}
)";
  const Environment env = loadEnvironment(dir.write("all.yaml", yaml));
  EXPECT_EQ(env.name(), "all");
  EXPECT_DOUBLE_EQ(env.resolution(), 0.001);
  auto occ = [&](double x, double y, double z) { return env.occupancy(Eigen::Vector3d(x, y, z) * 1e-3); };
  EXPECT_EQ(occ(6.5, 6.5, 6.5), Occupancy::Occupied);     // NIfTI label 2
  EXPECT_EQ(occ(4.5, 6.5, 6.5), Occupancy::Free);         // next to it
  EXPECT_EQ(occ(13.5, 13.5, 13.5), Occupancy::Occupied);  // inside the filled mesh
  EXPECT_EQ(occ(2.5, 17.5, 2.5), Occupancy::Occupied);    // point
  EXPECT_EQ(occ(16.5, 2.5, 2.5), Occupancy::Occupied);    // from the .bt
  EXPECT_EQ(occ(10.5, 10.5, 10.5), Occupancy::Free);
  EXPECT_EQ(occ(30, 30, 30), Occupancy::Unknown);  // outside the map
  EXPECT_EQ(env.sources().size(), 4u);
  EXPECT_NEAR(env.stats().occupied_volume, (27 + 27 + 1 + 1) * 1e-9, 1e-12);  // 3^3 + 3^3 mesh cells + 2
  ASSERT_EQ(env.starts().size(), 2u);
  EXPECT_TRUE(env.basePose().translation().isApprox(Eigen::Vector3d(0.001, 0.002, 0.003)));
  EXPECT_EQ(env.basePoseSource(), "side");
  EXPECT_TRUE(env.start("bronchus").pose.isApprox(readMedMpdStart(dir.file("start.txt"))));
  EXPECT_TRUE(env.target("b").position.isApprox(Eigen::Vector3d(0.0025, 0.0025, 0.0025)));
  EXPECT_DOUBLE_EQ(env.collisionDefaults().safety_margin, 0.0002);
  EXPECT_EQ(env.collisionDefaults().unknown_space, UnknownSpace::Occupied);
  // A coarser resolution override.
  BuildOptions bo;
  bo.resolution = 0.002;
  EXPECT_DOUBLE_EQ(loadEnvironment(dir.file("all.yaml"), bo).resolution(), 0.002);
}

TEST(EnvironmentYaml, StayInsideNiftiAndMesh) {
  TempDir dir;
  writeVolume(dir, "lumen.nii");
  Environment a = loadEnvironment(dir.write("a.yaml", "stay_inside: {nifti: lumen.nii, label: 2}\n"));
  // Free only in the 3x3x3 region; everything else in the map is an obstacle.
  EXPECT_NEAR(a.stats().free_volume, 27e-9, 1e-13);
  EXPECT_EQ(a.occupancy(Eigen::Vector3d(0.0065, 0.0065, 0.0065)), Occupancy::Free);
  EXPECT_EQ(a.occupancy(Eigen::Vector3d(0.0045, 0.0065, 0.0065)), Occupancy::Occupied);
  // A closed mesh as region plus an obstacle inside it.
  writeStl(dir.file("room.stl"), box(Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(0.01, 0.01, 0.01)));
  writeXyz(dir.file("p.xyz"), {Eigen::Vector3d(0.0055, 0.0055, 0.0055)});
  Environment b = loadEnvironment(dir.write("b.yaml",
                                            "resolution: 0.001\nstay_inside: {mesh: room.stl}\n"
                                            "obstacles: [{points: p.xyz}]\n"));
  // The walls lie on cell faces: cells 0 and 9 touch them, so only cells 1..8 are free (minus the point's cell).
  EXPECT_EQ(b.occupancy(Eigen::Vector3d(0.0045, 0.0045, 0.0045)), Occupancy::Free);
  EXPECT_EQ(b.occupancy(Eigen::Vector3d(0.0055, 0.0055, 0.0055)), Occupancy::Occupied);
  EXPECT_EQ(b.occupancy(Eigen::Vector3d(0.0005, 0.0045, 0.0045)), Occupancy::Occupied);
  EXPECT_EQ(b.occupancy(Eigen::Vector3d(-0.0015, 0.0045, 0.0045)), Occupancy::Occupied);
  EXPECT_NEAR(b.stats().free_volume, (8 * 8 * 8 - 1) * 1e-9, 1e-13);
}

TEST(EnvironmentYaml, PoseForms) {
  TempDir dir;
  writeVolume(dir, "v.nii");
  const Environment e = loadEnvironment(
      dir.write("p.yaml",
                "obstacles: [{nifti: v.nii}]\n"
                "base_pose:\n  matrix: [[0, 0, 1, 10], [0, 1, 0, 0], [-1, 0, 0, 5], [0, 0, 0, 1]]\n  units: mm\n"));
  EXPECT_TRUE(e.basePose().translation().isApprox(Eigen::Vector3d(0.01, 0, 0.005)));
  EXPECT_TRUE(e.basePose().linear().col(2).isApprox(Eigen::Vector3d(1, 0, 0)));
  const Environment f = loadEnvironment(
      dir.write("q.yaml",
                "obstacles: [{nifti: v.nii}]\nbase_pose: {position: [0.001, 0, 0], direction: [0, 2, 0], "
                "x_axis: [0, 0, 1]}\n"));
  EXPECT_TRUE(f.basePose().linear().col(2).isApprox(Eigen::Vector3d(0, 1, 0)));
  EXPECT_TRUE(f.basePose().linear().col(0).isApprox(Eigen::Vector3d(0, 0, 1)));
  // Without base_pose the first start is used; without starts the identity.
  dir.write("s.txt", kStart);
  const Environment g = loadEnvironment(dir.write("r.yaml",
                                                  "obstacles: [{nifti: v.nii}]\ncheck_targets: false\n"
                                                  "starts: {s1: {medmpd_start: s.txt}}\n"));
  EXPECT_TRUE(g.basePose().isApprox(readMedMpdStart(dir.file("s.txt"))));
}

TEST(EnvironmentYaml, BadInputs) {
  TempDir dir;
  writeVolume(dir, "v.nii");
  auto load = [&](const std::string& name, const std::string& yaml) { return loadEnvironment(dir.write(name, yaml)); };
  // 1. Missing description file.
  expectInputError([&] { loadEnvironment(dir.file("absent.yaml")); }, {"absent.yaml", "cannot open"});
  // 2. Malformed YAML, with the line.
  expectInputError([&] { load("m.yaml", "obstacles:\n  - nifti: [v.nii\n"); }, {"m.yaml:", "malformed YAML"});
  // 3. Unknown key, with line and key.
  expectInputError([&] { load("k.yaml", "resolution: 0.001\nobstacle: []\n"); },
                   {"k.yaml:2", "key 'obstacle'", "unknown key"});
  // 4. Missing NIfTI file.
  expectInputError([&] { load("n.yaml", "obstacles: [{nifti: nothere.nii.gz}]\n"); },
                   {"nothere.nii.gz", "cannot open"});
  // 5. Unknown label.
  expectInputError([&] { load("l.yaml", "obstacles: [{nifti: v.nii, label: 5}]\n"); },
                   {"v.nii", "label 5 does not occur", "values present: 0 2"});
  // 6. Target outside the map.
  expectInputError([&] { load("t.yaml", "obstacles: [{nifti: v.nii}]\ntargets: {far: [1.0, 0, 0]}\n"); },
                   {"t.yaml", "target 'far'", "outside the map bounds"});
  // 7. Empty mesh.
  dir.write("empty.stl", "solid e\nendsolid e\n");
  expectInputError([&] { load("e.yaml", "obstacles: [{mesh: empty.stl}]\n"); }, {"empty.stl"});
  // 8. Fill of an open mesh.
  dir.write("tri.obj", "v 0 0 0\nv 0.01 0 0\nv 0 0.01 0\nf 1 2 3\n");
  expectInputError([&] { load("f.yaml", "obstacles: [{mesh: tri.obj, fill: true}]\n"); }, {"tri.obj", "not closed"});
  // 9. Corrupt octree file.
  dir.write("bad.bt", "# Octomap OcTree binary file\nid OcTree\nsize 5\nres 0.01\ndata\n\x01");
  expectInputError([&] { load("o.yaml", "obstacles: [{octomap: bad.bt}]\n"); }, {"bad.bt", "corrupt"});
  // 10. Unknown procedural type.
  expectInputError([&] { load("p.yaml", "procedural: {type: kidney}\n"); },
                   {"p.yaml:1", "unknown procedural type 'kidney'", "intracardiac"});
  // 11. Unknown procedural parameter.
  expectInputError([&] { load("p2.yaml", "procedural: {type: airway, branches: 3}\n"); },
                   {"p2.yaml:1", "key 'procedural.branches'", "unknown key for procedural type 'airway'"});
  // 12. Bad unit.
  expectInputError([&] { load("u.yaml", "obstacles: [{mesh: tri.obj, units: inch}]\n"); },
                   {"u.yaml:1", "key 'obstacles[0].units'", "unknown unit 'inch'"});
  // 13. Nothing to map.
  expectInputError([&] { load("z.yaml", "name: nothing\n"); }, {"nothing to map"});
  // 14. Unknown start referenced by base_pose.
  expectInputError([&] { load("s.yaml", "obstacles: [{nifti: v.nii}]\nbase_pose: {start: start9}\n"); },
                   {"s.yaml:2", "start9"});
  // 15. Bad Med-MPD start file referenced from YAML.
  dir.write("short.txt", "1 2 3\n");
  expectInputError([&] { load("ms.yaml", "obstacles: [{nifti: v.nii}]\nstarts: {a: {medmpd_start: short.txt}}\n"); },
                   {"short.txt", "16 numbers"});
  // 16. Resolution out of range and a grid too large.
  expectInputError([&] { load("r.yaml", "resolution: 1.0\nobstacles: [{nifti: v.nii}]\n"); }, {"key 'resolution'"});
  BuildOptions tiny;
  tiny.max_cells = 100;
  expectInputError([&] { loadEnvironment(dir.write("big.yaml", "obstacles: [{nifti: v.nii}]\n"), tiny); },
                   {"cells", "coarser resolution"});
  // 17. Two ways of giving a pose.
  expectInputError(
      [&] {
        load("two.yaml",
             "obstacles: [{nifti: v.nii}]\nbase_pose: {start: a, position: [0, 0, 0], direction: [0, 0, 1]}\n");
      },
      {"exactly one of"});
  // 18. Point cloud as a stay-inside region.
  writeXyz(dir.file("p.xyz"), {Eigen::Vector3d::Zero()});
  expectInputError([&] { load("pi.yaml", "stay_inside: {points: p.xyz}\n"); }, {"cannot be a stay_inside"});
  // 19. Keys inside sources, poses and targets are named by their path in the document.
  expectInputError([&] { load("sk.yaml", "obstacles:\n  - nifti: v.nii\n    lable: 2\n"); },
                   {"sk.yaml:3", "key 'obstacles[0].lable'", "unknown key", "label"});
  expectInputError([&] { load("tv.yaml", "obstacles: [{nifti: v.nii}]\ntargets: {a: [0, x, 0]}\n"); },
                   {"tv.yaml:2", "key 'targets.a[1]'", "'x' is not a number"});
  expectInputError(
      [&] { load("pv.yaml", "obstacles: [{nifti: v.nii}]\nstarts: {s: {position: [0, 0], direction: [0, 0, 1]}}\n"); },
      {"pv.yaml:2", "key 'starts.s.position'", "3 numbers"});
  // 20. A flag that is not true or false.
  expectInputError([&] { load("b.yaml", "obstacles: [{nifti: v.nii}]\nmark_free: maybe\n"); },
                   {"b.yaml:2", "key 'mark_free'", "must be true or false"});
}

// Found by fuzz_environment_yaml: a mapping key that is not a scalar escaped as YAML::TypedBadConversion. Now refused
// by the reader with the key's line.
TEST(EnvironmentYaml, NonScalarKeysAreInputErrors) {
  for (const char* text : {"{{type: nope}}\n", "{[1, 2]: 3}\n", "procedural: {type: airway, [1]: 2}\n",
                           "procedural: {type: airway}\nstarts: {[a]: {position: [0, 0, 0], direction: [0, 0, 1]}}\n",
                           "procedural: {type: airway}\ntargets: {{a: 1}: [0, 0, 0]}\n",
                           "procedural: {type: airway}\ncollision: {{x: 1}: 2}\n"}) {
    SCOPED_TRACE(text);
    try {
      (void)parseEnvironmentDescription(text, "keys.yaml", ".");
      ADD_FAILURE() << "expected ctr::io::InputError";
    } catch (const io::InputError& e) {
      EXPECT_GT(e.line(), 0) << e.what();  // the shared YAML reader names the line of the key
    }
  }
}

}  // namespace
}  // namespace ctr::environments
