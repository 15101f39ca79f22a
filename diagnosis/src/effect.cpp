// Effects: names, parameters, and their action on the robot description.
#include "ctr/diagnosis/effect.hpp"

#include <cmath>
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
  int group;  // 1 = lag, 2 = shift, 0 = none (lookAlikeGroup)
};

// One row per kind, in the order of formats.md.
constexpr KindFacts kFacts[] = {
    {EffectKind::BoundaryFriction, "boundary_friction", "mu", "", false, true, 1},
    {EffectKind::DistributedFriction, "distributed_friction", "mu", "", false, true, 1},
    {EffectKind::TorsionalStiffness, "torsional_stiffness", "poisson_ratio", "", false, false, 2},
    {EffectKind::Precurvature, "precurvature", "curvature", "1/m", true, false, 0},
    {EffectKind::BendingStiffness, "bending_stiffness", "bending_stiffness", "N m^2", true, false, 0},
    {EffectKind::ActuatorBacklash, "actuator_backlash", "width", "rad", true, true, 1},
    {EffectKind::ActuatorOffset, "actuator_offset", "offset", "rad", true, false, 2},
    {EffectKind::TranslationBacklash, "translation_backlash", "width", "m", true, true, 1},
    {EffectKind::TranslationOffset, "translation_offset", "offset", "m", true, false, 2},
    {EffectKind::SensorLatency, "sensor_latency", "delay", "s", false, false, 1},
};
static_assert(sizeof(kFacts) / sizeof(kFacts[0]) == static_cast<std::size_t>(EffectKind::TranslationOffset) + 1,
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
    for (const KindFacts& f : kFacts) v.push_back(f.kind);
    return v;
  }();
  return k;
}

const char* effectName(EffectKind k) {
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
int lookAlikeGroup(EffectKind k) {
  return facts(k).group;
}
bool isLookAlike(EffectKind k) {
  return lookAlikeGroup(k) != 0;
}

EffectKind parseEffectKind(const std::string& name) {
  for (EffectKind k : allEffectKinds())
    if (name == effectName(k)) return k;
  std::string all;
  for (EffectKind k : allEffectKinds()) all += std::string(all.empty() ? "" : ", ") + effectName(k);
  throw std::invalid_argument("unknown effect '" + name + "' (known: " + all + ")");
}

std::string Effect::label() const {
  std::string s = effectName(kind);
  if (isPerTube(kind)) s += "[tube " + std::to_string(tube) + "]";
  return s;
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
  bool have_value = false;
  if (colon != std::string::npos) {
    std::stringstream ss(text.substr(colon + 1));
    std::string item;
    while (std::getline(ss, item, ',')) {
      const auto eq = item.find('=');
      if (eq == std::string::npos)
        throw std::invalid_argument("effect '" + text + "': expected key=value, got '" + item + "'");
      const std::string key = item.substr(0, eq), val = item.substr(eq + 1);
      if (key == "tube") {
        e.tube = static_cast<int>(parseValue(val, "tube"));
      } else if (key == parameterName(e.kind)) {
        e.value = parseValue(val, key);
        have_value = true;
      } else {
        throw std::invalid_argument("effect '" + text + "': unknown key '" + key + "' (expected " +
                                    (isPerTube(e.kind) ? "tube and " : "") + parameterName(e.kind) + ")");
      }
    }
  }
  if (!have_value) throw std::invalid_argument("effect '" + text + "': missing " + std::string(parameterName(e.kind)));
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

Robot applyToRobot(const Robot& nominal, const std::vector<Effect>& effects) {
  std::vector<Tube> tubes = nominal.tubes();
  FrictionCoefficients f = nominal.friction();
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
        break;
    }
  }
  return Robot(nominal.name(), std::move(tubes), f, nominal.loads());  // the nominal loads are kept
}

}  // namespace ctr::diagnosis
