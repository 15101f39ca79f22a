// Obstacle sources on small generated inputs: NIfTI (affines, labels, sampling), meshes, point clouds, octree files.
#include <gtest/gtest.h>
#include <nifti2_io.h>
#include <octomap/OcTree.h>

#include <algorithm>
#include <cstring>
#include <limits>

#include "ctr/environments/mesh_source.hpp"
#include "ctr/environments/nifti_source.hpp"
#include "ctr/environments/octomap_source.hpp"
#include "ctr/environments/pointcloud_source.hpp"
#include "ctr/environments/voxel_grid.hpp"
#include "env_test_util.hpp"

namespace ctr::environments {
namespace {

using test::expectInputError;
using test::TempDir;

// A 10x8x6 uint8 volume written directly with the NIfTI API: value 3 in a 2x2x2 block at (4..5, 3..4, 2..3),
// value 1 at voxel (0, 0, 0). sform: 2 mm spacing, origin (-10, 20, 30) mm; qform: 1 mm spacing, origin (0, 0, 0).
std::string writeTestNifti(const TempDir& dir, const std::string& name, int sform_code, int qform_code, int ndim = 3,
                           int nt = 1) {
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
        const bool overlaps =
            (cell.min.array() < ext.max.array() - 1e-9).all() && (cell.max.array() > ext.min.array() + 1e-9).all();
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
  expectInputError([&] { readNifti(writeTestNifti(dir, "fourd.nii", 1, 1, 4, 3)); },
                   {"fourd.nii", "3-D", "dim[4] = 3"});
  // A 4-D file with a single volume is fine.
  EXPECT_EQ(readNifti(writeTestNifti(dir, "single.nii", 1, 1, 4, 1)).dims, Eigen::Vector3i(10, 8, 6));
  // Truncated data.
  const std::string ok = writeTestNifti(dir, "trunc.nii", 1, 1);
  std::filesystem::resize_file(ok, 352 + 100);
  expectInputError([&] { readNifti(ok); }, {"trunc.nii"});
}

TriangleMesh cube(double lo, double hi) {
  TriangleMesh m;
  for (int c = 0; c < 8; ++c) m.vertices.emplace_back((c & 1) ? hi : lo, (c & 2) ? hi : lo, (c & 4) ? hi : lo);
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
  std::string bin =
      "ply\nformat binary_little_endian 1.0\nelement vertex 2\nproperty float x\nproperty float y\n"
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
  dir.write("ascii.ply",
            "ply\nformat ascii 1.0\nelement vertex 1\nproperty double x\nproperty double y\n"
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

// PLY files are validated whole before assimp reads them (ply_validation.cpp): assimp 5.2.5 aborted (an ai_assert
// in its triangulation after a face without indices), dereferenced null (a face texcoord list without vertex
// indices) or read past its buffers on malformed bodies (found by fuzz_mesh). Every message names the file and the
// line (ASCII) or the byte offset (binary), the element / property and what is wrong.
const char* const kPlyAsciiHeader =
    "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
    "element face 1\nproperty list uchar int vertex_indices\nend_header\n";  // 9 lines
const char* const kPlyVertices = "0 0 0\n1 0 0\n0 1 0\n";                    // lines 10-12

std::string plyBinary(bool big_endian, const std::string& count_type, std::uint64_t count,
                      const std::vector<std::int32_t>& indices, float x0 = 0.0f) {
  std::string s = std::string("ply\nformat ") + (big_endian ? "binary_big_endian" : "binary_little_endian") +
                  " 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\n"
                  "property list " +
                  count_type + " int vertex_indices\nend_header\n";
  auto put = [&](const void* p, std::size_t n) {
    std::string b(static_cast<const char*>(p), n);
    if (big_endian) std::reverse(b.begin(), b.end());
    s += b;
  };
  const float v[3][3] = {{x0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  for (const auto& r : v)
    for (float c : r) put(&c, 4);
  if (count_type == "uchar") {
    const auto c = static_cast<std::uint8_t>(count);
    put(&c, 1);
  } else {
    const auto c = static_cast<std::uint32_t>(count);
    put(&c, 4);
  }
  for (std::int32_t i : indices) put(&i, 4);
  return s;
}

// OFF counts are found where assimp's OFF reader finds them: after "OFF", across blanks, line ends and '#' comment
// lines (found by fuzz_mesh: "OFF\n44\n4444..." made assimp allocate 42 GB for the faces).
TEST(MeshSource, OffCountsAreCheckedWhereAssimpReadsThem) {
  TempDir dir;
  dir.write("split.off", "OFF\n3\n44444444444444444444444 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
  expectInputError([&] { loadMesh(dir.file("split.off")); },
                   {"split.off:3", "the header declares 44444444444444444444444 elements but the file has only"});
  dir.write("faces.off", "OFF\n# counts follow\n\n3\n# faces\n99999 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
  expectInputError([&] { loadMesh(dir.file("faces.off")); }, {"faces.off:6", "declares 99999 elements"});
  dir.write("ok.off", "OFF\n# counts follow\n\n3\n# faces\n1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
  EXPECT_EQ(loadMesh(dir.file("ok.off")).triangles.size(), 1u);
  // assimp copies OFF lines into a 4096-byte buffer and writes one byte past it for a longer line.
  dir.write("long.off", "OFF\n3 1 0\n0 0 0" + std::string(5000, ' ') + "\n1 0 0\n0 1 0\n3 0 1 2\n");
  expectInputError([&] { loadMesh(dir.file("long.off")); }, {"long.off:3", "longer than 4095 characters"});
}

TEST(MeshSource, WellFormedPlyVariantsLoad) {
  TempDir dir;
  // CRLF line ends, comments, obj_info, trailing whitespace.
  dir.write("crlf.ply",
            "ply\r\nformat ascii 1.0\r\ncomment made by hand\r\nobj_info test\r\nelement vertex 3\r\n"
            "property float x\r\ncomment inside\r\nproperty float y\r\nproperty float z\r\nelement face 1\r\n"
            "property list uchar int vertex_indices\r\nend_header\r\n0 0 0 \r\n1.5e0 -0 +0\r\n0 .5 0\t\r\n3 0 1 2\r\n");
  EXPECT_EQ(loadMesh(dir.file("crlf.ply")).triangles.size(), 1u);
  dir.write("le.ply", plyBinary(false, "uchar", 3, {0, 1, 2}));
  EXPECT_EQ(loadMesh(dir.file("le.ply")).triangles.size(), 1u);
  dir.write("be.ply", plyBinary(true, "uint", 3, {0, 1, 2}));
  const TriangleMesh be = loadMesh(dir.file("be.ply"), 1.0);
  ASSERT_EQ(be.triangles.size(), 1u);
  EXPECT_TRUE(be.extent().max.isApprox(Eigen::Vector3d(1, 1, 0)));
  // A quad (triangulated by assimp) and trailing bytes after a binary body are fine.
  dir.write("quad.ply",
            std::string(kPlyAsciiHeader).replace(std::string(kPlyAsciiHeader).find("vertex 3"), 8, "vertex 4") +
                kPlyVertices + "1 1 0\n4 0 1 3 2\n\n");
  EXPECT_EQ(loadMesh(dir.file("quad.ply")).triangles.size(), 2u);
  dir.write("tail.ply", plyBinary(false, "uchar", 3, {0, 1, 2}) + "\n");
  EXPECT_EQ(loadMesh(dir.file("tail.ply")).triangles.size(), 1u);
}

TEST(MeshSource, MalformedPlyAsciiBodiesNameTheLine) {
  TempDir dir;
  const std::string h = kPlyAsciiHeader, v = kPlyVertices;
  auto bad = [&](const std::string& name, const std::string& text, const std::vector<std::string>& fragments) {
    dir.write(name, text);
    expectInputError([&] { loadMesh(dir.file(name)); }, fragments);
  };
  bad("range.ply", h + v + "3 0 1 7\n",
      {"range.ply:13", "element 'face', property 'vertex_indices'", "vertex index 7 is out of range [0, 3)"});
  bad("negative.ply", h + v + "3 0 -1 2\n", {"negative.ply:13", "vertex index -1 is out of range [0, 3)"});
  bad("sign.ply", h + v + "+3 0 1 2\n", {"sign.ply:13", "'+3' is not a valid integer for type uchar"});
  bad("few.ply", h + "0 0 0\n1 0\n0 1 0\n3 0 1 2\n",
      {"few.ply:11", "element 'vertex', property 'z'", "missing value (the line has only 2 values)"});
  bad("extra.ply", h + "0 0 0 5\n1 0 0\n0 1 0\n3 0 1 2\n",
      {"extra.ply:10", "element 'vertex'", "1 extra value(s)", "'5'"});
  bad("word.ply", h + "0 0 0\n1 abc 0\n0 1 0\n3 0 1 2\n",
      {"word.ply:11", "element 'vertex', property 'y'", "'abc' is not a valid number for type float"});
  bad("dot.ply", h + "0 0 0\n1. 0 0\n0 1 0\n3 0 1 2\n", {"dot.ply:11", "property 'x'", "'1.'"});
  bad("inf.ply", h + "0 0 0\n1e39 0 0\n0 1 0\n3 0 1 2\n", {"inf.ply:11", "'1e39' is out of range"});
  bad("nul.ply", h + "0 0 0\n1 0" + std::string(1, '\0') + "0\n0 1 0\n3 0 1 2\n",
      {"nul.ply:11", "property 'y'", "'0\\x000' is not a valid number"});
  bad("items.ply", h + v + "3 0 1\n",
      {"items.ply:13", "property 'vertex_indices'", "the list declares 3 items but the line has only 2 more values"});
  bad("uchar.ply", h + v + "300 0 1 2\n", {"uchar.ply:13", "'300' is out of range [0, 255] for type uchar"});
  std::string huge = h;
  huge.replace(huge.find("list uchar int"), 14, "list uint int");
  bad("huge.ply", huge + v + "4000000000 0 1 2\n",
      {"huge.ply:13", "property 'vertex_indices'", "the list length '4000000000' exceeds the limit of 1024"});
  std::string neg = h;
  neg.replace(neg.find("list uchar int"), 14, "list int int");
  bad("negcount.ply", neg + v + "-3 0 1 2\n", {"negcount.ply:13", "the list length '-3' is negative"});
  bad("empty.ply", h + v + "0\n", {"empty.ply:13", "a face needs at least one vertex index"});
  bad("missing.ply", h + v, {"missing.ply:12", "element 'face' declares 1 instances but the body has only 0"});
  bad("blank.ply", h + "0 0 0\n\n1 0 0\n0 1 0\n3 0 1 2\n", {"blank.ply:11", "property 'x'", "missing value"});
  // assimp would glue the rest of an earlier, longer line to a last line without '\n' ("3 0 1 223456").
  bad("nonl.ply", h + "0 0 0\n1 0 0\n0 1 0.123456\n3 0 1 2",
      {"nonl.ply:13", "the last line does not end with a line break"});
  bad("after.ply", h + v + "3 0 1 2\n1 2 3\n", {"after.ply:14", "unexpected data after the last element"});
  // A folder named like a mesh (its reported size can be huge): a plain input error.
  std::filesystem::create_directories(dir.path() / "folder.ply");
  expectInputError([&] { loadMesh(dir.file("folder.ply")); }, {"folder.ply", "cannot read the mesh file"});
  // Header forms that assimp would misread (the body would no longer be what the header declares).
  std::string tc = h;
  tc.replace(tc.find("vertex_indices"), 14, "texcoord");
  tc.replace(tc.find("list uchar int"), 14, "list uchar float");
  bad("texcoord.ply", tc + v + "6 0 0 1 0 0 1\n", {"texcoord.ply:7", "texcoord list but no vertex_indices"});
  bad("comment.ply", std::string("ply\nformat ascii 1.0\ncomment 5 lines\n") + (h.c_str() + 21) + v + "3 0 1 2\n",
      {"comment.ply:3", "comment before the first element"});
  bad("twice.ply",
      "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nelement vertex 1\nproperty float x\n"
      "end_header\n0\n0\n",
      {"twice.ply:5", "element 'vertex' is declared twice"});
  bad("unknown.ply",
      "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nelement camera 1\nproperty float f\n"
      "end_header\n0\n1\n2\n1.5\n",
      {"unknown.ply:5", "element 'camera' is not supported"});
  std::string spaces = h;
  spaces.replace(spaces.find("list uchar"), 10, "list  uchar");
  bad("spaces.ply", spaces + v + "3 0 1 2\n", {"spaces.ply:8", "malformed PLY property line", "single spaces"});
  bad("strips.ply",
      "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nelement tristrips 1\n"
      "property list int int vertex_indices\nend_header\n0\n1\n2\n3 0 1 2\n",
      {"strips.ply:5", "element 'tristrips' is not supported"});
}

TEST(MeshSource, MalformedPlyBinaryBodiesNameTheByteOffset) {
  TempDir dir;
  auto bad = [&](const std::string& name, const std::string& bytes, const std::vector<std::string>& fragments) {
    dir.write(name, bytes);
    expectInputError([&] { loadMesh(dir.file(name)); }, fragments);
  };
  auto bodyOf = [](const std::string& s) { return s.find("end_header\n") + 11; };
  const std::string ok = plyBinary(false, "uchar", 3, {0, 1, 2});
  const std::size_t body = bodyOf(ok);  // 3 vertices (36 bytes), list length (1), indices (12)
  ASSERT_EQ(ok.size(), body + 49);
  bad("trunc.ply", ok.substr(0, ok.size() - 2),
      {"trunc.ply: byte offset " + std::to_string(body + 37), "the binary body is truncated",
       "element 'face' instance 0, property 'vertex_indices' needs 12 bytes", "has only 10 more"});
  bad("truncv.ply", ok.substr(0, body + 20),
      {"truncv.ply: byte offset " + std::to_string(body + 20), "element 'vertex' instance 1, property 'z'"});
  const std::string huge = plyBinary(false, "uint", 0xFFFFFFFFu, {0, 1, 2});
  bad("huge.ply", huge,
      {"huge.ply: byte offset " + std::to_string(bodyOf(huge) + 36),
       "element 'face' instance 0, property 'vertex_indices'", "the list length 4294967295 exceeds the limit of 1024"});
  const std::string range = plyBinary(true, "uchar", 3, {0, 1, 70000});
  bad("range.ply", range,
      {"range.ply: byte offset " + std::to_string(bodyOf(range) + 36),
       "element 'face' instance 0, property 'vertex_indices'", "vertex index 70000 is out of range [0, 3)"});
  bad("nan.ply", plyBinary(false, "uchar", 3, {0, 1, 2}, std::numeric_limits<float>::quiet_NaN()),
      {"nan.ply: byte offset " + std::to_string(body), "element 'vertex' instance 0, property 'x'", "not a finite"});
  bad("empty.ply", plyBinary(false, "uchar", 0, {}), {"empty.ply: byte offset", "at least one vertex index"});
  // assimp 5.2.5 skips a '\n' right after "end_header\n" (found by fuzz_mesh: a body starting with 0x0a was read one
  // byte late, then a face without indices aborted in assimp's triangulation). loadMesh hands assimp a copy whose
  // end_header line ends with "\r\n": the file loads with every value read where it is (the first coordinate's
  // low byte is 0x0a; one byte late it would be read as 1.0f and the face would be garbage). The same body after
  // "end_header\r\n" in the file itself loads identically.
  float x0 = 0.0f;
  const std::uint32_t bits = 0x3f80000au;  // 1.0000012f: little-endian, its first byte is 0x0a
  std::memcpy(&x0, &bits, 4);
  ASSERT_NE(x0, 1.0f);
  const std::string nl = plyBinary(false, "uchar", 3, {0, 1, 2}, x0);
  ASSERT_EQ(nl[bodyOf(nl)], '\n');
  std::string crlf = nl;
  crlf.insert(crlf.find("end_header\n") + 10, "\r");
  dir.write("nl.ply", nl);
  dir.write("crlf.ply", crlf);
  for (const char* f : {"nl.ply", "crlf.ply"}) {
    const TriangleMesh m = loadMesh(dir.file(f), 1.0);
    ASSERT_EQ(m.triangles.size(), 1u) << f;
    ASSERT_EQ(m.vertices.size(), 3u) << f;
    EXPECT_FLOAT_EQ(static_cast<float>(m.extent().max.x()), x0) << f;
    EXPECT_EQ(static_cast<float>(m.vertices[0].x()), x0) << f;
  }
  // The file on disk is not touched.
  std::ifstream in(dir.file("nl.ply"), std::ios::binary);
  EXPECT_EQ(std::string(std::istreambuf_iterator<char>(in), {}), nl);
}

}  // namespace
}  // namespace ctr::environments
