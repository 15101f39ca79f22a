#include "ctr/environments/environment_yaml.hpp"

#include <octomap/OcTree.h>
#include <yaml-cpp/yaml.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

#include "ctr/environments/medmpd.hpp"
#include "ctr/environments/mesh_source.hpp"
#include "ctr/environments/octomap_source.hpp"
#include "ctr/environments/pointcloud_source.hpp"
#include "ctr/environments/voxel_grid.hpp"
#include "ctr/io/input_error.hpp"

namespace ctr::environments {

namespace fs = std::filesystem;

namespace {

// ---------------------------------------------------------------------------------------------------------------
// YAML helpers with file/line/key errors.

struct Ctx {
  std::string file;
  std::string base_dir;
  [[noreturn]] void fail(const YAML::Node& n, const std::string& key, const std::string& msg) const {
    const int line = n.IsDefined() && n.Mark().line >= 0 ? n.Mark().line + 1 : 0;
    throw io::InputError(file, line, key, msg);
  }
  std::string resolve(const std::string& p) const {
    fs::path path(p);
    if (path.is_relative()) path = fs::path(base_dir) / path;
    return path.lexically_normal().string();
  }
};

int lineOf(const YAML::Node& n) { return n.IsDefined() && n.Mark().line >= 0 ? n.Mark().line + 1 : 0; }

void checkKeys(const Ctx& c, const YAML::Node& map, const std::string& what, const std::set<std::string>& allowed) {
  if (!map.IsMap()) c.fail(map, what, "must be a mapping");
  for (const auto& kv : map) {
    const std::string k = kv.first.as<std::string>();
    if (allowed.count(k) == 0) {
      std::string list;
      for (const auto& a : allowed) list += (list.empty() ? "" : ", ") + a;
      c.fail(kv.first, k, "unknown key in " + what + " (allowed: " + list + ")");
    }
  }
}

double number(const Ctx& c, const YAML::Node& n, const std::string& key) {
  if (!n.IsScalar()) c.fail(n, key, "must be a number");
  try {
    const double v = n.as<double>();
    if (!std::isfinite(v)) c.fail(n, key, "must be finite");
    return v;
  } catch (const YAML::Exception&) {
    c.fail(n, key, "'" + n.Scalar() + "' is not a number");
  }
}

bool boolean(const Ctx& c, const YAML::Node& n, const std::string& key) {
  try {
    return n.as<bool>();
  } catch (const YAML::Exception&) {
    c.fail(n, key, "must be true or false");
  }
}

std::string text(const Ctx& c, const YAML::Node& n, const std::string& key) {
  if (!n.IsScalar()) c.fail(n, key, "must be a string");
  return n.Scalar();
}

Eigen::Vector3d vec3(const Ctx& c, const YAML::Node& n, const std::string& key) {
  if (!n.IsSequence() || n.size() != 3) c.fail(n, key, "must be a list of 3 numbers [x, y, z]");
  return Eigen::Vector3d(number(c, n[0], key), number(c, n[1], key), number(c, n[2], key));
}

Eigen::Matrix4d mat4(const Ctx& c, const YAML::Node& n, const std::string& key) {
  Eigen::Matrix4d m;
  if (n.IsSequence() && n.size() == 4 && n[0].IsSequence()) {
    for (int r = 0; r < 4; ++r) {
      if (!n[r].IsSequence() || n[r].size() != 4) c.fail(n, key, "must be 4 rows of 4 numbers");
      for (int k = 0; k < 4; ++k) m(r, k) = number(c, n[r][k], key);
    }
  } else if (n.IsSequence() && n.size() == 16) {
    for (int i = 0; i < 16; ++i) m(i / 4, i % 4) = number(c, n[i], key);
  } else {
    c.fail(n, key, "must be a 4x4 matrix (4 rows of 4 numbers, or 16 numbers row by row)");
  }
  return m;
}

double unitScale(const Ctx& c, const YAML::Node& n, const std::string& key) {
  const std::string u = text(c, n, key);
  if (u == "m") return 1.0;
  if (u == "mm") return 1e-3;
  if (u == "cm") return 1e-2;
  if (u == "um") return 1e-6;
  c.fail(n, key, "unknown unit '" + u + "' (m, cm, mm, um)");
}

std::string fileKey(const Ctx& c, const YAML::Node& n, const std::string& key) {
  const std::string p = text(c, n, key);
  if (p.empty()) c.fail(n, key, "empty path");
  return c.resolve(p);
}

// A pose entry: {start: NAME} (base_pose only), {medmpd_start: FILE}, {matrix: 4x4, units}, or
// {position: [..], direction: [..], x_axis: [..], units}.
NamedPose parsePose(const Ctx& c, const YAML::Node& n, const std::string& what, const std::string& name,
                    std::string* start_ref) {
  if (!n.IsMap()) c.fail(n, what, "must be a mapping (medmpd_start, matrix, or position + direction)");
  std::set<std::string> allowed = {"medmpd_start", "matrix", "position", "direction", "x_axis", "units"};
  if (start_ref) allowed.insert("start");
  checkKeys(c, n, what, allowed);
  NamedPose p;
  p.name = name;
  const double units = n["units"] ? unitScale(c, n["units"], "units") : 1.0;
  const int forms = (n["start"] ? 1 : 0) + (n["medmpd_start"] ? 1 : 0) + (n["matrix"] ? 1 : 0) +
                    (n["position"] || n["direction"] ? 1 : 0);
  if (forms != 1)
    c.fail(n, what, "give exactly one of: " + std::string(start_ref ? "start, " : "") +
                        "medmpd_start, matrix, position + direction");
  if (n["start"]) {
    *start_ref = text(c, n["start"], "start");
    p.source = "start " + *start_ref;
    return p;
  }
  if (n["medmpd_start"]) {
    const std::string f = fileKey(c, n["medmpd_start"], "medmpd_start");
    p.pose = readMedMpdStart(f);
    p.source = f;
    return p;
  }
  if (n["matrix"]) {
    Eigen::Matrix4d m = mat4(c, n["matrix"], "matrix");
    m.topRightCorner<3, 1>() *= units;
    try {
      p.pose = poseFromMatrix(m);
    } catch (const std::invalid_argument& e) {
      c.fail(n["matrix"], "matrix", e.what());
    }
    p.source = "matrix";
    return p;
  }
  if (!n["position"] || !n["direction"]) c.fail(n, what, "position and direction must be given together");
  const Eigen::Vector3d pos = vec3(c, n["position"], "position") * units;
  const Eigen::Vector3d dir = vec3(c, n["direction"], "direction");
  Eigen::Vector3d hint;
  const bool has_hint = static_cast<bool>(n["x_axis"]);
  if (has_hint) hint = vec3(c, n["x_axis"], "x_axis");
  try {
    p.pose = poseFromDirection(pos, dir, has_hint ? &hint : nullptr);
  } catch (const std::invalid_argument& e) {
    c.fail(n["direction"], "direction", e.what());
  }
  p.source = "position + direction";
  return p;
}

NamedTarget parseTarget(const Ctx& c, const YAML::Node& n, const std::string& name) {
  NamedTarget t;
  t.name = name;
  if (n.IsSequence()) {
    t.position = vec3(c, n, name);
    t.source = "position";
    return t;
  }
  if (!n.IsMap()) c.fail(n, name, "a target is [x, y, z] (m), {position: [..], units: mm} or {medmpd_target: FILE}");
  checkKeys(c, n, "target '" + name + "'", {"medmpd_target", "position", "units"});
  if (n["medmpd_target"] && n["position"]) c.fail(n, name, "give either medmpd_target or position");
  if (n["medmpd_target"]) {
    const std::string f = fileKey(c, n["medmpd_target"], "medmpd_target");
    t.position = readMedMpdTarget(f);
    t.source = f;
    return t;
  }
  if (!n["position"]) c.fail(n, name, "missing key 'position' or 'medmpd_target'");
  const double units = n["units"] ? unitScale(c, n["units"], "units") : 1.0;
  t.position = vec3(c, n["position"], "position") * units;
  t.source = "position";
  return t;
}

SourceSpec parseSource(const Ctx& c, const YAML::Node& n, const std::string& what, bool stay) {
  if (!n.IsMap()) c.fail(n, what, "a source is a mapping with one of the keys nifti, mesh, points, octomap");
  SourceSpec s;
  s.line = lineOf(n);
  s.where = c.file + ":" + std::to_string(s.line);
  const int kinds = (n["nifti"] ? 1 : 0) + (n["mesh"] ? 1 : 0) + (n["points"] ? 1 : 0) + (n["octomap"] ? 1 : 0);
  if (kinds != 1) c.fail(n, what, "give exactly one of the keys nifti, mesh, points, octomap");
  if (n["nifti"]) {
    checkKeys(c, n, what, {"nifti", "label", "labels", "threshold", "affine", "sampling", "name"});
    s.kind = SourceSpec::Kind::Nifti;
    s.path = fileKey(c, n["nifti"], "nifti");
    if (n["label"]) s.selection.labels.push_back(number(c, n["label"], "label"));
    if (n["labels"]) {
      if (!n["labels"].IsSequence() || n["labels"].size() == 0) c.fail(n["labels"], "labels", "must be a non-empty list");
      for (const auto& l : n["labels"]) s.selection.labels.push_back(number(c, l, "labels"));
    }
    if (n["threshold"]) s.selection.threshold = number(c, n["threshold"], "threshold");
    if (n["affine"]) {
      const std::string a = text(c, n["affine"], "affine");
      bool known = false;
      for (NiftiAffine f : {NiftiAffine::Auto, NiftiAffine::Sform, NiftiAffine::Qform})
        if (a == toString(f)) {
          s.affine = f;
          known = true;
        }
      if (!known) c.fail(n["affine"], "affine", "must be auto, sform or qform");
    }
    if (n["sampling"]) {
      const std::string a = text(c, n["sampling"], "sampling");
      if (a == toString(NiftiSampling::Conservative))
        s.sampling = NiftiSampling::Conservative;
      else if (a == toString(NiftiSampling::Centre) || a == "center")
        s.sampling = NiftiSampling::Centre;
      else
        c.fail(n["sampling"], "sampling", "must be conservative or centre");
    }
    return s;
  }
  auto scaleAndTransform = [&]() {
    if (n["units"] && n["scale"]) c.fail(n, "scale", "give either units or scale");
    if (n["units"]) s.scale = unitScale(c, n["units"], "units");
    if (n["scale"]) {
      s.scale = number(c, n["scale"], "scale");
      if (!(s.scale > 0)) c.fail(n["scale"], "scale", "must be > 0");
    }
    if (n["transform"]) {
      try {
        s.transform = poseFromMatrix(mat4(c, n["transform"], "transform"));
      } catch (const std::invalid_argument& e) {
        c.fail(n["transform"], "transform", e.what());
      }
    }
  };
  if (n["mesh"]) {
    checkKeys(c, n, what, {"mesh", "units", "scale", "transform", "fill", "name"});
    s.kind = SourceSpec::Kind::Mesh;
    s.path = fileKey(c, n["mesh"], "mesh");
    scaleAndTransform();
    if (n["fill"]) s.fill = boolean(c, n["fill"], "fill");
    if (stay) s.fill = true;
    return s;
  }
  if (n["points"]) {
    if (stay) c.fail(n, "points", "a point cloud cannot be a stay_inside region");
    checkKeys(c, n, what, {"points", "units", "scale", "transform", "radius", "name"});
    s.kind = SourceSpec::Kind::Points;
    s.path = fileKey(c, n["points"], "points");
    scaleAndTransform();
    if (n["radius"]) {
      s.point_radius = number(c, n["radius"], "radius");
      if (s.point_radius < 0) c.fail(n["radius"], "radius", "must be >= 0");
    }
    return s;
  }
  checkKeys(c, n, what, {"octomap", "name"});
  s.kind = SourceSpec::Kind::OcTree;
  s.path = fileKey(c, n["octomap"], "octomap");
  return s;
}

ProceduralSpec parseProcedural(const Ctx& c, const YAML::Node& n) {
  if (!n.IsMap()) c.fail(n, "procedural", "must be a mapping {type: ..., seed: ...}");
  ProceduralSpec p;
  if (!n["type"]) c.fail(n, "procedural", "missing key 'type'");
  p.type = text(c, n["type"], "type");
  std::map<std::string, std::pair<double, std::string>> defs;
  try {
    defs = proceduralParameters(p.type);
  } catch (const std::invalid_argument& e) {
    c.fail(n["type"], "type", e.what());
  }
  for (const auto& kv : n) {
    const std::string k = kv.first.as<std::string>();
    if (k == "type") continue;
    if (k == "seed") {
      const double v = number(c, kv.second, "seed");
      if (v < 0 || v != std::floor(v) || v > 9.007e15) c.fail(kv.second, "seed", "must be a non-negative integer");
      p.seed = static_cast<std::uint64_t>(v);
    } else if (k == "scale") {
      p.scale = number(c, kv.second, "scale");
    } else if (defs.count(k)) {
      p.params[k] = number(c, kv.second, k);
    } else {
      std::string known = "type, seed, scale";
      for (const auto& d : defs) known += ", " + d.first;
      c.fail(kv.first, k, "unknown key for procedural type '" + p.type + "' (allowed: " + known + ")");
    }
  }
  try {
    (void)makeProcedural(p);  // validates ranges
  } catch (const std::invalid_argument& e) {
    c.fail(n, "procedural", e.what());
  }
  return p;
}

}  // namespace

namespace {
EnvironmentDescription parseDescription(const std::string& text_in, const std::string& source,
                                        const std::string& base_dir) {
  Ctx c{source, base_dir};
  YAML::Node root;
  try {
    root = YAML::Load(text_in);
  } catch (const YAML::ParserException& e) {
    throw io::InputError(source, e.mark.line >= 0 ? e.mark.line + 1 : 0, "", "malformed YAML: " + e.msg);
  }
  if (!root.IsMap()) throw io::InputError(source, 0, "", "an environment description must be a YAML mapping");
  checkKeys(c, root, "the environment",
            {"name", "resolution", "padding", "bounds", "mark_free", "obstacles", "stay_inside", "procedural",
             "base_pose", "starts", "targets", "collision", "check_targets", "description"});
  EnvironmentDescription d;
  d.file = source;
  d.name = root["name"] ? text(c, root["name"], "name") : fs::path(source).stem().string();
  if (root["resolution"]) {
    d.resolution = number(c, root["resolution"], "resolution");
    if (!(d.resolution >= 1e-5 && d.resolution <= 0.1))
      c.fail(root["resolution"], "resolution", "must be in [1e-5, 0.1] m (it is a leaf size in metres)");
  }
  if (root["padding"]) {
    d.padding = number(c, root["padding"], "padding");
    if (d.padding < 0) c.fail(root["padding"], "padding", "must be >= 0");
  }
  if (root["mark_free"]) d.mark_free = boolean(c, root["mark_free"], "mark_free");
  if (root["check_targets"]) d.check_targets = boolean(c, root["check_targets"], "check_targets");
  if (root["bounds"]) {
    const YAML::Node b = root["bounds"];
    checkKeys(c, b, "bounds", {"min", "max", "units"});
    if (!b["min"] || !b["max"]) c.fail(b, "bounds", "needs min and max");
    const double u = b["units"] ? unitScale(c, b["units"], "units") : 1.0;
    d.crop = Aabb(vec3(c, b["min"], "min") * u, vec3(c, b["max"], "max") * u);
    if (d.crop.empty()) c.fail(b, "bounds", "min must be <= max on every axis");
  }
  if (root["obstacles"]) {
    const YAML::Node o = root["obstacles"];
    if (!o.IsSequence()) c.fail(o, "obstacles", "must be a list of sources");
    for (std::size_t i = 0; i < o.size(); ++i)
      d.obstacles.push_back(parseSource(c, o[i], "obstacles[" + std::to_string(i) + "]", false));
  }
  if (root["stay_inside"]) d.stay_inside = parseSource(c, root["stay_inside"], "stay_inside", true);
  if (root["procedural"]) {
    if (d.stay_inside) c.fail(root["procedural"], "procedural", "cannot be combined with stay_inside");
    SourceSpec s;
    s.kind = SourceSpec::Kind::Procedural;
    s.line = lineOf(root["procedural"]);
    s.where = source + ":" + std::to_string(s.line);
    s.procedural = parseProcedural(c, root["procedural"]);
    d.stay_inside = s;
  }
  if (d.obstacles.empty() && !d.stay_inside)
    throw io::InputError(source, 0, "obstacles", "nothing to map: give obstacles, stay_inside or procedural");
  if (root["starts"]) {
    const YAML::Node s = root["starts"];
    if (!s.IsMap()) c.fail(s, "starts", "must be a mapping NAME: pose");
    for (const auto& kv : s) {
      const std::string name = kv.first.as<std::string>();
      d.starts.push_back(parsePose(c, kv.second, "starts." + name, name, nullptr));
    }
  }
  if (root["base_pose"]) {
    std::string ref;
    NamedPose p = parsePose(c, root["base_pose"], "base_pose", "base", &ref);
    if (!ref.empty()) {
      d.base_start = ref;
      bool found = false;
      for (const auto& s : d.starts) found = found || s.name == ref;
      const bool procedural_start = d.stay_inside && d.stay_inside->kind == SourceSpec::Kind::Procedural;
      if (!found && !procedural_start) {
        std::string known;
        for (const auto& s : d.starts) known += (known.empty() ? "" : ", ") + s.name;
        c.fail(root["base_pose"]["start"], "start",
               "no start pose named '" + ref + "' (known: " + (known.empty() ? "none" : known) + ")");
      }
    } else {
      d.base_pose = p;
    }
  }
  if (root["targets"]) {
    const YAML::Node t = root["targets"];
    if (!t.IsMap()) c.fail(t, "targets", "must be a mapping NAME: target");
    for (const auto& kv : t) d.targets.push_back(parseTarget(c, kv.second, kv.first.as<std::string>()));
  }
  if (root["collision"]) {
    const YAML::Node col = root["collision"];
    checkKeys(c, col, "collision", {"safety_margin", "unknown_space", "exclude_proximal"});
    if (col["exclude_proximal"]) {
      d.collision.exclude_proximal = number(c, col["exclude_proximal"], "exclude_proximal");
      if (d.collision.exclude_proximal < 0) c.fail(col["exclude_proximal"], "exclude_proximal", "must be >= 0");
    }
    if (col["safety_margin"]) {
      d.collision.safety_margin = number(c, col["safety_margin"], "safety_margin");
      if (d.collision.safety_margin < 0) c.fail(col["safety_margin"], "safety_margin", "must be >= 0");
    }
    if (col["unknown_space"]) {
      try {
        d.collision.unknown_space = parseUnknownSpace(text(c, col["unknown_space"], "unknown_space"));
      } catch (const std::invalid_argument& e) {
        c.fail(col["unknown_space"], "unknown_space", e.what());
      }
    }
  }
  return d;
}
}  // namespace

EnvironmentDescription parseEnvironmentDescription(const std::string& text_in, const std::string& source,
                                                   const std::string& base_dir) {
  try {
    return parseDescription(text_in, source, base_dir);
  } catch (const YAML::Exception& e) {
    // E.g. a key that is not a scalar ({[1]: 2}): a conversion error of yaml-cpp, reported as bad input (it used
    // to escape as YAML::TypedBadConversion; found by fuzz_environment_yaml).
    throw io::InputError(source, e.mark.line >= 0 ? e.mark.line + 1 : 0, "", "malformed description: " + e.msg);
  }
}

EnvironmentDescription loadEnvironmentDescription(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw io::InputError(path, 0, "", "cannot open the environment description (missing or unreadable)");
  std::stringstream ss;
  ss << in.rdbuf();
  const std::string dir = fs::path(path).parent_path().string();
  return parseEnvironmentDescription(ss.str(), path, dir.empty() ? "." : dir);
}

// ---------------------------------------------------------------------------------------------------------------
// Building.

namespace {

struct Loaded {
  const SourceSpec* spec = nullptr;
  NiftiVolume vol;
  std::vector<std::uint8_t> mask;
  TriangleMesh mesh;
  std::vector<Eigen::Vector3d> points;
  std::shared_ptr<octomap::OcTree> tree;
  ProceduralAnatomy anatomy;
  Aabb extent;        // region the source describes (known space)
  std::string note;
};

std::string mm(const Eigen::Vector3d& v) {
  std::ostringstream os;
  os.precision(4);
  os << "(" << v.x() * 1e3 << ", " << v.y() * 1e3 << ", " << v.z() * 1e3 << ") mm";
  return os.str();
}

Loaded load(const SourceSpec& s, bool stay, double res) {
  Loaded l;
  l.spec = &s;
  std::ostringstream note;
  switch (s.kind) {
    case SourceSpec::Kind::Nifti: {
      l.vol = readNifti(s.path, s.affine);
      l.mask = selectVoxels(l.vol, s.selection);
      std::size_t n = 0;
      for (auto b : l.mask) n += b;
      l.extent = stay ? selectedExtent(l.vol, l.mask).inflated(2.0 * res) : l.vol.extent();
      note << "nifti " << s.path << " (" << l.vol.dims.x() << "x" << l.vol.dims.y() << "x" << l.vol.dims.z() << ", "
           << l.vol.affine_used << ", " << n << " voxels selected)";
      break;
    }
    case SourceSpec::Kind::Mesh: {
      l.mesh = loadMesh(s.path, s.scale, s.transform);
      l.extent = l.mesh.extent().inflated(stay ? 2.0 * res : 0.0);
      note << "mesh " << s.path << " (" << l.mesh.triangles.size() << " triangles" << (s.fill ? ", filled" : "")
           << ")";
      break;
    }
    case SourceSpec::Kind::Points: {
      l.points = loadPointCloud(s.path, s.scale, s.transform);
      l.extent = pointsExtent(l.points).inflated(s.point_radius);
      note << "points " << s.path << " (" << l.points.size() << " points)";
      break;
    }
    case SourceSpec::Kind::OcTree: {
      l.tree = loadOcTreeFile(s.path);
      double x0, y0, z0, x1, y1, z1;
      l.tree->getMetricMin(x0, y0, z0);
      l.tree->getMetricMax(x1, y1, z1);
      l.extent = Aabb(Eigen::Vector3d(x0, y0, z0), Eigen::Vector3d(x1, y1, z1));
      note << "octomap " << s.path << " (" << l.tree->getNumLeafNodes() << " leaves, resolution "
           << l.tree->getResolution() << " m)";
      break;
    }
    case SourceSpec::Kind::Procedural: {
      try {
        l.anatomy = makeProcedural(s.procedural);
      } catch (const std::invalid_argument& e) {
        throw io::InputError(s.where, 0, "procedural", e.what());
      }
      l.extent = l.anatomy.extent(std::max(3e-3 * s.procedural.scale, 3.0 * res));
      note << "procedural " << l.anatomy.description;
      break;
    }
  }
  l.note = note.str();
  return l;
}

void rasterizeObstacle(const Loaded& l, VoxelGrid& grid) {
  const SourceSpec& s = *l.spec;
  switch (s.kind) {
    case SourceSpec::Kind::Nifti: rasterizeNifti(l.vol, l.mask, grid, VoxelGrid::kOccupied, s.sampling); break;
    case SourceSpec::Kind::Mesh:
      if (s.fill)
        voxelizeSolid(l.mesh, grid, VoxelGrid::kOccupied, false, s.path);
      else
        voxelizeSurface(l.mesh, grid, VoxelGrid::kOccupied);
      break;
    case SourceSpec::Kind::Points: rasterizePoints(l.points, grid, s.point_radius, VoxelGrid::kOccupied); break;
    case SourceSpec::Kind::OcTree: rasterizeOcTree(*l.tree, grid, false); break;
    case SourceSpec::Kind::Procedural: break;
  }
}

// Stay-inside: cells inside the region free, all other cells of the grid occupied.
void rasterizeStay(const Loaded& l, VoxelGrid& grid) {
  const SourceSpec& s = *l.spec;
  switch (s.kind) {
    case SourceSpec::Kind::Nifti: rasterizeNiftiInside(l.vol, l.mask, grid); break;
    case SourceSpec::Kind::Mesh:
      std::fill(grid.data().begin(), grid.data().end(), VoxelGrid::kOccupied);
      voxelizeSolid(l.mesh, grid, VoxelGrid::kFree, true, s.path);
      break;
    case SourceSpec::Kind::OcTree: {
      VoxelGrid tmp = grid;
      std::fill(tmp.data().begin(), tmp.data().end(), VoxelGrid::kUnknown);
      rasterizeOcTree(*l.tree, tmp, true);
      std::fill(grid.data().begin(), grid.data().end(), VoxelGrid::kOccupied);
      grid.paint(tmp, VoxelGrid::kFree, VoxelGrid::kFree);
      grid.paint(tmp, VoxelGrid::kOccupied, VoxelGrid::kOccupied);
      break;
    }
    case SourceSpec::Kind::Procedural: rasterizeProcedural(l.anatomy, grid); break;
    case SourceSpec::Kind::Points: break;
  }
}

}  // namespace

Environment buildEnvironment(const EnvironmentDescription& d, const BuildOptions& options) {
  const auto t0 = std::chrono::steady_clock::now();
  const double res = options.resolution ? *options.resolution : d.resolution;
  if (!(res > 0.0)) throw io::InputError(d.file, 0, "resolution", "must be > 0");
  auto log = [&](const std::string& m) {
    if (options.log) options.log(m);
  };
  std::vector<Loaded> obstacles;
  for (const auto& s : d.obstacles) {
    log("loading " + s.path);
    obstacles.push_back(load(s, false, res));
  }
  std::optional<Loaded> stay;
  if (d.stay_inside) {
    log("loading stay_inside region");
    stay = load(*d.stay_inside, true, res);
  }
  // Region to map.
  Aabb region;
  if (stay) {
    region = stay->extent;
  } else {
    for (const auto& l : obstacles) region.extend(l.extent);
    region = region.inflated(d.padding);
  }
  if (!d.crop.empty()) region = region.intersection(d.crop);
  if (region.empty()) throw io::InputError(d.file, 0, "bounds", "the region to map is empty (check bounds:)");

  std::shared_ptr<octomap::OcTree> tree;
  Aabb bounds;
  // A single octree file at the same resolution is used as it is (keeps its unknown space and occupancy values).
  const bool passthrough = !stay && obstacles.size() == 1 && d.obstacles[0].kind == SourceSpec::Kind::OcTree &&
                           d.crop.empty() && d.padding == 0.0 &&
                           std::abs(obstacles[0].tree->getResolution() - res) < 1e-9 * res;
  if (passthrough) {
    tree = obstacles[0].tree;
    bounds = obstacles[0].extent;
  } else {
    VoxelGrid grid;
    try {
      grid = VoxelGrid(res, region, VoxelGrid::kFree, options.max_cells);
    } catch (const std::invalid_argument& e) {
      throw io::InputError(d.file, 0, "resolution", e.what());
    }
    log("rasterising " + std::to_string(grid.cells()) + " cells");
    if (stay) rasterizeStay(*stay, grid);
    for (const auto& l : obstacles) rasterizeObstacle(l, grid);
    tree = gridToOcTree(grid, d.mark_free);
    bounds = grid.bounds();
  }
  Environment env(d.name, tree, bounds);
  for (const auto& l : obstacles) env.addSourceNote(l.note);
  if (stay) env.addSourceNote("stay inside: " + stay->note);
  // Starts, base pose, targets.
  if (stay && stay->spec->kind == SourceSpec::Kind::Procedural) {
    env.addStart(stay->anatomy.start);
    for (const auto& t : stay->anatomy.targets) env.addTarget(t);
  }
  for (const auto& s : d.starts) env.addStart(s);
  for (const auto& t : d.targets) env.addTarget(t);
  if (d.base_pose) {
    env.setBasePose(d.base_pose->pose, d.base_pose->source);
  } else if (!d.base_start.empty()) {
    try {
      env.useStart(d.base_start);
    } catch (const std::invalid_argument& e) {
      throw io::InputError(d.file, 0, "base_pose", e.what());
    }
  } else if (!env.starts().empty()) {
    env.useStart(env.starts().front().name);
  }
  if (d.check_targets) {
    for (const auto& t : env.targets())
      if (!bounds.contains(t.position, 1e-9)) {
        throw io::InputError(d.file, 0, "targets",
                             "target '" + t.name + "' at " + mm(t.position) + " lies outside the map bounds " +
                                 mm(bounds.min) + " .. " + mm(bounds.max) +
                                 " (wrong file, units or coordinate frame?)");
      }
  }
  env.setCollisionDefaults(d.collision);
  env.setBuildSeconds(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  return env;
}

Environment loadEnvironment(const std::string& path, const BuildOptions& options) {
  return buildEnvironment(loadEnvironmentDescription(path), options);
}

}  // namespace ctr::environments
