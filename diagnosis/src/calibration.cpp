// Calibration of the robot's description: a description given as calibration starting values is off in several
// parameters at once, each too small alone to pass the selection's tests on top of the others' error. When the
// selection leaves a remainder, what a robot calibration fits (the description's shape and stiffness, the drive
// zeros) is fitted together and accepted (or not) as a block.
#include <algorithm>
#include <cmath>

#include "diagnosis_state.hpp"

namespace ctr::diagnosis::detail {

namespace {
/// Parameters a calibration of the robot fits: the description's shape and stiffness, and the zeros of the drives
/// (as opposed to plays, friction, sensors and loads). In an unknown tracker frame a common rotation of all tubes is a
/// rotation of the frame: the rotation zeros are then calibrated relative to the first tube's.
bool isCalibrated(const Effect& e, FrameMode frame) {
  switch (e.kind) {
    case EffectKind::Precurvature:
    case EffectKind::BendingStiffness:
    case EffectKind::TorsionalStiffness:
    case EffectKind::TranslationOffset:
      return true;
    case EffectKind::ActuatorOffset:
      return frame != FrameMode::Unknown || e.tube > 1;
    default:
      return false;
  }
}

/// " Also <text>." after the explanation of every finding of `labels` that was not accepted.
void addToRejectedFindings(State& s, const std::vector<std::string>& labels, const std::string& text) {
  for (const std::string& lab : labels) {
    const auto f = s.last.find(lab);
    if (f != s.last.end() && !f->second.accepted) f->second.explanation += " Also " + text + ".";
  }
}
}  // namespace

bool calibrateDescription(State& s, int round) {
  const DiagnoseOptions& o = s.o;
  Candidate& cur = s.cur;
  if (!o.calibrate_description || !s.rep.unexplained.present) return false;
  for (const Effect& e : cur.fit.effects)
    if (isGeneric(e.kind)) return false;  // the remainder is already described as physics outside the library
  std::vector<Effect> block;
  for (const Effect& slot : s.slots) {
    if (isCalibrated(slot, o.frame) && !s.inModel(slot)) block.push_back(slot);
  }
  if (block.size() < 2) return false;  // one parameter alone was tried by the selection
  std::string names;
  for (const Effect& e : block) names += (names.empty() ? "" : ", ") + e.label();
  s.say(DiagnoseProgress::Stage::Calibration, "calibration: fitting the description's " + std::to_string(block.size()) +
                                                  " parameters (" + names + ") together on top of " +
                                                  modelName(cur.fit.effects));
  Candidate c;
  c.slot = block.front();
  std::vector<Effect> start = cur.fit.effects;
  start.insert(start.end(), block.begin(), block.end());
  FitOptions co = s.fo_alone;
  co.max_iterations = o.calibration_iterations;
  guarded(s, c, s.ws, [&](Candidate& x, Workspace& w) {
    x.fit = fitEffects(s.nominal, s.rec, start, s.all, co, w, coordinateCount(start));
    s.count(x.fit.evaluations);
    x.delta_bic = s.deltaBic(cur.fit.residuals, coordinateCount(cur.fit.effects), x.fit.residuals,
                             coordinateCount(x.fit.effects));
    x.bic = cur.bic + x.delta_bic;
    if (x.delta_bic < -o.bic_threshold) {
      // Folds refitted by iterations: one Gauss-Newton step from the full fit is not trusted for a block this large.
      s.count(heldOut(s, x, w, o.threads, false));
      x.pass = x.heldout_p < o.heldout_p && x.gain > o.min_heldout_gain;
    }
  });
  s.say(DiagnoseProgress::Stage::Calibration,
        fmt("calibration: dBIC = %+.1f, held-out gain %.1f %%, p = %.2g", c.delta_bic, 100 * c.gain, c.heldout_p) +
            (c.pass ? "; accepted" : "; not accepted"));
  const double dbic = c.delta_bic, gain = c.gain, p = c.heldout_p;
  const std::string tested =
      fmt("fitted together on top of the previous model, the description's %.0f parameters lower BIC by %.1f and the "
          "held-out error by %.1f %% ",
          static_cast<double>(block.size()), -dbic, 100 * gain) +
      fmt("(one-sided p = %.2g)", p);
  std::vector<std::string> labels;
  for (const Effect& e : block) labels.push_back(e.label());
  if (!c.pass) {
    const std::string note = c.failed ? "the calibration of the description " + c.reason
                                      : "calibrated with the description's other parameters: " + tested +
                                            ", not enough to accept the calibration";
    addToRejectedFindings(s, labels, note);
    return false;
  }
  cur = std::move(c);
  s.without.clear();
  // Parameters the others make redundant are removed (the description may be right in them).
  backwardElimination(s,
                      "removed after the calibration of the description: without it BIC changes by only %+.1f, so "
                      "the other effects explain what it explained");
  for (const Effect& e : cur.fit.effects) {
    const std::string lab = e.label();
    if (std::find(labels.begin(), labels.end(), lab) == labels.end()) continue;
    s.calibrated.insert(lab);
    s.removed.erase(lab);
    s.rivals_of[lab] = {};
    Finding f;
    f.effect = e;
    f.model = cur.fit.effects;
    f.round = round;
    f.accepted = true;
    f.delta_bic = dbic;
    f.heldout_rmse = cur.cv.rmse;
    f.heldout_score = cur.cv.score;
    f.heldout_p = p;
    f.explanation = "accepted with the calibration of the robot's description: " + describePhysics(e.kind) + "; " +
                    tested + ", and each parameter kept lowers BIC by more than " + fmt("%.0f", o.bic_threshold) +
                    " on top of the others.";
    if (!s.last.count(lab)) s.order.push_back(lab);
    s.last[lab] = f;
  }
  s.progress.accepted = static_cast<int>(cur.fit.effects.size());
  s.say(DiagnoseProgress::Stage::Accepted, "calibration: accepted " + modelName(cur.fit.effects));
  return true;
}

void keepCalibrationIfBetter(State& s, Snapshot& before) {
  // Both held-out errors against the noise the model before the calibration was judged with.
  const HeldOutComparison h = compareHeldOut(rowScores(s.rec, before.cur.cv.heldout, before.fo.noise),
                                             rowScores(s.rec, s.cur.cv.heldout, before.fo.noise), s.chunks);
  const std::string versus =
      fmt("held-out error %+.1f %% against the model without the calibration, p = %.2g", -100 * h.gain, h.p);
  s.say(DiagnoseProgress::Stage::Calibration, "calibration: the final model's " + versus);
  if (h.p < s.o.heldout_p && h.gain > s.o.min_heldout_gain) return;
  std::vector<std::string> labels(s.calibrated.begin(), s.calibrated.end());
  const int replays = s.rep.evaluations;
  snapshotFields(s) = before.fields();
  s.rep.evaluations = replays;
  s.without.clear();
  const std::string why =
      "the calibration of the description passed its tests, but the model the selection ended with "
      "on top of it (" +
      versus + ") does not predict held-out rows significantly better";
  s.rep.warnings.push_back(why + ": the result without the calibration is kept");
  addToRejectedFindings(s, labels, why);
  s.say(DiagnoseProgress::Stage::Calibration, "calibration: not kept; " + why);
}

}  // namespace ctr::diagnosis::detail
