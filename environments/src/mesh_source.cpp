#include "ctr/environments/mesh_source.hpp"

#include <assimp/Importer.hpp>
#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <map>
#include <unordered_map>
#include <sstream>

#include "ctr/io/input_error.hpp"

namespace ctr::env {

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

// OFF and PLY headers declare element counts that assimp allocates before reading the data: a count larger than
// the file's size in bytes cannot be genuine (every element takes at least one byte), so it is refused before
// assimp allocates gigabytes for a few hundred bytes (found by fuzz_mesh in CI: "OFF\n44444444444 4 0").
void checkDeclaredCounts(const std::string& path, std::istream& in) {
  in.seekg(0, std::ios::end);
  const auto bytes = static_cast<unsigned long long>(std::max<std::streamoff>(0, in.tellg()));
  in.seekg(0);
  auto tooMany = [&](const std::string& token, int line) {
    const std::size_t digits = token.find_first_not_of("0123456789");
    if (token.empty() || digits == 0) return;
    const std::string d = token.substr(0, digits);
    if (d.size() > 18 || std::stoull(d) > bytes)
      throw io::InputError(path, line, "", "the header declares " + d + " elements but the file has only " +
                                               std::to_string(bytes) + " bytes");
  };
  std::string ext = path.substr(path.find_last_of('.') == std::string::npos ? path.size() : path.find_last_of('.'));
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char ch) { return std::tolower(ch); });
  std::string line;
  if (ext == ".off") {
    // Header keyword line, then (after comments / blank lines) the counts line.
    int n = 0;
    bool header = false;
    while (n < 64 && std::getline(in, line)) {
      ++n;
      const std::size_t a = line.find_first_not_of(" \t\r");
      if (a == std::string::npos || line[a] == '#') continue;
      if (!header && line.find("OFF") != std::string::npos) {
        header = true;
        std::istringstream rest(line.substr(line.find("OFF") + 3));
        std::string tok;
        while (rest >> tok) tooMany(tok, n);  // counts on the header line itself
        continue;
      }
      std::istringstream ss(line);
      std::string tok;
      for (int k = 0; k < 3 && ss >> tok; ++k) tooMany(tok, n);
      break;
    }
  } else if (ext == ".ply") {
    int n = 0;
    bool end = false;
    while (n < 1000 && std::getline(in, line)) {
      ++n;
      std::istringstream ss(line);
      std::string kw, name, count;
      ss >> kw;
      if (kw == "end_header") {
        end = true;
        break;
      }
      // assimp's PLY reader can loop forever on a header line it does not know: allow only the PLY keywords.
      if (n > 1 && !kw.empty() && kw != "format" && kw != "element" && kw != "property" && kw != "comment" &&
          kw != "obj_info")
        throw io::InputError(path, n, "", "malformed PLY header line '" + line + "'");
      if (kw == "element" && ss >> name >> count) tooMany(count, n);
      if (kw == "property") {
        // assimp's PLY reader loops forever on a property with an unknown type (found by fuzz_mesh: "property 0 0").
        static const char* const kTypes[] = {"char",  "uchar",  "short", "ushort", "int",    "uint",
                                             "float", "double", "int8",  "uint8",  "int16",  "uint16",
                                             "int32", "uint32", "float32", "float64"};
        auto known = [&](const std::string& t) {
          return std::any_of(std::begin(kTypes), std::end(kTypes), [&](const char* k) { return t == k; });
        };
        std::string type, a, b, c;
        ss >> type >> a;
        bool ok = known(type) && !a.empty();                                         // property TYPE NAME
        if (type == "list") ok = static_cast<bool>(ss >> b >> c) && known(a) && known(b);  // property list T T NAME
        if (!ok) throw io::InputError(path, n, "", "malformed PLY property line '" + line + "'");
      }
    }
    // Without end_header assimp's PLY reader can loop forever (found by fuzz_mesh).
    if (!end) throw io::InputError(path, n, "", "the PLY header has no end_header line");
  }
}

}  // namespace

TriangleMesh loadMesh(const std::string& path, double scale, const Eigen::Isometry3d& transform) {
  {
    std::ifstream probe(path, std::ios::binary);
    if (!probe) throw io::InputError(path, 0, "", "cannot open the mesh file (missing or unreadable)");
    checkDeclaredCounts(path, probe);
  }
  Assimp::Importer importer;
  importer.SetPropertyInteger(AI_CONFIG_PP_SBP_REMOVE, aiPrimitiveType_POINT | aiPrimitiveType_LINE);
  const aiScene* scene =
      // ValidateDataStructure runs first and rejects a malformed scene (e.g. faces without indices) that would
      // otherwise trip an ai_assert -> abort() in Debian's assimp post-processing (found by fuzz_mesh).
      importer.ReadFile(path, aiProcess_ValidateDataStructure | aiProcess_Triangulate |
                                  aiProcess_PreTransformVertices | aiProcess_SortByPType);
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

}  // namespace ctr::env
