// The verdict, the findings with their final values, reliability and the summary paragraph: one consistent account
// of what the recording shows, never claiming more than the tests and the noise support.
#include <algorithm>
#include <cmath>
#include <set>

#include "diagnosis_state.hpp"

namespace ctr::diagnosis {

std::vector<std::string> verdictNames(const std::vector<std::vector<EffectKind>>& entries) {
  std::vector<std::vector<EffectKind>> sorted;
  for (const std::vector<EffectKind>& e : entries) {
    if (e.empty()) continue;
    std::vector<EffectKind> kinds;
    for (EffectKind k : e)
      if (std::find(kinds.begin(), kinds.end(), k) == kinds.end()) kinds.push_back(k);
    // The effect's own kind, then its look-alikes by name; the one with fewer parameters first.
    std::stable_sort(kinds.begin() + 1, kinds.end(),
                     [](EffectKind a, EffectKind b) { return std::string(toString(a)) < toString(b); });
    std::stable_sort(kinds.begin(), kinds.end(),
                     [](EffectKind a, EffectKind b) { return parameterCount(a) < parameterCount(b); });
    sorted.push_back(kinds);
  }
  std::set<EffectKind> alone;
  for (const auto& k : sorted)
    if (k.size() == 1) alone.insert(k.front());
  std::vector<std::string> out;
  std::set<std::string> seen;
  for (const auto& kinds : sorted) {
    if (kinds.size() > 1 && std::any_of(kinds.begin(), kinds.end(), [&](EffectKind k) { return alone.count(k) > 0; }))
      continue;
    std::string name;
    for (EffectKind k : kinds) name += (name.empty() ? "" : " or ") + std::string(toString(k));
    if (seen.insert(name).second) out.push_back(name);
  }
  return out;
}

}  // namespace ctr::diagnosis

namespace ctr::diagnosis::detail {

namespace {

std::string joinWords(const std::vector<std::string>& v) {
  std::string t;
  for (std::size_t k = 0; k < v.size(); ++k) t += (k ? (k + 1 == v.size() ? " and " : ", ") : "") + v[k];
  return t;
}

/// "tip_position 0.98 mm (neighbours)" for the summary's noise sentence.
std::string noiseWords(const NoiseReport& n) {
  std::vector<std::string> parts;
  for (const auto& [q, e] : n.by_quantity) {
    const bool pos = q == Quantity::TipPosition;
    parts.push_back(std::string(toString(q)) +
                    fmt(pos ? " %.3g mm" : " %.3g deg", pos ? e.sigma * 1e3 : e.sigma * 180 / M_PI) + " (" + e.source +
                    ")");
  }
  return joinWords(parts);
}

/// A sentence when a fitted coordinate of `e` lies at a limit of its search range that its nominal value does not lie
/// at ("" otherwise).
std::string rangeLimitWords(const State& s, const Effect& e) {
  const Effect e0 = nominalEffect(s.nominal, e.kind, e.tube);
  for (int c = 0; c < parameterCount(e.kind); ++c) {
    const ParameterRange r = parameterRange(s.nominal, s.rec, e.kind, e.tube, c);
    const double v = e.coordinate(c), v0 = e0.coordinate(c), tol = 1e-6 * (r.hi - r.lo);
    for (const double bound : {r.lo, r.hi})
      if (std::abs(v - bound) <= tol && std::abs(v0 - bound) > tol)
        return fmt(
            "Its fitted value is at the limit of the search range (%.4g): the recording asks for more, so "
            "it is a bound, not an estimate.",
            bound);
  }
  return "";
}

}  // namespace

void writeVerdict(State& s) {
  DiagnosisReport& rep = s.rep;
  const Candidate& cur = s.cur;
  const io::Recording& rec = s.rec;
  const int rows = rec.rows();
  // The final model: fitted values with intervals (from its full-data fit).
  rep.final_effects = cur.fit.effects;
  for (std::size_t j = 0; j < cur.fit.effects.size() && j < cur.fit.uncertainty.size(); ++j)
    rep.final_uncertainty[cur.fit.effects[j].label()] = cur.fit.uncertainty[j];
  for (const Effect& e : cur.fit.effects)
    if (e.kind == EffectKind::Gravity && nominalEffect(s.nominal, EffectKind::Gravity, 0).vec.isZero() &&
        !s.nominal.hasWeight())
      rep.warnings.push_back(
          "gravity: the description gives no tube a density, so its weight assumes nitinol (" +
          fmt("%.0f kg/m^3) with the tubes' diameters; the fitted scale %.3g is relative to that weight",
              kNitinolDensity, e.gravityScale()));
  rep.registration = cur.fit.registration;
  rep.final.model = modelName(cur.fit.effects);
  rep.final.effects = cur.fit.effects;
  rep.final.heldout_rmse = cur.cv.rmse;
  rep.final.last_block_rmse = rmse(rec, cur.cv.heldout, s.last_block);
  rep.final.fit_rmse = rmse(rec, cur.fit.residuals, s.evaluable);
  rep.final.heldout_score = cur.cv.score;
  rep.final.bic = cur.bic;
  // Rows the final model could not evaluate (the nominal model could): excluded from its scores, and listed.
  for (int k = 0; k < rows; ++k)
    if (s.evaluable[static_cast<std::size_t>(k)] && k < cur.fit.prediction.rows() &&
        !cur.fit.prediction.ok[static_cast<std::size_t>(k)])
      rep.failed_rows.push_back({s.origin[static_cast<std::size_t>(k)],
                                 cur.fit.prediction.failure[static_cast<std::size_t>(k)],
                                 cur.fit.prediction.message[static_cast<std::size_t>(k)], rep.final.model});
  // Rows reached through a snap are excluded (the landing state of a dynamic jump is uncertain) but are a physical
  // prediction of the model, not a failure of it: they count separately from the rows the model could not solve.
  int snapped = 0;
  for (const FailedRow& fr : rep.failed_rows) snapped += fr.failure == Failure::Snapped;
  const double failed_fraction = static_cast<double>(rep.failed_rows.size() - static_cast<std::size_t>(snapped)) / rows;
  rep.reliable = failed_fraction <= s.o.unreliable_fraction;
  if (!rep.reliable)
    rep.warnings.push_back(fmt("%.1f %% of the rows could not be evaluated (limit %.0f %%): the verdict is unreliable",
                               100 * failed_fraction, 100 * s.o.unreliable_fraction));
  if (snapped > 0)
    rep.warnings.push_back(
        fmt("%.0f row(s) are reached through a snap of the model (a jump to another equilibrium "
            "branch) and are excluded; the verdict rests on the other rows",
            snapped));
  // Effects fitted at a limit of their search range are bounds, not estimates: never named.
  std::map<std::string, std::string> at_limit;
  for (const Effect& e : cur.fit.effects) {
    const std::string limit = rangeLimitWords(s, e);
    if (!limit.empty()) at_limit[e.label()] = limit;
  }
  // The verdict: named library effects, each kind once (verdictNames).
  std::vector<std::vector<EffectKind>> entries;
  for (const Effect& e : cur.fit.effects) {
    if (s.confounded.count(e.label()) || isGeneric(e.kind) || at_limit.count(e.label()))
      continue;  // partial explanations, descriptions, bounds
    std::vector<EffectKind> kinds{e.kind};
    for (const Rival& r : s.rivals_of[e.label()]) kinds.push_back(r.effect.kind);
    entries.push_back(kinds);
  }
  rep.verdict = verdictNames(entries);
  // A noise estimated from neighbouring rows whose differences are serially correlated (a filtered or oversampled
  // stream) cannot be told from these data: no effect is established against it.
  std::vector<std::string> not_white;
  for (const auto& [q, e] : rep.noise.by_quantity)
    if (!e.white) not_white.push_back(toString(q));
  const std::vector<std::string> would_name = rep.verdict;
  if (!not_white.empty()) {
    rep.verdict.clear();
    rep.warnings.push_back("the noise of " + joinWords(not_white) +
                           " cannot be told from these data (serially correlated differences between neighbouring "
                           "rows): no effect is established; give --noise");
  }
  // `[]` without `unexplained` says that the nominal model explains the data within noise (docs/formats.md): not so
  // when effects would be named and only the noise is unknown. The baseline's mismatch is then the remainder.
  if (!not_white.empty() && !would_name.empty()) {
    Unexplained& u = rep.unexplained;
    const std::string would = joinWords(would_name) + " would explain against a noise these data cannot establish";
    if (!u.present) {
      u.present = true;
      u.fraction_explained = 0.0;
      u.heldout_rmse = rep.baseline.heldout_rmse;
      u.mismatch = rep.mismatch.findings;
      u.where = "the nominal model leaves a mismatch that " + would;
    } else {
      u.where += "; of the nominal model's mismatch, " + would;
    }
  }
  const std::string not_established =
      "not established: the noise of " + joinWords(not_white) +
      " cannot be told from these data (the differences between neighbouring rows are serially correlated: a "
      "filtered or oversampled stream, or model error from row to row); give --noise";
  // Findings: accepted ones report the final joint values.
  for (const std::string& key : s.order) {
    Finding f = s.last[key];
    if (s.removed.count(key)) {
      f.accepted = false;
      f.ambiguous_with.clear();
      f.explanation = "rejected: " + describePhysics(f.effect.kind) + "; " + s.removed[key] + ".";
    }
    for (const Effect& e : cur.fit.effects)
      if (e.label() == key) {
        f.accepted = true;
        f.effect = e;
        f.parameters = namedParameters(e, rep.final_uncertainty.count(key) ? &rep.final_uncertainty[key] : nullptr);
        f.partial = rep.unexplained.present;
        if (isGeneric(e.kind)) {
          f.named = false;
          f.partial = true;
          f.explanation = "describes the remainder, not named: " + describePhysics(e.kind) + "; " + f.explanation;
        } else if (s.removed_partial.count(key)) {
          f.named = false;
          f.explanation =
              "partial explanation, not named: " + describePhysics(e.kind) + "; " + s.removed_partial[key] + ".";
        }
        const auto limit = at_limit.find(key);
        if (limit != at_limit.end()) {
          f.at_range_limit = true;
          f.named = false;
          f.explanation += " " + limit->second + " Not named.";
          rep.warnings.push_back(key + ": " + limit->second);
        }
        if (!not_white.empty() && f.named) {
          f.named = false;
          f.explanation = not_established + ". " + f.explanation;
        }
      }
    const auto d = s.detection.find(key);
    if (!f.accepted && d != s.detection.end()) {
      f.detection_limit = d->second.value;
      f.explanation += (f.explanation.empty() || f.explanation.back() == '.' ? " " : ". ") + d->second.text + ".";
    }
    rep.findings.push_back(f);
  }
  std::stable_sort(rep.findings.begin(), rep.findings.end(),
                   [](const Finding& a, const Finding& b) { return a.accepted > b.accepted; });
  rep.plot.nominal = s.base.prediction;
  rep.plot.fitted = cur.fit.prediction;
  rep.plot.nominal_residuals = s.base.residuals;
  rep.plot.fitted_residuals = cur.fit.residuals;
  rep.plot.variables = configVariables(rec);
  rep.plot.final_mismatch = s.final_mismatch;

  // The summary: one account. "At the noise" only against a noise the recording supports (given, repeated poses,
  // or neighbour differences that do not grow with distance); "consistent with the noise" never next to a remainder.
  const Unexplained& u = rep.unexplained;
  const bool supported = rep.noise.supported();
  double base_p = 1.0;
  const double base_ratio = s.heldoutRatio(s.baseline_cv, base_p);
  const bool nominal_misses = !rep.mismatch.findings.empty() ||
                              (base_p < 0.5 * s.o.mismatch.alpha && base_ratio > 1.3) || !rep.verdict.empty() ||
                              u.present;
  std::string t;
  if (!rep.reliable)
    t += fmt("Unreliable: %.1f %% of the rows could not be evaluated by the model (see failed_rows). ",
             100 * failed_fraction);
  else if (!rep.failed_rows.empty())
    t += std::to_string(rep.failed_rows.size()) + " row(s) could not be evaluated and were excluded (failed_rows). ";
  if (!rep.outlier_rows.empty())
    t += std::to_string(rep.outlier_rows.size()) +
         " sample(s) look like tracker glitches and were left out (outlier_rows). ";
  int excluded = 0;
  for (const BranchAmbiguousRow& b : rep.branch_ambiguous_rows) excluded += b.excluded;
  if (excluded > 0)
    t += std::to_string(excluded) +
         " row(s) lie nearer another stable equilibrium of the model than the one replayed (the robot may have "
         "reached another branch by a path the recording does not show) and were excluded (branch_ambiguous_rows). ";
  if (!nominal_misses) {
    t += supported ? "The nominal model's residuals are consistent with the measurement noise"
                   : "The nominal model's residuals are no larger than the differences between neighbouring rows";
  } else if (!rep.mismatch.findings.empty()) {
    t += "The nominal model misses the recording: ";
    int k = 0;
    for (const auto& f : rep.mismatch.findings) {
      if (k++ >= 3) break;
      t += (k > 1 ? "; " : "") + f.where + fmt(" (p = %.2g)", f.p_value);
    }
  } else {
    t += fmt("The nominal model misses the recording: its held-out residuals are %.2f x the noise variance (p = %.2g)",
             base_ratio, base_p);
  }
  t += ". ";
  auto listEffects = [&](bool named) {
    std::string x;
    for (const Effect& e : cur.fit.effects) {
      const bool unnamed = s.confounded.count(e.label()) || at_limit.count(e.label());
      if (isGeneric(e.kind) || unnamed == named) continue;
      x += (x.empty() ? "" : ", ") + e.label() + " (" + e.valueText() + ")";
      const auto& rv = s.rivals_of[e.label()];
      if (!rv.empty()) {
        x += " or";
        for (std::size_t r = 0; r < rv.size(); ++r) x += (r ? ", " : " ") + rv[r].effect.label();
        x += " (this recording cannot tell them apart)";
      }
    }
    return x;
  };
  std::string rmse_change = "Held-out RMSE before -> after:";
  for (const auto& kv : rep.baseline.heldout_rmse) {
    const double after = rep.final.heldout_rmse.count(kv.first) ? rep.final.heldout_rmse.at(kv.first) : kv.second;
    rmse_change += " " + kv.first + fmt(" %.4g -> %.4g;", kv.second, after);
  }
  std::string described;
  for (const GenericDescription& g : u.described)
    described += (described.empty() ? "" : " ") + std::string("The remainder is described by ") + g.description +
                 fmt(" (held-out error %.0f %% lower with it, p = %.2g).", 100 * g.heldout_gain, g.heldout_p);
  const std::string partial = listEffects(false);
  if (!not_white.empty()) {
    t += "The noise of " + joinWords(not_white) +
         " cannot be told from these data: the differences between neighbouring rows are serially correlated (a "
         "filtered or oversampled stream, or model error from row to row), so they understate it and no effect is "
         "established. ";
    if (!would_name.empty())
      t += "Against that estimate the selection would name " + joinWords(would_name) + " (" + listEffects(true) + "). ";
    t += rmse_change + " Give --noise with the tracker's noise to test against it.";
    t += " Noise: " + noiseWords(rep.noise) + ".";
    rep.summary = t;
    return;
  }
  const std::string unknown_noise =
      " This recording cannot separate its noise from model error (the noise from neighbouring rows is an upper "
      "bound): give --noise to test against the tracker's noise.";
  if (rep.verdict.empty() && !u.present) {
    t += supported ? "No candidate effect improved both the held-out error and BIC, and the residuals are at the "
                     "noise: nothing was left out (within the noise)."
                   : "No candidate effect improved both the held-out error and BIC; nothing is named." + unknown_noise;
  } else if (rep.verdict.empty()) {
    t += "Not explained by any candidate: " + u.where +
         ". The cause is not in the candidate library, or this recording cannot identify it.";
    if (!described.empty()) t += " " + described;
    if (!partial.empty())
      t += " Candidates that absorb part of it without being the answer (partial explanations, not named): " + partial +
           fmt(" (together %.0f %% of the mismatch). ", 100 * u.fraction_explained) + rmse_change;
  } else {
    t += (u.present ? "Left out (a partial explanation): " : "Left out: ") + listEffects(true) + ". ";
    if (!partial.empty())
      t += "Also in the fit, but not named (they may stand in for part of the remainder; see their findings): " +
           partial + ". ";
    t += rmse_change;
    if (u.present) {
      t += fmt(" The candidates explain %.0f %% of the mismatch; ", 100 * u.fraction_explained) + u.where +
           ", which the candidate library does not explain.";
      if (!described.empty()) t += " " + described;
    } else {
      t += supported ? " The remaining residuals are at the noise."
                     : " The remaining residuals are no larger than the differences between neighbouring rows." +
                           unknown_noise;
    }
  }
  t += " Noise: " + noiseWords(rep.noise) + ".";
  rep.summary = t;
}

}  // namespace ctr::diagnosis::detail
