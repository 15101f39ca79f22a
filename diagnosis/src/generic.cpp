// Generic models of physics outside the library: a transmission error of a rotation drive (a ratio error and two
// harmonics in the drive's own angle), a smooth error of a translation stage along its travel, a drift of the
// tracker in time. They compete in the selection rounds like library effects (screened at first order, fitted by
// replays, held out) but win a round only when they predict the held-out rows significantly better than the library's
// best; an accepted one is never named: it describes the remainder the library leaves, in words.
#include <algorithm>
#include <cmath>

#include "diagnosis_state.hpp"
#include "parallel.hpp"

namespace ctr::diagnosis::detail {

namespace {

/// True when coordinate c's 95 % interval excludes zero (no interval: when it is not zero).
bool significant(const EffectUncertainty* u, const Effect& e, int c) {
  if (!u || static_cast<int>(u->interval95.size()) <= c) return e.coef[c] != 0.0;
  return u->interval95[static_cast<std::size_t>(c)][0] > 0.0 || u->interval95[static_cast<std::size_t>(c)][1] < 0.0;
}

/// The structure of a fitted generic model, in words.
std::string describeGeneric(const Effect& e, const EffectUncertainty* u, const io::Recording& rec) {
  const double deg = 180.0 / M_PI;
  switch (e.kind) {
    case EffectKind::DriveRatio:
      return fmt(
          "a ratio error of the tube-%.0f drive of %+.2g %% (the tube turns %.4g times the commanded angle) -- "
          "such as a wrong gear ratio (not physics of the library)",
          e.tube, 100 * e.coef[0], 1 + e.coef[0]);
    case EffectKind::DrivePeriodic: {
      // c0 cos(alpha) + c1 sin(alpha) = a1 cos(alpha - phi), largest at alpha = phi; likewise at twice the angle.
      const std::string var = "alpha_" + std::to_string(e.tube);
      const double a1 = std::hypot(e.coef[0], e.coef[1]), a2 = std::hypot(e.coef[2], e.coef[3]);
      std::vector<std::string> parts;
      if (significant(u, e, 0) || significant(u, e, 1))
        parts.push_back(fmt("one cycle per turn, %.2g deg amplitude (largest at ", a1 * deg) + var +
                        fmt(" = %.0f deg)", std::fmod(std::atan2(e.coef[1], e.coef[0]) * deg + 360.0, 360.0)));
      if (significant(u, e, 2) || significant(u, e, 3))
        parts.push_back(fmt("two cycles per turn, %.2g deg amplitude", a2 * deg));
      if (parts.empty()) parts.push_back(fmt("up to %.2g deg", (a1 + a2) * deg));
      std::string t =
          "a transmission error of the tube-" + std::to_string(e.tube) + " drive, periodic in " + var + ": ";
      for (std::size_t k = 0; k < parts.size(); ++k) t += (k ? "; " : "") + parts[k];
      return t + " -- such as an eccentric gear or coupling (not physics of the library)";
    }
    case EffectKind::StageError: {
      double worst = 0.0;
      for (const Configuration& q : rec.commands) worst = std::max(worst, std::abs(e.genericAt(q.beta[e.tube - 1])));
      return fmt(
          "a smooth error of the tube-%.0f stage along its travel, up to %.2g mm over its %.3g mm of travel -- "
          "such as a lead-screw pitch error (not physics of the library)",
          e.tube, worst * 1e3, 2e3 * e.ref[1]);
    }
    case EffectKind::TrackerDrift: {
      const int rows = rec.rows();
      Eigen::Vector3d d;
      for (int a = 0; a < 3; ++a) d[a] = e.genericAt(rec.time[rows - 1], a) - e.genericAt(rec.time[0], a);
      const Eigen::Vector3d u3 = d.norm() > 0 ? Eigen::Vector3d(d / d.norm()) : Eigen::Vector3d::UnitX();
      return fmt("a drift of the measured tip position of %.2g mm along (%.2f, %.2f, %.2f) in the base frame over the "
                 "recording",
                 d.norm() * 1e3, u3.x(), u3.y(), u3.z()) +
             fmt(" (%.3g s) -- the tracker or its mount moving (not physics of the robot)",
                 rec.time[rows - 1] - rec.time[0]);
    }
    default:
      return e.label();
  }
}

}  // namespace

/// The generic slots of a recording: a drive error per rotating tube, a stage error per translating tube, a tracker
/// drift with time and tip positions; references (mean command, centre and half-range) from the recording.
std::vector<Effect> genericSlots(const io::Recording& rec) {
  std::vector<Effect> out;
  const int n = rec.tubes, rows = rec.rows();
  for (int i = 0; i < n; ++i)
    for (EffectKind kind : {EffectKind::DriveRatio, EffectKind::DrivePeriodic, EffectKind::StageError}) {
      const bool rot = kind != EffectKind::StageError;
      double lo = 1e300, hi = -1e300;
      for (const Configuration& q : rec.commands) {
        const double x = rot ? q.alpha[i] : q.beta[i];
        lo = std::min(lo, x);
        hi = std::max(hi, x);
      }
      if (!(hi - lo > (rot ? 1e-3 : 1e-5))) continue;
      Effect e;
      e.kind = kind;
      e.tube = i + 1;
      // A drive's ratio error scales its angle from the drive's zero; a stage's error is a polynomial over its
      // travel in the recording.
      e.ref = rot ? Eigen::Vector2d(0.0, 1.0) : Eigen::Vector2d(0.5 * (lo + hi), 0.5 * (hi - lo));
      out.push_back(e);
    }
  if (rec.hasTime() && rec.hasTipPosition() && rows > 2 && rec.time[rows - 1] > rec.time[0]) {
    Effect e;
    e.kind = EffectKind::TrackerDrift;
    e.ref = Eigen::Vector2d(rec.time[0], rec.time[rows - 1] - rec.time[0]);
    out.push_back(e);
  }
  return out;
}

void describeRemainder(State& s) {
  std::vector<std::size_t> generic;
  for (std::size_t j = 0; j < s.cur.fit.effects.size(); ++j)
    if (isGeneric(s.cur.fit.effects[j].kind)) generic.push_back(j);
  if (generic.empty()) return;
  using Stage = DiagnoseProgress::Stage;
  // The library's model: the final one without the generic descriptions, refitted, with its held-out error.
  Candidate lib;
  const std::vector<Effect> lib_effects = withoutEffects(s, generic);
  if (lib_effects.empty()) {
    lib.fit = s.base;
    lib.cv = s.baseline_cv;
  } else {
    lib.fit = fitEffects(s.nominal, s.rec, lib_effects, s.all, s.fo_alone, s.ws, coordinateCount(lib_effects));
    s.count(lib.fit.evaluations);
    lib.cv = crossValidate(s.nominal, s.rec, lib.fit.effects, s.o.folds, s.fo, s.ws, s.o.cv_iterations, s.o.threads,
                           s.o.one_step_cv ? &lib.fit : nullptr);
    s.count(lib.cv.evaluations);
  }
  // What the library leaves unexplained is what the descriptions describe.
  Unexplained& u = s.rep.unexplained;
  MismatchOptions mo = s.o.mismatch;
  mo.alpha = 0.5 * s.o.mismatch.alpha;
  const MismatchReport m = locateMismatch(s.rec, lib.fit.prediction, lib.fit.residuals, s.fo.noise, mo);
  u.present = true;
  u.heldout_ratio = s.heldoutRatio(lib.cv, u.heldout_p);
  u.heldout_rmse = lib.cv.rmse;
  u.mismatch = m.findings;
  u.fraction_explained =
      s.base_ratio > 1.0 ? std::clamp((s.base_ratio - u.heldout_ratio) / (s.base_ratio - 1.0), 0.0, 1.0) : 0.0;
  u.where = remainderWords(m, u.heldout_ratio, s.rep.noise);
  u.described.clear();
  const double delta_bic = s.deltaBic(lib.fit.residuals, coordinateCount(lib.fit.effects), s.cur.fit.residuals,
                                      coordinateCount(s.cur.fit.effects));
  for (std::size_t j : generic) {
    const Effect& g = s.cur.fit.effects[j];
    GenericDescription d;
    d.model = g;
    d.description = describeGeneric(g, j < s.cur.fit.uncertainty.size() ? &s.cur.fit.uncertainty[j] : nullptr, s.rec);
    d.delta_bic = delta_bic;
    d.heldout_rmse = s.cur.cv.rmse;
    double p = 1.0;
    d.heldout_ratio = s.heldoutRatio(s.cur.cv, p);
    const HeldOutComparison h = compareHeldOut(lib.cv.row_score, s.cur.cv.row_score, s.chunks);
    d.heldout_gain = h.gain;
    d.heldout_p = h.p;
    const auto r = s.replaced_by.find(g.label());
    if (r != s.replaced_by.end()) d.replaces = r->second;
    s.say(Stage::Remainder, "described: " + g.label() + ": " + d.description +
                                fmt(" (held-out gain %.1f %% over the library's model)", 100 * d.heldout_gain));
    u.described.push_back(std::move(d));
  }
}

}  // namespace ctr::diagnosis::detail
