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

#include "ctr/diagnosis/load_screen.hpp"
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
  bool probed_only = false;  ///< Not fitted: distributed friction probed at a large coefficient, or a load whose
                             ///< first-order screen predicts no BIC gain (screenLoads).
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
  }
  return "";
}

/// Name of fitted coordinate c of an effect, for messages ("mu", "force x", "gravity x" = scale * direction x).
std::string coordinateLabel(const Effect& e, int c) {
  if (parameterCount(e.kind) == 1) return parameterName(e.kind);
  const char* axis[] = {"x", "y", "z"};
  return std::string(e.kind == EffectKind::Gravity ? "scale*direction " : "force ") + axis[c];
}

bool isLoad(EffectKind k) {
  return k == EffectKind::Gravity || k == EffectKind::TipLoad;
}

}  // namespace

std::vector<Effect> candidateSlots(const Robot& nominal, const io::Recording& rec, const DiagnoseOptions& o) {
  std::vector<Effect> s;
  const int n = nominal.size();
  auto add = [&](EffectKind k, int tube) {
    if (!hasKind(o.candidates, k)) return;
    s.push_back(nominalEffect(nominal, k, tube));
  };
  // Does tube i (0-based) rotate (absolute) or translate in the recording?
  auto varies = [&](Eigen::VectorXd Configuration::*joint, int i) {
    double lo = 1e300, hi = -1e300;
    for (const auto& q : rec.commands) {
      lo = std::min(lo, (q.*joint)[i]);
      hi = std::max(hi, (q.*joint)[i]);
    }
    return hi - lo > 1e-6;
  };
  auto rotates = [&](int i) { return varies(&Configuration::alpha, i); };
  auto translates = [&](int i) { return varies(&Configuration::beta, i); };
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
  bool any_translation = false;
  for (int i = 1; i <= n; ++i) {
    if (!translates(i - 1)) continue;
    any_translation = true;
    add(EffectKind::TranslationBacklash, i);
  }
  // A zero error of one stage changes how far that tube extends relative to the others (a common shift of all
  // tubes moves the tip along z: absorbed by the registration in an unknown frame, observable in the base frame).
  if (any_translation)
    for (int i = 1; i <= n; ++i) add(EffectKind::TranslationOffset, i);
  // External loads (screened at first order before any loaded fit; diagnose()). Gravity needs a weight: the
  // description's linear densities, or nitinol's density with the diameters.
  if (gravityUnavailable(nominal).empty()) add(EffectKind::Gravity, 0);
  add(EffectKind::TipLoad, 0);
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

namespace {

/// The significant locate tests of a residual, in plain words (for `unexplained.where`).
std::string describeRemainder(const MismatchReport& m, double ratio) {
  // Up to three located bins (one phrase) and the first three other signatures, in order of significance.
  std::vector<std::string> parts, bins;
  std::set<std::string> seen;
  for (const MismatchFinding& f : m.findings) {
    std::string p;
    if (f.signature == "drift")
      p = "grows with time (drift)";
    else if (f.signature == "scales_with_speed")
      p = "grows with the actuator speed";
    else if (f.signature == "scales_with_moment")
      p = "grows with the concentrated bending moment";
    else if (f.signature == "direction_dependent")
      p = "depends on the direction of approach of " + f.variable;
    else if (f.signature == "constant")
      p = "is spread over all configurations (no direction, moment, speed or time dependence)";
    else if (f.signature == "exceeds_noise" && f.variable != "all") {
      const std::string b = f.where.substr(0, f.where.find(':'));
      if (bins.size() < 3 && seen.insert(b).second) bins.push_back(b);
      continue;
    }
    if (p.empty() || parts.size() >= 3 || !seen.insert(p).second) continue;
    parts.push_back(p);
  }
  auto join = [](const std::vector<std::string>& v) {
    std::string t;
    for (std::size_t k = 0; k < v.size(); ++k) t += (k ? (k + 1 == v.size() ? " and " : ", ") : "") + v[k];
    return t;
  };
  if (!bins.empty()) parts.insert(parts.begin(), "is largest at " + join(bins));
  std::string s = fmt("the held-out residuals are %.2f x the noise variance", ratio);
  if (parts.empty()) return s + " without a located structure";
  return s + " and the remainder " + join(parts);
}

}  // namespace

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
    rep.warnings.push_back("the recording has " + std::to_string(full.rows()) + " rows; every " +
                           std::to_string(stride) + "th row was used (" + std::to_string(rows) +
                           " rows) to bound the run time (max_rows = " + std::to_string(o.max_rows) + ")");
  const std::vector<char> all(static_cast<std::size_t>(rows), 1);
  std::vector<char> lastBlock(static_cast<std::size_t>(rows), 0);
  {
    const std::vector<int> fold = foldOfRows(rows, o.folds);
    for (int k = 0; k < rows; ++k)
      lastBlock[static_cast<std::size_t>(k)] = fold[static_cast<std::size_t>(k)] == fold.back();
  }
  FitOptions fo;
  fo.frame = o.frame;
  fo.predict = o.predict;
  CommandHistory history;  // a decimated recording's actuation effects act on the full-rate log
  if (stride > 1) {
    history.commands = full.commands;
    if (full.hasTime()) history.time = full.time;
    for (int r = 0; r < full.rows(); r += stride) history.rows.push_back(r);
    fo.predict.history = &history;
  }
  fo.max_iterations = o.max_iterations;
  Workspace ws;
  // 1. Baseline: replay, failed rows, noise estimate (twice: the registration weights depend on it), residuals.
  progress("baseline: replaying " + std::to_string(rows) + " rows through the nominal model");
  FitResult base = evaluateModel(nominal, rec, {}, all, fo, ws);
  // Rows the nominal model cannot evaluate are left out of every residual, fit, noise estimate and score.
  std::vector<char> evaluable(static_cast<std::size_t>(rows), 0);
  int nfailed = 0;
  for (int k = 0; k < rows; ++k) {
    evaluable[static_cast<std::size_t>(k)] = base.prediction.ok[static_cast<std::size_t>(k)];
    if (evaluable[static_cast<std::size_t>(k)]) continue;
    ++nfailed;
    rep.failed_rows.push_back({k * stride + 1, base.prediction.reason[static_cast<std::size_t>(k)], "nominal"});
  }
  if (nfailed == rows)
    throw std::runtime_error(
        "the nominal model could not evaluate any row of the recording (row 1: " + base.prediction.reason[0] + ")");
  if (nfailed > 0) {
    rep.warnings.push_back(std::to_string(nfailed) + " of " + std::to_string(rows) +
                           " rows could not be evaluated by the nominal model and are excluded from every residual, "
                           "fit, noise estimate and score (failed_rows)");
    progress(rep.warnings.back());
  }
  fo.rows = evaluable;  // (the registration already skipped them: their predictions are NaN)
  fo.noise = estimateNoise(rec, base.residuals);
  if (o.frame == FrameMode::Unknown) {
    base = evaluateModel(nominal, rec, {}, all, fo, ws);
    fo.noise = estimateNoise(rec, base.residuals);
    base = evaluateModel(nominal, rec, {}, all, fo, ws);
  }
  rep.noise = fo.noise;
  // Fits that run alone (not beside other fits): their difference and grid points are replayed on every thread.
  FitOptions fo_alone = fo;
  fo_alone.threads = o.threads;
  rep.mismatch = locateMismatch(rec, base.prediction, base.residuals, fo.noise, o.mismatch);
  for (const auto& f : rep.mismatch.findings) progress("mismatch: " + f.signature + " " + f.variable + ": " + f.where);
  // BIC difference of model b over model a, on the rows both evaluated (a model that fails on a row is never
  // compared on fewer rows than its rival).
  auto deltaBic = [&](const Residuals& a, int ka, const Residuals& b, int kb) {
    const std::vector<char> m = commonRows(a, b, evaluable);
    return bic(rec, b, m, kb) - bic(rec, a, m, ka);
  };
  auto nparams = [](const std::vector<Effect>& e) { return coordinateCount(e); };
  Candidate cur;
  cur.fit = base;
  cur.cv = crossValidate(nominal, rec, {}, o.folds, fo, ws, 6, o.threads);
  cur.bic = bic(rec, base.residuals, evaluable, 0);
  rep.folds = std::min(o.folds, rows);
  rep.evaluations += base.evaluations + cur.cv.evaluations + 2;
  rep.baseline.model = "nominal";
  rep.baseline.heldout_rmse = cur.cv.rmse;
  rep.baseline.last_block_rmse = rmse(rec, cur.cv.heldout, lastBlock);
  rep.baseline.fit_rmse = rmse(rec, base.residuals, evaluable);
  rep.baseline.heldout_score = cur.cv.score;
  rep.baseline.bic = cur.bic;
  const CrossValidation baseline_cv = cur.cv;
  const std::vector<Effect> slots = candidateSlots(nominal, rec, o);
  if (hasKind(o.candidates, EffectKind::Gravity) && !gravityUnavailable(nominal).empty())
    rep.warnings.push_back("gravity was not tried: " + gravityUnavailable(nominal));
  std::map<std::string, Finding> last;                  // latest finding per slot label
  std::map<std::string, std::vector<Rival>> rivals_of;  // accepted label -> look-alikes it cannot be told from
  std::vector<std::string> order;
  const int chunks = std::max(3, std::min(24, rows / 3));
  std::vector<LoadScreen> load_screens;  // of the current round
  // 2. Forward selection.
  for (int round = 1; static_cast<int>(cur.fit.effects.size()) < o.max_effects; ++round) {
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
    {
      // First-order screen of the loads on top of the current model (shared by the load candidates of the round).
      std::vector<Effect> loads;
      for (const Effect& s : todo)
        if (isLoad(s.kind)) loads.push_back(s);
      if (!loads.empty()) {
        try {
          load_screens = screenLoads(nominal, rec, cur.fit.effects, cur.fit, loads, all, fo_alone, ws);
        } catch (const std::exception& ex) {
          load_screens.clear();
          progress(std::string("  loads: first-order screen failed: ") + ex.what());
        }
        rep.evaluations += 1;
      }
    }
    // Held-out test of a candidate's model against the current one, on the rows both evaluated: cross-validation
    // (one-step from its linearisation when asked and available), bootstrap p and gain. Returns the replays used.
    auto heldOut = [&](Candidate& c, Workspace& tws, int threads, bool one_step) {
      c.cv = crossValidate(nominal, rec, c.fit.effects, o.folds, fo, tws, o.cv_iterations, threads,
                           one_step ? &c.fit : nullptr);
      c.cv_done = true;
      c.heldout_p = stats::chunkedBootstrapTest(cur.cv.row_score, c.cv.row_score, chunks);
      const auto means = commonMeans(cur.cv.row_score, c.cv.row_score);
      c.gain = means[0] > 0 ? 1.0 - means[1] / means[0] : 0.0;
      return c.cv.evaluations;
    };
    // Phase 1 (every candidate): screening -- only the new effect is fitted (grid + a few iterations), the accepted
    // ones held.
    auto screenCandidate = [&](Candidate& c, Workspace& tws) {
      // Accepted look-alikes of the candidate's group are refitted with it (a look-alike accepted earlier may have
      // absorbed part of this one); the others are held.
      std::vector<Effect> start, freed;
      for (const Effect& e : cur.fit.effects) (areLookAlikes(e.kind, c.slot.kind) ? freed : start).push_back(e);
      const int first_free = static_cast<int>(start.size());
      start.insert(start.end(), freed.begin(), freed.end());
      start.push_back(c.slot);
      const int nprev = static_cast<int>(cur.fit.effects.size());
      if (c.slot.kind == EffectKind::DistributedFriction) {
        // Expensive (a root solve per integration step): probe one large coefficient before fitting.
        std::vector<Effect> probe = start;
        probe.back().value = 0.3;
        FitResult pr = evaluateModel(nominal, rec, probe, all, fo, tws);
        evals += pr.evaluations;
        const double pb = deltaBic(cur.fit.residuals, nparams(cur.fit.effects), pr.residuals, nparams(start));
        if (pb > -0.5 * o.bic_threshold) {
          c.fit = std::move(pr);
          c.bic = cur.bic + pb;
          c.delta_bic = pb;
          c.probed_only = true;
          c.reason =
              fmt("even mu = 0.3 changes BIC by only %+.1f: the distributed contact forces are too small to "
                  "produce the observed twist (as the paper found, sec. II.C)",
                  pb);
          progress("  " + c.slot.label() + fmt(": probe mu = 0.3, dBIC = %+.1f; not fitted", pb));
          return;
        }
      }
      FitOptions so = fo;
      so.first_free = first_free;
      so.max_iterations = o.screen_iterations;
      so.function_tolerance = 1e-3;
      so.intervals = false;
      so.gate_bic = 0.5 * o.bic_threshold;
      int grid_from = nprev;
      if (isLoad(c.slot.kind)) {
        // Loads: the first-order screen (one replay per round for all loads, then warm loaded solves per row)
        // decides whether the loaded fit is worth its replays, and gives its start (no grid, no gate).
        const LoadScreen* ls = nullptr;
        for (const LoadScreen& x : load_screens)
          if (x.effect.sameSlot(c.slot)) ls = &x;
        if (!ls || !ls->ok) throw std::runtime_error(ls ? ls->message : "no first-order screen");
        start.back() = ls->effect;
        if (ls->predicted_delta_bic > -0.5 * o.bic_threshold) {
          c.fit.effects = start;
          c.delta_bic = ls->predicted_delta_bic;
          c.bic = cur.bic + c.delta_bic;
          c.probed_only = true;
          c.reason = fmt("its first-order screen (the model linearised in the load at every row, least squares on "
                         "the residuals) predicts a BIC change of only %+.1f at ",
                         ls->predicted_delta_bic) +
                     ls->effect.valueText() + ", so no loaded fit was run";
          progress("  " + c.slot.label() + ": first-order " + ls->effect.valueText() +
                   fmt(", predicted dBIC = %+.1f; not fitted", ls->predicted_delta_bic));
          return;
        }
        progress("  " + c.slot.label() + ": first-order " + ls->effect.valueText() +
                 fmt(", predicted dBIC = %+.1f; fitting", ls->predicted_delta_bic));
        so.gate_bic = 0.0;
        grid_from = static_cast<int>(start.size());
      }
      c.fit = fitEffects(nominal, rec, start, all, so, tws, grid_from);
      evals += c.fit.evaluations;
      c.delta_bic = deltaBic(cur.fit.residuals, nparams(cur.fit.effects), c.fit.residuals, nparams(start));
      c.bic = cur.bic + c.delta_bic;
      if (c.delta_bic >= -o.bic_threshold)
        c.reason =
            fmt("it does not lower BIC by more than %.0f (change %+.1f): the fit does not improve beyond "
                "what one more parameter buys by chance",
                o.bic_threshold, c.delta_bic);
      progress("  " + c.slot.label() + ": " + c.fit.effects.back().valueText() +
               fmt(", screening dBIC = %+.1f", c.delta_bic));
    };
    // Phase 2 (finalists): the linearisation of the screened model in all its parameters (intervals, and the
    // one-step held-out test from it). The winner alone is then refined jointly (below).
    auto refineCandidate = [&](Candidate& c, Workspace& tws) {
      c.fit = linearizeModel(nominal, rec, c.fit.effects, all, fo, tws);
      evals += c.fit.evaluations;
      evals += heldOut(c, tws, 1, o.one_step_cv);
      // Near the decision the one-step folds (a linearisation) are not trusted: the folds are refitted iteratively.
      if (o.one_step_cv && c.gain > 0 && c.heldout_p > 0.2 * o.heldout_p && c.heldout_p < 5 * o.heldout_p)
        evals += heldOut(c, tws, 1, false);
      c.pass = c.heldout_p < o.heldout_p && c.gain > o.min_heldout_gain;
      if (!c.pass)
        c.reason = fmt("it lowers BIC by %.1f but does not improve the held-out error enough (%.1f %% lower, p = %.2g)",
                       -c.delta_bic, 100 * c.gain, c.heldout_p);
      progress("  " + c.slot.label() + ": " + c.fit.effects.back().valueText() + fmt(", dBIC = %+.1f", c.delta_bic) +
               fmt(", held-out gain %.1f %%, p = %.2g", 100 * c.gain, c.heldout_p));
    };
    auto guarded = [&](Candidate& c, Workspace& tws, const std::function<void(Candidate&, Workspace&)>& fn) {
      try {
        fn(c, tws);
      } catch (const std::exception& ex) {
        // E.g. a model the kinematics layer cannot evaluate: the candidate cannot be tried.
        c.pass = false;
        c.failed = true;
        c.delta_bic = std::numeric_limits<double>::quiet_NaN();
        c.reason = std::string("it could not be evaluated (") + ex.what() + ")";
        progress("  " + c.slot.label() + ": not evaluated: " + ex.what());
      }
    };
    detail::parallelFor(static_cast<int>(todo.size()), o.threads, ws, [&](int i, Workspace& tws) {
      Candidate& c = cands[static_cast<std::size_t>(i)];
      c.slot = todo[static_cast<std::size_t>(i)];
      guarded(c, tws, screenCandidate);
    });
    load_screens.clear();
    // Finalists: the best few by screening BIC (and every one within twice the threshold of the best, so that
    // look-alikes are compared on equal terms); the others cannot win the round.
    std::vector<int> ranked;
    for (std::size_t i = 0; i < cands.size(); ++i)
      if (!cands[i].failed && !cands[i].probed_only && cands[i].delta_bic < -o.bic_threshold)
        ranked.push_back(static_cast<int>(i));
    std::stable_sort(ranked.begin(), ranked.end(), [&](int a, int b) {
      return cands[static_cast<std::size_t>(a)].delta_bic < cands[static_cast<std::size_t>(b)].delta_bic;
    });
    std::vector<int> finalists;
    for (std::size_t r = 0; r < ranked.size(); ++r) {
      const Candidate& c = cands[static_cast<std::size_t>(ranked[r])];
      if (static_cast<int>(r) < o.finalists ||
          c.delta_bic < cands[static_cast<std::size_t>(ranked[0])].delta_bic + 2 * o.bic_threshold)
        finalists.push_back(ranked[r]);
      else
        cands[static_cast<std::size_t>(ranked[r])].reason =
            fmt("its screening fit lowers BIC by %.1f, ", -c.delta_bic) +
            fmt("%.1f less than the best candidate of the round: it cannot win the round, so it was not refined or "
                "cross-validated",
                c.delta_bic - cands[static_cast<std::size_t>(ranked[0])].delta_bic);
    }
    detail::parallelFor(static_cast<int>(finalists.size()), o.threads, ws, [&](int i, Workspace& tws) {
      guarded(cands[static_cast<std::size_t>(finalists[static_cast<std::size_t>(i)])], tws, refineCandidate);
    });
    rep.evaluations += evals;
    // Best passing candidate by BIC ...
    int best = -1;
    for (std::size_t i = 0; i < cands.size(); ++i)
      if (cands[i].pass && (best < 0 || cands[i].bic < cands[static_cast<std::size_t>(best)].bic))
        best = static_cast<int>(i);
    // ... unless another passing candidate predicts the held-out rows significantly better: in-sample BIC and
    // held-out prediction disagree when a candidate with more parameters mimics the left-out physics on this path
    // (e.g. a large tip load plus a precurvature standing in for a torsional stiffness), and the held-out test is the
    // one the verdict rests on.
    if (best >= 0 && cands[static_cast<std::size_t>(best)].cv_done) {
      const Candidate& W = cands[static_cast<std::size_t>(best)];
      int better = -1;
      double better_p = o.heldout_p;
      for (std::size_t i = 0; i < cands.size(); ++i) {
        const Candidate& c = cands[i];
        if (static_cast<int>(i) == best || !c.pass || !c.cv_done || !(c.gain > W.gain)) continue;
        const double p = stats::chunkedBootstrapTest(W.cv.row_score, c.cv.row_score, chunks);
        if (p < better_p) {
          better = static_cast<int>(i);
          better_p = p;
        }
      }
      if (better >= 0) {
        const Candidate& c = cands[static_cast<std::size_t>(better)];
        progress("held-out: " + c.slot.label() + " predicts the held-out rows better than " + W.slot.label() +
                 fmt(" (gain %.1f %% vs %.1f %%, p = %.2g) though its BIC is %.1f higher; it wins the round", 100 * c.gain,
                     100 * W.gain, better_p, c.bic - W.bic));
        best = better;
      }
    }
    // Look-alikes: before accepting the best of the group, test it against the best screened rivals of its group
    // with encompassing fits: both together, then does each add on top of the other? Only the one that
    // adds is named; when neither adds, the recording cannot tell them apart; when both add, both are present and
    // are accepted together from their joint fit (a look-alike accepted alone absorbs part of the other -- e.g.
    // latency absorbing one joint's backlash -- and the other then screens too small on top of it).
    std::map<int, std::string> rival_note;  // candidate index -> why it lost to (or ties with) the winner
    std::vector<Rival> ties;
    std::vector<int> partners;  // look-alikes accepted together with the winner (each adds on top of it and it on
                                // top of each)
    Candidate pair;             // the model with the winner and its partners
    if (best >= 0 && isLookAlike(cands[static_cast<std::size_t>(best)].slot.kind)) {
      // Rivals: the best (by screening BIC) up to 4 candidates of the winner's group that lower BIC by more than
      // the threshold on their own, finalists or not.
      std::vector<int> rv;
      for (int i : ranked) {
        const Candidate& c = cands[static_cast<std::size_t>(i)];
        if (i == best || c.failed || !areLookAlikes(c.slot.kind, cands[static_cast<std::size_t>(best)].slot.kind))
          continue;
        if (rv.size() < 4) rv.push_back(i);
      }
      struct Encompassing {
        double add_winner = 0, add_rival = 0;  // BIC drop of adding each on top of the other
        bool ok = false;
        FitResult joint;
      };
      std::vector<Encompassing> enc(rv.size());
      evals = 0;
      const Candidate& W = cands[static_cast<std::size_t>(best)];
      // W's screening model lists the accepted effects outside its group first (screenCandidate).
      int group_start = 0;
      for (const Effect& e : cur.fit.effects) group_start += !areLookAlikes(e.kind, W.slot.kind);
      detail::parallelFor(static_cast<int>(rv.size()), o.threads, ws, [&](int j, Workspace& tws) {
        const Candidate& R = cands[static_cast<std::size_t>(rv[static_cast<std::size_t>(j)])];
        std::vector<Effect> both = W.fit.effects;
        both.push_back(R.fit.effects.back());
        FitOptions jo = fo;
        jo.intervals = false;
        // As in screening: the accepted effects outside the group are held (W's and R's screening fits held them
        // too, so the BIC comparisons are like for like); the group's accepted members, W and R are fitted.
        jo.first_free = group_start;
        try {
          const FitResult J = fitEffects(nominal, rec, both, all, jo, tws, static_cast<int>(both.size()));
          evals += J.evaluations;
          const int k = nparams(both);
          enc[static_cast<std::size_t>(j)] = {deltaBic(J.residuals, k, R.fit.residuals, nparams(R.fit.effects)),
                                              deltaBic(J.residuals, k, W.fit.residuals, nparams(W.fit.effects)), true,
                                              J};
        } catch (const std::exception&) {
          enc[static_cast<std::size_t>(j)].ok = false;
        }
      });
      rep.evaluations += evals;
      // Rivals that may tie or win need their own held-out scores.
      evals = 0;
      detail::parallelFor(static_cast<int>(rv.size()), o.threads, ws, [&](int j, Workspace& tws) {
        Candidate& R = cands[static_cast<std::size_t>(rv[static_cast<std::size_t>(j)])];
        const Encompassing& e = enc[static_cast<std::size_t>(j)];
        if (!R.cv_done && e.ok && e.add_winner <= o.bic_threshold) guarded(R, tws, refineCandidate);
      });
      rep.evaluations += evals;
      int switch_to = -1;
      std::vector<int> both_add;  // rivals that each add on top of the winner and the winner on top of them
      for (std::size_t j = 0; j < rv.size(); ++j) {
        const int i = rv[j];
        const Candidate& R = cands[static_cast<std::size_t>(i)];
        const Encompassing& e = enc[j];
        if (!e.ok) continue;
        const bool w_adds = e.add_winner > o.bic_threshold, r_adds = e.add_rival > o.bic_threshold;
        const std::string wl = W.slot.label(), rl = R.slot.label();
        progress("look-alikes: " + wl + " vs " + rl +
                 fmt(": on top of each other they lower BIC by %.1f and %.1f", e.add_winner, e.add_rival));
        if (w_adds && !r_adds) {
          rival_note[i] = "its look-alike " + wl + " explains what it explains and more (on top of it, " + wl +
                          fmt(" lowers BIC by %.1f; on top of ", e.add_winner) + wl +
                          fmt(", it lowers BIC by only %.1f)", e.add_rival);
        } else if (r_adds && !w_adds && R.pass) {
          if (switch_to < 0 || R.bic < cands[static_cast<std::size_t>(switch_to)].bic) switch_to = i;
          rival_note[best] = "its look-alike " + rl + " explains what it explains and more (on top of it, " + rl +
                             fmt(" lowers BIC by %.1f; the reverse only %.1f)", e.add_rival, e.add_winner);
        } else if (w_adds && r_adds) {
          rival_note[i] =
              "both it and " + wl + fmt(" add on top of each other (BIC %.1f and %.1f)", -e.add_rival, -e.add_winner);
          both_add.push_back(static_cast<int>(j));
        } else {
          Rival r;
          r.effect = R.fit.effects.back();
          r.delta_bic = R.delta_bic;
          r.heldout_rmse = R.cv.rmse;
          r.heldout_p = stats::chunkedBootstrapTest(R.cv.row_score, W.cv.row_score, chunks);
          r.why =
              fmt("alone they fit equally well (BIC %.1f apart); together, neither adds on top of the other (BIC "
                  "%.1f and %.1f)",
                  R.bic - W.bic, -e.add_winner, -e.add_rival);
          if (r.heldout_p < o.heldout_p) {
            rival_note[i] =
                "it fits as well in-sample but " + wl + fmt(" predicts held-out rows better (p = %.2g)", r.heldout_p);
          } else {
            rival_note[i] = "this recording cannot tell it from " + wl + " (" + r.why + ")";
            ties.push_back(r);
          }
        }
      }
      // Partners: per kind, the rival that adds most. A kind whose second-best slot (another tube) adds nearly as
      // much (within the threshold) is ambiguous between its slots: then no partner is taken, the winner is
      // accepted alone and the next round, which refits it with each of them, decides.
      bool ambiguous_slots = false;
      for (int j : both_add) {
        const EffectKind kind = cands[static_cast<std::size_t>(rv[static_cast<std::size_t>(j)])].slot.kind;
        int top = -1;
        for (int jj : both_add)
          if (cands[static_cast<std::size_t>(rv[static_cast<std::size_t>(jj)])].slot.kind == kind &&
              (top < 0 || enc[static_cast<std::size_t>(jj)].add_rival > enc[static_cast<std::size_t>(top)].add_rival))
            top = jj;
        if (top != j) {
          if (enc[static_cast<std::size_t>(top)].add_rival - enc[static_cast<std::size_t>(j)].add_rival <
              o.bic_threshold) {
            progress("look-alikes: " + cands[static_cast<std::size_t>(rv[static_cast<std::size_t>(top)])].slot.label() +
                     " and " + cands[static_cast<std::size_t>(rv[static_cast<std::size_t>(j)])].slot.label() +
                     " add on top of " + W.slot.label() + " about equally; " + W.slot.label() + " accepted alone");
            ambiguous_slots = true;
          }
          continue;
        }
        partners.push_back(rv[static_cast<std::size_t>(j)]);
      }
      if (ambiguous_slots) partners.clear();
      // Strongest partners first, within the room left under max_effects.
      std::stable_sort(partners.begin(), partners.end(), [&](int a, int b) {
        auto add = [&](int i) {
          for (std::size_t j = 0; j < rv.size(); ++j)
            if (rv[j] == i) return enc[j].add_rival;
          return 0.0;
        };
        return add(a) > add(b);
      });
      const int room = o.max_effects - static_cast<int>(cur.fit.effects.size()) - 1;
      if (static_cast<int>(partners.size()) > room) partners.resize(static_cast<std::size_t>(std::max(0, room)));
      if (switch_to >= 0) {
        progress("look-alikes: " + cands[static_cast<std::size_t>(switch_to)].slot.label() + " explains what " +
                 W.slot.label() + " explains and more; accepted instead");
        best = switch_to;
        ties.clear();  // the rivals were compared with the former winner only
        partners.clear();
      } else if (!partners.empty()) {
        // All present: the winner and its partners from their joint fit, with their own held-out test against the
        // current model.
        Candidate P;
        P.slot = W.slot;
        // Started from the encompassing fit with the strongest partner (converged in the group's parameters).
        std::vector<Effect> start;
        for (std::size_t j = 0; j < rv.size(); ++j)
          if (rv[j] == partners.front()) start = enc[j].joint.effects;
        for (std::size_t i = 1; i < partners.size(); ++i)
          start.push_back(cands[static_cast<std::size_t>(partners[i])].fit.effects.back());
        const int k = nparams(start);
        P.fit = fitEffects(nominal, rec, start, all, fo_alone, ws, k);  // + intervals, linearisation
        rep.evaluations += P.fit.evaluations;
        P.delta_bic = deltaBic(cur.fit.residuals, nparams(cur.fit.effects), P.fit.residuals, k);
        P.bic = cur.bic + P.delta_bic;
        rep.evaluations += heldOut(P, ws, o.threads, o.one_step_cv);
        P.pass = P.delta_bic < -(1.0 + partners.size()) * o.bic_threshold && P.heldout_p < o.heldout_p &&
                 P.gain > o.min_heldout_gain;
        std::string names = W.slot.label();
        for (int i : partners) names += " + " + cands[static_cast<std::size_t>(i)].slot.label();
        if (P.pass) {
          progress("look-alikes: " + names + " each add on top of the other; accepted together" +
                   fmt(" (dBIC %+.1f, held-out gain %.1f %%)", P.delta_bic, 100 * P.gain));
          pair = std::move(P);
        } else {
          partners.clear();
        }
      }
    }
    if (best >= 0 && !partners.empty()) {
      // The joint values for the winner's and the partners' findings; the model of the round has them all.
      const std::size_t k = pair.fit.effects.size(), m = partners.size();
      auto take = [&](Candidate& c, std::size_t at) {
        c.fit.effects.back() = pair.fit.effects[at];
        if (pair.fit.uncertainty.size() == k) {
          c.fit.uncertainty.assign(c.fit.effects.size(), EffectUncertainty{});
          c.fit.uncertainty.back() = pair.fit.uncertainty[at];
        }
        c.delta_bic = pair.delta_bic;
        c.gain = pair.gain;
        c.heldout_p = pair.heldout_p;
        c.cv = pair.cv;
        c.cv_done = true;
      };
      take(cands[static_cast<std::size_t>(best)], k - m - 1);
      for (std::size_t j = 0; j < m; ++j) take(cands[static_cast<std::size_t>(partners[j])], k - m + j);
    } else if (best >= 0) {
      // The winner's joint refinement of all parameters (from the screening optimum), its intervals and its
      // held-out scores at the refined values.
      Candidate& W = cands[static_cast<std::size_t>(best)];
      const int k = nparams(W.fit.effects);
      FitResult joint = fitEffects(nominal, rec, W.fit.effects, all, fo_alone, ws, k);
      rep.evaluations += joint.evaluations;
      if (deltaBic(W.fit.residuals, k, joint.residuals, k) <= 1e-9) {
        W.fit = std::move(joint);
        W.delta_bic = deltaBic(cur.fit.residuals, nparams(cur.fit.effects), W.fit.residuals, k);
        W.bic = cur.bic + W.delta_bic;
        rep.evaluations += heldOut(W, ws, o.threads, o.one_step_cv);
      }
    }
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
      const bool partner = std::find(partners.begin(), partners.end(), static_cast<int>(i)) != partners.end();
      f.accepted = static_cast<int>(i) == best || partner;
      f.parameters = namedParameters(f.effect, c.fit.uncertainty.empty() ? nullptr : &c.fit.uncertainty.back());
      if (c.cv_done) {
        f.heldout_rmse = c.cv.rmse;
        f.heldout_score = c.cv.score;
        f.heldout_p = c.heldout_p;
      }
      f.delta_bic = c.delta_bic;
      const auto note = rival_note.find(static_cast<int>(i));
      if (f.accepted && !partners.empty()) {
        std::string others;
        for (int x : partners)
          if (x != static_cast<int>(i))
            others += (others.empty() ? "" : ", ") + cands[static_cast<std::size_t>(x)].slot.label();
        if (static_cast<int>(i) != best)
          others = cands[static_cast<std::size_t>(best)].slot.label() + (others.empty() ? "" : ", " + others);
        f.explanation = "accepted together with its look-alike(s) " + others + ": " + physics(c.slot.kind) + ". " +
                        (note != rival_note.end() ? note->second + ". " : std::string()) +
                        fmt("Fitted together on top of the previous model they lower BIC by %.1f and the held-out "
                            "error by %.1f %% (one-sided p = %.2g).",
                            -c.delta_bic, 100 * c.gain, c.heldout_p);
      } else if (f.accepted) {
        f.explanation =
            "accepted: " + physics(c.slot.kind) + ". " +
            fmt("Fitted on top of the previous model it lowers BIC by %.1f and the held-out error by %.1f %% "
                "(one-sided p = %.2g over contiguous held-out blocks).",
                -c.delta_bic, 100 * c.gain, c.heldout_p);
        if (!ties.empty()) {
          f.ambiguous_with = ties;
          f.explanation += " This recording cannot tell it from";
          for (std::size_t t = 0; t < ties.size(); ++t) f.explanation += (t ? ", " : " ") + ties[t].effect.label();
          f.explanation += " (" + ties.front().why + ").";
        }
      } else if (note != rival_note.end()) {
        f.explanation = "rejected: " + physics(c.slot.kind) + "; " + note->second + ".";
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
    if (!partners.empty()) {
      for (int x : partners) rivals_of[cands[static_cast<std::size_t>(x)].slot.label()] = {};
      cur = std::move(pair);
    } else {
      cur = std::move(cands[static_cast<std::size_t>(best)]);
    }
    rivals_of[cur.slot.label()] = ties;
    progress("round " + std::to_string(round) + ": accepted " + cur.slot.label() +
             (ties.empty() ? std::string() : " (tied with " + std::to_string(ties.size()) + " look-alike(s))"));
  }
  // 2b. Backward elimination: greedy forward steps can accept an effect that later ones make redundant.
  std::map<std::string, std::string> removed;
  std::map<std::string, std::string> removed_partial;  // accepted, kept in the final model, not named
  auto without_effects = [&](const std::vector<std::size_t>& drop) {
    std::vector<Effect> reduced;
    for (std::size_t j = 0; j < cur.fit.effects.size(); ++j)
      if (std::find(drop.begin(), drop.end(), j) == drop.end()) reduced.push_back(cur.fit.effects[j]);
    return reduced;
  };
  auto refitWithout = [&](const std::vector<std::size_t>& drop) {
    const std::vector<Effect> reduced = without_effects(drop);
    return fitEffects(nominal, rec, reduced, all, fo_alone, ws, nparams(reduced));
  };
  // Refits of the current model without each of its effects (in parallel); kept for the confounding test (3c)
  // while the current model does not change.
  std::vector<FitResult> without;
  auto refitEachWithout = [&]() {
    without.assign(cur.fit.effects.size(), FitResult{});
    detail::parallelFor(static_cast<int>(without.size()), o.threads, ws, [&](int j, Workspace& tws) {
      const std::vector<Effect> reduced = without_effects({static_cast<std::size_t>(j)});
      FitOptions bo = fo;  // warm start: a few iterations, no intervals (recomputed if the reduced model is kept)
      bo.intervals = false;
      bo.max_iterations = 4;
      without[static_cast<std::size_t>(j)] = fitEffects(nominal, rec, reduced, all, bo, tws, nparams(reduced));
    });
    for (const FitResult& f : without) rep.evaluations += f.evaluations;
  };
  while (cur.fit.effects.size() >= 2) {
    int drop = -1;
    double best_d = 0;
    refitEachWithout();
    for (std::size_t j = 0; j < cur.fit.effects.size(); ++j) {
      const FitResult& f = without[j];
      const double d = deltaBic(cur.fit.residuals, nparams(cur.fit.effects), f.residuals, nparams(f.effects));
      if (d < o.bic_threshold && (drop < 0 || d < best_d)) {
        drop = static_cast<int>(j);
        best_d = d;
      }
    }
    if (drop < 0) break;
    const std::string lab = cur.fit.effects[static_cast<std::size_t>(drop)].label();
    removed[lab] =
        fmt("removed again after the later rounds: without it BIC changes by only %+.1f, so the other "
            "accepted effects explain what it explained",
            best_d);
    progress("backward elimination: removed " + lab);
    cur.bic += best_d;
    cur.fit = fitEffects(nominal, rec, without[static_cast<std::size_t>(drop)].effects, all, fo_alone, ws,
                         nparams(without[static_cast<std::size_t>(drop)].effects));
    rep.evaluations += cur.fit.evaluations;
    without.clear();
    cur.cv = crossValidate(nominal, rec, cur.fit.effects, o.folds, fo, ws, o.cv_iterations, o.threads,
                           o.one_step_cv ? &cur.fit : nullptr);
  }
  // 3. The remainder: locate tests on the final model's residuals and its held-out error against the noise.
  auto heldoutRatio = [&](const CrossValidation& cv, double& p) {
    double chi = 0;
    int dof = 0;
    for (Quantity q : presentQuantities(rec)) {
      const Eigen::MatrixXd& R = cv.heldout.of(q);
      const double s = fo.noise.of(q);
      for (int k = 0; k < rows; ++k)
        for (Eigen::Index c = 0; c < R.cols(); ++c)
          if (evaluable[static_cast<std::size_t>(k)] && std::isfinite(R(k, c)) && s > 0) {
            chi += R(k, c) * R(k, c) / (s * s);
            ++dof;
          }
    }
    p = dof ? stats::chiSquareSf(chi, dof) : 1.0;
    return dof ? chi / dof : 1.0;
  };
  double base_p = 1.0;
  const double base_ratio = heldoutRatio(baseline_cv, base_p);
  MismatchReport final_mismatch;
  auto assess = [&](Unexplained& u) {
    final_mismatch = locateMismatch(rec, cur.fit.prediction, cur.fit.residuals, fo.noise, o.mismatch);
    u = Unexplained{};
    u.heldout_ratio = heldoutRatio(cur.cv, u.heldout_p);
    u.heldout_rmse = cur.cv.rmse;
    u.mismatch = final_mismatch.findings;
    const bool above = u.heldout_p < o.mismatch.alpha && u.heldout_ratio > 1.3;
    u.present = above || !final_mismatch.findings.empty();
    u.fraction_explained = base_ratio > 1.0 ? std::clamp((base_ratio - u.heldout_ratio) / (base_ratio - 1.0), 0.0, 1.0)
                                            : (u.present ? 0.0 : 1.0);
    u.where = describeRemainder(final_mismatch, u.heldout_ratio);
  };
  assess(rep.unexplained);
  // The variable along which the remainder is largest: the first located finding of the final residuals that names
  // a configuration variable (nullptr: time, for drift, or when no variable is named).
  const std::vector<ConfigVariable> vars = configVariables(rec);
  auto remainderVariable = [&]() -> const ConfigVariable* {
    for (const auto* findings : {&final_mismatch.findings, &rep.mismatch.findings})
      for (const MismatchFinding& f : *findings) {
        if (f.variable == "time") return nullptr;
        for (const ConfigVariable& v : vars)
          if (v.name == f.variable) return &v;
      }
    return vars.empty() ? nullptr : &vars.front();
  };
  // 3b. With a structured remainder, an accepted effect may be a proxy absorbing part of physics it does not model.
  // A real effect has one value for the whole recording; a proxy's fitted value follows whatever part of the
  // mismatch the rows it is fitted on hold. Two parameter-constancy checks: the held-out folds (contiguous blocks in
  // time) and a split of the rows in two halves by the configuration variable where the remainder is largest (each
  // half refitted with its own intervals). An effect whose values disagree beyond their uncertainty (z > 3) and by
  // more than a quarter of its size is dropped from the verdict.
  if (rep.unexplained.present && !cur.fit.effects.empty()) {
    const ConfigVariable* split = remainderVariable();
    std::array<std::vector<char>, 2> half;
    std::string split_name = "time";
    {
      std::vector<std::pair<double, int>> order_rows;
      for (int k = 0; k < rows; ++k)
        if (evaluable[static_cast<std::size_t>(k)])
          order_rows.push_back({split ? split->value[k] : static_cast<double>(k), k});
      std::stable_sort(order_rows.begin(), order_rows.end(),
                       [](const auto& a, const auto& b) { return a.first < b.first; });
      half[0].assign(static_cast<std::size_t>(rows), 0);
      half[1].assign(static_cast<std::size_t>(rows), 0);
      for (std::size_t i = 0; i < order_rows.size(); ++i)
        half[2 * i < order_rows.size() ? 0 : 1][static_cast<std::size_t>(order_rows[i].second)] = 1;
      if (split) split_name = split->name;
    }
    std::array<FitResult, 2> halves;
    FitOptions ho = fo;
    ho.intervals = true;
    ho.grid_search = false;
    ho.max_iterations = 4;  // warm start from the full-data values
    detail::parallelFor(2, o.threads, ws, [&](int h, Workspace& tws) {
      halves[static_cast<std::size_t>(h)] = fitEffects(nominal, rec, cur.fit.effects, half[static_cast<std::size_t>(h)],
                                                       ho, tws, nparams(cur.fit.effects));
    });
    rep.evaluations += halves[0].evaluations + halves[1].evaluations;
    std::vector<std::size_t> unstable;
    for (std::size_t j = 0; j < cur.fit.effects.size(); ++j) {
      const Effect& e = cur.fit.effects[j];
      const Effect e0 = nominalEffect(nominal, e.kind, e.tube);
      const int nc = parameterCount(e.kind);
      // The effect's size: its distance from the nominal over all its coordinates.
      double size = 0.0;
      for (int c = 0; c < nc; ++c) size = std::hypot(size, e.coordinate(c) - e0.coordinate(c));
      bool time_unstable = false, split_unstable = false;
      std::string why_time, why_split;
      for (int c = 0; c < nc; ++c) {
        const std::string cname = coordinateLabel(e, c);
        // Time folds.
        double lo = e.coordinate(c), hi = e.coordinate(c);
        for (const auto& fe : cur.cv.fold_effects)
          if (j < fe.size()) {
            lo = std::min(lo, fe[j].coordinate(c));
            hi = std::max(hi, fe[j].coordinate(c));
          }
        auto widthOf = [&](const FitResult& f) {
          if (j >= f.uncertainty.size() || static_cast<int>(f.uncertainty[j].interval95.size()) <= c)
            return std::numeric_limits<double>::infinity();
          const auto& iv = f.uncertainty[j].interval95[static_cast<std::size_t>(c)];
          return std::isfinite(iv[1] - iv[0]) ? iv[1] - iv[0] : std::numeric_limits<double>::infinity();
        };
        const double w0 = widthOf(cur.fit);
        const double width = std::isfinite(w0) ? w0 : 0.0;
        const bool tu = cur.cv.fold_effects.size() >= 2 && hi - lo > std::max(width, 0.25 * size);
        // Configuration halves.
        const double va = halves[0].effects[j].coordinate(c), vb = halves[1].effects[j].coordinate(c);
        const double z = std::abs(va - vb) / std::max(1e-300, std::hypot(widthOf(halves[0]) / 3.92,
                                                                         widthOf(halves[1]) / 3.92));
        const bool su = z > 3.0 && std::abs(va - vb) > 0.25 * size;
        progress("constancy: " + e.label() + " " + cname +
                 fmt(" = %.4g; time folds %.4g .. %.4g; halves by ", e.coordinate(c), lo, hi) + split_name +
                 fmt(" %.4g vs %.4g (z = %.1f)", va, vb, z));
        if (tu && !time_unstable)
          why_time = "its fitted " + cname +
                     fmt(" changes between held-out blocks in time (%.4g to %.4g, against a 95 %% interval of width "
                         "%.3g): it absorbs part of a mismatch it does not model, so it is not named",
                         lo, hi, width);
        if (su && !split_unstable)
          why_split = "its fitted " + cname + " depends on which rows it is fitted on (" + fmt("%.4g", va) + " with " +
                      split_name + " below its median, " +
                      fmt("%.4g above, z = %.1f): it absorbs part of a mismatch it does not ", vb, z) +
                      "model, so it is not named";
        time_unstable = time_unstable || tu;
        split_unstable = split_unstable || su;
      }
      if (time_unstable || split_unstable) {
        unstable.push_back(j);
        removed[e.label()] = time_unstable ? why_time : why_split;
        progress("constancy: " + e.label() + " is not constant over the recording; dropped");
      }
    }
    if (!unstable.empty()) {
      without.clear();
      FitResult f = refitWithout(unstable);
      rep.evaluations += f.evaluations;
      cur.bic += deltaBic(cur.fit.residuals, nparams(cur.fit.effects), f.residuals, nparams(f.effects));
      cur.fit = std::move(f);
      cur.cv = cur.fit.effects.empty() ? baseline_cv
                                       : crossValidate(nominal, rec, cur.fit.effects, o.folds, fo, ws, o.cv_iterations,
                                                       o.threads, o.one_step_cv ? &cur.fit : nullptr);
      if (cur.fit.effects.empty()) cur.fit = base;
      assess(rep.unexplained);
    }
  }
  // 3c. Confounding with the remainder: an effect is named only if it explains something that a generic smooth
  // correction of every measured component along the remainder's variable (Fourier series up to 3 harmonics for
  // an angle, a cubic for a translation or time) does not. Both models -- with and without the effect -- get the
  // correction (profiled out by linear least squares), so its own parameters cancel; an effect whose BIC gain then
  // falls below the threshold could be part of the unexplained physics and is reported as a partial explanation,
  // not named in the verdict.
  std::set<std::string> confounded;
  if (rep.unexplained.present && !cur.fit.effects.empty()) {
    const ConfigVariable* v = remainderVariable();
    Eigen::VectorXd x(rows);
    bool angle = v && v->angle;
    for (int k = 0; k < rows; ++k) x[k] = v ? v->value[k] : (rec.hasTime() ? rec.time[k] : k);
    const double xlo = x.minCoeff(), xhi = x.maxCoeff();
    const int nb = angle ? 7 : 4;
    auto basis = [&](int k, int b) {
      if (angle) return b == 0 ? 1.0 : (b % 2 ? std::cos((b + 1) / 2 * x[k]) : std::sin(b / 2 * x[k]));
      const double t = xhi > xlo ? 2 * (x[k] - xlo) / (xhi - xlo) - 1 : 0.0;
      return std::pow(t, b);
    };
    auto projectedBic = [&](const Residuals& r, const std::vector<char>& m, int k) {
      double b = 0;
      int total = 0;
      for (Quantity q : presentQuantities(rec)) {
        const Eigen::MatrixXd& R = r.of(q);
        double rss = 0;
        int n = 0;
        for (Eigen::Index c = 0; c < R.cols(); ++c) {
          std::vector<int> idx;
          for (int kk = 0; kk < rows; ++kk)
            if (m[static_cast<std::size_t>(kk)] && std::isfinite(R(kk, c))) idx.push_back(kk);
          if (static_cast<int>(idx.size()) <= nb) continue;
          Eigen::MatrixXd B(static_cast<Eigen::Index>(idx.size()), nb);
          Eigen::VectorXd y(static_cast<Eigen::Index>(idx.size()));
          for (std::size_t i = 0; i < idx.size(); ++i) {
            for (int bb = 0; bb < nb; ++bb) B(static_cast<Eigen::Index>(i), bb) = basis(idx[i], bb);
            y[static_cast<Eigen::Index>(i)] = R(idx[i], c);
          }
          const Eigen::VectorXd coef = B.colPivHouseholderQr().solve(y);
          rss += (y - B * coef).squaredNorm();
          n += static_cast<int>(idx.size());
        }
        if (n == 0) continue;
        b += n * std::log(std::max(1e-300, rss / n));
        total += n;
      }
      return b + k * std::log(std::max(1, total));
    };
    if (without.size() != cur.fit.effects.size()) refitEachWithout();
    const std::string vname = v ? v->name : "time";
    for (std::size_t j = 0; j < cur.fit.effects.size(); ++j) {
      const FitResult& f = without[j];
      const std::vector<char> m = commonRows(cur.fit.residuals, f.residuals, evaluable);
      const int k = nparams(cur.fit.effects), kw = nparams(f.effects);
      const double plain = bic(rec, f.residuals, m, kw) - bic(rec, cur.fit.residuals, m, k);
      const double d = projectedBic(f.residuals, m, kw) - projectedBic(cur.fit.residuals, m, k);
      const std::string lab = cur.fit.effects[j].label();
      progress("confounding: " + lab + fmt(" BIC gain %.1f; with a smooth correction along ", plain) + vname +
               fmt(" %.1f", d));
      if (d < o.bic_threshold) {
        confounded.insert(lab);
        removed_partial[lab] =
            std::string("a smooth correction of the outputs along ") + vname +
            fmt(" -- a stand-in for the unexplained remainder -- does what it does (its BIC gain drops from %.1f to "
                "%.1f): it may be part of physics the library does not have, so it is a partial explanation, not named",
                plain, d);
      }
    }
  }
  // 4. Final model: fitted values with intervals (already from its full-data fit).
  rep.final_effects = cur.fit.effects;
  for (std::size_t j = 0; j < cur.fit.effects.size() && j < cur.fit.uncertainty.size(); ++j)
    rep.final_uncertainty[cur.fit.effects[j].label()] = cur.fit.uncertainty[j];
  for (const Effect& e : cur.fit.effects)
    if (e.kind == EffectKind::Gravity && nominalEffect(nominal, EffectKind::Gravity, 0).vec.isZero() &&
        !nominal.hasWeight())
      rep.warnings.push_back(
          "gravity: the description gives no tube a density, so its weight assumes nitinol (" +
          fmt("%.0f kg/m^3) with the tubes' diameters; the fitted scale %.3g is relative to that weight", kNitinolDensity,
              e.gravityScale()));
  rep.registration = cur.fit.registration;
  rep.final.model = modelName(cur.fit.effects);
  rep.final.effects = cur.fit.effects;
  rep.final.heldout_rmse = cur.cv.rmse;
  rep.final.last_block_rmse = rmse(rec, cur.cv.heldout, lastBlock);
  rep.final.fit_rmse = rmse(rec, cur.fit.residuals, evaluable);
  rep.final.heldout_score = cur.cv.score;
  rep.final.bic = cur.bic;
  // Rows the final model could not evaluate (the nominal model could): excluded from its scores, and listed.
  int final_failed = 0;
  for (int k = 0; k < rows; ++k)
    if (evaluable[static_cast<std::size_t>(k)] && k < cur.fit.prediction.rows() &&
        !cur.fit.prediction.ok[static_cast<std::size_t>(k)]) {
      ++final_failed;
      rep.failed_rows.push_back(
          {k * stride + 1, cur.fit.prediction.reason[static_cast<std::size_t>(k)], rep.final.model});
    }
  // Rows reached through a snap are excluded (the landing state of a dynamic jump is uncertain) but are a physical
  // prediction of the model, not a failure of it: they count separately from the rows the model could not solve.
  int snapped = 0;
  for (const FailedRow& fr : rep.failed_rows) snapped += fr.reason.rfind("snapped", 0) == 0;
  const double failed_fraction = static_cast<double>(nfailed + final_failed - snapped) / rows;
  rep.reliable = failed_fraction <= o.unreliable_fraction;
  if (!rep.reliable)
    rep.warnings.push_back(fmt("%.1f %% of the rows could not be evaluated (limit %.0f %%): the verdict is unreliable",
                               100 * failed_fraction, 100 * o.unreliable_fraction));
  if (snapped > 0)
    rep.warnings.push_back(
        fmt("%.0f row(s) are reached through a snap of the model (a jump to another equilibrium "
            "branch) and are excluded; the verdict rests on the other rows",
            snapped));
  std::set<std::string> seen;
  for (const Effect& e : cur.fit.effects) {
    if (confounded.count(e.label())) continue;  // a partial explanation, not named
    std::string name = effectName(e.kind);
    std::set<std::string> alt;
    for (const Rival& r : rivals_of[e.label()])
      if (std::string(effectName(r.effect.kind)) != name) alt.insert(effectName(r.effect.kind));
    for (const std::string& a : alt) name += " or " + a;
    if (seen.insert(name).second) rep.verdict.push_back(name);
  }
  // Accepted findings report the final joint values.
  for (const std::string& key : order) {
    Finding f = last[key];
    if (removed.count(key)) {
      f.accepted = false;
      f.ambiguous_with.clear();
      f.explanation = "rejected: " + physics(f.effect.kind) + "; " + removed[key] + ".";
    }
    for (const Effect& e : cur.fit.effects)
      if (e.label() == key) {
        f.accepted = true;
        f.effect = e;
        f.parameters = namedParameters(e, rep.final_uncertainty.count(key) ? &rep.final_uncertainty[key] : nullptr);
        f.partial = rep.unexplained.present;
        if (removed_partial.count(key)) {
          f.named = false;
          f.explanation = "partial explanation, not named: " + physics(e.kind) + "; " + removed_partial[key] + ".";
        }
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
  rep.plot.final_mismatch = final_mismatch;
  // 5. Summary paragraph: never "nothing was left out" while the residual is above the noise.
  std::string s;
  if (!rep.reliable)
    s += fmt("Unreliable: %.1f %% of the rows could not be evaluated by the model (see failed_rows). ",
             100 * failed_fraction);
  else if (!rep.failed_rows.empty())
    s += std::to_string(rep.failed_rows.size()) + " row(s) could not be evaluated and were excluded (failed_rows). ";
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
  const Unexplained& u = rep.unexplained;
  auto listEffects = [&](bool named) {
    std::string t;
    for (const Effect& e : cur.fit.effects) {
      if ((confounded.count(e.label()) == 0) != named) continue;
      t += (t.empty() ? "" : ", ") + e.label() + " (" + e.valueText() + ")";
      const auto& rv = rivals_of[e.label()];
      if (!rv.empty()) {
        t += " or";
        for (std::size_t r = 0; r < rv.size(); ++r) t += (r ? ", " : " ") + rv[r].effect.label();
        t += " (this recording cannot tell them apart)";
      }
    }
    return t;
  };
  std::string rmse_change = "Held-out RMSE before -> after:";
  for (const auto& kv : rep.baseline.heldout_rmse) {
    const double after = rep.final.heldout_rmse.count(kv.first) ? rep.final.heldout_rmse.at(kv.first) : kv.second;
    rmse_change += " " + kv.first + fmt(" %.4g -> %.4g;", kv.second, after);
  }
  const std::string partial = listEffects(false);
  if (rep.verdict.empty() && !u.present) {
    s += "No candidate effect improved both the held-out error and BIC, and the residuals are at the noise: nothing "
         "was left out (within the noise).";
  } else if (rep.verdict.empty()) {
    s += "Not explained by any candidate: " + u.where +
         ". The cause is not in the candidate library, or this recording cannot identify it.";
    if (!partial.empty())
      s += " Candidates that absorb part of it without being the answer (partial explanations, not named): " + partial +
           fmt(" (together %.0f %% of the mismatch). ", 100 * u.fraction_explained) + rmse_change;
  } else {
    s += (u.present ? "Left out (a partial explanation): " : "Left out: ") + listEffects(true) + ". ";
    if (!partial.empty()) s += "Also in the fit, but not named (confounded with the remainder): " + partial + ". ";
    s += rmse_change;
    if (u.present)
      s += fmt(" The candidates explain %.0f %% of the mismatch; ", 100 * u.fraction_explained) + u.where +
           ", which the candidate library does not explain.";
    else
      s += " The remaining residuals are at the noise.";
  }
  rep.summary = s;
  rep.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  progress(fmt("done in %.1f s, %.0f replays", rep.seconds, rep.evaluations));
  return rep;
}

}  // namespace ctr::diagnosis
