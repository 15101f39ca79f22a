#include "ctr/environments/mesh_source.hpp"

#include <assimp/postprocess.h>
#include <assimp/scene.h>
#include <assimp/Importer.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <map>
#include <sstream>
#include <unordered_map>

#include "ctr/io/input_error.hpp"
#include "ply_validation.hpp"

namespace ctr::environments {

Aabb TriangleMesh::extent() const {
  Aabb b;
  for (const auto& v : vertices) b.extend(v);
  return b;
}

std::size_t TriangleMesh::openEdges() const {
  std::unordered_map<std::uint64_t, int> count;
  count.reserve(triangles.size() * 2);
  for (const auto& t : triangles) {
    if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2]) continue;
    for (int e = 0; e < 3; ++e) {
      const auto a = static_cast<std::uint64_t>(std::min(t[e], t[(e + 1) % 3]));
      const auto b = static_cast<std::uint64_t>(std::max(t[e], t[(e + 1) % 3]));
      ++count[(a << 32) | b];
    }
  }
  std::size_t open = 0;
  for (const auto& kv : count)
    if (kv.second != 2) ++open;
  return open;
}

namespace {

struct VecHash {
  std::size_t operator()(const std::array<double, 3>& v) const {
    std::size_t h = 1469598103934665603ull;
    for (double d : v) {
      std::uint64_t bits;
      const double z = d == 0.0 ? 0.0 : d;  // -0 == +0
      std::memcpy(&bits, &z, sizeof(bits));
      h = (h ^ bits) * 1099511628211ull;
    }
    return h;
  }
};

// The whole file (read to the end rather than trusting tellg: a folder reports a huge size on some file systems).
std::string readAll(const std::string& path, std::istream& in) {
  std::string content;
  char chunk[1 << 16];
  while (in.read(chunk, sizeof(chunk)) || in.gcount() > 0) content.append(chunk, static_cast<std::size_t>(in.gcount()));
  if (in.bad()) throw io::InputError(path, 0, "", "cannot read the mesh file");
  return content;
}

// OFF headers declare vertex and face counts that assimp allocates before reading the data: a count larger than
// the file's size in bytes cannot be genuine (every element takes at least one byte), so it is refused before
// assimp allocates gigabytes for a few hundred bytes (found by fuzz_mesh in CI: "OFF\n44444444444 4 0"; then, in
// a seeded run, "OFF\n44\n4444...": the counts may span lines). The counts are found exactly as assimp 5.2.5's OFF
// reader finds them: optional ST / C / N / 4 / n prefixes, "OFF", an optional dimension, then the counts, with
// blanks, line ends and '#' comment lines skipped in between; its strtoul10 reads a token's leading digits.
void checkOff(const std::string& path, const std::string& b) {
  const std::size_t n = b.size();
  const std::size_t end = n + 1;  // assimp's buffer end: the file and a '\0'
  auto at = [&](std::size_t i) { return i < n ? b[i] : '\0'; };
  auto lineOf = [&](std::size_t i) { return 1 + static_cast<int>(std::count(b.begin(), b.begin() + i, '\n')); };
  std::size_t i = 0;
  auto blanks = [&] {
    while (at(i) == ' ' || at(i) == '\t' || at(i) == '\r' || at(i) == '\n') ++i;
  };
  auto nextToken = [&] {  // assimp's NextToken
    blanks();
    while (i < end && (at(i) == '#' || at(i) == '\n' || at(i) == '\r')) {
      while (at(i) != '\r' && at(i) != '\n' && at(i) != '\0') ++i;
      while (at(i) == '\r' || at(i) == '\n') ++i;
      blanks();
    }
  };
  auto digits = [&] {
    const std::size_t a = i;
    while (at(i) >= '0' && at(i) <= '9') ++i;
    return b.substr(a, i - a);
  };
  auto count = [&] {
    const std::size_t a = i;
    std::string d = digits();
    std::size_t zeros = 0;
    while (zeros + 1 < d.size() && d[zeros] == '0') ++zeros;
    d.erase(0, zeros);
    if (d.size() > 18 || (!d.empty() && std::stoull(d) > n))
      throw io::InputError(
          path, lineOf(a), "",
          "the header declares " + d + " elements but the file has only " + std::to_string(n) + " bytes");
  };
  nextToken();
  if (i + 2 < end && at(i) == 'S' && at(i + 1) == 'T') i += 2;
  if (i + 1 < end && at(i) == 'C') ++i;
  if (i + 1 < end && at(i) == 'N') ++i;
  if (i + 1 < end && at(i) == '4') ++i;
  const bool dimension = i + 1 < end && at(i) == 'n';
  if (dimension) ++i;
  if (i + 3 < end && at(i) == 'O' && at(i + 1) == 'F' && at(i + 2) == 'F') {
    i += 3;
    nextToken();
  } else {
    nextToken();
    if (i + 1 >= end || at(i) < '0' || at(i) > '9') return;  // assimp: "OFF: Header is invalid"
  }
  if (dimension) {
    digits();
    nextToken();
  }
  nextToken();
  count();  // vertices
  nextToken();
  count();  // faces
  // assimp copies each line into a 4096-byte buffer and writes its terminator one past the end of a longer line.
  std::size_t run = 0;
  for (std::size_t k = 0; k < n; ++k) {
    const char c = b[k];
    run = (c == '\r' || c == '\n' || c == '\0' || c == '\f') ? 0 : run + 1;
    if (run > 4095) throw io::InputError(path, lineOf(k), "", "the line is longer than 4095 characters");
  }
}

// Checks run before assimp sees the file: OFF counts (checkOff) and the whole PLY file (header and body, see
// ply_validation.hpp): assimp's PLY reader loops forever on unknown header lines / property types or a missing
// end_header, and aborts (ai_assert), reads out of bounds or allocates gigabytes on malformed bodies (found by
// fuzz_mesh). Returns the bytes assimp must read instead of the file (a binary PLY whose body starts with '\n'
// after "end_header\n" gets "end_header\r\n"), or an empty string when assimp can read the file itself.
std::string prevalidate(const std::string& path, std::istream& in) {
  std::string ext = path.substr(path.find_last_of('.') == std::string::npos ? path.size() : path.find_last_of('.'));
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char ch) { return std::tolower(ch); });
  if (ext == ".off") checkOff(path, readAll(path, in));
  if (ext == ".ply") {
    std::string bytes = readAll(path, in);
    const std::size_t at = detail::validatePly(path, bytes);
    if (at != std::string::npos) return bytes.insert(at, 1, '\r');
  }
  return {};
}

}  // namespace

TriangleMesh loadMesh(const std::string& path, double scale, const Eigen::Isometry3d& transform) {
  std::string patched;
  {
    std::ifstream probe(path, std::ios::binary);
    if (!probe) throw io::InputError(path, 0, "", "cannot open the mesh file (missing or unreadable)");
    patched = prevalidate(path, probe);
  }
  Assimp::Importer importer;
  importer.SetPropertyInteger(AI_CONFIG_PP_SBP_REMOVE, aiPrimitiveType_POINT | aiPrimitiveType_LINE);
  // ValidateDataStructure runs first and rejects a malformed scene (e.g. faces without indices) that would
  // otherwise trip an ai_assert -> abort() in Debian's assimp post-processing (found by fuzz_mesh).
  const unsigned flags =
      aiProcess_ValidateDataStructure | aiProcess_Triangulate | aiProcess_PreTransformVertices | aiProcess_SortByPType;
  const aiScene* scene = patched.empty() ? importer.ReadFile(path, flags)
                                         : importer.ReadFileFromMemory(patched.data(), patched.size(), flags, "ply");
  if (scene == nullptr)
    throw io::InputError(path, 0, "", std::string("cannot read the mesh: ") + importer.GetErrorString());
  TriangleMesh mesh;
  std::unordered_map<std::array<double, 3>, int, VecHash> weld;
  for (unsigned m = 0; m < scene->mNumMeshes; ++m) {
    const aiMesh* am = scene->mMeshes[m];
    if (am == nullptr || !(am->mPrimitiveTypes & aiPrimitiveType_TRIANGLE)) continue;
    std::vector<int> remap(am->mNumVertices);
    for (unsigned v = 0; v < am->mNumVertices; ++v) {
      const aiVector3D& p = am->mVertices[v];
      const Eigen::Vector3d w = transform * (scale * Eigen::Vector3d(p.x, p.y, p.z));
      const std::array<double, 3> key{w.x(), w.y(), w.z()};
      auto it = weld.find(key);
      if (it == weld.end()) {
        it = weld.emplace(key, static_cast<int>(mesh.vertices.size())).first;
        mesh.vertices.push_back(w);
      }
      remap[v] = it->second;
    }
    for (unsigned f = 0; f < am->mNumFaces; ++f) {
      const aiFace& face = am->mFaces[f];
      if (face.mNumIndices != 3) continue;
      if (face.mIndices[0] >= am->mNumVertices || face.mIndices[1] >= am->mNumVertices ||
          face.mIndices[2] >= am->mNumVertices)
        throw io::InputError(path, 0, "", "the mesh has a face with a vertex index out of range");
      mesh.triangles.push_back({remap[face.mIndices[0]], remap[face.mIndices[1]], remap[face.mIndices[2]]});
    }
  }
  if (mesh.triangles.empty()) throw io::InputError(path, 0, "", "the mesh has no triangles (empty mesh)");
  for (const auto& v : mesh.vertices)
    if (!v.allFinite()) throw io::InputError(path, 0, "", "the mesh has non-finite vertex coordinates");
  return mesh;
}

namespace {

// Akenine-Moeller triangle / box overlap (separating axis theorem). Box centred at the origin, half size h.
bool axisTest(const Eigen::Vector3d& axis, const Eigen::Vector3d& v0, const Eigen::Vector3d& v1,
              const Eigen::Vector3d& v2, const Eigen::Vector3d& h) {
  const double p0 = axis.dot(v0), p1 = axis.dot(v1), p2 = axis.dot(v2);
  const double mn = std::min({p0, p1, p2}), mx = std::max({p0, p1, p2});
  const double r = h.x() * std::abs(axis.x()) + h.y() * std::abs(axis.y()) + h.z() * std::abs(axis.z());
  return !(mn > r || mx < -r);  // true: overlap on this axis
}

bool triBoxOverlap(const Eigen::Vector3d& c, const Eigen::Vector3d& h, const Eigen::Vector3d& a,
                   const Eigen::Vector3d& b, const Eigen::Vector3d& d) {
  const Eigen::Vector3d v0 = a - c, v1 = b - c, v2 = d - c;
  // Box face normals (AABB of the triangle vs the box).
  for (int k = 0; k < 3; ++k) {
    const double mn = std::min({v0[k], v1[k], v2[k]}), mx = std::max({v0[k], v1[k], v2[k]});
    if (mn > h[k] || mx < -h[k]) return false;
  }
  const Eigen::Vector3d e[3] = {v1 - v0, v2 - v1, v0 - v2};
  // Triangle normal.
  const Eigen::Vector3d n = e[0].cross(e[1]);
  if (n.squaredNorm() > 0.0 && !axisTest(n, v0, v1, v2, h)) return false;
  // Edge x box axis.
  for (const auto& ed : e)
    for (int k = 0; k < 3; ++k) {
      Eigen::Vector3d ax = Eigen::Vector3d::Zero();
      ax[k] = 1.0;
      const Eigen::Vector3d axis = ed.cross(ax);
      if (axis.squaredNorm() < 1e-300) continue;
      if (!axisTest(axis, v0, v1, v2, h)) return false;
    }
  return true;
}

}  // namespace

void voxelizeSurface(const TriangleMesh& mesh, VoxelGrid& grid, std::uint8_t value, double grow) {
  const double res = grid.resolution();
  const Eigen::Vector3d h = Eigen::Vector3d::Constant(0.5 * res + grow);
  for (const auto& t : mesh.triangles) {
    const Eigen::Vector3d& a = mesh.vertices[static_cast<std::size_t>(t[0])];
    const Eigen::Vector3d& b = mesh.vertices[static_cast<std::size_t>(t[1])];
    const Eigen::Vector3d& d = mesh.vertices[static_cast<std::size_t>(t[2])];
    Aabb box;
    box.extend(a);
    box.extend(b);
    box.extend(d);
    Eigen::Vector3i lo, hi;
    if (!grid.cellRange(box.inflated(grow), lo, hi, 0.0)) continue;
    // cellRange with eps = 0 misses cells that only touch the box faces; widen by one cell and test exactly.
    lo = (lo - Eigen::Vector3i::Ones()).cwiseMax(Eigen::Vector3i::Zero());
    hi = (hi + Eigen::Vector3i::Ones()).cwiseMin(grid.dims() - Eigen::Vector3i::Ones());
    for (int k = lo.z(); k <= hi.z(); ++k)
      for (int j = lo.y(); j <= hi.y(); ++j)
        for (int i = lo.x(); i <= hi.x(); ++i) {
          if (grid.at(i, j, k) == value) continue;
          if (triBoxOverlap(grid.centre(i, j, k), h, a, b, d)) grid.set(i, j, k, value);
        }
  }
}

void voxelizeSolid(const TriangleMesh& mesh, VoxelGrid& grid, std::uint8_t value, bool interior_only,
                   const std::string& source) {
  const std::size_t open = mesh.openEdges();
  if (open != 0) {
    std::ostringstream os;
    os << "key 'fill': the mesh is not closed (" << open
       << " edges are not shared by exactly two triangles); a solid fill needs a closed surface";
    throw io::InputError(source, 0, "fill", os.str());
  }
  // Local grid: the mesh extent plus one free cell on every side, aligned with the target grid.
  const double res = grid.resolution();
  VoxelGrid local(res, mesh.extent().inflated(1.5 * res), VoxelGrid::kFree);
  constexpr std::uint8_t kSurface = 1, kOutside = 2;
  voxelizeSurface(mesh, local, kSurface);
  // Flood fill the outside from the border (6-connectivity).
  const Eigen::Vector3i n = local.dims();
  std::vector<std::size_t> stack;
  auto push = [&](int i, int j, int k) {
    const std::size_t id = local.index(i, j, k);
    if (local.data()[id] != VoxelGrid::kFree) return;
    local.data()[id] = kOutside;
    stack.push_back(id);
  };
  for (int k = 0; k < n.z(); ++k)
    for (int j = 0; j < n.y(); ++j)
      for (int i = 0; i < n.x(); ++i)
        if (i == 0 || j == 0 || k == 0 || i == n.x() - 1 || j == n.y() - 1 || k == n.z() - 1) push(i, j, k);
  const std::size_t sx = static_cast<std::size_t>(n.x()), sxy = sx * static_cast<std::size_t>(n.y());
  while (!stack.empty()) {
    const std::size_t id = stack.back();
    stack.pop_back();
    const int k = static_cast<int>(id / sxy), j = static_cast<int>((id % sxy) / sx), i = static_cast<int>(id % sx);
    if (i > 0) push(i - 1, j, k);
    if (i + 1 < n.x()) push(i + 1, j, k);
    if (j > 0) push(i, j - 1, k);
    if (j + 1 < n.y()) push(i, j + 1, k);
    if (k > 0) push(i, j, k - 1);
    if (k + 1 < n.z()) push(i, j, k + 1);
  }
  if (!interior_only) grid.paint(local, kSurface, value);
  grid.paint(local, VoxelGrid::kFree, value);  // enclosed cells
}

void writeStl(const std::string& path, const TriangleMesh& mesh) {
  std::ofstream out(path);
  if (!out) throw io::InputError(path, 0, "", "cannot write the STL file");
  out.precision(17);
  out << "solid mesh\n";
  for (const auto& t : mesh.triangles) {
    const Eigen::Vector3d& a = mesh.vertices[static_cast<std::size_t>(t[0])];
    const Eigen::Vector3d& b = mesh.vertices[static_cast<std::size_t>(t[1])];
    const Eigen::Vector3d& c = mesh.vertices[static_cast<std::size_t>(t[2])];
    Eigen::Vector3d nn = (b - a).cross(c - a);
    if (nn.norm() > 0) nn.normalize();
    out << " facet normal " << nn.x() << " " << nn.y() << " " << nn.z() << "\n  outer loop\n";
    for (const auto* v : {&a, &b, &c}) out << "   vertex " << v->x() << " " << v->y() << " " << v->z() << "\n";
    out << "  endloop\n endfacet\n";
  }
  out << "endsolid mesh\n";
}

}  // namespace ctr::environments
