// Obstacle sources on small generated inputs: NIfTI (affines, labels, sampling), meshes, point clouds, octree files.
#include <gtest/gtest.h>
#include <nifti2_io.h>
#include <octomap/OcTree.h>

#include <cstring>

#include "ctr/environments/mesh_source.hpp"
#include "ctr/environments/nifti_source.hpp"
#include "ctr/environments/octomap_source.hpp"
#include "ctr/environments/pointcloud_source.hpp"
#include "ctr/environments/voxel_grid.hpp"
#include "env_test_util.hpp"

namespace ctr::env {
namespace {

using test::expectInputError;
using test::TempDir;

// A 10x8x6 uint8 volume written directly with the NIfTI API: value 3 in a 2x2x2 block at (4..5, 3..4, 2..3),
// value 1 at voxel (0, 0, 0). sform: 2 mm spacing, origin (-10, 20, 30) mm; qform: 1 mm spacing, origin (0, 0, 0).
std::string writeTestNifti(const TempDir& dir, const std::string& name, int sform_code, int qform_code,
                           int ndim = 3, int nt = 1) {
  nifti_set_debug_level(0);
  const int64_t dims[8] = {ndim, 10, 8, 6, nt, 1, 1, 1};
  nifti_image* nim = nifti_make_new_nim(dims, DT_UINT8, 1);
  auto* d = static_cast<std::uint8_t*>(nim->data);
  for (int t = 0; t < nt; ++t) {
    std::uint8_t* v = d + t * 480;
    v[0] = 1;
    for (int k = 2; k <= 3; ++k)
      for (int j = 3; j <= 4; ++j)
        for (int i = 4; i <= 5; ++i) v[i + 10 * (j + 8 * k)] = 3;
  }
  nim->xyz_units = NIFTI_UNITS_MM;
  nim->sform_code = sform_code;
  nim->qform_code = qform_code;
  nifti_dmat44 s{};
  s.m[0][0] = 2;
  s.m[1][1] = 2;
  s.m[2][2] = 2;
  s.m[0][3] = -10;
  s.m[1][3] = 20;
  s.m[2][3] = 30;
  s.m[3][3] = 1;
  nim->sto_xyz = s;
  nim->quatern_b = nim->quatern_c = nim->quatern_d = 0;
  nim->qoffset_x = nim->qoffset_y = nim->qoffset_z = 0;
  nim->qfac = 1;
  nim->dx = nim->dy = nim->dz = 1;
  nim->pixdim[1] = nim->pixdim[2] = nim->pixdim[3] = 1;
  nim->nifti_type = NIFTI_FTYPE_NIFTI1_1;
  const std::string path = dir.file(name);
  nifti_set_filenames(nim, path.c_str(), 0, 1);
  nifti_image_write(nim);
  nifti_image_free(nim);
  return path;
}

TEST(NiftiSource, SformPreferredOverQform) {
  TempDir dir;
  const std::string both = writeTestNifti(dir, "both.nii", 1, 1);
  NiftiVolume v = readNifti(both);
  EXPECT_EQ(v.affine_used, "sform");
  EXPECT_EQ(v.dims, Eigen::Vector3i(10, 8, 6));
  // Voxel (4, 3, 2) centre: (-10 + 8, 20 + 6, 30 + 4) mm.
  const Eigen::Vector4d c = v.ijk_to_world * Eigen::Vector4d(4, 3, 2, 1);
  EXPECT_TRUE(c.head<3>().isApprox(Eigen::Vector3d(-0.002, 0.026, 0.034), 1e-12));
  NiftiVolume q = readNifti(both, NiftiAffine::Qform);
  EXPECT_EQ(q.affine_used, "qform");
  EXPECT_TRUE((q.ijk_to_world * Eigen::Vector4d(4, 3, 2, 1)).head<3>().isApprox(Eigen::Vector3d(0.004, 0.003, 0.002)));
  // Only a qform: auto falls back to it.
  NiftiVolume qo = readNifti(writeTestNifti(dir, "qonly.nii.gz", 0, 1));
  EXPECT_EQ(qo.affine_used, "qform");
  expectInputError([&] { readNifti(qo.path, NiftiAffine::Sform); }, {"qonly.nii.gz", "no sform"});
}

TEST(NiftiSource, QformWithRotationAndFlip) {
  // A qform with a rotation and qfac = -1 (left-handed index space), written through the library helper.
  TempDir dir;
  Eigen::Matrix4d A = Eigen::Matrix4d::Identity();
  A.topLeftCorner<3, 3>() = Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix() *
                            Eigen::Vector3d(0.001, 0.0015, -0.002).asDiagonal();
  A.topRightCorner<3, 1>() = Eigen::Vector3d(0.01, -0.02, 0.03);
  std::vector<float> vals(4 * 5 * 6, 0.0f);
  vals[1 + 4 * (2 + 5 * 3)] = 1.0f;
  const std::string path = dir.file("rot.nii");
  writeNifti(path, Eigen::Vector3i(4, 5, 6), vals, A, 0, 1);
  const NiftiVolume v = readNifti(path);
  EXPECT_EQ(v.affine_used, "qform");
  EXPECT_LT((v.ijk_to_world - A).cwiseAbs().maxCoeff(), 1e-7);
}

TEST(NiftiSource, SelectionAndSampling) {
  TempDir dir;
  NiftiVolume v = readNifti(writeTestNifti(dir, "sel.nii", 1, 0));
  NiftiSelection three;
  three.labels = {3};
  auto mask = selectVoxels(v, three);
  EXPECT_EQ(std::count(mask.begin(), mask.end(), 1), 8);
  NiftiSelection any;  // non-zero
  const auto many = selectVoxels(v, any);
  EXPECT_EQ(std::count(many.begin(), many.end(), 1), 9);
  NiftiSelection thr;
  thr.threshold = 2.0;
  auto mt = selectVoxels(v, thr);
  EXPECT_EQ(std::count(mt.begin(), mt.end(), 1), 8);
  NiftiSelection missing;
  missing.labels = {7};
  expectInputError([&] { selectVoxels(v, missing); }, {"sel.nii", "label", "7 does not occur", "0 1 3"});
  NiftiSelection none;
  none.threshold = 100;
  expectInputError([&] { selectVoxels(v, none); }, {"threshold 100"});

  // Block of 2x2x2 voxels of 2 mm: world [-2, 2] x [25, 29] x [33, 37] mm (voxel boxes, centres +-1 mm).
  const Aabb ext = selectedExtent(v, mask);
  EXPECT_TRUE(ext.min.isApprox(Eigen::Vector3d(-0.003, 0.025, 0.033), 1e-9));
  EXPECT_TRUE(ext.max.isApprox(Eigen::Vector3d(0.001, 0.029, 0.037), 1e-9));
  // Conservative at 1.5 mm: every cell overlapping the block. Centre sampling: cells whose centre is in it.
  VoxelGrid g(0.0015, v.extent());
  rasterizeNifti(v, mask, g, VoxelGrid::kOccupied, NiftiSampling::Conservative);
  VoxelGrid gc(0.0015, v.extent());
  rasterizeNifti(v, mask, gc, VoxelGrid::kOccupied, NiftiSampling::Centre);
  std::size_t cons = 0, cent = 0;
  for (int k = 0; k < g.dims().z(); ++k)
    for (int j = 0; j < g.dims().y(); ++j)
      for (int i = 0; i < g.dims().x(); ++i) {
        const Eigen::Vector3d c = g.centre(i, j, k);
        const Aabb cell(c.array() - 0.00075, c.array() + 0.00075);
        const bool overlaps = (cell.min.array() < ext.max.array() - 1e-9).all() &&
                              (cell.max.array() > ext.min.array() + 1e-9).all();
        EXPECT_EQ(g.at(i, j, k) == VoxelGrid::kOccupied, overlaps) << i << " " << j << " " << k;
        EXPECT_EQ(gc.at(i, j, k) == VoxelGrid::kOccupied, ext.contains(c)) << i << " " << j << " " << k;
        cons += overlaps;
        cent += gc.at(i, j, k) == VoxelGrid::kOccupied;
      }
  EXPECT_GT(cons, cent);
  EXPECT_GT(cent, 0u);
}

TEST(NiftiSource, StayInside) {
  TempDir dir;
  // A 12^3 volume of 1 mm voxels with a 6^3 region (label 1) in the middle.
  std::vector<float> vals(12 * 12 * 12, 0.0f);
  for (int k = 3; k < 9; ++k)
    for (int j = 3; j < 9; ++j)
      for (int i = 3; i < 9; ++i) vals[i + 12 * (j + 12 * k)] = 1.0f;
  Eigen::Matrix4d A = Eigen::Matrix4d::Identity();
  A.topLeftCorner<3, 3>() *= 0.001;
  A.topRightCorner<3, 1>().setConstant(0.0005);  // voxel i spans [i, i + 1] mm, aligned with 1 mm cells
  const std::string path = dir.file("lumen.nii.gz");
  writeNifti(path, Eigen::Vector3i(12, 12, 12), vals, A);
  const NiftiVolume v = readNifti(path);
  const auto mask = selectVoxels(v, NiftiSelection{{1.0}, std::nullopt});
  VoxelGrid g(0.001, v.extent().inflated(0.002));
  rasterizeNiftiInside(v, mask, g);
  // Region voxels [2.5, 8.5] mm; cells of the same size and alignment -> exactly the 6^3 cells are free.
  EXPECT_EQ(g.count(VoxelGrid::kFree), 216u);
  const Eigen::Vector3i in = g.cellOf(Eigen::Vector3d(0.005, 0.005, 0.005));
  const Eigen::Vector3i out = g.cellOf(Eigen::Vector3d(0.0015, 0.005, 0.005));
  EXPECT_EQ(g.at(in.x(), in.y(), in.z()), VoxelGrid::kFree);
  EXPECT_EQ(g.at(out.x(), out.y(), out.z()), VoxelGrid::kOccupied);
}

TEST(NiftiSource, BadFiles) {
  TempDir dir;
  expectInputError([&] { readNifti(dir.file("missing.nii.gz")); }, {"missing.nii.gz", "cannot open"});
  const std::string junk = dir.write("junk.nii", std::string(400, 'x'));
  expectInputError([&] { readNifti(junk); }, {"junk.nii", "not a readable NIfTI"});
  expectInputError([&] { readNifti(writeTestNifti(dir, "noaffine.nii", 0, 0)); },
                   {"noaffine.nii", "no voxel-to-world affine"});
  expectInputError([&] { readNifti(writeTestNifti(dir, "fourd.nii", 1, 1, 4, 3)); }, {"fourd.nii", "3-D", "dim[4] = 3"});
  // A 4-D file with a single volume is fine.
  EXPECT_EQ(readNifti(writeTestNifti(dir, "single.nii", 1, 1, 4, 1)).dims, Eigen::Vector3i(10, 8, 6));
  // Truncated data.
  const std::string ok = writeTestNifti(dir, "trunc.nii", 1, 1);
  std::filesystem::resize_file(ok, 352 + 100);
  expectInputError([&] { readNifti(ok); }, {"trunc.nii"});
}

TriangleMesh cube(double lo, double hi) {
  TriangleMesh m;
  for (int c = 0; c < 8; ++c)
    m.vertices.emplace_back((c & 1) ? hi : lo, (c & 2) ? hi : lo, (c & 4) ? hi : lo);
  const int f[12][3] = {{0, 2, 1}, {1, 2, 3}, {4, 5, 6}, {5, 7, 6}, {0, 1, 4}, {1, 5, 4},
                        {2, 6, 3}, {3, 6, 7}, {0, 4, 2}, {2, 4, 6}, {1, 3, 5}, {3, 7, 5}};
  for (const auto& t : f) m.triangles.push_back({t[0], t[1], t[2]});
  return m;
}

TEST(MeshSource, StlAndObjSurfaceAndFill) {
  TempDir dir;
  // A 6.5 mm cube from 0.75 to 7.25 mm.
  const TriangleMesh c = cube(0.00075, 0.00725);
  EXPECT_TRUE(c.closed());
  writeStl(dir.file("cube.stl"), c);
  const TriangleMesh m = loadMesh(dir.file("cube.stl"));
  EXPECT_EQ(m.triangles.size(), 12u);
  EXPECT_EQ(m.vertices.size(), 8u);  // welded
  EXPECT_TRUE(m.closed());
  VoxelGrid surf(0.001, m.extent().inflated(0.002));
  voxelizeSurface(m, surf);
  VoxelGrid solid(0.001, m.extent().inflated(0.002));
  voxelizeSolid(m, solid);
  // Cells 0..7 on each axis touch the cube; the surface shell is 8^3 - 6^3 cells, the solid 8^3.
  EXPECT_EQ(solid.count(VoxelGrid::kOccupied), 512u);
  EXPECT_EQ(surf.count(VoxelGrid::kOccupied), 512u - 216u);
  // Interior only (stay-inside of a closed mesh): cells strictly inside.
  VoxelGrid inner(0.001, m.extent().inflated(0.002));
  voxelizeSolid(m, inner, VoxelGrid::kOccupied, true);
  EXPECT_EQ(inner.count(VoxelGrid::kOccupied), 216u);

  // OBJ in millimetres with a transform.
  dir.write("tri.obj", "v 0 0 0\nv 10 0 0\nv 0 10 0\nf 1 2 3\n");
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = Eigen::Vector3d(0, 0, 0.005);
  const TriangleMesh tri = loadMesh(dir.file("tri.obj"), 1e-3, T);
  ASSERT_EQ(tri.triangles.size(), 1u);
  EXPECT_TRUE(tri.extent().max.isApprox(Eigen::Vector3d(0.01, 0.01, 0.005)));
  EXPECT_FALSE(tri.closed());
  VoxelGrid g(0.001, tri.extent().inflated(0.001));
  expectInputError([&] { voxelizeSolid(tri, g, VoxelGrid::kOccupied, false, "tri.obj"); }, {"tri.obj", "not closed"});
  voxelizeSurface(tri, g);
  EXPECT_GT(g.count(VoxelGrid::kOccupied), 50u);
  // PLY mesh.
  dir.write("tri.ply",
            "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
            "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
  EXPECT_EQ(loadMesh(dir.file("tri.ply")).triangles.size(), 1u);
}

TEST(MeshSource, BadMeshes) {
  TempDir dir;
  expectInputError([&] { loadMesh(dir.file("none.stl")); }, {"none.stl", "cannot open"});
  dir.write("empty.stl", "solid empty\nendsolid empty\n");
  expectInputError([&] { loadMesh(dir.file("empty.stl")); }, {"empty.stl"});
  dir.write("garbage.obj", "this is not a mesh\n");
  expectInputError([&] { loadMesh(dir.file("garbage.obj")); }, {"garbage.obj"});
}

TEST(PointCloudSource, XyzAndPly) {
  TempDir dir;
  dir.write("pts.xyz", "# x y z\n0.0012 0.0022 0.0032\n0.0025, 0.0035, 0.0045, 7\n\n-0.0005\t0.0005 0.0005\n");
  auto pts = loadPointCloud(dir.file("pts.xyz"));
  ASSERT_EQ(pts.size(), 3u);
  EXPECT_TRUE(pts[1].isApprox(Eigen::Vector3d(0.0025, 0.0035, 0.0045)));
  auto mm = loadPointCloud(dir.file("pts.xyz"), 1e3);
  EXPECT_NEAR(mm[0].x(), 1.2, 1e-12);
  VoxelGrid g(0.001, pointsExtent(pts).inflated(0.002));
  rasterizePoints(pts, g);
  EXPECT_EQ(g.count(VoxelGrid::kOccupied), 3u);
  VoxelGrid gr(0.001, pointsExtent(pts).inflated(0.004));
  rasterizePoints({Eigen::Vector3d(0.0005, 0.0005, 0.0005)}, gr, 0.0012);
  EXPECT_EQ(gr.count(VoxelGrid::kOccupied), 27u);  // the cell and its 26 neighbours are within 1.2 mm

  // Binary little-endian PLY with an extra property.
  std::string bin = "ply\nformat binary_little_endian 1.0\nelement vertex 2\nproperty float x\nproperty float y\n"
                    "property float z\nproperty uchar red\nend_header\n";
  const float v[2][3] = {{0.01f, 0.02f, 0.03f}, {-0.01f, 0.0f, 0.005f}};
  for (const auto& p : v) {
    bin.append(reinterpret_cast<const char*>(p), 12);
    bin.push_back('\x7f');
  }
  dir.write("pts.ply", bin);
  auto pp = loadPointCloud(dir.file("pts.ply"));
  ASSERT_EQ(pp.size(), 2u);
  EXPECT_NEAR(pp[0].z(), 0.03, 1e-7);
  dir.write("ascii.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty double x\nproperty double y\n"
                         "property double z\nend_header\n1 2 3\n");
  EXPECT_TRUE(loadPointCloud(dir.file("ascii.ply"))[0].isApprox(Eigen::Vector3d(1, 2, 3)));

  dir.write("bad.xyz", "0 0 0\n1 2\n");
  expectInputError([&] { loadPointCloud(dir.file("bad.xyz")); }, {"bad.xyz:2", "three coordinates"});
  dir.write("nan.xyz", "0 0 0\n1 2 abc\n");
  expectInputError([&] { loadPointCloud(dir.file("nan.xyz")); }, {"nan.xyz:2", "abc"});
  dir.write("empty.xyz", "# nothing\n");
  expectInputError([&] { loadPointCloud(dir.file("empty.xyz")); }, {"empty.xyz", "no points"});
}

TEST(OcTreeSource, ReadAndReject) {
  TempDir dir;
  octomap::OcTree t(0.002);
  t.updateNode(0.01, 0.01, 0.01, true);
  t.updateNode(0.02, 0.01, 0.01, false);
  ASSERT_TRUE(t.writeBinary(dir.file("t.bt")));
  ASSERT_TRUE(t.write(dir.file("t.ot")));
  auto a = loadOcTreeFile(dir.file("t.bt"));
  auto b = loadOcTreeFile(dir.file("t.ot"));
  EXPECT_DOUBLE_EQ(a->getResolution(), 0.002);
  EXPECT_TRUE(a->isNodeOccupied(a->search(0.01, 0.01, 0.01)));
  EXPECT_FALSE(b->isNodeOccupied(b->search(0.02, 0.01, 0.01)));

  expectInputError([&] { loadOcTreeFile(dir.file("none.bt")); }, {"none.bt", "cannot open"});
  dir.write("text.bt", "hello\n");
  expectInputError([&] { loadOcTreeFile(dir.file("text.bt")); }, {"text.bt", "not an OctoMap binary file"});
  // Corrupt: valid header, truncated data.
  std::string content;
  {
    std::ifstream in(dir.file("t.bt"), std::ios::binary);
    content.assign(std::istreambuf_iterator<char>(in), {});
  }
  dir.write("trunc.bt", content.substr(0, content.size() - 3));
  expectInputError([&] { loadOcTreeFile(dir.file("trunc.bt")); }, {"trunc.bt", "corrupt"});
  // Corrupt: header claims more nodes than the data holds.
  std::string wrong = content;
  const auto pos = wrong.find("size ");
  wrong.replace(pos, wrong.find('\n', pos) - pos, "size 999");
  dir.write("size.bt", wrong);
  expectInputError([&] { loadOcTreeFile(dir.file("size.bt")); }, {"size.bt", "corrupt"});
  octomap::OcTree empty(0.01);
  empty.writeBinary(dir.file("empty.bt"));
  expectInputError([&] { loadOcTreeFile(dir.file("empty.bt")); }, {"empty.bt", "empty"});
}

// Found by review while fuzzing NIfTI: a few hundred bytes whose header claims 100000 x 100000 x 100 voxels made
// libnifti allocate the whole (10 GB) volume before noticing the data is missing. Now refused from the file size.
TEST(NiftiSource, HeaderClaimingMoreDataThanTheFileHoldsIsRefusedWithoutAllocating) {
  TempDir dir;
  std::string h(352, '\0');
  auto put16 = [&](std::size_t at, std::int16_t v) { std::memcpy(&h[at], &v, 2); };
  auto put32f = [&](std::size_t at, float v) { std::memcpy(&h[at], &v, 4); };
  const std::int32_t sizeof_hdr = 348;
  std::memcpy(&h[0], &sizeof_hdr, 4);
  const std::int16_t dims[8] = {3, 30000, 30000, 100, 1, 1, 1, 1};
  for (int i = 0; i < 8; ++i) put16(40 + 2 * i, dims[i]);
  put16(70, DT_UINT8);
  put16(72, 8);
  for (int i = 0; i < 8; ++i) put32f(76 + 4 * i, 1.0f);
  put32f(108, 352.0f);
  put16(254, 1);  // sform_code
  put32f(280, 1.0f);
  put32f(300, 1.0f);
  put32f(320, 1.0f);
  std::memcpy(&h[344], "n+1\0", 4);
  const std::string path = dir.write("huge.nii", h + std::string(64, '\1'));
  expectInputError([&] { readNifti(path); }, {"huge.nii", "shorter than the dimensions say"});
}

// Found by fuzz_mesh: a malformed OFF file tripped an ai_assert (abort) in assimp's triangulation; a malformed STL
// leaked inside assimp (suppressed in tests/sanitizers/lsan.supp). Both must be plain bad input.
TEST(MeshSource, MalformedFilesFoundByFuzzingAreInputErrorsOrMeshes) {
  TempDir dir;
  dir.write("bad.off", "OFF\n4 4 0\n0 0  0\n0 1 0\n0 0 10 0 1\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n");
  try {
    const TriangleMesh m = loadMesh(dir.file("bad.off"));
    for (const auto& t : m.triangles)
      for (int v : t) EXPECT_LT(static_cast<std::size_t>(v), m.vertices.size());
  } catch (const io::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("bad.off"), std::string::npos);
  }
}

}  // namespace
}  // namespace ctr::env
