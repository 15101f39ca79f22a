// Effects: names, parameters, and their action on the robot description.
#include "ctr/diagnosis/effect.hpp"

#include <cmath>
#include <sstream>
#include <stdexcept>

namespace ctr::diagnosis {

const std::vector<EffectKind>& allEffectKinds() {
  static const std::vector<EffectKind> k{EffectKind::BoundaryFriction,   EffectKind::DistributedFriction,
                                         EffectKind::TorsionalStiffness, EffectKind::Precurvature,
                                         EffectKind::BendingStiffness,   EffectKind::ActuatorBacklash,
                                         EffectKind::ActuatorOffset,     EffectKind::TranslationBacklash,
                                         EffectKind::TranslationOffset,  EffectKind::SensorLatency};
  return k;
}

const char* effectName(EffectKind k) {
  switch (k) {
    case EffectKind::BoundaryFriction:
      return "boundary_friction";
    case EffectKind::DistributedFriction:
      return "distributed_friction";
    case EffectKind::TorsionalStiffness:
      return "torsional_stiffness";
    case EffectKind::Precurvature:
      return "precurvature";
    case EffectKind::BendingStiffness:
      return "bending_stiffness";
    case EffectKind::ActuatorBacklash:
      return "actuator_backlash";
    case EffectKind::ActuatorOffset:
      return "actuator_offset";
    case EffectKind::SensorLatency:
      return "sensor_latency";
    case EffectKind::TranslationBacklash:
      return "translation_backlash";
    case EffectKind::TranslationOffset:
      return "translation_offset";
  }
  return "?";
}

const char* parameterName(EffectKind k) {
  switch (k) {
    case EffectKind::BoundaryFriction:
    case EffectKind::DistributedFriction:
      return "mu";
    case EffectKind::TorsionalStiffness:
      return "poisson_ratio";
    case EffectKind::Precurvature:
      return "curvature";
    case EffectKind::BendingStiffness:
      return "bending_stiffness";
    case EffectKind::ActuatorBacklash:
    case EffectKind::TranslationBacklash:
      return "width";
    case EffectKind::ActuatorOffset:
    case EffectKind::TranslationOffset:
      return "offset";
    case EffectKind::SensorLatency:
      return "delay";
  }
  return "?";
}

const char* parameterUnit(EffectKind k) {
  switch (k) {
    case EffectKind::Precurvature:
      return "1/m";
    case EffectKind::BendingStiffness:
      return "N m^2";
    case EffectKind::ActuatorBacklash:
    case EffectKind::ActuatorOffset:
      return "rad";
    case EffectKind::SensorLatency:
      return "s";
    case EffectKind::TranslationBacklash:
    case EffectKind::TranslationOffset:
      return "m";
    default:
      return "";
  }
}

bool isPerTube(EffectKind k) {
  return k == EffectKind::Precurvature || k == EffectKind::BendingStiffness || k == EffectKind::ActuatorBacklash ||
         k == EffectKind::ActuatorOffset || k == EffectKind::TranslationBacklash || k == EffectKind::TranslationOffset;
}

bool isStateful(EffectKind k) {
  return k == EffectKind::BoundaryFriction || k == EffectKind::DistributedFriction ||
         k == EffectKind::ActuatorBacklash || k == EffectKind::TranslationBacklash;
}

int lookAlikeGroup(EffectKind k) {
  switch (k) {
    case EffectKind::BoundaryFriction:
    case EffectKind::DistributedFriction:
    case EffectKind::SensorLatency:
    case EffectKind::ActuatorBacklash:
    case EffectKind::TranslationBacklash:
      return 1;
    case EffectKind::ActuatorOffset:
    case EffectKind::TranslationOffset:
    case EffectKind::TorsionalStiffness:
      return 2;
    default:
      return 0;
  }
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
  return Robot(nominal.name(), std::move(tubes), f);
}

}  // namespace ctr::diagnosis
