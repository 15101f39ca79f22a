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
#include "ctr/io/data.hpp"
#include "ctr/io/input_error.hpp"
#include "ctr/io/yaml_reader.hpp"

namespace ctr::environments {

namespace fs = std::filesystem;

namespace {

// ---------------------------------------------------------------------------------------------------------------
// Reading a description: the checked YAML reader of ctr::io (file/line/key messages) and the environment's own types.
// Keys are named by their path in the document ("obstacles[0].units", "starts.side.position").

struct Ctx : io::YamlReader {
  std::string base_dir;

  std::string resolve(const std::string& p) const {
    fs::path fp(p);
    if (fp.is_relative()) fp = fs::path(base_dir) / fp;
    return fp.lexically_normal().string();
  }
  /// A mapping with only the keys `allowed`.
  void mapping(const YAML::Node& map, const std::string& where, const std::set<std::string>& allowed) const {
    if (!map.IsMap()) fail(map, where, "must be a mapping");
    allowOnly(map, where, allowed);
  }
  Eigen::Vector3d vec3(const YAML::Node& n, const std::string& key) const {
    if (!n.IsSequence() || n.size() != 3) fail(n, key, "must be a list of 3 numbers [x, y, z]");
    return Eigen::Vector3d(number(n[0], key + "[0]"), number(n[1], key + "[1]"), number(n[2], key + "[2]"));
  }
  Eigen::Matrix4d mat4(const YAML::Node& n, const std::string& key) const {
    Eigen::Matrix4d m;
    if (n.IsSequence() && n.size() == 4 && n[0].IsSequence()) {
      for (int r = 0; r < 4; ++r) {
        const std::string row = key + "[" + std::to_string(r) + "]";
        if (!n[r].IsSequence() || n[r].size() != 4) fail(n[r], row, "must be a row of 4 numbers");
        for (int k = 0; k < 4; ++k) m(r, k) = number(n[r][k], row + "[" + std::to_string(k) + "]");
      }
    } else if (n.IsSequence() && n.size() == 16) {
      for (int i = 0; i < 16; ++i) m(i / 4, i % 4) = number(n[i], key + "[" + std::to_string(i) + "]");
    } else {
      fail(n, key, "must be a 4x4 matrix (4 rows of 4 numbers, or 16 numbers row by row)");
    }
    return m;
  }
  double unitScale(const YAML::Node& n, const std::string& key) const {
    const std::string u = text(n, key);
    if (u == "m") return 1.0;
    if (u == "mm") return 1e-3;
    if (u == "cm") return 1e-2;
    if (u == "um") return 1e-6;
    fail(n, key, "unknown unit '" + u + "' (m, cm, mm, um)");
  }
  /// A file path: relative to the description's folder, or "${CTR_DATA}/..." in the data folder (io/data.hpp).
  std::string path(const YAML::Node& n, const std::string& key) const {
    const std::string p = text(n, key);
    if (p.empty()) fail(n, key, "empty path");
    if (!io::isDataPath(p)) return resolve(p);
    const std::string d = io::expandDataPath(p);
    if (!fs::exists(d)) fail(n, key, io::missingDataMessage(p));
    return fs::path(d).lexically_normal().string();
  }
};

// A pose entry: {start: NAME} (base_pose only), {medmpd_start: FILE}, {matrix: 4x4, units}, or
// {position: [..], direction: [..], x_axis: [..], units}. `what` is its key ("base_pose", "starts.NAME").
NamedPose parsePose(const Ctx& c, const YAML::Node& n, const std::string& what, const std::string& name,
                    std::string* start_ref) {
  if (!n.IsMap()) c.fail(n, what, "must be a mapping (medmpd_start, matrix, or position + direction)");
  std::set<std::string> allowed = {"medmpd_start", "matrix", "position", "direction", "x_axis", "units"};
  if (start_ref) allowed.insert("start");
  c.allowOnly(n, what, allowed);
  const std::string at = what + ".";
  NamedPose p;
  p.name = name;
  const double units = n["units"] ? c.unitScale(n["units"], at + "units") : 1.0;
  const int forms = (n["start"] ? 1 : 0) + (n["medmpd_start"] ? 1 : 0) + (n["matrix"] ? 1 : 0) +
                    (n["position"] || n["direction"] ? 1 : 0);
  if (forms != 1)
    c.fail(n, what,
           "give exactly one of: " + std::string(start_ref ? "start, " : "") +
               "medmpd_start, matrix, position + direction");
  if (n["start"]) {
    *start_ref = c.text(n["start"], at + "start");
    p.source = "start " + *start_ref;
    return p;
  }
  if (n["medmpd_start"]) {
    const std::string f = c.path(n["medmpd_start"], at + "medmpd_start");
    p.pose = readMedMpdStart(f);
    p.source = f;
    return p;
  }
  if (n["matrix"]) {
    Eigen::Matrix4d m = c.mat4(n["matrix"], at + "matrix");
    m.topRightCorner<3, 1>() *= units;
    try {
      p.pose = poseFromMatrix(m);
    } catch (const std::invalid_argument& e) {
      c.fail(n["matrix"], at + "matrix", e.what());
    }
    p.source = "matrix";
    return p;
  }
  if (!n["position"] || !n["direction"]) c.fail(n, what, "position and direction must be given together");
  const Eigen::Vector3d pos = c.vec3(n["position"], at + "position") * units;
  const Eigen::Vector3d dir = c.vec3(n["direction"], at + "direction");
  Eigen::Vector3d hint;
  const bool has_hint = static_cast<bool>(n["x_axis"]);
  if (has_hint) hint = c.vec3(n["x_axis"], at + "x_axis");
  try {
    p.pose = poseFromDirection(pos, dir, has_hint ? &hint : nullptr);
  } catch (const std::invalid_argument& e) {
    c.fail(n["direction"], at + "direction", e.what());
  }
  p.source = "position + direction";
  return p;
}

// A target: [x, y, z] (m), {position: [..], units} or {medmpd_target: FILE}. `what` is its key ("targets.NAME").
NamedTarget parseTarget(const Ctx& c, const YAML::Node& n, const std::string& what, const std::string& name) {
  NamedTarget t;
  t.name = name;
  if (n.IsSequence()) {
    t.position = c.vec3(n, what);
    t.source = "position";
    return t;
  }
  if (!n.IsMap()) c.fail(n, what, "a target is [x, y, z] (m), {position: [..], units: mm} or {medmpd_target: FILE}");
  c.allowOnly(n, what, {"medmpd_target", "position", "units"});
  const std::string at = what + ".";
  if (n["medmpd_target"] && n["position"]) c.fail(n, what, "give either medmpd_target or position");
  if (n["medmpd_target"]) {
    const std::string f = c.path(n["medmpd_target"], at + "medmpd_target");
    t.position = readMedMpdTarget(f);
    t.source = f;
    return t;
  }
  if (!n["position"]) c.fail(n, what, "missing key 'position' or 'medmpd_target'");
  const double units = n["units"] ? c.unitScale(n["units"], at + "units") : 1.0;
  t.position = c.vec3(n["position"], at + "position") * units;
  t.source = "position";
  return t;
}

// A source of obstacles or the stay-inside region. `what` is its key ("obstacles[0]", "stay_inside").
SourceSpec parseSource(const Ctx& c, const YAML::Node& n, const std::string& what, bool stay) {
  if (!n.IsMap()) c.fail(n, what, "a source is a mapping with one of the keys nifti, mesh, points, octomap");
  const std::string at = what + ".";
  SourceSpec s;
  s.line = Ctx::lineOf(n);
  s.where = c.file + ":" + std::to_string(s.line);
  const int kinds = (n["nifti"] ? 1 : 0) + (n["mesh"] ? 1 : 0) + (n["points"] ? 1 : 0) + (n["octomap"] ? 1 : 0);
  if (kinds != 1) c.fail(n, what, "give exactly one of the keys nifti, mesh, points, octomap");
  if (n["nifti"]) {
    c.allowOnly(n, what, {"nifti", "label", "labels", "threshold", "affine", "sampling", "name"});
    s.kind = SourceSpec::Kind::Nifti;
    s.path = c.path(n["nifti"], at + "nifti");
    if (n["label"]) s.selection.labels.push_back(c.number(n["label"], at + "label"));
    if (n["labels"]) {
      const YAML::Node l = n["labels"];
      if (!l.IsSequence() || l.size() == 0) c.fail(l, at + "labels", "must be a non-empty list");
      for (std::size_t i = 0; i < l.size(); ++i)
        s.selection.labels.push_back(c.number(l[i], at + "labels[" + std::to_string(i) + "]"));
    }
    if (n["threshold"]) s.selection.threshold = c.number(n["threshold"], at + "threshold");
    if (n["affine"]) {
      const std::string a = c.text(n["affine"], at + "affine");
      bool known = false;
      for (NiftiAffine f : {NiftiAffine::Auto, NiftiAffine::Sform, NiftiAffine::Qform})
        if (a == toString(f)) {
          s.affine = f;
          known = true;
        }
      if (!known) c.fail(n["affine"], at + "affine", "must be auto, sform or qform, not '" + a + "'");
    }
    if (n["sampling"]) {
      const std::string a = c.text(n["sampling"], at + "sampling");
      if (a == toString(NiftiSampling::Conservative))
        s.sampling = NiftiSampling::Conservative;
      else if (a == toString(NiftiSampling::Centre) || a == "center")
        s.sampling = NiftiSampling::Centre;
      else
        c.fail(n["sampling"], at + "sampling", "must be conservative or centre, not '" + a + "'");
    }
    return s;
  }
  auto scaleAndTransform = [&]() {
    if (n["units"] && n["scale"]) c.fail(n, at + "scale", "give either units or scale");
    if (n["units"]) s.scale = c.unitScale(n["units"], at + "units");
    if (n["scale"]) {
      s.scale = c.number(n["scale"], at + "scale");
      if (!(s.scale > 0)) c.fail(n["scale"], at + "scale", "must be > 0");
    }
    if (n["transform"]) {
      try {
        s.transform = poseFromMatrix(c.mat4(n["transform"], at + "transform"));
      } catch (const std::invalid_argument& e) {
        c.fail(n["transform"], at + "transform", e.what());
      }
    }
  };
  if (n["mesh"]) {
    c.allowOnly(n, what, {"mesh", "units", "scale", "transform", "fill", "name"});
    s.kind = SourceSpec::Kind::Mesh;
    s.path = c.path(n["mesh"], at + "mesh");
    scaleAndTransform();
    if (n["fill"]) s.fill = c.boolean(n["fill"], at + "fill");
    if (stay) s.fill = true;
    return s;
  }
  if (n["points"]) {
    if (stay) c.fail(n, at + "points", "a point cloud cannot be a stay_inside region");
    c.allowOnly(n, what, {"points", "units", "scale", "transform", "radius", "name"});
    s.kind = SourceSpec::Kind::Points;
    s.path = c.path(n["points"], at + "points");
    scaleAndTransform();
    if (n["radius"]) {
      s.point_radius = c.number(n["radius"], at + "radius");
      if (s.point_radius < 0) c.fail(n["radius"], at + "radius", "must be >= 0");
    }
    return s;
  }
  c.allowOnly(n, what, {"octomap", "name"});
  s.kind = SourceSpec::Kind::OcTree;
  s.path = c.path(n["octomap"], at + "octomap");
  return s;
}

ProceduralSpec parseProcedural(const Ctx& c, const YAML::Node& n) {
  if (!n.IsMap()) c.fail(n, "procedural", "must be a mapping {type: ..., seed: ...}");
  ProceduralSpec p;
  if (!n["type"]) c.fail(n, "procedural", "missing key 'type'");
  p.type = c.text(n["type"], "procedural.type");
  std::map<std::string, std::pair<double, std::string>> defs;
  try {
    defs = proceduralParameters(p.type);
  } catch (const std::invalid_argument& e) {
    c.fail(n["type"], "procedural.type", e.what());
  }
  for (const auto& kv : n) {
    if (kv.first.IsSequence() || kv.first.IsMap())
      c.fail(kv.first, "procedural", "a key must be a name, not a list or a mapping");
    const std::string k = kv.first.as<std::string>("");
    const std::string key = "procedural." + k;
    if (k == "type") continue;
    if (k == "seed") {
      const double v = c.number(kv.second, key);
      if (v < 0 || v != std::floor(v) || v > 9.007e15) c.fail(kv.second, key, "must be a non-negative integer");
      p.seed = static_cast<std::uint64_t>(v);
    } else if (k == "scale") {
      p.scale = c.number(kv.second, key);
    } else if (defs.count(k)) {
      p.params[k] = c.number(kv.second, key);
    } else {
      std::string known = "type, seed, scale";
      for (const auto& d : defs) known += ", " + d.first;
      c.fail(kv.first, key, "unknown key for procedural type '" + p.type + "' (known: " + known + ")");
    }
  }
  try {
    (void)makeProcedural(p);  // validates ranges
  } catch (const std::invalid_argument& e) {
    c.fail(n, "procedural", e.what());
  }
  return p;
}

EnvironmentDescription parseDescription(const std::string& text_in, const std::string& source,
                                        const std::string& base_dir) {
  Ctx c;
  c.file = source;
  c.base_dir = base_dir;
  YAML::Node root;
  try {
    root = YAML::Load(text_in);
  } catch (const YAML::ParserException& e) {
    throw io::InputError(source, e.mark.line >= 0 ? e.mark.line + 1 : 0, "", "malformed YAML: " + e.msg);
  }
  if (!root.IsMap()) throw io::InputError(source, 0, "", "an environment description must be a YAML mapping");
  c.allowOnly(root, "",
              {"name", "resolution", "padding", "bounds", "mark_free", "obstacles", "stay_inside", "procedural",
               "base_pose", "starts", "targets", "collision", "check_targets", "description"});
  EnvironmentDescription d;
  d.file = source;
  d.name = root["name"] ? c.text(root["name"], "name") : fs::path(source).stem().string();
  if (root["resolution"]) {
    d.resolution = c.number(root["resolution"], "resolution");
    if (!(d.resolution >= 1e-5 && d.resolution <= 0.1))
      c.fail(root["resolution"], "resolution", "must be in [1e-5, 0.1] m (it is a leaf size in metres)");
  }
  if (root["padding"]) {
    d.padding = c.number(root["padding"], "padding");
    if (d.padding < 0) c.fail(root["padding"], "padding", "must be >= 0");
  }
  if (root["mark_free"]) d.mark_free = c.boolean(root["mark_free"], "mark_free");
  if (root["check_targets"]) d.check_targets = c.boolean(root["check_targets"], "check_targets");
  if (root["bounds"]) {
    const YAML::Node b = root["bounds"];
    c.mapping(b, "bounds", {"min", "max", "units"});
    if (!b["min"] || !b["max"]) c.fail(b, "bounds", "needs min and max");
    const double u = b["units"] ? c.unitScale(b["units"], "bounds.units") : 1.0;
    d.crop = Aabb(c.vec3(b["min"], "bounds.min") * u, c.vec3(b["max"], "bounds.max") * u);
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
    s.line = Ctx::lineOf(root["procedural"]);
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
      const std::string name = c.text(kv.first, "starts");
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
        c.fail(root["base_pose"]["start"], "base_pose.start",
               "no start pose named '" + ref + "' (known: " + (known.empty() ? "none" : known) + ")");
      }
    } else {
      d.base_pose = p;
    }
  }
  if (root["targets"]) {
    const YAML::Node t = root["targets"];
    if (!t.IsMap()) c.fail(t, "targets", "must be a mapping NAME: target");
    for (const auto& kv : t) {
      const std::string name = c.text(kv.first, "targets");
      d.targets.push_back(parseTarget(c, kv.second, "targets." + name, name));
    }
  }
  if (root["collision"]) {
    const YAML::Node col = root["collision"];
    c.mapping(col, "collision", {"safety_margin", "unknown_space", "exclude_proximal"});
    if (col["exclude_proximal"]) {
      d.collision.exclude_proximal = c.number(col["exclude_proximal"], "collision.exclude_proximal");
      if (d.collision.exclude_proximal < 0)
        c.fail(col["exclude_proximal"], "collision.exclude_proximal", "must be >= 0");
    }
    if (col["safety_margin"]) {
      d.collision.safety_margin = c.number(col["safety_margin"], "collision.safety_margin");
      if (d.collision.safety_margin < 0) c.fail(col["safety_margin"], "collision.safety_margin", "must be >= 0");
    }
    if (col["unknown_space"]) {
      try {
        d.collision.unknown_space = parseUnknownSpace(c.text(col["unknown_space"], "collision.unknown_space"));
      } catch (const std::invalid_argument& e) {
        c.fail(col["unknown_space"], "collision.unknown_space", e.what());
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
  Aabb extent;  // region the source describes (known space)
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
      note << "mesh " << s.path << " (" << l.mesh.triangles.size() << " triangles" << (s.fill ? ", filled" : "") << ")";
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
    case SourceSpec::Kind::Nifti:
      rasterizeNifti(l.vol, l.mask, grid, VoxelGrid::kOccupied, s.sampling);
      break;
    case SourceSpec::Kind::Mesh:
      if (s.fill)
        voxelizeSolid(l.mesh, grid, VoxelGrid::kOccupied, false, s.path);
      else
        voxelizeSurface(l.mesh, grid, VoxelGrid::kOccupied);
      break;
    case SourceSpec::Kind::Points:
      rasterizePoints(l.points, grid, s.point_radius, VoxelGrid::kOccupied);
      break;
    case SourceSpec::Kind::OcTree:
      rasterizeOcTree(*l.tree, grid, false);
      break;
    case SourceSpec::Kind::Procedural:
      break;
  }
}

// Stay-inside: cells inside the region free, all other cells of the grid occupied.
void rasterizeStay(const Loaded& l, VoxelGrid& grid) {
  const SourceSpec& s = *l.spec;
  switch (s.kind) {
    case SourceSpec::Kind::Nifti:
      rasterizeNiftiInside(l.vol, l.mask, grid);
      break;
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
    case SourceSpec::Kind::Procedural:
      rasterizeProcedural(l.anatomy, grid);
      break;
    case SourceSpec::Kind::Points:
      break;
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
