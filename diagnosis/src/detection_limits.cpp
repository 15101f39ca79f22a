// Detection limits: for every candidate of the library not in the final model, the smallest size this recording
// could tell from none on top of that model. A rejected candidate is "not seen", never "absent": the limit says how
// large it would have had to be.
#include <algorithm>
#include <cmath>
#include <exception>
#include <limits>

#include "diagnosis_state.hpp"

namespace ctr::diagnosis::detail {

namespace {

/// "6.1 deg", "0.52 mm", "0.031" in the parameter's natural unit.
std::string limitText(EffectKind kind, double v) {
  const std::string unit = parameterUnit(kind);
  if (unit == "rad") return fmt("%.3g deg", v * 180 / M_PI);
  if (unit == "m") return fmt("%.3g mm", v * 1e3);
  if (unit == "s") return fmt("%.3g s", v);
  return fmt("%.3g", v) + (unit.empty() ? "" : " " + unit);
}

}  // namespace

void assessDetectionLimits(State& s) {
  std::vector<Effect> cands;
  for (const Effect& slot : s.slots) {
    if (isGeneric(slot.kind) || parameterCount(slot.kind) != 1) continue;
    if (!s.inModel(slot)) cands.push_back(nominalEffect(s.nominal, slot.kind, slot.tube));
  }
  if (cands.empty()) return;
  s.say(DiagnoseProgress::Stage::Remainder,
        "detection limits of " + std::to_string(cands.size()) + " candidate(s) not in the final model");
  FitOptions fo = s.fo_alone;
  fo.rows = s.evaluable;
  std::vector<DetectionLimit> lim;
  try {
    lim = detectionLimits(s.nominal, s.rec, s.cur.fit.effects, cands, s.evaluable, fo, s.o.bic_threshold, s.ws);
  } catch (const std::exception& e) {  // the verdict stands without them
    s.rep.warnings.push_back(std::string("detection limits not computed: ") + e.what());
    return;
  }
  s.count(2 * coordinateCount(s.cur.fit.effects) + 1 + static_cast<int>(cands.size()));
  for (std::size_t i = 0; i < cands.size(); ++i) {
    const EffectKind kind = cands[i].kind;
    const ParameterRange r = parameterRange(s.nominal, s.rec, kind, cands[i].tube);
    const double reach = std::max(r.hi - cands[i].coordinate(0), cands[i].coordinate(0) - r.lo);
    const double v = lim[i].value;
    DetectionNote d;
    d.value = v;
    const std::string what = std::string(parameterName(kind));
    if (!std::isfinite(v))
      d.text = lim[i].confounded ? "Detection limit: on top of the final model, no " + what +
                                       " can be told from the nominal one (its effect is a combination of the final "
                                       "model's effects, to first order)"
                                 : "Detection limit: no output of this recording depends on its " + what;
    else if (v > reach)
      d.text = "Detection limit: on top of the final model, no " + what + " within its range (up to " +
               limitText(kind, reach) + " from the nominal value) can be told from the nominal one (it would take " +
               limitText(kind, v) + ")";
    else
      d.text = "Detection limit: on top of the final model, this recording cannot tell " +
               (cands[i].coordinate(0) == 0.0 ? what + " < " + limitText(kind, v) + " from none"
                                              : what + " within " + limitText(kind, v) + " of its nominal value") +
               " (first order: the 95 % interval with the residuals' serial correlation, and the BIC threshold; the "
               "held-out test can reject larger ones)";
    s.detection[cands[i].label()] = d;
  }
}

}  // namespace ctr::diagnosis::detail
