#include "ctr/design/space.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <functional>
#include <set>
#include <sstream>
#include <stdexcept>

#include "ctr/io/file.hpp"
#include "ctr/io/input_error.hpp"
#include "ctr/io/yaml_reader.hpp"
#include "ctr/model/sampling.hpp"

namespace ctr::design {
namespace {

using io::InputError;
constexpr double kPi = 3.14159265358979323846;

std::string fmt(double v) {
  std::ostringstream o;
  o << v;
  return o.str();
}

struct Parser : io::YamlReader {
  double positive(const YAML::Node& n, const std::string& key) const {
    const double v = number(n, key);
    if (!(v > 0)) fail(n, key, "must be > 0");
    return v;
  }
  double nonNegative(const YAML::Node& n, const std::string& key) const {
    const double v = number(n, key);
    if (v < 0) fail(n, key, "must be >= 0");
    return v;
  }
  // A range: one number (fixed) or [min, max] with min <= max, both >= 0.
  Range range(const YAML::Node& n, const std::string& key) const {
    Range r;
    if (n.IsScalar()) {
      r.min = r.max = nonNegative(n, key);
    } else if (n.IsSequence() && n.size() == 2) {
      r.min = nonNegative(n[0], key + "[0]");
      r.max = nonNegative(n[1], key + "[1]");
      if (r.min > r.max) fail(n, key, "impossible range: min " + fmt(r.min) + " > max " + fmt(r.max));
    } else {
      fail(n, key, "must be a number or a [min, max] range");
    }
    return r;
  }
};

double bendingStiffness(double E, double od, double id) {
  return E * kPi * (std::pow(od, 4) - std::pow(id, 4)) / 64.0;
}

}  // namespace

std::vector<std::vector<int>> DesignSpace::size_combinations() const {
  std::vector<std::vector<int>> out;
  std::vector<int> cur(tubes.size());
  std::function<void(std::size_t)> rec = [&](std::size_t i) {
    if (i == tubes.size()) {
      out.push_back(cur);
      return;
    }
    for (int s : tubes[i].sizes) {
      if (i > 0) {
        const TubeSize& outer = catalogue[static_cast<std::size_t>(cur[i - 1])];
        const TubeSize& inner = catalogue[static_cast<std::size_t>(s)];
        if (outer.inner_diameter - inner.outer_diameter < nesting_clearance - 1e-12) continue;
      }
      cur[i] = s;
      rec(i + 1);
    }
  };
  rec(0);
  return out;
}

namespace {
std::vector<Tube> tubesOf(const DesignSpace& space, const Candidate& c);
}

double strain(const DesignSpace& space, const Candidate& c, int i) {
  const auto& t = c.tubes.at(static_cast<std::size_t>(i));
  return std::abs(t.curvature) * 0.5 * space.catalogue.at(static_cast<std::size_t>(t.size)).outer_diameter;
}

std::string violation(const DesignSpace& space, const Candidate& c) {
  if (c.tubes.size() != space.tubes.size())
    return "has " + std::to_string(c.tubes.size()) + " tubes, the space " + std::to_string(space.tubes.size());
  for (std::size_t i = 0; i < c.tubes.size(); ++i) {
    const auto& t = c.tubes[i];
    const TubeSpace& s = space.tubes[i];
    const std::string w = "tube '" + s.name + "': ";
    if (!s.straight_length.contains(t.straight_length)) return w + "straight_length outside its range";
    if (!s.curved_length.contains(t.curved_length)) return w + "curved_length outside its range";
    if (!s.curvature.contains(t.curvature)) return w + "curvature outside its range";
    if (std::find(s.sizes.begin(), s.sizes.end(), t.size) == s.sizes.end()) return w + "size not allowed";
    if (t.straight_length + t.curved_length <= 0) return w + "zero length";
    const double e = strain(space, c, static_cast<int>(i));
    if (e > space.strain_limit * (1 + 1e-12))
      return w + "strain " + fmt(e) + " above the limit " + fmt(space.strain_limit);
    if (i > 0) {
      const auto& o = c.tubes[i - 1];
      const TubeSize& outer = space.catalogue[static_cast<std::size_t>(o.size)];
      const TubeSize& inner = space.catalogue[static_cast<std::size_t>(t.size)];
      if (outer.inner_diameter - inner.outer_diameter < space.nesting_clearance - 1e-12)
        return w + "does not fit inside tube '" + space.tubes[i - 1].name + "' with the nesting clearance";
      const double lo = o.straight_length + o.curved_length, li = t.straight_length + t.curved_length;
      if (li < lo + space.length_step - 1e-12)
        return w + "shorter than tube '" + space.tubes[i - 1].name + "' plus the length step";
    }
    if (t.straight_length + t.curved_length < space.actuation.min_extension)
      return w + "shorter than the actuation's min_extension";
  }
  try {
    if (!translationBounds(Robot("candidate", tubesOf(space, c)), 1e-3).feasible())
      return "no admissible translation (actuation limits and length nesting)";
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

namespace {
std::vector<Tube> tubesOf(const DesignSpace& space, const Candidate& c) {
  std::vector<Tube> tubes;
  for (std::size_t i = 0; i < c.tubes.size(); ++i) {
    const auto& d = c.tubes[i];
    const TubeSize& sz = space.catalogue[static_cast<std::size_t>(d.size)];
    Tube t;
    t.name = space.tubes[i].name;
    t.straight_length = d.straight_length;
    t.curved_length = d.curved_length;
    t.curvature = d.curved_length > 0 ? d.curvature : 0.0;
    t.outer_diameter = sz.outer_diameter;
    t.inner_diameter = sz.inner_diameter;
    t.bending_stiffness = bendingStiffness(space.material.youngs_modulus, sz.outer_diameter, sz.inner_diameter);
    t.poisson_ratio = space.material.poisson_ratio;
    t.torsional_stiffness = t.bending_stiffness / (1.0 + space.material.poisson_ratio);
    if (space.material.density > 0)
      t.linear_density = space.material.density * kPi *
                         (sz.outer_diameter * sz.outer_diameter - sz.inner_diameter * sz.inner_diameter) / 4.0;
    const double L = t.length();
    t.translation_limits =
        std::array<double, 2>{space.actuation.min_extension - L, std::min(0.0, space.actuation.max_extension - L)};
    t.rotation_limits = space.tubes[i].rotation_limits;
    tubes.push_back(std::move(t));
  }
  return tubes;
}
}  // namespace

Robot makeRobot(const DesignSpace& space, const Candidate& c, const Robot& base, const std::string& name) {
  const std::string v = violation(space, c);
  if (!v.empty()) throw std::invalid_argument("candidate outside the design space: " + v);
  return Robot(name, tubesOf(space, c), base.friction(), base.loads());
}

std::optional<Candidate> candidateOf(const DesignSpace& space, const Robot& robot) {
  if (robot.size() != static_cast<int>(space.tubes.size())) return std::nullopt;
  Candidate c;
  for (int i = 0; i < robot.size(); ++i) {
    const Tube& t = robot.tube(i);
    Candidate::TubeDesign d;
    d.straight_length = t.straight_length;
    d.curved_length = t.curved_length;
    d.curvature = t.curvature;
    d.size = -1;
    for (std::size_t k = 0; k < space.catalogue.size(); ++k)
      if (std::abs(space.catalogue[k].outer_diameter - t.outer_diameter) < 1e-9 &&
          std::abs(space.catalogue[k].inner_diameter - t.inner_diameter) < 1e-9)
        d.size = static_cast<int>(k);
    if (d.size < 0) return std::nullopt;
    c.tubes.push_back(d);
  }
  if (!violation(space, c).empty()) return std::nullopt;
  return c;
}

bool adaptStart(const Robot& base, const Configuration& start, const Robot& designed, Configuration& out) {
  if (start.size() != designed.size() || base.size() != designed.size()) return false;
  out = start;
  for (int i = 0; i < designed.size(); ++i)
    out.beta[i] = start.beta[i] + base.tube(i).length() - designed.tube(i).length();
  return static_cast<bool>(projectAdmissible(designed, out));
}

int continuousDimension(const DesignSpace& space) {
  return 3 * static_cast<int>(space.tubes.size());
}

std::optional<Candidate> candidateAt(const DesignSpace& space, const std::vector<double>& x, std::size_t combo) {
  const auto combos = space.size_combinations();
  if (combo >= combos.size() || x.size() != static_cast<std::size_t>(continuousDimension(space))) return std::nullopt;
  auto at = [](const Range& r, double u) { return r.min + std::clamp(u, 0.0, 1.0) * (r.max - r.min); };
  Candidate c;
  for (std::size_t i = 0; i < space.tubes.size(); ++i) {
    const TubeSpace& s = space.tubes[i];
    Candidate::TubeDesign d;
    d.size = combos[combo][i];
    d.straight_length = at(s.straight_length, x[3 * i]);
    d.curved_length = at(s.curved_length, x[3 * i + 1]);
    d.curvature = at(s.curvature, x[3 * i + 2]);
    // Strain: clamp the precurvature to the limit of this size.
    const double kmax = space.strain_limit / (0.5 * space.catalogue[static_cast<std::size_t>(d.size)].outer_diameter);
    d.curvature = std::min(d.curvature, kmax);
    if (d.curvature < s.curvature.min) return std::nullopt;  // the whole range is above the strain limit
    // Nesting in length: lengthen the straight part of an inner tube that is too short.
    if (i > 0) {
      const auto& o = c.tubes[i - 1];
      const double need = o.straight_length + o.curved_length + space.length_step - d.curved_length;
      if (d.straight_length < need) d.straight_length = need;
      if (!s.straight_length.contains(d.straight_length, 1e-12)) return std::nullopt;
      d.straight_length = std::min(d.straight_length, s.straight_length.max);
    }
    c.tubes.push_back(d);
  }
  if (!violation(space, c).empty()) return std::nullopt;
  return c;
}

std::vector<double> unitPoint(const DesignSpace& space, const Candidate& c) {
  auto u = [](const Range& r, double v) {
    return r.fixed() ? 0.5 : std::clamp((v - r.min) / (r.max - r.min), 0.0, 1.0);
  };
  std::vector<double> x;
  for (std::size_t i = 0; i < space.tubes.size(); ++i) {
    x.push_back(u(space.tubes[i].straight_length, c.tubes[i].straight_length));
    x.push_back(u(space.tubes[i].curved_length, c.tubes[i].curved_length));
    x.push_back(u(space.tubes[i].curvature, c.tubes[i].curvature));
  }
  return x;
}

DesignSpace parseSpace(const std::string& text, const std::string& source) {
  Parser p;
  p.file = source;
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::ParserException& e) {
    throw InputError(source, e.mark.line + 1, "", std::string("not valid YAML: ") + e.msg);
  }
  if (!root.IsMap()) throw InputError(source, 0, "", "a design space must be a YAML map");
  p.allowOnly(
      root, "",
      {"name", "catalogue", "tubes", "material", "strain_limit", "nesting_clearance", "actuation", "length_step"});
  DesignSpace s;
  s.file = source;
  s.name = root["name"] ? p.text(root["name"], "name") : std::filesystem::path(source).stem().string();
  if (root["strain_limit"]) {
    s.strain_limit = p.positive(root["strain_limit"], "strain_limit");
    if (s.strain_limit > 0.2) p.fail(root["strain_limit"], "strain_limit", "must be a fraction (0.06 is 6 %)");
  }
  if (root["nesting_clearance"]) s.nesting_clearance = p.nonNegative(root["nesting_clearance"], "nesting_clearance");
  if (root["length_step"]) s.length_step = p.nonNegative(root["length_step"], "length_step");
  if (root["material"]) {
    const YAML::Node m = root["material"];
    if (!m.IsMap()) p.fail(m, "material", "must be a map with youngs_modulus, poisson_ratio, density");
    p.allowOnly(m, "material", {"youngs_modulus", "poisson_ratio", "density"});
    if (m["youngs_modulus"]) s.material.youngs_modulus = p.positive(m["youngs_modulus"], "material.youngs_modulus");
    if (m["poisson_ratio"]) {
      s.material.poisson_ratio = p.number(m["poisson_ratio"], "material.poisson_ratio");
      if (!(s.material.poisson_ratio > -1.0 && s.material.poisson_ratio < 0.5))
        p.fail(m["poisson_ratio"], "material.poisson_ratio", "must lie in (-1, 0.5)");
    }
    if (m["density"]) s.material.density = p.nonNegative(m["density"], "material.density");
  }
  if (root["actuation"]) {
    const YAML::Node a = root["actuation"];
    if (!a.IsMap()) p.fail(a, "actuation", "must be a map with max_extension and/or min_extension");
    p.allowOnly(a, "actuation", {"max_extension", "min_extension"});
    if (a["max_extension"]) s.actuation.max_extension = p.positive(a["max_extension"], "actuation.max_extension");
    if (a["min_extension"]) s.actuation.min_extension = p.nonNegative(a["min_extension"], "actuation.min_extension");
    if (s.actuation.min_extension >= s.actuation.max_extension)
      p.fail(a, "actuation", "min_extension must be smaller than max_extension");
  }
  const YAML::Node cat = root["catalogue"];
  if (!cat) throw InputError(source, 0, "catalogue", "missing (the available tube sizes)");
  if (!cat.IsSequence() || cat.size() == 0) p.fail(cat, "catalogue", "must be a non-empty list of tube sizes");
  std::set<std::string> names;
  for (std::size_t k = 0; k < cat.size(); ++k) {
    const std::string w = "catalogue[" + std::to_string(k) + "]";
    const YAML::Node e = cat[k];
    if (!e.IsMap()) p.fail(e, w, "must be a map with name, outer_diameter and inner_diameter or wall_thickness");
    p.allowOnly(e, w, {"name", "outer_diameter", "inner_diameter", "wall_thickness"});
    TubeSize t;
    if (!e["outer_diameter"]) p.fail(e, w + ".outer_diameter", "missing");
    t.outer_diameter = p.positive(e["outer_diameter"], w + ".outer_diameter");
    if (t.outer_diameter > 0.05) p.fail(e["outer_diameter"], w + ".outer_diameter", "implausible (m, not mm?)");
    if (e["inner_diameter"] && e["wall_thickness"]) p.fail(e, w, "give inner_diameter or wall_thickness, not both");
    if (e["inner_diameter"]) {
      t.inner_diameter = p.nonNegative(e["inner_diameter"], w + ".inner_diameter");
    } else if (e["wall_thickness"]) {
      t.inner_diameter = t.outer_diameter - 2.0 * p.positive(e["wall_thickness"], w + ".wall_thickness");
    } else {
      p.fail(e, w + ".inner_diameter", "missing (or wall_thickness)");
    }
    if (!(t.inner_diameter >= 0 && t.inner_diameter < t.outer_diameter))
      p.fail(e, w, "the inner diameter must lie in [0, outer_diameter)");
    t.name =
        e["name"] ? p.text(e["name"], w + ".name") : fmt(t.outer_diameter * 1e3) + "x" + fmt(t.inner_diameter * 1e3);
    if (!names.insert(t.name).second) p.fail(e, w + ".name", "duplicate size name '" + t.name + "'");
    s.catalogue.push_back(t);
  }
  const YAML::Node tubes = root["tubes"];
  if (!tubes) throw InputError(source, 0, "tubes", "missing (one entry per tube, outermost first)");
  if (!tubes.IsSequence() || tubes.size() == 0) p.fail(tubes, "tubes", "must be a non-empty list (outermost first)");
  for (std::size_t i = 0; i < tubes.size(); ++i) {
    const std::string w = "tubes[" + std::to_string(i) + "]";
    const YAML::Node t = tubes[i];
    if (!t.IsMap()) p.fail(t, w, "must be a map");
    p.allowOnly(t, w, {"name", "straight_length", "curved_length", "curvature", "sizes", "rotation_limits"});
    TubeSpace ts;
    ts.name = t["name"] ? p.text(t["name"], w + ".name") : "tube " + std::to_string(i + 1);
    for (const char* k : {"straight_length", "curved_length", "curvature"})
      if (!t[k]) p.fail(t, w + "." + k, "missing");
    ts.straight_length = p.range(t["straight_length"], w + ".straight_length");
    ts.curved_length = p.range(t["curved_length"], w + ".curved_length");
    ts.curvature = p.range(t["curvature"], w + ".curvature");
    if (ts.straight_length.max + ts.curved_length.max <= 0) p.fail(t, w, "the tube has no length");
    if (ts.straight_length.max > 2.0 || ts.curved_length.max > 2.0) p.fail(t, w, "implausible length (m, not mm?)");
    if (t["sizes"]) {
      const YAML::Node sz = t["sizes"];
      if (!sz.IsSequence() || sz.size() == 0) p.fail(sz, w + ".sizes", "must be a non-empty list of catalogue names");
      for (std::size_t k = 0; k < sz.size(); ++k) {
        const std::string n = p.text(sz[k], w + ".sizes");
        auto it = std::find_if(s.catalogue.begin(), s.catalogue.end(), [&](const TubeSize& c) { return c.name == n; });
        if (it == s.catalogue.end()) p.fail(sz[k], w + ".sizes", "'" + n + "' is not in the catalogue");
        ts.sizes.push_back(static_cast<int>(it - s.catalogue.begin()));
      }
    } else {
      for (std::size_t k = 0; k < s.catalogue.size(); ++k) ts.sizes.push_back(static_cast<int>(k));
    }
    if (t["rotation_limits"]) {
      const YAML::Node r = t["rotation_limits"];
      if (!r.IsSequence() || r.size() != 2) p.fail(r, w + ".rotation_limits", "must be [min, max] (rad)");
      ts.rotation_limits =
          std::array<double, 2>{p.number(r[0], w + ".rotation_limits[0]"), p.number(r[1], w + ".rotation_limits[1]")};
      if ((*ts.rotation_limits)[0] >= (*ts.rotation_limits)[1])
        p.fail(r, w + ".rotation_limits", "min must be smaller than max");
    }
    // A tube whose every size breaks the strain limit at its smallest precurvature cannot exist.
    bool any = false;
    for (int k : ts.sizes)
      any = any || ts.curvature.min * 0.5 * s.catalogue[static_cast<std::size_t>(k)].outer_diameter <=
                       s.strain_limit * (1 + 1e-12);
    if (!any)
      p.fail(t["curvature"], w + ".curvature",
             "impossible range: the smallest precurvature " + fmt(ts.curvature.min) + " 1/m exceeds the strain limit " +
                 fmt(s.strain_limit) + " with every allowed size");
    s.tubes.push_back(ts);
  }
  if (s.size_combinations().empty())
    p.fail(tubes, "tubes",
           "no combination of the allowed sizes nests with the clearance " + fmt(s.nesting_clearance) +
               " m (inner_diameter of a tube - outer_diameter of the next)");
  // Lengths must be able to nest (each inner tube at least as long as its outer tube plus the length step) and every
  // tube must be able to reach the actuation's extension range.
  double prev_min = 0.0;
  for (std::size_t i = 0; i < s.tubes.size(); ++i) {
    const TubeSpace& ts = s.tubes[i];
    const double lmin = std::max(ts.straight_length.min + ts.curved_length.min, i > 0 ? prev_min + s.length_step : 0.0);
    if (lmin > ts.straight_length.max + ts.curved_length.max + 1e-12)
      p.fail(tubes[i], "tubes[" + std::to_string(i) + "]",
             "impossible ranges: the tube cannot be at least as long as the tube around it plus length_step (" +
                 fmt(lmin) + " m needed, " + fmt(ts.straight_length.max + ts.curved_length.max) + " m at most)");
    prev_min = lmin;
  }
  // At least one candidate must satisfy every constraint (checked on a grid of corners and the centre).
  bool any = false;
  const int d = continuousDimension(s);
  for (std::size_t combo = 0; combo < s.size_combinations().size() && !any; ++combo)
    for (double u : {0.0, 0.5, 1.0}) {
      std::vector<double> x(static_cast<std::size_t>(d), u);
      for (std::size_t i = 0; i < s.tubes.size(); ++i) x[3 * i + 2] = 0.0;  // lowest precurvature: least strain
      if (candidateAt(s, x, combo)) {
        any = true;
        break;
      }
    }
  if (!any) throw InputError(source, 0, "tubes", "impossible ranges: no candidate satisfies every constraint");
  return s;
}

DesignSpace loadSpace(const std::string& path) {
  std::string text;
  try {
    text = io::readFile(path);
  } catch (const std::exception& e) {
    throw InputError(path, 0, "", e.what());
  }
  return parseSpace(text, path);
}

DesignSpace defaultSpace(const Robot& robot, double strain_limit) {
  DesignSpace s;
  s.name = robot.name() + "_space";
  s.strain_limit = strain_limit;
  const Tube& t0 = robot.tube(0);
  s.material.youngs_modulus = 60e9;
  if (t0.outer_diameter > 0 && t0.bending_stiffness > 0) {
    const double I = kPi * (std::pow(t0.outer_diameter, 4) - std::pow(t0.inner_diameter, 4)) / 64.0;
    s.material.youngs_modulus = t0.bending_stiffness / I;
  }
  s.material.poisson_ratio = t0.poisson_ratio ? *t0.poisson_ratio : t0.bending_stiffness / t0.torsional_stiffness - 1.0;
  double rho = 0.0;
  if (t0.linear_density > 0 && t0.outer_diameter > 0)
    rho =
        t0.linear_density / (kPi * (t0.outer_diameter * t0.outer_diameter - t0.inner_diameter * t0.inner_diameter) / 4);
  s.material.density = rho;
  double max_ext = 0.0, min_ext = 0.0;
  bool first = true;
  double clearance = std::numeric_limits<double>::infinity();
  for (int i = 0; i < robot.size(); ++i) {
    const Tube& t = robot.tube(i);
    if (!(t.outer_diameter > 0))
      throw std::invalid_argument("robot '" + robot.name() + "': tube '" + t.name +
                                  "' has no outer_diameter (a design space needs the tube sizes)");
    TubeSize sz{t.name + "_size", t.outer_diameter, t.inner_diameter};
    s.catalogue.push_back(sz);
    if (i > 0) clearance = std::min(clearance, robot.tube(i - 1).inner_diameter - t.outer_diameter);
    TubeSpace ts;
    ts.name = t.name;
    ts.sizes = {i};
    ts.rotation_limits = t.rotation_limits;
    ts.straight_length = {0.5 * t.straight_length, 1.5 * t.straight_length};
    if (t.curved_length > 0 && t.curvature != 0) {
      ts.curved_length = {0.5 * t.curved_length, 1.5 * t.curved_length};
      const double kmax = strain_limit / (0.5 * t.outer_diameter);
      ts.curvature = {std::min(0.25 * std::abs(t.curvature), kmax), std::min(4.0 * std::abs(t.curvature), kmax)};
    } else {
      ts.curved_length = {t.curved_length, t.curved_length};
      ts.curvature = {0.0, 0.0};
    }
    s.tubes.push_back(ts);
    const double L = t.length();
    const double lo = t.translation_limits ? (*t.translation_limits)[0] : -L;
    const double hi = t.translation_limits ? (*t.translation_limits)[1] : 0.0;
    // The extension range every tube allows: the largest reach beyond the base and the least.
    max_ext = first ? hi + L : std::max(max_ext, hi + L);
    min_ext = first ? lo + L : std::min(min_ext, lo + L);
    first = false;
  }
  if (robot.size() > 1) {
    if (clearance < 0) throw std::invalid_argument("robot '" + robot.name() + "': its tubes do not nest (diameters)");
    s.nesting_clearance = std::min(s.nesting_clearance, clearance);
  }
  s.actuation.max_extension = max_ext;
  s.actuation.min_extension = std::max(0.0, min_ext);
  return s;
}

std::string spaceToYaml(const DesignSpace& s) {
  std::ostringstream o;
  o.precision(10);
  o << "# Design space (docs/design.md). SI units: m, 1/m, Pa, kg/m^3.\n";
  o << "name: " << s.name << "\n";
  o << "strain_limit: " << s.strain_limit << "\n";
  o << "nesting_clearance: " << s.nesting_clearance << "\n";
  o << "length_step: " << s.length_step << "\n";
  o << "material: {youngs_modulus: " << s.material.youngs_modulus << ", poisson_ratio: " << s.material.poisson_ratio
    << ", density: " << s.material.density << "}\n";
  o << "actuation: {max_extension: " << s.actuation.max_extension << ", min_extension: " << s.actuation.min_extension
    << "}\n";
  o << "catalogue:\n";
  for (const TubeSize& c : s.catalogue)
    o << "  - {name: \"" << c.name << "\", outer_diameter: " << c.outer_diameter
      << ", inner_diameter: " << c.inner_diameter << "}\n";
  o << "tubes:  # outermost first\n";
  auto r = [](const Range& x) {
    std::ostringstream t;
    t.precision(10);
    if (x.fixed())
      t << x.min;
    else
      t << "[" << x.min << ", " << x.max << "]";
    return t.str();
  };
  for (const TubeSpace& t : s.tubes) {
    o << "  - name: \"" << t.name << "\"\n";
    o << "    straight_length: " << r(t.straight_length) << "\n";
    o << "    curved_length: " << r(t.curved_length) << "\n";
    o << "    curvature: " << r(t.curvature) << "\n";
    o << "    sizes: [";
    for (std::size_t k = 0; k < t.sizes.size(); ++k)
      o << (k ? ", " : "") << "\"" << s.catalogue[static_cast<std::size_t>(t.sizes[k])].name << "\"";
    o << "]\n";
    if (t.rotation_limits)
      o << "    rotation_limits: [" << (*t.rotation_limits)[0] << ", " << (*t.rotation_limits)[1] << "]\n";
  }
  return o.str();
}

}  // namespace ctr::design
