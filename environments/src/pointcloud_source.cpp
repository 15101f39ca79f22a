#include "ctr/environments/pointcloud_source.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <sstream>

#include "ctr/io/input_error.hpp"

namespace ctr::environments {

namespace {

[[noreturn]] void fail(const std::string& path, int line, const std::string& msg) {
  throw io::InputError(path, line, "", msg);
}

std::string lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

std::vector<Eigen::Vector3d> readXyz(const std::string& path, std::istream& in) {
  std::vector<Eigen::Vector3d> pts;
  std::string line;
  int ln = 0;
  while (std::getline(in, line)) {
    ++ln;
    const auto hash = line.find('#');
    if (hash != std::string::npos) line.resize(hash);
    for (char& c : line)
      if (c == ',' || c == ';' || c == '\t' || c == '\r') c = ' ';
    std::istringstream ss(line);
    std::string tok;
    double v[3];
    int n = 0;
    while (n < 3 && ss >> tok) {
      std::size_t used = 0;
      try {
        v[n] = std::stod(tok, &used);
      } catch (const std::exception&) {
        used = 0;
      }
      if (used != tok.size() || !std::isfinite(v[n])) {
        if (pts.empty() && n == 0) break;  // a header line such as "x y z"
        fail(path, ln, "'" + tok + "' is not a finite number");
      }
      ++n;
    }
    if (n == 0) continue;
    if (n < 3) fail(path, ln, "a point needs three coordinates x y z");
    pts.emplace_back(v[0], v[1], v[2]);
  }
  return pts;
}

struct PlyProp {
  std::string name, type;
  bool list = false;
};

int typeSize(const std::string& t) {
  if (t == "char" || t == "uchar" || t == "int8" || t == "uint8") return 1;
  if (t == "short" || t == "ushort" || t == "int16" || t == "uint16") return 2;
  if (t == "int" || t == "uint" || t == "int32" || t == "uint32" || t == "float" || t == "float32") return 4;
  if (t == "double" || t == "float64") return 8;
  return 0;
}

double readBinary(const char* p, const std::string& t, bool swap) {
  char b[8];
  const int n = typeSize(t);
  std::memcpy(b, p, static_cast<std::size_t>(n));
  if (swap) std::reverse(b, b + n);
  if (t == "char" || t == "int8") return static_cast<double>(static_cast<std::int8_t>(b[0]));
  if (t == "uchar" || t == "uint8") return static_cast<double>(static_cast<std::uint8_t>(b[0]));
  auto get = [&](auto tag) {
    decltype(tag) x;
    std::memcpy(&x, b, sizeof(x));
    return static_cast<double>(x);
  };
  if (t == "short" || t == "int16") return get(std::int16_t{});
  if (t == "ushort" || t == "uint16") return get(std::uint16_t{});
  if (t == "int" || t == "int32") return get(std::int32_t{});
  if (t == "uint" || t == "uint32") return get(std::uint32_t{});
  if (t == "float" || t == "float32") return get(float{});
  return get(double{});
}

std::vector<Eigen::Vector3d> readPly(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::string line;
  int ln = 0;
  auto next = [&]() -> bool {
    if (!std::getline(in, line)) return false;
    ++ln;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    return true;
  };
  if (!next() || line != "ply") fail(path, 1, "not a PLY file (first line must be 'ply')");
  std::string format;
  bool vertex_first = false, seen_element = false, in_vertex = false;
  long long nvert = -1;
  std::vector<PlyProp> props;
  while (true) {
    if (!next()) fail(path, ln, "PLY header without end_header");
    std::istringstream ss(line);
    std::string w;
    ss >> w;
    if (w == "format") {
      ss >> format;
    } else if (w == "element") {
      std::string name;
      long long count = -1;
      ss >> name >> count;
      if (!seen_element && name == "vertex") vertex_first = true;
      if (name == "vertex") nvert = count;
      in_vertex = name == "vertex";
      seen_element = true;
    } else if (w == "property" && in_vertex) {
      PlyProp p;
      std::string t;
      ss >> t;
      if (t == "list") {
        std::string ct, it;
        ss >> ct >> it >> p.name;
        p.list = true;
      } else {
        p.type = t;
        ss >> p.name;
        if (typeSize(t) == 0) fail(path, ln, "unknown PLY property type '" + t + "'");
      }
      props.push_back(p);
    } else if (w == "end_header") {
      break;
    }
  }
  if (nvert < 0) fail(path, ln, "the PLY file has no vertex element");
  if (!vertex_first) fail(path, ln, "the vertex element must come first in the PLY file");
  int ix = -1, iy = -1, iz = -1;
  for (std::size_t i = 0; i < props.size(); ++i) {
    if (props[i].list) fail(path, ln, "list properties in the vertex element are not supported");
    if (props[i].name == "x") ix = static_cast<int>(i);
    if (props[i].name == "y") iy = static_cast<int>(i);
    if (props[i].name == "z") iz = static_cast<int>(i);
  }
  if (ix < 0 || iy < 0 || iz < 0) fail(path, ln, "the PLY vertex element lacks x, y or z");
  std::vector<Eigen::Vector3d> pts;
  pts.reserve(static_cast<std::size_t>(std::min<long long>(nvert, 50000000)));
  if (format == "ascii") {
    for (long long v = 0; v < nvert; ++v) {
      if (!next()) fail(path, ln, "the PLY file ends before all vertices were read");
      std::istringstream ss(line);
      std::vector<double> vals(props.size());
      for (auto& x : vals)
        if (!(ss >> x)) fail(path, ln, "malformed PLY vertex line");
      pts.emplace_back(vals[static_cast<std::size_t>(ix)], vals[static_cast<std::size_t>(iy)],
                       vals[static_cast<std::size_t>(iz)]);
    }
  } else if (format == "binary_little_endian" || format == "binary_big_endian") {
    const bool little_host = [] {
      const std::uint16_t x = 1;
      return *reinterpret_cast<const std::uint8_t*>(&x) == 1;
    }();
    const bool swap = (format == "binary_little_endian") != little_host;
    std::vector<int> off(props.size());
    int stride = 0;
    for (std::size_t i = 0; i < props.size(); ++i) {
      off[i] = stride;
      stride += typeSize(props[i].type);
    }
    std::vector<char> buf(static_cast<std::size_t>(stride));
    for (long long v = 0; v < nvert; ++v) {
      if (!in.read(buf.data(), stride)) fail(path, 0, "the PLY file ends before all vertices were read");
      pts.emplace_back(
          readBinary(buf.data() + off[static_cast<std::size_t>(ix)], props[static_cast<std::size_t>(ix)].type, swap),
          readBinary(buf.data() + off[static_cast<std::size_t>(iy)], props[static_cast<std::size_t>(iy)].type, swap),
          readBinary(buf.data() + off[static_cast<std::size_t>(iz)], props[static_cast<std::size_t>(iz)].type, swap));
    }
  } else {
    fail(path, 0, "unknown PLY format '" + format + "'");
  }
  return pts;
}

}  // namespace

std::vector<Eigen::Vector3d> loadPointCloud(const std::string& path, double scale, const Eigen::Isometry3d& transform) {
  std::ifstream in(path, std::ios::binary);
  if (!in) fail(path, 0, "cannot open the point cloud (missing or unreadable)");
  const std::string l = lower(path);
  std::vector<Eigen::Vector3d> pts;
  if (l.size() > 4 && l.compare(l.size() - 4, 4, ".ply") == 0) {
    in.close();
    pts = readPly(path);
  } else {
    pts = readXyz(path, in);
  }
  if (pts.empty()) fail(path, 0, "the point cloud has no points");
  for (auto& p : pts) {
    if (!p.allFinite()) fail(path, 0, "the point cloud has non-finite coordinates");
    p = transform * (scale * p);
  }
  return pts;
}

Aabb pointsExtent(const std::vector<Eigen::Vector3d>& points) {
  Aabb b;
  for (const auto& p : points) b.extend(p);
  return b;
}

void rasterizePoints(const std::vector<Eigen::Vector3d>& points, VoxelGrid& grid, double radius, std::uint8_t value) {
  for (const auto& p : points) {
    if (radius <= 0.0) {
      const Eigen::Vector3i c = grid.cellOf(p);
      if (grid.inside(c.x(), c.y(), c.z())) grid.set(c.x(), c.y(), c.z(), value);
      continue;
    }
    Eigen::Vector3i lo, hi;
    if (!grid.cellRange(Aabb(p.array() - radius, p.array() + radius), lo, hi, 0.0)) continue;
    const double h = 0.5 * grid.resolution();
    for (int k = lo.z(); k <= hi.z(); ++k)
      for (int j = lo.y(); j <= hi.y(); ++j)
        for (int i = lo.x(); i <= hi.x(); ++i) {
          const Eigen::Vector3d c = grid.centre(i, j, k);
          if (distance(Aabb(c.array() - h, c.array() + h), p) <= radius) grid.set(i, j, k, value);
        }
  }
}

void writeXyz(const std::string& path, const std::vector<Eigen::Vector3d>& points) {
  std::ofstream out(path);
  if (!out) throw io::InputError(path, 0, "", "cannot write the point cloud");
  out.precision(17);
  for (const auto& p : points) out << p.x() << " " << p.y() << " " << p.z() << "\n";
}

}  // namespace ctr::environments
