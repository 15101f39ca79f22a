// Effects: names, parameters, and their action on the robot description.
#include "ctr/diagnosis/effect.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <sstream>
#include <stdexcept>

namespace ctr::diagnosis {

namespace {

/// The facts of one kind: JSON name, parameter name and unit, per tube, stateful, look-alike group.
struct KindFacts {
  EffectKind kind;
  const char* name;
  const char* parameter;
  const char* unit;
  bool per_tube;
  bool stateful;
  int group;        // 1 = lag, 2 = shift, 3 = load, 0 = none (lookAlikeGroup)
  int coordinates;  // fitted coordinates (parameterCount)
  bool generic = false;
};

// One row per kind, in the order of the effect table of docs/formats.md.
constexpr KindFacts kFacts[] = {
    {EffectKind::BoundaryFriction, "boundary_friction", "mu", "", false, true, 1, 1},
    {EffectKind::DistributedFriction, "distributed_friction", "mu", "", false, true, 1, 1},
    {EffectKind::TorsionalStiffness, "torsional_stiffness", "poisson_ratio", "", false, false, 2, 1},
    {EffectKind::Precurvature, "precurvature", "curvature", "1/m", true, false, 0, 1},
    {EffectKind::BendingStiffness, "bending_stiffness", "bending_stiffness", "N m^2", true, false, 0, 1},
    {EffectKind::ActuatorBacklash, "actuator_backlash", "width", "rad", true, true, 1, 1},
    {EffectKind::ActuatorOffset, "actuator_offset", "offset", "rad", true, false, 2, 1},
    {EffectKind::TranslationBacklash, "translation_backlash", "width", "m", true, true, 1, 1},
    {EffectKind::TranslationOffset, "translation_offset", "offset", "m", true, false, 2, 1},
    {EffectKind::Gravity, "gravity", "scale", "", false, false, 3, 3},
    {EffectKind::TipLoad, "tip_load", "force", "N", false, false, 3, 3},
    {EffectKind::SensorLatency, "sensor_latency", "delay", "s", false, false, 1, 1},
    {EffectKind::DriveRatio, "drive_ratio", "coefficients", "", true, false, 0, 1, true},
    {EffectKind::DrivePeriodic, "drive_periodic", "coefficients", "rad", true, false, 0, 4, true},
    {EffectKind::StageError, "stage_error", "coefficients", "m", true, false, 0, 3, true},
    {EffectKind::TrackerDrift, "tracker_drift", "coefficients", "m", false, false, 0, 3, true},
};
static_assert(sizeof(kFacts) / sizeof(kFacts[0]) == static_cast<std::size_t>(EffectKind::TrackerDrift) + 1,
              "one row of facts per EffectKind");

const KindFacts& facts(EffectKind k) {
  for (const KindFacts& f : kFacts)
    if (f.kind == k) return f;
  throw std::logic_error("EffectKind without facts");
}

}  // namespace

const std::vector<EffectKind>& allEffectKinds() {
  static const std::vector<EffectKind> k = [] {
    std::vector<EffectKind> v;
    for (const KindFacts& f : kFacts)
      if (!f.generic) v.push_back(f.kind);
    return v;
  }();
  return k;
}

const std::vector<EffectKind>& genericEffectKinds() {
  static const std::vector<EffectKind> k = [] {
    std::vector<EffectKind> v;
    for (const KindFacts& f : kFacts)
      if (f.generic) v.push_back(f.kind);
    return v;
  }();
  return k;
}

bool isGeneric(EffectKind k) {
  return facts(k).generic;
}

const char* toString(EffectKind k) {
  return facts(k).name;
}
const char* parameterName(EffectKind k) {
  return facts(k).parameter;
}
const char* parameterUnit(EffectKind k) {
  return facts(k).unit;
}
bool isPerTube(EffectKind k) {
  return facts(k).per_tube;
}
bool isStateful(EffectKind k) {
  return facts(k).stateful;
}
int parameterCount(EffectKind k) {
  return facts(k).coordinates;
}
int lookAlikeGroup(EffectKind k) {
  return facts(k).group;
}
bool areLookAlikes(EffectKind a, EffectKind b) {
  const int ga = lookAlikeGroup(a), gb = lookAlikeGroup(b);
  if (ga != 0 && ga == gb) return true;
  // A load bends the robot as a different precurvature or stiffness would.
  auto shape = [](EffectKind k) { return k == EffectKind::Precurvature || k == EffectKind::BendingStiffness; };
  return (ga == 3 && shape(b)) || (gb == 3 && shape(a));
}
bool isLookAlike(EffectKind k) {
  for (const KindFacts& f : kFacts)
    if (areLookAlikes(k, f.kind)) return true;
  return false;
}

std::string describePhysics(EffectKind k) {
  switch (k) {
    case EffectKind::BoundaryFriction:
      return "Coulomb friction torque mu'|m| at the concentrated bending moments (tube ends, curvature "
             "discontinuities) with stick-slip memory (Lock & Dupont 2011, sec. II.D): the twist lags the "
             "commanded rotation in the direction of motion, most where the moments are largest";
    case EffectKind::DistributedFriction:
      return "Coulomb friction of the distributed inter-tube contact forces (sec. II.B)";
    case EffectKind::TorsionalStiffness:
      return "a different ratio of bending to torsional stiffness (Poisson ratio), which changes how much the "
             "tubes wind up between base and tip (the paper itself moved nu from 0.3 to 0.6)";
    case EffectKind::Precurvature:
      return "a tube's precurvature differing from its description";
    case EffectKind::BendingStiffness:
      return "a tube's bending stiffness (stiffness ratio) differing from its description";
    case EffectKind::ActuatorBacklash:
      return "a dead band in a rotation drive: after each reversal the tube does not turn until the play is taken up, "
             "giving a constant-width direction-dependent offset";
    case EffectKind::ActuatorOffset:
      return "a constant offset between commanded and true rotation of a tube";
    case EffectKind::SensorLatency:
      return "the measurement lagging the joint reading: a direction-dependent error whose size grows with the "
             "actuator speed rather than with the bending moment";
    case EffectKind::TranslationBacklash:
      return "play in a linear stage: after each reversal of the translation the tube does not move until the play "
             "is taken up";
    case EffectKind::TranslationOffset:
      return "a zero error of a linear stage: the tube is translated by a constant amount more or less than commanded";
    case EffectKind::Gravity:
      return "the robot's own weight (a distributed dead load on every tube outside the actuation unit, in a fixed "
             "direction of the base frame), which bends it more where it is long and where its tubes are flexible";
    case EffectKind::TipLoad:
      return "a constant external force at the tip (a dead load in the base frame), which bends the robot like a "
             "weight hung on its tip";
    case EffectKind::DriveRatio:
      return "a ratio error of a rotation drive (the tube turns a constant factor more or less than commanded, e.g. "
             "a wrong gear ratio): not physics of the library, a description of the remainder";
    case EffectKind::DrivePeriodic:
      return "a periodic transmission error of a rotation drive, one or two cycles per turn of the drive (an "
             "eccentric gear or coupling): not physics of the library, a description of the remainder";
    case EffectKind::StageError:
      return "a smooth error of a translation stage along its travel (a lead-screw pitch error, a bent rail): not "
             "physics of the library, a description of the remainder";
    case EffectKind::TrackerDrift:
      return "the tracker's measurements drifting with time: not physics of the robot, a description of the remainder";
  }
  return "";
}

EffectKind parseEffectKind(const std::string& name) {
  for (EffectKind k : allEffectKinds())
    if (name == toString(k)) return k;
  std::string all;
  for (EffectKind k : allEffectKinds()) all += std::string(all.empty() ? "" : ", ") + toString(k);
  throw std::invalid_argument("unknown effect '" + name + "' (known: " + all + ")");
}

std::string Effect::label() const {
  std::string s = toString(kind);
  if (isPerTube(kind)) s += "[tube " + std::to_string(tube) + "]";
  return s;
}

double Effect::coordinate(int i) const {
  if (isGeneric(kind)) return coef[i];
  return parameterCount(kind) == 1 ? value : vec[i];
}

void Effect::setCoordinate(int i, double v) {
  if (isGeneric(kind))
    coef[i] = v;
  else if (parameterCount(kind) == 1)
    value = v;
  else
    vec[i] = v;
}

double Effect::genericAt(double x, int axis) const {
  switch (kind) {
    case EffectKind::DriveRatio:
      return coef[0] * (x - ref[0]);
    case EffectKind::DrivePeriodic:
      return coef[0] * std::cos(x) + coef[1] * std::sin(x) + coef[2] * std::cos(2 * x) + coef[3] * std::sin(2 * x);
    case EffectKind::StageError: {
      const double u = (x - ref[0]) / ref[1];
      return u * (coef[0] + u * (coef[1] + u * coef[2]));
    }
    case EffectKind::TrackerDrift: {
      const double t = (x - ref[0]) / ref[1];
      return coef[axis] * t;
    }
    default:
      return 0.0;
  }
}

Eigen::Vector3d Effect::gravityDirection() const {
  const double s = vec.norm();
  return s > 0 ? Eigen::Vector3d(vec / s) : Eigen::Vector3d(0, 0, -1);
}

namespace {
std::string g4(double v) {
  char b[64];
  std::snprintf(b, sizeof b, "%.4g", std::abs(v) < 5e-13 ? 0.0 : v);
  return b;
}
std::string vec3(const Eigen::Vector3d& v) {
  return "(" + g4(v.x()) + ", " + g4(v.y()) + ", " + g4(v.z()) + ")";
}
}  // namespace

std::string Effect::valueText() const {
  switch (kind) {
    case EffectKind::Gravity:
      return "scale = " + g4(gravityScale()) + ", direction = " + vec3(gravityDirection());
    case EffectKind::TipLoad:
      return "force = " + vec3(vec) + " N";
    case EffectKind::DriveRatio:
      return "ratio error " + g4(coef[0]);
    case EffectKind::DrivePeriodic:
      return "1st harmonic " + g4(std::hypot(coef[0], coef[1]) * 180 / M_PI) + " deg, 2nd harmonic " +
             g4(std::hypot(coef[2], coef[3]) * 180 / M_PI) + " deg";
    case EffectKind::StageError:
      return "u, u^2, u^3 terms " + g4(coef[0] * 1e3) + ", " + g4(coef[1] * 1e3) + ", " + g4(coef[2] * 1e3) + " mm";
    case EffectKind::TrackerDrift:
      return "drift " + vec3(coef.head<3>() * 1e3) + " mm over the recording";
    default:
      return std::string(parameterName(kind)) + " = " + g4(value);
  }
}

std::vector<NamedParameter> namedParameters(const Effect& e, const EffectUncertainty* u) {
  std::vector<NamedParameter> out;
  if (isPerTube(e.kind)) out.push_back({"tube", {static_cast<double>(e.tube)}, {}});
  const bool have = u && !u->empty();
  switch (e.kind) {
    case EffectKind::TipLoad: {
      NamedParameter f{"force", {e.vec.x(), e.vec.y(), e.vec.z()}, {}};
      if (have && u->interval95.size() == 3) f.interval95 = u->interval95;
      out.push_back(f);
      break;
    }
    case EffectKind::Gravity: {
      // scale = |w|, direction = w / |w| for w = scale * direction; intervals by the delta method.
      const double s = e.gravityScale();
      const Eigen::Vector3d d = e.gravityDirection();
      NamedParameter sc{"scale", {s}, {}}, dir{"direction", {d.x(), d.y(), d.z()}, {}};
      if (have && u->covariance.rows() == 3 && u->covariance.cols() == 3 && s > 0) {
        const Eigen::Matrix3d C = u->covariance;
        const double sd_s = std::sqrt(std::max(0.0, d.dot(C * d)));
        sc.interval95.push_back({std::max(0.0, s - 1.96 * sd_s), s + 1.96 * sd_s});
        const Eigen::Matrix3d J = (Eigen::Matrix3d::Identity() - d * d.transpose()) / s;
        const Eigen::Matrix3d Cd = J * C * J.transpose();
        for (int i = 0; i < 3; ++i) {
          const double h = 1.96 * std::sqrt(std::max(0.0, Cd(i, i)));
          dir.interval95.push_back({std::max(-1.0, d[i] - h), std::min(1.0, d[i] + h)});
        }
      }
      out.push_back(sc);
      out.push_back(dir);
      break;
    }
    case EffectKind::DriveRatio:
    case EffectKind::DrivePeriodic:
    case EffectKind::StageError:
    case EffectKind::TrackerDrift: {
      NamedParameter p{"coefficients", {}, {}};
      for (int i = 0; i < parameterCount(e.kind); ++i) p.value.push_back(e.coef[i]);
      if (have && static_cast<int>(u->interval95.size()) == parameterCount(e.kind)) p.interval95 = u->interval95;
      out.push_back(p);
      break;
    }
    default: {
      NamedParameter p{parameterName(e.kind), {e.value}, {}};
      if (have) p.interval95.push_back(u->interval95.front());
      out.push_back(p);
    }
  }
  return out;
}

namespace {
double parseValue(const std::string& text0, const std::string& what) {
  std::string text = text0;
  double scale = 1.0;
  if (text.size() > 3 && text.compare(text.size() - 3, 3, "deg") == 0) {
    scale = M_PI / 180.0;
    text.resize(text.size() - 3);
  }
  std::size_t used = 0;
  double v = 0;
  try {
    v = std::stod(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (text.empty() || used != text.size() || !std::isfinite(v))
    throw std::invalid_argument(what + ": '" + text0 + "' is not a finite number");
  return v * scale;
}
}  // namespace

Effect parseEffect(const std::string& text) {
  const auto colon = text.find(':');
  Effect e;
  e.kind = parseEffectKind(text.substr(0, colon));
  // Keys of the kind and how many numbers each takes.
  auto arity = [&](const std::string& key) -> int {
    if (key == "tube") return 1;
    if (e.kind == EffectKind::TipLoad) return key == "force" ? 3 : 0;
    if (e.kind == EffectKind::Gravity) return key == "scale" ? 1 : key == "direction" ? 3 : 0;
    return key == parameterName(e.kind) ? 1 : 0;
  };
  auto expected = [&]() -> std::string {
    std::string t = isPerTube(e.kind) ? "tube and " : "";
    if (e.kind == EffectKind::TipLoad) return t + "force=FX,FY,FZ (N)";
    if (e.kind == EffectKind::Gravity) return t + "direction=X,Y,Z and optionally scale (default 1)";
    return t + parameterName(e.kind);
  };
  std::map<std::string, std::vector<double>> got;
  if (colon != std::string::npos) {
    std::stringstream ss(text.substr(colon + 1));
    std::string item, key;  // key: the vector key still taking numbers
    while (std::getline(ss, item, ',')) {
      const auto eq = item.find('=');
      if (eq == std::string::npos) {
        if (key.empty() || static_cast<int>(got[key].size()) >= arity(key))
          throw std::invalid_argument("effect '" + text + "': expected key=value, got '" + item + "'");
        got[key].push_back(parseValue(item, key));
        continue;
      }
      if (!key.empty() && static_cast<int>(got[key].size()) != arity(key))
        throw std::invalid_argument("effect '" + text + "': " + key + " needs " + std::to_string(arity(key)) +
                                    " comma-separated numbers");
      key = item.substr(0, eq);
      const std::string val = item.substr(eq + 1);
      if (arity(key) == 0)
        throw std::invalid_argument("effect '" + text + "': unknown key '" + key + "' (expected " + expected() + ")");
      if (got.count(key)) throw std::invalid_argument("effect '" + text + "': " + key + " given twice");
      got[key].push_back(parseValue(val, key));
    }
    if (!key.empty() && static_cast<int>(got[key].size()) != arity(key))
      throw std::invalid_argument("effect '" + text + "': " + key + " needs " + std::to_string(arity(key)) +
                                  " comma-separated numbers");
  }
  if (got.count("tube")) e.tube = static_cast<int>(got["tube"][0]);
  if (e.kind == EffectKind::TipLoad) {
    if (!got.count("force")) throw std::invalid_argument("effect '" + text + "': missing force=FX,FY,FZ");
    e.vec = Eigen::Vector3d(got["force"][0], got["force"][1], got["force"][2]);
  } else if (e.kind == EffectKind::Gravity) {
    if (!got.count("direction")) throw std::invalid_argument("effect '" + text + "': missing direction=X,Y,Z");
    const Eigen::Vector3d d(got["direction"][0], got["direction"][1], got["direction"][2]);
    if (!(d.norm() > 0)) throw std::invalid_argument("effect '" + text + "': direction must not be zero");
    const double scale = got.count("scale") ? got["scale"][0] : 1.0;
    if (scale < 0) throw std::invalid_argument("effect '" + text + "': scale must be >= 0");
    e.vec = scale * d.normalized();
  } else if (!got.count(parameterName(e.kind))) {
    throw std::invalid_argument("effect '" + text + "': missing " + std::string(parameterName(e.kind)));
  } else {
    e.value = got[parameterName(e.kind)][0];
  }
  if (isPerTube(e.kind) && e.tube < 1) throw std::invalid_argument("effect '" + text + "': missing tube=K (1-based)");
  if (!isPerTube(e.kind)) e.tube = 0;
  return e;
}

double nominalValue(const Robot& nominal, EffectKind kind, int tube) {
  switch (kind) {
    case EffectKind::TorsionalStiffness: {
      const Tube& t = nominal.tube(0);
      if (t.poisson_ratio) return *t.poisson_ratio;
      return t.bending_stiffness / t.torsional_stiffness - 1.0;
    }
    case EffectKind::Precurvature:
      return nominal.tube(tube - 1).curvature;
    case EffectKind::BendingStiffness:
      return nominal.tube(tube - 1).bending_stiffness;
    default:
      return 0.0;
  }
}

Effect nominalEffect(const Robot& nominal, EffectKind kind, int tube) {
  Effect e;
  e.kind = kind;
  e.tube = isPerTube(kind) ? tube : 0;
  if (kind == EffectKind::Gravity)
    e.vec = nominal.hasWeight() ? Eigen::Vector3d(nominal.loads().gravity / kStandardGravity) : Eigen::Vector3d::Zero();
  else if (kind == EffectKind::TipLoad)
    e.vec = nominal.loads().tip_force;
  else
    e.value = nominalValue(nominal, kind, tube);
  return e;
}

std::string gravityUnavailable(const Robot& nominal) {
  if (nominal.hasWeight()) return "";
  for (const Tube& t : nominal.tubes())
    if (t.outer_diameter > t.inner_diameter) return "";
  return "no tube has a linear density, a density or diameters to compute its weight from";
}

bool addDriveEffect(const Effect& e, Drive& rotation, Drive& translation) {
  switch (e.kind) {
    case EffectKind::ActuatorBacklash:
      rotation.play += e.value;
      return true;
    case EffectKind::TranslationBacklash:
      translation.play += e.value;
      return true;
    case EffectKind::ActuatorOffset:
      rotation.offset += e.value;
      return true;
    case EffectKind::TranslationOffset:
      translation.offset += e.value;
      return true;
    case EffectKind::DriveRatio:
      rotation.ratio_error += e.coef[0];
      rotation.ratio_reference = e.ref[0];
      return true;
    case EffectKind::DrivePeriodic:
      for (std::size_t j = 0; j < 4; ++j) rotation.periodic[j] += e.coef[static_cast<Eigen::Index>(j)];
      return true;
    case EffectKind::StageError:
      for (std::size_t j = 0; j < 3; ++j) translation.stage[j] += e.coef[static_cast<Eigen::Index>(j)];
      translation.stage_reference = e.ref[0];
      translation.stage_scale = e.ref[1];
      return true;
    default:
      return false;
  }
}

Robot robotWithEffects(const Robot& nominal, const std::vector<Effect>& effects) {
  const Robot physics = applyToRobot(nominal, effects);
  std::vector<Tube> tubes = physics.tubes();
  bool driven = false;
  for (const Effect& e : effects) {
    if (e.tube < 1 || e.tube > physics.size()) continue;  // applyToRobot checked the drive kinds' tubes
    Tube& t = tubes[static_cast<std::size_t>(e.tube - 1)];
    driven = addDriveEffect(e, t.rotation_drive, t.translation_drive) || driven;
  }
  if (!driven) return physics;
  return Robot(physics.name(), std::move(tubes), physics.friction(), physics.loads());
}

Robot applyToRobot(const Robot& nominal, const std::vector<Effect>& effects) {
  std::vector<Tube> tubes = nominal.tubes();
  FrictionCoefficients f = nominal.friction();
  Loads loads = nominal.loads();  // the nominal loads are kept unless an effect replaces them
  const int n = nominal.size();
  auto check = [&](const Effect& e) {
    if (e.tube < 1 || e.tube > n)
      throw std::invalid_argument(e.label() + ": tube " + std::to_string(e.tube) + " out of 1.." + std::to_string(n));
  };
  for (const Effect& e : effects) {
    switch (e.kind) {
      case EffectKind::BoundaryFriction:
        f.boundary = e.value;
        break;
      case EffectKind::DistributedFriction:
        f.distributed = e.value;
        break;
      case EffectKind::TorsionalStiffness:
        for (Tube& t : tubes) {
          t.poisson_ratio = e.value;
          t.torsional_stiffness = t.bending_stiffness / (1.0 + e.value);
        }
        break;
      case EffectKind::Precurvature:
        check(e);
        tubes[static_cast<std::size_t>(e.tube - 1)].curvature = e.value;
        break;
      case EffectKind::BendingStiffness: {
        check(e);
        Tube& t = tubes[static_cast<std::size_t>(e.tube - 1)];
        const double ratio = t.torsional_stiffness / t.bending_stiffness;
        t.bending_stiffness = e.value;
        t.torsional_stiffness = e.value * ratio;
        break;
      }
      case EffectKind::ActuatorBacklash:
      case EffectKind::ActuatorOffset:
      case EffectKind::TranslationBacklash:
      case EffectKind::TranslationOffset:
        check(e);
        break;
      case EffectKind::SensorLatency:
      case EffectKind::TrackerDrift:
        break;
      case EffectKind::DriveRatio:
      case EffectKind::DrivePeriodic:
      case EffectKind::StageError:
        check(e);
        break;
      case EffectKind::TipLoad:
        loads.tip_force = e.vec;
        break;
      case EffectKind::Gravity:
        loads.gravity = kStandardGravity * e.vec;
        // A weightless description: each tube weighs nitinol's density times its cross-section (an assumption;
        // the fitted scale absorbs a different density).
        if (!nominal.hasWeight())
          for (Tube& t : tubes)
            if (t.outer_diameter > t.inner_diameter)
              t.linear_density = kNitinolDensity * M_PI / 4 *
                                 (t.outer_diameter * t.outer_diameter - t.inner_diameter * t.inner_diameter);
        break;
    }
  }
  return Robot(nominal.name(), std::move(tubes), f, loads);
}

}  // namespace ctr::diagnosis
