#include "ctr/io/robot_yaml.hpp"

#include <yaml-cpp/eventhandler.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <map>
#include <new>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <utility>
#include <vector>

#include "ctr/io/file.hpp"
#include "text_util.hpp"

namespace ctr::io {
namespace {

using detail::formatNumber;

const std::vector<std::string> kTopKeys = {"name", "tubes", "friction", "loads"};
const std::vector<std::string> kTubeKeys = {"name",
                                            "straight_length",
                                            "curved_length",
                                            "curvature",
                                            "bending_stiffness",
                                            "poisson_ratio",
                                            "torsional_stiffness",
                                            "youngs_modulus",
                                            "outer_diameter",
                                            "inner_diameter",
                                            "rotation_limits",
                                            "translation_limits",
                                            "linear_density",
                                            "density",
                                            "actuation"};
const std::vector<std::string> kActuationKeys = {"rotation", "translation"};
const std::vector<std::string> kRotationDriveKeys = {"offset", "play", "ratio_error", "ratio_reference", "periodic"};
const std::vector<std::string> kTranslationDriveKeys = {
    "offset", "play", "ratio_error", "ratio_reference", "stage_error", "stage_reference", "stage_scale"};
const std::vector<std::string> kFrictionKeys = {"boundary", "distributed"};
const std::vector<std::string> kLoadsKeys = {"gravity", "tip_force", "tip_moment"};
constexpr double kPi = 3.14159265358979323846;

// 1-based line of a node, 0 when unknown. Never throws (Mark() throws on invalid nodes).
int lineOf(const YAML::Node& n) {
  if (!n.IsDefined()) return 0;
  const YAML::Mark m = n.Mark();
  return m.line >= 0 ? m.line + 1 : 0;
}

// Text of a user value for messages, cut when long.
std::string quoted(const std::string& s) {
  if (s.size() <= 40) return "'" + s + "'";
  return "'" + s.substr(0, 37) + "...'";
}

std::string describe(const YAML::Node& n) {
  if (!n.IsDefined() || n.IsNull()) return "no value";
  if (n.IsSequence()) return "a list";
  if (n.IsMap()) return "a map";
  return quoted(n.Scalar());
}

// A YAML scalar for a name: plain when it cannot be misread, otherwise double-quoted with escapes.
std::string yamlString(const std::string& s) {
  bool plain = !s.empty() && (std::isalpha(static_cast<unsigned char>(s[0])) || s[0] == '_');
  for (char c : s)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' || c == '.')) plain = false;
  const std::string l = detail::lower(s);
  for (const char* reserved : {"true", "false", "yes", "no", "on", "off", "null", "y", "n"})
    if (l == reserved) plain = false;
  if (plain) return s;
  std::string out = "\"";
  for (char c : s) {
    const auto u = static_cast<unsigned char>(c);
    if (c == '"' || c == '\\') {
      out += '\\';
      out += c;
    } else if (u < 0x20 || u == 0x7f) {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\x%02x", u);
      out += buf;
    } else {
      out += c;
    }
  }
  return out + "\"";
}

// One key: value pair of a map, with the line of the key.
struct Entry {
  std::string key;
  YAML::Node value;
  int line = 0;
};

class RobotParser {
public:
  explicit RobotParser(std::string source) : src_(std::move(source)) {}
  Robot parse(const std::string& text);

private:
  [[noreturn]] void fail(int line, const std::string& key, const std::string& message) const {
    throw InputError(src_, line, key, message);
  }
  std::vector<Entry> entries(const YAML::Node& map, const std::vector<std::string>& known,
                             const std::string& where) const;
  double number(const YAML::Node& v, int line, const std::string& key, const std::string& where) const;
  std::array<double, 2> range(const Entry& e, const std::string& where) const;
  Tube tube(const YAML::Node& node, int k);
  void actuation(const Entry& e, const std::string& where, Tube& t, std::map<std::string, int>& lines) const;
  FrictionCoefficients friction(const Entry& e);
  Loads loads(const Entry& e);
  Eigen::Vector3d vector3(const Entry& e, const std::string& where) const;
  InputError fromModel(const std::string& what) const;
  std::string defaultName() const;

  std::string src_;
  // Where keys are, to point errors from the Robot constructor back into the file.
  std::vector<std::map<std::string, int>> tube_lines_;
  std::vector<int> tube_item_lines_;
  std::vector<std::string> tube_names_;
  std::map<std::string, int> friction_lines_;
  std::map<std::string, int> loads_lines_;
  int tubes_line_ = 0;
};

// Pairs of a map in file order; rejects non-scalar keys, duplicates and unknown keys (with a suggestion).
std::vector<Entry> RobotParser::entries(const YAML::Node& map, const std::vector<std::string>& known,
                                        const std::string& where) const {
  std::vector<Entry> out;
  std::map<std::string, int> seen;
  for (auto it = map.begin(); it != map.end(); ++it) {
    const YAML::Node key = it->first;
    const int line = lineOf(key);
    if (!key.IsScalar()) fail(line, "", where + "keys must be plain names, got " + describe(key) + " as a key");
    const std::string name = key.Scalar();
    if (auto s = seen.find(name); s != seen.end())
      fail(line, name, where + "duplicate key (first given on line " + std::to_string(s->second) + ")");
    seen[name] = line;
    bool ok = false;
    for (const std::string& k : known) ok = ok || k == name;
    if (!ok) fail(line, name, where + "unknown key; " + detail::suggestion(name, known));
    out.push_back(Entry{name, it->second, line});
  }
  return out;
}

double RobotParser::number(const YAML::Node& v, int line, const std::string& key, const std::string& where) const {
  if (!v.IsDefined() || v.IsNull()) fail(line, key, where + "has no value; expected a number");
  if (!v.IsScalar()) fail(line, key, where + "expected a number, got " + describe(v));
  double x = 0.0;
  switch (detail::parseDouble(v.Scalar(), x)) {
    case detail::NumberStatus::kOk:
      return x;
    case detail::NumberStatus::kNotFinite:
      fail(line, key, where + "must be a finite number, got " + quoted(v.Scalar()));
    default:
      fail(line, key, where + "expected a number, got " + quoted(v.Scalar()));
  }
}

std::array<double, 2> RobotParser::range(const Entry& e, const std::string& where) const {
  if (!e.value.IsSequence() || e.value.size() != 2)
    fail(e.line, e.key, where + "expected a list [min, max] of two numbers, got " +
                            (e.value.IsSequence() ? "a list of " + std::to_string(e.value.size()) + " items"
                                                  : describe(e.value)));
  std::array<double, 2> r{};
  for (std::size_t i = 0; i < 2; ++i) {
    const YAML::Node item = e.value[i];
    const int line = lineOf(item) > 0 ? lineOf(item) : e.line;
    r[i] = number(item, line, e.key, where + (i == 0 ? "min: " : "max: "));
  }
  if (r[0] > r[1])
    fail(e.line, e.key, where + "min " + formatNumber(r[0]) + " is greater than max " + formatNumber(r[1]));
  return r;
}

Tube RobotParser::tube(const YAML::Node& node, int k) {
  const int item_line = lineOf(node);
  const std::string ks = std::to_string(k);
  if (!node.IsMap())
    fail(item_line, "tubes",
         "tube " + ks + ": expected a map of tube keys (straight_length, curved_length, curvature, ...), got " +
             describe(node));
  Tube t;
  t.name = "tube" + ks;
  // The name first, so that every later message names the tube.
  for (auto it = node.begin(); it != node.end(); ++it) {
    if (!it->first.IsScalar() || it->first.Scalar() != "name") continue;
    if (!it->second.IsScalar())
      fail(lineOf(it->first), "name", "tube " + ks + ": expected a text, got " + describe(it->second));
    const std::string_view n = detail::trim(it->second.Scalar());
    if (!n.empty()) t.name = std::string(n);
    break;
  }
  const std::string where = "tube '" + t.name + "' (" + ks + "): ";
  const std::vector<Entry> es = entries(node, kTubeKeys, where);

  std::map<std::string, double> v;
  std::map<std::string, int> lines;
  for (const Entry& e : es) {
    lines[e.key] = e.line;
    if (e.key == "rotation_limits") {
      t.rotation_limits = range(e, where);
    } else if (e.key == "translation_limits") {
      t.translation_limits = range(e, where);
      if ((*t.translation_limits)[1] > 0.0)
        fail(e.line, e.key, where + "max " + formatNumber((*t.translation_limits)[1]) +
                                " m > 0; translations beta are <= 0 (tubes leave the actuation unit at s = 0)");
    } else if (e.key == "actuation") {
      actuation(e, where, t, lines);
    } else if (e.key != "name") {
      v[e.key] = number(e.value, e.line, e.key, where);
    }
  }
  tube_lines_.push_back(lines);
  tube_item_lines_.push_back(item_line);
  tube_names_.push_back(t.name);

  auto has = [&](const std::string& key) { return v.count(key) > 0; };
  auto require = [&](const std::string& key, const std::string& what) {
    if (!has(key)) fail(item_line, key, where + "missing required key (" + what + ")");
    return v[key];
  };
  auto lineAt = [&](const std::string& key) { return lines.count(key) ? lines[key] : item_line; };
  auto atLeast = [&](const std::string& key, double lo, bool strict, const std::string& unit) {
    if (!has(key)) return;
    const double x = v[key];
    if (strict ? x <= lo : x < lo)
      fail(lineAt(key), key, where + "must be " + (strict ? "> " : ">= ") + formatNumber(lo) + unit + ", got " +
                                 formatNumber(x));
  };

  // Lengths and diameters are in metres (docs/formats.md): values a robot cannot have are almost always mm or um.
  auto plausible = [&](const std::string& key, double hi) {
    if (!has(key)) return;
    const double x = v[key];
    if (x > hi)
      fail(lineAt(key), key, where + formatNumber(x) + " m is implausible (> " + formatNumber(hi) +
                                 " m); lengths and diameters are in metres: was it given in mm?");
  };
  t.straight_length = require("straight_length", "proximal straight length in m; may be 0");
  atLeast("straight_length", 0.0, false, " m");
  plausible("straight_length", 5.0);
  t.curved_length = require("curved_length", "distal precurved length in m");
  atLeast("curved_length", 0.0, false, " m");
  plausible("curved_length", 5.0);
  plausible("outer_diameter", 0.05);
  plausible("inner_diameter", 0.05);
  if (t.length() <= 0.0)
    fail(lineAt("curved_length"), "curved_length", where + "straight_length + curved_length must be > 0 m");
  t.curvature = require("curvature", "precurvature of the curved part in 1/m; 0 for a straight tube");

  atLeast("outer_diameter", 0.0, false, " m");
  atLeast("inner_diameter", 0.0, false, " m");
  if (has("outer_diameter")) t.outer_diameter = v["outer_diameter"];
  if (has("inner_diameter")) t.inner_diameter = v["inner_diameter"];
  if (t.outer_diameter > 0.0 && t.inner_diameter >= t.outer_diameter)
    fail(lineAt("inner_diameter"), "inner_diameter",
         where + "inner_diameter " + formatNumber(t.inner_diameter) + " m must be smaller than outer_diameter " +
             formatNumber(t.outer_diameter) + " m");

  // Bending stiffness E*I: given directly, or from Young's modulus and the cross-section.
  atLeast("bending_stiffness", 0.0, true, " N m^2");
  atLeast("youngs_modulus", 0.0, true, " Pa");
  if (has("bending_stiffness")) {
    t.bending_stiffness = v["bending_stiffness"];
  } else if (has("youngs_modulus")) {
    for (const char* d : {"outer_diameter", "inner_diameter"})
      if (!has(d))
        fail(lineAt("youngs_modulus"), d,
             where + "youngs_modulus needs both outer_diameter and inner_diameter to give E*I = E*pi*(od^4 - "
                     "id^4)/64 (inner_diameter 0 for a solid wire); or give bending_stiffness (N m^2)");
    if (t.outer_diameter <= 0.0)
      fail(lineAt("outer_diameter"), "outer_diameter", where + "must be > 0 m to compute E*I from youngs_modulus");
    const double od = t.outer_diameter, id = t.inner_diameter;
    t.bending_stiffness = v["youngs_modulus"] * kPi * (od * od * od * od - id * id * id * id) / 64.0;
  } else {
    fail(item_line, "bending_stiffness",
         where + "missing required key: give bending_stiffness (E*I, N m^2) or youngs_modulus (Pa) with "
                 "outer_diameter and inner_diameter");
  }

  // Mass per unit length (gravity): given directly (overrides), or density * pi (od^2 - id^2) / 4.
  atLeast("linear_density", 0.0, false, " kg/m");
  atLeast("density", 0.0, false, " kg/m^3");
  if (has("linear_density")) {
    t.linear_density = v["linear_density"];
  } else if (has("density")) {
    if (t.outer_diameter <= 0.0)
      fail(lineAt("density"), "density",
           where + "density needs outer_diameter (and inner_diameter, 0 for a solid wire) to give the linear "
                   "density rho*pi*(od^2 - id^2)/4; or give linear_density (kg/m)");
    const double od = t.outer_diameter, id = t.inner_diameter;
    t.linear_density = v["density"] * kPi * (od * od - id * id) / 4.0;
  }

  // Torsional stiffness G*J: given directly (overrides), or E*I / (1 + poisson_ratio).
  if (has("poisson_ratio")) {
    const double nu = v["poisson_ratio"];
    if (nu <= -1.0) fail(lineAt("poisson_ratio"), "poisson_ratio", where + "must be > -1, got " + formatNumber(nu));
    t.poisson_ratio = nu;
  }
  atLeast("torsional_stiffness", 0.0, true, " N m^2");
  if (has("torsional_stiffness")) {
    t.torsional_stiffness = v["torsional_stiffness"];
  } else if (t.poisson_ratio) {
    t.torsional_stiffness = t.bending_stiffness / (1.0 + *t.poisson_ratio);
  } else {
    fail(item_line, "poisson_ratio",
         where + "missing torsion: give poisson_ratio (G*J = E*I / (1 + poisson_ratio)) or torsional_stiffness "
                 "(G*J, N m^2)");
  }
  return t;
}

// `actuation:` of a tube: the drives between its commands and the tube (ctr::Drive). Values are checked again by the
// Robot (validateTube), whose messages name the keys recorded in `lines` ("actuation.rotation.play").
void RobotParser::actuation(const Entry& e, const std::string& where, Tube& t,
                            std::map<std::string, int>& lines) const {
  if (!e.value.IsMap())
    fail(e.line, e.key, where + "expected a map with keys rotation, translation, got " + describe(e.value));
  for (const Entry& axis : entries(e.value, kActuationKeys, where + "actuation: ")) {
    const bool rotation = axis.key == "rotation";
    const std::string at = where + "actuation: " + axis.key + ": ";
    if (!axis.value.IsMap())
      fail(axis.line, axis.key, at + "expected a map of drive keys (offset, play, ...), got " + describe(axis.value));
    Drive& d = rotation ? t.rotation_drive : t.translation_drive;
    for (const Entry& k : entries(axis.value, rotation ? kRotationDriveKeys : kTranslationDriveKeys, at)) {
      const std::string key = "actuation." + axis.key + "." + k.key;
      lines[key] = k.line;
      if (k.key == "periodic" || k.key == "stage_error") {
        const std::size_t size = k.key == "periodic" ? 4 : 3;
        if (!k.value.IsSequence() || k.value.size() != size)
          fail(k.line, key,
               at + k.key + ": expected a list of " + std::to_string(size) + " numbers (" +
                   (size == 4 ? "cos x, sin x, cos 2x, sin 2x coefficients, rad" : "u, u^2, u^3 coefficients, m") +
                   "), got " +
                   (k.value.IsSequence() ? "a list of " + std::to_string(k.value.size()) + " items"
                                         : describe(k.value)));
        for (std::size_t j = 0; j < size; ++j) {
          const YAML::Node item = k.value[j];
          const double x = number(item, lineOf(item) > 0 ? lineOf(item) : k.line, key, at);
          (size == 4 ? d.periodic[j] : d.stage[j]) = x;
        }
        continue;
      }
      const double x = number(k.value, k.line, key, at);
      if (k.key == "offset") d.offset = x;
      if (k.key == "play") d.play = x;
      if (k.key == "ratio_error") d.ratio_error = x;
      if (k.key == "ratio_reference") d.ratio_reference = x;
      if (k.key == "stage_reference") d.stage_reference = x;
      if (k.key == "stage_scale") d.stage_scale = x;
    }
  }
}

FrictionCoefficients RobotParser::friction(const Entry& e) {
  FrictionCoefficients f;
  if (!e.value.IsDefined() || e.value.IsNull()) return f;  // "friction:" alone: frictionless
  if (!e.value.IsMap())
    fail(e.line, "friction", "expected a map with keys boundary, distributed, got " + describe(e.value));
  for (const Entry& c : entries(e.value, kFrictionKeys, "friction: ")) {
    friction_lines_[c.key] = c.line;
    const double x = number(c.value, c.line, c.key, "friction: ");
    if (x < 0.0) fail(c.line, c.key, "friction: coefficient must be >= 0, got " + formatNumber(x));
    (c.key == "boundary" ? f.boundary : f.distributed) = x;
  }
  return f;
}

Eigen::Vector3d RobotParser::vector3(const Entry& e, const std::string& where) const {
  if (!e.value.IsSequence() || e.value.size() != 3)
    fail(e.line, e.key, where + "expected a list [x, y, z] of three numbers (base frame), got " +
                            (e.value.IsSequence() ? "a list of " + std::to_string(e.value.size()) + " items"
                                                  : describe(e.value)));
  Eigen::Vector3d r;
  for (std::size_t i = 0; i < 3; ++i) {
    const YAML::Node item = e.value[i];
    const int line = lineOf(item) > 0 ? lineOf(item) : e.line;
    r[static_cast<int>(i)] = number(item, line, e.key, where);
  }
  return r;
}

Loads RobotParser::loads(const Entry& e) {
  Loads l;
  if (!e.value.IsDefined() || e.value.IsNull()) return l;  // "loads:" alone: no external load
  if (!e.value.IsMap())
    fail(e.line, "loads", "expected a map with keys gravity, tip_force, tip_moment, got " + describe(e.value));
  for (const Entry& c : entries(e.value, kLoadsKeys, "loads: ")) {
    loads_lines_[c.key] = c.line;
    const std::string unit = c.key == "gravity" ? "m/s^2" : (c.key == "tip_force" ? "N" : "N m");
    const Eigen::Vector3d v = vector3(c, "loads: " + c.key + " (" + unit + "): ");
    (c.key == "gravity" ? l.gravity : (c.key == "tip_force" ? l.tip_force : l.tip_moment)) = v;
  }
  return l;
}

// Robot's std::invalid_argument ("tube 'x' (k): key 'y': what") as an InputError at the key's line.
InputError RobotParser::fromModel(const std::string& what) const {
  auto split = [&](const std::string& prefix, std::string& key, std::string& rest) {
    if (what.compare(0, prefix.size(), prefix) != 0) return false;
    const std::size_t end = what.find("': ", prefix.size());
    if (end == std::string::npos) return false;
    key = what.substr(prefix.size(), end - prefix.size());
    rest = what.substr(end + 3);
    return true;
  };
  std::string key, rest;
  for (std::size_t i = 0; i < tube_names_.size(); ++i) {
    const std::string tube = "tube '" + tube_names_[i] + "' (" + std::to_string(i + 1) + ")";
    if (split(tube + ": key '", key, rest)) {
      const auto& lines = tube_lines_[i];
      const int line = lines.count(key) ? lines.at(key) : tube_item_lines_[i];
      return InputError(src_, line, key, tube + ": " + rest);
    }
  }
  if (split("friction: key '", key, rest))
    return InputError(src_, friction_lines_.count(key) ? friction_lines_.at(key) : 0, key, "friction: " + rest);
  if (split("loads: key '", key, rest))
    return InputError(src_, loads_lines_.count(key) ? loads_lines_.at(key) : 0, key, "loads: " + rest);
  if (split("key '", key, rest)) return InputError(src_, key == "tubes" ? tubes_line_ : 0, key, rest);
  return InputError(src_, 0, "", what);
}

std::string RobotParser::defaultName() const {
  std::string stem = std::filesystem::path(src_).stem().string();
  return stem.empty() ? std::string("robot") : stem;
}

// Events of one document: whether it holds anything, and where that starts.
class DocumentProbe : public YAML::EventHandler {
public:
  bool content = false;
  int line = 0;
  void OnDocumentStart(const YAML::Mark&) override {}
  void OnDocumentEnd() override {}
  void OnNull(const YAML::Mark&, YAML::anchor_t) override {}
  void OnAlias(const YAML::Mark& m, YAML::anchor_t) override { seen(m); }
  void OnScalar(const YAML::Mark& m, const std::string&, YAML::anchor_t, const std::string&) override { seen(m); }
  void OnSequenceStart(const YAML::Mark& m, const std::string&, YAML::anchor_t, YAML::EmitterStyle::value) override {
    seen(m);
  }
  void OnSequenceEnd() override {}
  void OnMapStart(const YAML::Mark& m, const std::string&, YAML::anchor_t, YAML::EmitterStyle::value) override {
    seen(m);
  }
  void OnMapEnd() override {}

private:
  void seen(const YAML::Mark& m) {
    if (!content) line = m.line >= 0 ? m.line + 1 : 0;
    content = true;
  }
};

// Line of a second document with content, 0 if none. Reads at most two documents: yaml-cpp 0.7's LoadAll
// can loop forever on some malformed input (a stray ',' at the start), so it is not used.
int secondDocumentLine(const std::string& text) {
  std::istringstream in(text);
  YAML::Parser parser(in);
  DocumentProbe first, second;
  if (!parser.HandleNextDocument(first)) return 0;
  if (!parser.HandleNextDocument(second)) return 0;
  return second.content ? std::max(second.line, 1) : 0;
}

// 1-based line of the first line that is neither blank nor a comment, 0 if none.
int firstContentLine(const std::string& text) {
  std::istringstream in(text);
  std::string line;
  for (int n = 1; std::getline(in, line); ++n) {
    const std::string_view t = detail::trim(line);
    if (!t.empty() && t.front() != '#') return n;
  }
  return 0;
}

Robot RobotParser::parse(const std::string& text) {
  const std::string empty_help = "expected a robot description: a map with a 'tubes' list (docs/formats.md)";
  const int content_line = firstContentLine(text);
  if (content_line == 0) fail(0, "", "empty file; " + empty_help);
  const YAML::Node root = YAML::Load(text);
  if (!root.IsDefined() || root.IsNull())
    fail(content_line, "", "no robot description found (empty document or not valid YAML); " + empty_help);
  if (const int second = secondDocumentLine(text))
    fail(second, "", "more than one YAML document ('---'): a robot file holds one robot");
  if (!root.IsMap())
    fail(lineOf(root), "", "the top level must be a map with keys name, tubes, friction, loads; got " + describe(root));

  std::string name = defaultName();
  std::optional<Entry> tubes_entry;
  FrictionCoefficients fr;
  Loads ld;
  for (const Entry& e : entries(root, kTopKeys, "")) {
    if (e.key == "name") {
      if (!e.value.IsScalar()) fail(e.line, "name", "expected a text, got " + describe(e.value));
      const std::string_view n = detail::trim(e.value.Scalar());
      if (!n.empty()) name = std::string(n);
    } else if (e.key == "tubes") {
      tubes_entry = e;
    } else if (e.key == "loads") {
      ld = loads(e);
    } else {
      fr = friction(e);
    }
  }
  if (!tubes_entry) fail(lineOf(root), "tubes", "missing required key: the list of tubes, outermost first");
  tubes_line_ = tubes_entry->line;
  const YAML::Node& list = tubes_entry->value;
  if (!list.IsSequence())
    fail(tubes_line_, "tubes", "expected a list of tubes (outermost first), got " + describe(list));
  if (list.size() == 0) fail(tubes_line_, "tubes", "the list is empty; a robot needs at least one tube");

  std::vector<Tube> tubes;
  for (std::size_t i = 0; i < list.size(); ++i) tubes.push_back(tube(list[i], static_cast<int>(i) + 1));
  try {
    return Robot(name, std::move(tubes), fr, ld);
  } catch (const std::invalid_argument& e) {
    throw fromModel(e.what());
  }
}

}  // namespace

Robot parseRobot(const std::string& text, const std::string& source) {
  // Only InputError leaves: parser, conversion and allocation failures are converted with what is known.
  try {
    return RobotParser(source).parse(text);
  } catch (const InputError&) {
    throw;
  } catch (const YAML::ParserException& e) {
    throw InputError(source, e.mark.line >= 0 ? e.mark.line + 1 : 0, "", "not valid YAML: " + e.msg);
  } catch (const YAML::Exception& e) {
    throw InputError(source, e.mark.line >= 0 ? e.mark.line + 1 : 0, "", "YAML error: " + e.msg);
  } catch (const std::bad_alloc&) {
    throw InputError(source, 0, "", "out of memory while reading the robot description");
  } catch (const std::exception& e) {
    throw InputError(source, 0, "", e.what());
  }
}

Robot loadRobot(const std::string& path) { return parseRobot(readFile(path), path); }

std::string robotToYaml(const Robot& robot) {
  std::ostringstream os;
  os << "# Concentric tube robot (docs/formats.md). SI units: m, 1/m, N m^2, rad.\n";
  os << "name: " << yamlString(robot.name()) << "\n";
  os << "tubes:  # outermost first\n";
  for (const Tube& t : robot.tubes()) {
    os << "  - name: " << yamlString(t.name) << "\n";
    os << "    straight_length: " << formatNumber(t.straight_length) << "\n";
    os << "    curved_length: " << formatNumber(t.curved_length) << "\n";
    os << "    curvature: " << formatNumber(t.curvature) << "\n";
    os << "    bending_stiffness: " << formatNumber(t.bending_stiffness) << "\n";
    // poisson_ratio alone when it reproduces G*J exactly; torsional_stiffness overrides otherwise.
    if (t.poisson_ratio) os << "    poisson_ratio: " << formatNumber(*t.poisson_ratio) << "\n";
    if (!t.poisson_ratio || t.bending_stiffness / (1.0 + *t.poisson_ratio) != t.torsional_stiffness)
      os << "    torsional_stiffness: " << formatNumber(t.torsional_stiffness) << "\n";
    if (t.outer_diameter > 0.0) os << "    outer_diameter: " << formatNumber(t.outer_diameter) << "\n";
    if (t.inner_diameter > 0.0) os << "    inner_diameter: " << formatNumber(t.inner_diameter) << "\n";
    if (t.linear_density > 0.0) os << "    linear_density: " << formatNumber(t.linear_density) << "\n";
    if (t.rotation_limits)
      os << "    rotation_limits: [" << formatNumber((*t.rotation_limits)[0]) << ", "
         << formatNumber((*t.rotation_limits)[1]) << "]\n";
    if (t.translation_limits)
      os << "    translation_limits: [" << formatNumber((*t.translation_limits)[0]) << ", "
         << formatNumber((*t.translation_limits)[1]) << "]\n";
    if (!t.rotation_drive.ideal() || !t.translation_drive.ideal()) {
      os << "    actuation:  # drives between the commands and the tube: play, transmission errors, offset\n";
      for (const bool rotation : {true, false}) {
        const Drive& d = rotation ? t.rotation_drive : t.translation_drive;
        if (d.ideal()) continue;
        os << "      " << (rotation ? "rotation:" : "translation:") << (rotation ? "  # rad" : "  # m") << "\n";
        if (d.offset != 0.0) os << "        offset: " << formatNumber(d.offset) << "\n";
        if (d.play != 0.0) os << "        play: " << formatNumber(d.play) << "\n";
        if (d.ratio_error != 0.0)
          os << "        ratio_error: " << formatNumber(d.ratio_error) << "\n"
             << "        ratio_reference: " << formatNumber(d.ratio_reference) << "\n";
        if (d.periodic != std::array<double, 4>{})
          os << "        periodic: [" << formatNumber(d.periodic[0]) << ", " << formatNumber(d.periodic[1]) << ", "
             << formatNumber(d.periodic[2]) << ", " << formatNumber(d.periodic[3]) << "]\n";
        if (d.stage != std::array<double, 3>{})
          os << "        stage_error: [" << formatNumber(d.stage[0]) << ", " << formatNumber(d.stage[1]) << ", "
             << formatNumber(d.stage[2]) << "]\n"
             << "        stage_reference: " << formatNumber(d.stage_reference) << "\n"
             << "        stage_scale: " << formatNumber(d.stage_scale) << "\n";
      }
    }
  }
  const FrictionCoefficients& f = robot.friction();
  if (f.boundary != 0.0 || f.distributed != 0.0) {
    os << "friction:\n";
    os << "  boundary: " << formatNumber(f.boundary) << "\n";
    os << "  distributed: " << formatNumber(f.distributed) << "\n";
  }
  const Loads& l = robot.loads();
  if (!l.empty()) {
    auto vec = [&](const Eigen::Vector3d& v) {
      return "[" + formatNumber(v.x()) + ", " + formatNumber(v.y()) + ", " + formatNumber(v.z()) + "]";
    };
    os << "loads:  # base frame\n";
    os << "  gravity: " << vec(l.gravity) << "\n";
    os << "  tip_force: " << vec(l.tip_force) << "\n";
    os << "  tip_moment: " << vec(l.tip_moment) << "\n";
  }
  return os.str();
}

void saveRobot(const Robot& robot, const std::string& path) { writeFileAtomic(path, robotToYaml(robot)); }

}  // namespace ctr::io
