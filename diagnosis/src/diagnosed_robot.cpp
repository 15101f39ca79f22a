// The robot a diagnosis found (`ctr diagnose --robot-out`): the nominal description with the named effects applied,
// written as a robot description whose comments say where each value came from.
#include <cstdio>
#include <sstream>

#include "ctr/diagnosis/diagnose.hpp"
#include "ctr/io/robot_yaml.hpp"
#include "diagnosis_state.hpp"

namespace ctr::diagnosis {
namespace detail {

const Finding* namingFinding(const DiagnosisReport& r, const Effect& e) {
  for (const Finding& f : r.findings)
    if (f.accepted && f.named && f.effect.sameSlot(e)) return &f;
  return nullptr;
}

bool ofTheRecording(EffectKind k) {
  return k == EffectKind::SensorLatency || k == EffectKind::TrackerDrift;
}

bool robotEffectOf(const DiagnosisReport& r, const Effect& e) {
  return !r.verdict.empty() && !ofTheRecording(e.kind) && !isGeneric(e.kind) && namingFinding(r, e);
}

}  // namespace detail

namespace {

using detail::namingFinding;
using detail::ofTheRecording;

/// Where the effect goes in the description.
std::string keyOf(const Effect& e) {
  const std::string tube = "tubes[" + std::to_string(e.tube) + "]";
  switch (e.kind) {
    case EffectKind::BoundaryFriction:
      return "friction.boundary";
    case EffectKind::DistributedFriction:
      return "friction.distributed";
    case EffectKind::TorsionalStiffness:
      return "tubes[*].poisson_ratio";
    case EffectKind::Precurvature:
      return tube + ".curvature";
    case EffectKind::BendingStiffness:
      return tube + ".bending_stiffness";
    case EffectKind::ActuatorBacklash:
      return tube + ".actuation.rotation.play";
    case EffectKind::ActuatorOffset:
      return tube + ".actuation.rotation.offset";
    case EffectKind::TranslationBacklash:
      return tube + ".actuation.translation.play";
    case EffectKind::TranslationOffset:
      return tube + ".actuation.translation.offset";
    case EffectKind::TipLoad:
      return "loads.tip_force";
    case EffectKind::Gravity:
      return "loads.gravity";
    default:
      return toString(e.kind);
  }
}

/// "width=0.21 (95 %: [0.19, 0.23])" for each reported parameter but the tube, then the unit.
std::string parameterWords(const std::vector<NamedParameter>& ps, EffectKind kind) {
  std::string out;
  for (const NamedParameter& p : ps) {
    if (p.name == "tube") continue;
    out += (out.empty() ? "" : ", ") + detail::paramText(p);
    if (!p.interval95.empty()) out += " (95 %: " + detail::intervalText(p) + ")";
  }
  return out + " " + parameterUnit(kind);
}

/// parameterWords of an effect of the final model, with its interval.
std::string valueWords(const DiagnosisReport& r, const Effect& e) {
  const auto u = r.final_uncertainty.find(e.label());
  return parameterWords(namedParameters(e, u != r.final_uncertainty.end() ? &u->second : nullptr), e.kind);
}

/// "A.csv, B.csv" of the recordings at these indices.
std::string recordingList(const MultiDiagnosisReport& r, const std::vector<int>& which) {
  std::string t;
  for (int i : which) t += (t.empty() ? "" : ", ") + r.names[static_cast<std::size_t>(i)];
  return t.empty() ? "none" : t;
}

}  // namespace

Robot diagnosedRobot(const Robot& nominal, const DiagnosisReport& r) {
  std::vector<Effect> applied;
  for (const Effect& e : r.final_effects)
    if (detail::robotEffectOf(r, e)) applied.push_back(e);
  return robotWithEffects(nominal, applied);
}

std::string diagnosedRobotYaml(const Robot& nominal, const DiagnosisReport& r, const std::string& recording) {
  const Robot robot = diagnosedRobot(nominal, r);
  std::ostringstream os;
  os << "# Written by `ctr diagnose --robot-out` from the recording " << recording << ": the nominal description\n"
     << "# '" << nominal.name() << "' with the effects the diagnosis names applied at their final fitted values.\n";
  std::ostringstream applied, left;
  for (const Effect& e : r.final_effects) {
    const Finding* f = namingFinding(r, e);
    if (detail::robotEffectOf(r, e)) {
      applied << "#   " << e.label() << " -> " << keyOf(e) << ": " << valueWords(r, e) << "; named in round "
              << f->round << " (held-out p " << detail::fmt("%.4g", f->heldout_p) << ", delta BIC "
              << detail::fmt("%.4g", f->delta_bic) << ")";
      for (const Rival& rv : f->ambiguous_with) applied << "; this recording cannot tell it from " << rv.effect.label();
      applied << "\n";
    } else {
      const std::string why = ofTheRecording(e.kind) ? "an effect of the recording, not of the robot"
                              : r.verdict.empty()    ? "the verdict names nothing"
                                                     : "kept in the fit but not named (a partial explanation)";
      left << "#   " << e.label() << ": " << valueWords(r, e) << " -- " << why << "\n";
    }
  }
  if (r.frame == FrameMode::Unknown)
    left << "#   the tracker frame (registration) -- of the recording, not of the robot\n";
  if (!r.verdict.empty()) {
    os << "# Applied (value, 95 % interval of the final fit, the finding):\n" << applied.str();
  } else {
    os << "# Nothing applied: the verdict names no effect"
       << (r.unexplained.present ? " (a mismatch remains that no candidate explains, or a noise these data cannot "
                                   "establish: see the diagnosis)"
                                 : " (the nominal description explains the recording)")
       << ".\n";
  }
  for (const GenericDescription& g : r.unexplained.described)
    left << "#   described, not applied (physics outside the library): " << g.description << "\n";
  if (!left.str().empty()) os << "# Not applied:\n" << left.str();
  os << io::robotToYaml(robot);
  return os.str();
}

std::string diagnosedRobotYaml(const Robot& nominal, const MultiDiagnosisReport& r) {
  const Robot robot = diagnosedRobot(nominal, r);
  std::ostringstream os, applied, left;
  os << "# Written by `ctr diagnose --robot-out` from " << r.names.size() << " recordings diagnosed together ("
     << recordingList(r,
                      [&] {
                        std::vector<int> all(r.names.size());
                        for (std::size_t i = 0; i < all.size(); ++i) all[i] = static_cast<int>(i);
                        return all;
                      }())
     << "): the nominal description\n# '" << nominal.name()
     << "' with the effects shared by the recordings applied at their common values.\n";
  for (const JointEffect& j : r.effects) {
    std::vector<int> named;
    for (const RecordingValue& v : j.per_recording)
      if (v.named) named.push_back(v.recording);
    if (j.agreement == Agreement::Shared) {
      applied << "#   " << j.effect.label() << " -> " << keyOf(j.effect) << ": "
              << parameterWords(j.parameters, j.effect.kind) << "; named by " << recordingList(r, named)
              << "; consistency p " << detail::fmt("%.3g", j.p) << "\n";
    } else {
      std::string values;
      for (const RecordingValue& v : j.per_recording)
        values += (values.empty() ? "" : "; ") + r.names[static_cast<std::size_t>(v.recording)] + " " +
                  parameterWords(v.parameters, j.effect.kind);
      left << "#   " << j.effect.label() << " (" << toString(j.agreement) << "): " << values << " -- " << j.explanation
           << "\n";
    }
  }
  if (r.frame == FrameMode::Unknown)
    left << "#   the tracker frames (one registration per recording) -- of the recordings, not of the robot\n";
  if (applied.str().empty())
    os << "# Nothing applied: no robot effect holds across the recordings.\n";
  else
    os << "# Applied (common value, 95 % interval of the joint estimate, the recordings that named it):\n"
       << applied.str();
  if (!left.str().empty()) os << "# Not applied:\n" << left.str();
  os << io::robotToYaml(robot);
  return os.str();
}

}  // namespace ctr::diagnosis
