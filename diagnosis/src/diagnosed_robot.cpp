// The robot a diagnosis found (`ctr diagnose --robot-out`): the nominal description with the named effects applied,
// written as a robot description whose comments say where each value came from.
#include <cstdio>
#include <sstream>

#include "ctr/diagnosis/diagnose.hpp"
#include "ctr/io/robot_yaml.hpp"
#include "diagnosis_state.hpp"

namespace ctr::diagnosis {
namespace {

/// The accepted finding that names `e`'s slot in the verdict (nullptr: none).
const Finding* namingFinding(const DiagnosisReport& r, const Effect& e) {
  for (const Finding& f : r.findings)
    if (f.accepted && f.named && f.effect.sameSlot(e)) return &f;
  return nullptr;
}

/// Effects of the recording (its timing and its tracker), not of the robot.
bool ofTheRecording(EffectKind k) {
  return k == EffectKind::SensorLatency || k == EffectKind::TrackerDrift;
}

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
std::string valueWords(const DiagnosisReport& r, const Effect& e) {
  const auto u = r.final_uncertainty.find(e.label());
  std::string out;
  for (const NamedParameter& p : namedParameters(e, u != r.final_uncertainty.end() ? &u->second : nullptr)) {
    if (p.name == "tube") continue;
    out += (out.empty() ? "" : ", ") + detail::paramText(p);
    if (!p.interval95.empty()) out += " (95 %: " + detail::intervalText(p) + ")";
  }
  return out + " " + parameterUnit(e.kind);
}

}  // namespace

Robot diagnosedRobot(const Robot& nominal, const DiagnosisReport& r) {
  std::vector<Effect> applied;
  if (!r.verdict.empty())
    for (const Effect& e : r.final_effects)
      if (!ofTheRecording(e.kind) && !isGeneric(e.kind) && namingFinding(r, e)) applied.push_back(e);
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
    if (!r.verdict.empty() && f && !ofTheRecording(e.kind) && !isGeneric(e.kind)) {
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

}  // namespace ctr::diagnosis
