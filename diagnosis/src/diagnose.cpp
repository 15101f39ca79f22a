// The diagnosis driver: baseline, mismatch, candidate fits in parallel, forward selection, explanation.
#include "ctr/diagnosis/diagnose.hpp"

#include "parallel.hpp"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <mutex>
#include <set>
#include <stdexcept>
#include <thread>

#include "ctr/diagnosis/statistics.hpp"

namespace ctr::diagnosis {

namespace {

std::string fmt(const char* f, double a, double b = 0, double c = 0, double d = 0) {
  char buf[512];
  std::snprintf(buf, sizeof buf, f, a, b, c, d);
  return buf;
}

std::string modelName(const std::vector<Effect>& e) {
  std::string s = "nominal";
  for (const Effect& x : e) s += "+" + x.label();
  return s;
}

bool hasKind(const std::vector<EffectKind>& ks, EffectKind k) {
  return ks.empty() || std::find(ks.begin(), ks.end(), k) != ks.end();
}

/// A model of the selection: effects, full-data fit, cross-validation, BIC.
struct Candidate {
  Effect slot;
  FitResult fit;
  CrossValidation cv;
  bool cv_done = false;
  double bic = 0.0;
  double delta_bic = 0.0;
  double heldout_p = 1.0;
  double gain = 0.0;
  bool pass = false;
  bool failed = false;
  std::string reason;
};

std::string physics(EffectKind k) {
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
    case EffectKind::Precurvature: return "a tube's precurvature differing from its description";
    case EffectKind::BendingStiffness: return "a tube's bending stiffness (stiffness ratio) differing from its description";
    case EffectKind::ActuatorBacklash:
      return "a dead band in a rotation drive: after each reversal the tube does not turn until the play is taken up, "
             "giving a constant-width direction-dependent offset";
    case EffectKind::ActuatorOffset: return "a constant offset between commanded and true rotation of a tube";
    case EffectKind::SensorLatency:
      return "the measurement lagging the joint reading: a direction-dependent error whose size grows with the "
             "actuator speed rather than with the bending moment";
  }
  return "";
}

std::map<std::string, double> paramsOf(const Effect& e) {
  std::map<std::string, double> p;
  if (isPerTube(e.kind)) p["tube"] = e.tube;
  p[parameterName(e.kind)] = e.value;
  return p;
}

}  // namespace

std::vector<Effect> candidateSlots(const Robot& nominal, const io::Recording& rec, const DiagnoseOptions& o) {
  std::vector<Effect> s;
  const int n = nominal.size();
  auto add = [&](EffectKind k, int tube) {
    if (!hasKind(o.candidates, k)) return;
    Effect e;
    e.kind = k;
    e.tube = tube;
    e.value = nominalValue(nominal, k, tube);
    s.push_back(e);
  };
  auto rotates = [&](int i) {  // does tube i (0-based) rotate (absolute) in the recording?
    double lo = 1e300, hi = -1e300;
    for (const auto& q : rec.commands) {
      lo = std::min(lo, q.alpha[i]);
      hi = std::max(hi, q.alpha[i]);
    }
    return hi - lo > 1e-6;
  };
  if (n >= 2) {
    add(EffectKind::BoundaryFriction, 0);
    add(EffectKind::DistributedFriction, 0);
    add(EffectKind::TorsionalStiffness, 0);
  }
  for (int i = 1; i <= n; ++i)
    if (nominal.tube(i - 1).curved_length > 0 && nominal.tube(i - 1).curvature != 0) add(EffectKind::Precurvature, i);
  for (int i = 2; i <= n; ++i) add(EffectKind::BendingStiffness, i);
  for (int i = 1; i <= n; ++i)
    if (rotates(i - 1)) add(EffectKind::ActuatorBacklash, i);
  for (int i = (o.frame == FrameMode::Base ? 1 : 2); i <= n; ++i) add(EffectKind::ActuatorOffset, i);
  if (rec.hasTime() && rec.rows() > 2 && rec.time[rec.rows() - 1] > rec.time[0]) add(EffectKind::SensorLatency, 0);
  return s;
}

io::Recording decimateRecording(const io::Recording& in, int k) {
  io::Recording out;
  out.tubes = in.tubes;
  const int rows = in.rows();
  std::vector<int> keep;
  for (int r = 0; r < rows; r += k) keep.push_back(r);
  auto take = [&](const Eigen::MatrixXd& M) {
    if (M.cols() == 0) return Eigen::MatrixXd(0, 0);
    Eigen::MatrixXd o(static_cast<Eigen::Index>(keep.size()), M.cols());
    for (std::size_t j = 0; j < keep.size(); ++j) o.row(static_cast<Eigen::Index>(j)) = M.row(keep[j]);
    return o;
  };
  for (int r : keep) out.commands.push_back(in.commands[static_cast<std::size_t>(r)]);
  out.twist = take(in.twist);
  out.tip_position = take(in.tip_position);
  out.tip_tangent = take(in.tip_tangent);
  if (in.hasTime()) out.time = take(in.time);
  return out;
}

DiagnosisReport diagnose(const Robot& nominal, const io::Recording& full, const DiagnoseOptions& o) {
  const auto t0 = std::chrono::steady_clock::now();
  const int stride = (o.max_rows > 0 && full.rows() > o.max_rows) ? (full.rows() + o.max_rows - 1) / o.max_rows : 1;
  const io::Recording decimated = stride > 1 ? decimateRecording(full, stride) : io::Recording{};
  const io::Recording& rec = stride > 1 ? decimated : full;
  if (rec.tubes != nominal.size())
    throw std::invalid_argument("recording has " + std::to_string(rec.tubes) + " tubes, robot '" + nominal.name() +
                                "' has " + std::to_string(nominal.size()));
  const int rows = rec.rows();
  if (rows < 8) throw std::invalid_argument("recording has " + std::to_string(rows) + " rows; at least 8 are needed");
  std::mutex mu;
  auto progress = [&](const std::string& s) {
    if (!o.progress) return;
    std::lock_guard<std::mutex> lock(mu);
    const double el = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    o.progress(fmt("[%6.1f s] ", el) + s);
  };
  DiagnosisReport rep;
  rep.frame = o.frame;
  rep.rows = rows;
  rep.stride = stride;
  if (stride > 1)
    rep.warnings.push_back("the recording has " + std::to_string(full.rows()) + " rows; every " + std::to_string(stride) +
                           "th row was used (" + std::to_string(rows) + " rows) to bound the run time (max_rows = " +
                           std::to_string(o.max_rows) + ")");
  const std::vector<char> all(static_cast<std::size_t>(rows), 1);
  std::vector<char> lastBlock(static_cast<std::size_t>(rows), 0);
  {
    const std::vector<int> fold = foldOfRows(rows, o.folds);
    for (int k = 0; k < rows; ++k) lastBlock[static_cast<std::size_t>(k)] = fold[static_cast<std::size_t>(k)] == fold.back();
  }
  FitOptions fo;
  fo.frame = o.frame;
  fo.predict = o.predict;
  fo.max_iterations = o.max_iterations;
  Workspace ws;
  // 1. Baseline: replay, noise estimate (twice: the registration weights depend on it), residuals.
  progress("baseline: replaying " + std::to_string(rows) + " rows through the nominal model");
  FitResult base = evaluateModel(nominal, rec, {}, all, fo, ws);
  fo.noise = estimateNoise(rec, base.residuals);
  if (o.frame == FrameMode::Unknown) {
    base = evaluateModel(nominal, rec, {}, all, fo, ws);
    fo.noise = estimateNoise(rec, base.residuals);
    base = evaluateModel(nominal, rec, {}, all, fo, ws);
  }
  rep.noise = fo.noise;
  if (base.prediction.failures > 0)
    rep.warnings.push_back(std::to_string(base.prediction.failures) + " rows did not converge in the nominal model");
  rep.mismatch = locateMismatch(rec, base.prediction, base.residuals, fo.noise, o.mismatch);
  for (const auto& f : rep.mismatch.findings) progress("mismatch: " + f.signature + " " + f.variable + ": " + f.where);
  Candidate cur;
  cur.fit = base;
  cur.cv = crossValidate(nominal, rec, {}, o.folds, fo, ws, 6, o.threads);
  cur.bic = bic(rec, base.residuals, all, 0);
  rep.folds = std::min(o.folds, rows);
  rep.evaluations += base.evaluations + cur.cv.evaluations + 2;
  rep.baseline.model = "nominal";
  rep.baseline.heldout_rmse = cur.cv.rmse;
  rep.baseline.last_block_rmse = rmse(rec, cur.cv.heldout, lastBlock);
  rep.baseline.fit_rmse = rmse(rec, base.residuals, all);
  rep.baseline.heldout_score = cur.cv.score;
  rep.baseline.bic = cur.bic;
  const std::vector<Effect> slots = candidateSlots(nominal, rec, o);
  std::map<std::string, Finding> last;  // latest finding per slot label
  std::vector<std::string> order;
  const int chunks = std::max(3, std::min(24, rows / 3));
  // 2. Forward selection.
  for (int round = 1; round <= o.max_effects; ++round) {
    std::vector<Effect> todo;
    for (const Effect& s : slots) {
      bool in = false;
      for (const Effect& e : cur.fit.effects) in = in || e.sameSlot(s);
      // Distributed friction is expensive; once its probe showed no effect it is not retried on top.
      if (s.kind == EffectKind::DistributedFriction && last.count(s.label()) && !last[s.label()].heldout_rmse.size() &&
          last[s.label()].explanation.find("even mu") != std::string::npos)
        in = true;
      if (!in) todo.push_back(s);
    }
    if (todo.empty()) break;
    progress("round " + std::to_string(round) + ": fitting " + std::to_string(todo.size()) + " candidates on top of " +
             modelName(cur.fit.effects));
    std::vector<Candidate> cands(todo.size());
    std::atomic<int> evals{0};
    auto evaluateCandidate = [&](Candidate& c, Workspace& tws) {
      {
        std::vector<Effect> start = cur.fit.effects;
        start.push_back(c.slot);
        const int nprev = static_cast<int>(cur.fit.effects.size());
        if (c.slot.kind == EffectKind::DistributedFriction) {
          // Expensive (a root solve per integration step): probe one large coefficient before fitting.
          std::vector<Effect> probe = start;
          probe.back().value = 0.3;
          FitResult pr = evaluateModel(nominal, rec, probe, all, fo, tws);
          evals += pr.evaluations;
          const double pb = bic(rec, pr.residuals, all, static_cast<int>(start.size())) - cur.bic;
          if (pb > -0.5 * o.bic_threshold) {
            c.fit = std::move(pr);
            c.bic = cur.bic + pb;
            c.delta_bic = pb;
            c.reason = fmt("even mu = 0.3 changes BIC by only %+.1f: the distributed contact forces are too small to "
                           "produce the observed twist (as the paper found, sec. II.C)", pb);
            progress("  " + c.slot.label() + fmt(": probe mu = 0.3, dBIC = %+.1f; not fitted", pb));
            return;
          }
        }
        // Screening: only the new effect is fitted (grid + a few iterations), the accepted ones held.
        FitOptions so = fo;
        so.first_free = nprev;
        so.max_iterations = o.screen_iterations;
        so.function_tolerance = 1e-3;
        so.intervals = false;
        c.fit = fitEffects(nominal, rec, start, all, so, tws, nprev);
        evals += c.fit.evaluations;
        c.bic = bic(rec, c.fit.residuals, all, static_cast<int>(start.size()));
        c.delta_bic = c.bic - cur.bic;
        if (c.delta_bic < -o.bic_threshold) {
          // Joint refinement of all parameters with intervals, from the screening optimum.
          FitOptions jo = fo;
          FitResult joint = fitEffects(nominal, rec, c.fit.effects, all, jo, tws, static_cast<int>(start.size()));
          evals += joint.evaluations;
          const double jb = bic(rec, joint.residuals, all, static_cast<int>(start.size()));
          if (jb <= c.bic + 1e-9) {
            c.fit = std::move(joint);
            c.bic = jb;
            c.delta_bic = c.bic - cur.bic;
          }
        }
        if (c.delta_bic < -o.bic_threshold) {
          c.cv = crossValidate(nominal, rec, c.fit.effects, o.folds, fo, tws, o.cv_iterations, o.threads);
          c.cv_done = true;
          evals += c.cv.evaluations;
          c.heldout_p = stats::chunkedBootstrapTest(cur.cv.row_score, c.cv.row_score, chunks);
          c.gain = cur.cv.score > 0 ? 1.0 - c.cv.score / cur.cv.score : 0.0;
          c.pass = c.heldout_p < o.heldout_p && c.gain > o.min_heldout_gain;
          if (!c.pass)
            c.reason = fmt("it lowers BIC by %.1f but does not improve the held-out error enough (%.1f %% lower, p = %.2g)",
                           -c.delta_bic, 100 * c.gain, c.heldout_p);
        } else {
          c.reason = fmt("it does not lower BIC by more than %.0f (change %+.1f): the fit does not improve beyond "
                         "what one more parameter buys by chance",
                         o.bic_threshold, c.delta_bic);
        }
        progress("  " + c.slot.label() + ": " + parameterName(c.slot.kind) +
                 fmt(" = %.4g, dBIC = %+.1f", c.fit.effects.back().value, c.delta_bic) +
                 (c.cv_done ? fmt(", held-out gain %.1f %%, p = %.2g", 100 * c.gain, c.heldout_p) : std::string()));
      }
    };
    detail::parallelFor(static_cast<int>(todo.size()), o.threads, ws, [&](int i, Workspace& tws) {
      Candidate& c = cands[static_cast<std::size_t>(i)];
      c.slot = todo[static_cast<std::size_t>(i)];
      try {
        evaluateCandidate(c, tws);
      } catch (const std::exception& ex) {
        // E.g. a model the kinematics layer cannot evaluate: the candidate cannot be tried.
        c.pass = false;
        c.failed = true;
        c.delta_bic = std::numeric_limits<double>::quiet_NaN();
        c.reason = std::string("it could not be evaluated (") + ex.what() + ")";
        progress("  " + c.slot.label() + ": not evaluated: " + ex.what());
      }
    });
    rep.evaluations += evals;
    // Best passing candidate by BIC.
    int best = -1;
    for (std::size_t i = 0; i < cands.size(); ++i)
      if (cands[i].pass && (best < 0 || cands[i].bic < cands[static_cast<std::size_t>(best)].bic)) best = static_cast<int>(i);
    for (std::size_t i = 0; i < cands.size(); ++i) {
      Candidate& c = cands[i];
      Finding f;
      f.effect = c.fit.effects.empty() ? c.slot : c.fit.effects.back();
      f.model = c.fit.effects;
      if (f.model.empty()) {
        f.model = cur.fit.effects;
        f.model.push_back(c.slot);
      }
      f.round = round;
      f.accepted = static_cast<int>(i) == best;
      f.parameters = paramsOf(f.effect);
      if (!c.fit.interval95.empty()) f.interval95[parameterName(c.slot.kind)] = c.fit.interval95.back();
      if (c.cv_done) {
        f.heldout_rmse = c.cv.rmse;
        f.heldout_score = c.cv.score;
        f.heldout_p = c.heldout_p;
      }
      f.delta_bic = c.delta_bic;
      if (f.accepted) {
        f.explanation = "accepted: " + physics(c.slot.kind) + ". " +
                        fmt("Fitted on top of the previous model it lowers BIC by %.1f and the held-out error by %.1f %% "
                            "(one-sided p = %.2g over contiguous held-out blocks).",
                            -c.delta_bic, 100 * c.gain, c.heldout_p);
      } else if (c.pass && best >= 0) {
        const Candidate& w = cands[static_cast<std::size_t>(best)];
        f.explanation = "rejected: " + physics(c.slot.kind) + " explains less than the accepted " + w.slot.label() +
                        fmt(" (BIC %.1f vs %.1f higher; held-out gain %.1f %% vs %.1f %%).", c.bic - cur.bic,
                            w.bic - cur.bic, 100 * c.gain, 100 * w.gain);
      } else {
        f.explanation = "rejected: " + physics(c.slot.kind) + "; " + c.reason + ".";
      }
      const std::string key = c.slot.label();
      if (!last.count(key)) order.push_back(key);
      last[key] = f;
    }
    if (best < 0) {
      progress("round " + std::to_string(round) + ": no candidate improves held-out error and BIC; stopping");
      break;
    }
    cur = std::move(cands[static_cast<std::size_t>(best)]);
    progress("round " + std::to_string(round) + ": accepted " + cur.slot.label());
  }
  // 2b. Backward elimination: greedy forward steps can accept an effect that later ones make redundant.
  std::map<std::string, std::string> removed;
  while (cur.fit.effects.size() >= 2) {
    int drop = -1;
    double best_b = 0;
    FitResult best_fit;
    for (std::size_t j = 0; j < cur.fit.effects.size(); ++j) {
      std::vector<Effect> reduced = cur.fit.effects;
      reduced.erase(reduced.begin() + static_cast<long>(j));
      FitResult f = fitEffects(nominal, rec, reduced, all, fo, ws, static_cast<int>(reduced.size()));
      rep.evaluations += f.evaluations;
      const double b = bic(rec, f.residuals, all, static_cast<int>(reduced.size()));
      if (b - cur.bic < o.bic_threshold && (drop < 0 || b < best_b)) {
        drop = static_cast<int>(j);
        best_b = b;
        best_fit = std::move(f);
      }
    }
    if (drop < 0) break;
    const std::string lab = cur.fit.effects[static_cast<std::size_t>(drop)].label();
    removed[lab] = fmt("removed again after the later rounds: without it BIC changes by only %+.1f, so the other "
                       "accepted effects explain what it explained",
                       best_b - cur.bic);
    progress("backward elimination: removed " + lab);
    cur.fit = std::move(best_fit);
    cur.bic = best_b;
    cur.cv = crossValidate(nominal, rec, cur.fit.effects, o.folds, fo, ws, o.cv_iterations, o.threads);
  }
  // 3. Final model: fitted values with intervals (already from its full-data fit).
  rep.final_effects = cur.fit.effects;
  for (std::size_t j = 0; j < cur.fit.effects.size() && j < cur.fit.interval95.size(); ++j)
    rep.final_intervals[cur.fit.effects[j].label()] = cur.fit.interval95[j];
  rep.registration = cur.fit.registration;
  rep.final.model = modelName(cur.fit.effects);
  rep.final.effects = cur.fit.effects;
  rep.final.heldout_rmse = cur.cv.rmse;
  rep.final.last_block_rmse = rmse(rec, cur.cv.heldout, lastBlock);
  rep.final.fit_rmse = rmse(rec, cur.fit.residuals, all);
  rep.final.heldout_score = cur.cv.score;
  rep.final.bic = cur.bic;
  std::set<std::string> seen;
  for (const Effect& e : cur.fit.effects)
    if (seen.insert(effectName(e.kind)).second) rep.verdict.push_back(effectName(e.kind));
  // Accepted findings report the final joint values.
  for (const std::string& key : order) {
    Finding f = last[key];
    if (removed.count(key)) {
      f.accepted = false;
      f.explanation = "rejected: " + physics(f.effect.kind) + "; " + removed[key] + ".";
    }
    for (const Effect& e : cur.fit.effects)
      if (e.label() == key) {
        f.accepted = true;
        f.effect = e;
        f.parameters = paramsOf(e);
        f.interval95.clear();
        if (rep.final_intervals.count(key)) f.interval95[parameterName(e.kind)] = rep.final_intervals[key];
      }
    rep.findings.push_back(f);
  }
  std::stable_sort(rep.findings.begin(), rep.findings.end(),
                   [](const Finding& a, const Finding& b) { return a.accepted > b.accepted; });
  rep.plot.nominal = base.prediction;
  rep.plot.fitted = cur.fit.prediction;
  rep.plot.nominal_residuals = base.residuals;
  rep.plot.fitted_residuals = cur.fit.residuals;
  rep.plot.variables = configVariables(rec);
  rep.plot.final_mismatch = locateMismatch(rec, cur.fit.prediction, cur.fit.residuals, fo.noise, o.mismatch);
  // 4. Summary paragraph.
  std::string s;
  if (rep.mismatch.findings.empty()) {
    s += "The nominal model's residuals are consistent with the measurement noise";
  } else {
    s += "The nominal model misses the recording: ";
    int k = 0;
    for (const auto& f : rep.mismatch.findings) {
      if (k++ >= 3) break;
      s += (k > 1 ? "; " : "") + f.where + fmt(" (p = %.2g)", f.p_value);
    }
  }
  s += ". ";
  if (rep.verdict.empty()) {
    s += "No candidate effect improved both the held-out error and BIC, so the verdict is that nothing was left out "
         "(within the noise).";
  } else {
    s += "Left out: ";
    for (std::size_t j = 0; j < cur.fit.effects.size(); ++j) {
      const Effect& e = cur.fit.effects[j];
      s += (j ? ", " : "") + e.label() + " (" + parameterName(e.kind) + fmt(" = %.4g", e.value) + ")";
    }
    s += ". Held-out RMSE before -> after:";
    for (const auto& kv : rep.baseline.heldout_rmse) {
      const double after = rep.final.heldout_rmse.count(kv.first) ? rep.final.heldout_rmse.at(kv.first) : kv.second;
      s += " " + kv.first + fmt(" %.4g -> %.4g;", kv.second, after);
    }
  }
  rep.summary = s;
  rep.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  progress(fmt("done in %.1f s, %.0f replays", rep.seconds, rep.evaluations));
  return rep;
}

}  // namespace ctr::diagnosis
