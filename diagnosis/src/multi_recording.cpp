// Several recordings of one robot: each diagnosed alone; the robot effects any of them names (and the recording
// effects) refitted in every recording; a consistency test of each effect's values across the recordings; the robot
// effects that agree and that two or more recordings support estimated once and held while each recording's own
// effects are refitted.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <deque>
#include <stdexcept>

#include "ctr/diagnosis/diagnose.hpp"
#include "ctr/diagnosis/statistics.hpp"
#include "diagnosis_state.hpp"

namespace ctr::diagnosis {

const char* toString(Agreement agreement) {
  switch (agreement) {
    case Agreement::Shared:
      return "shared";
    case Agreement::Differs:
      return "differs";
    case Agreement::OneRecording:
      return "one_recording";
    case Agreement::OfTheRecording:
      return "of_the_recording";
  }
  return "?";
}

namespace {

using detail::fmt;

/// The rows of one recording as its diagnosis used them, and the options its final model was fitted with.
struct Context {
  io::Recording rows;
  CommandHistory history;
  FitOptions fo;
  std::vector<char> all;
};

/// One effect slot across the recordings: the start value and the recordings that named it.
struct Slot {
  Effect start;
  std::vector<int> named_in;
};

/// Index of the slot of `e` in `slots` (-1: none).
int slotIndex(const std::vector<Slot>& slots, const Effect& e) {
  for (std::size_t k = 0; k < slots.size(); ++k)
    if (slots[k].start.sameSlot(e)) return static_cast<int>(k);
  return -1;
}

/// Index of the first fitted coordinate of effect j of a model.
int coordinateOffset(const std::vector<Effect>& effects, std::size_t j) {
  int off = 0;
  for (std::size_t k = 0; k < j; ++k) off += parameterCount(effects[k].kind);
  return off;
}

/// The coordinates of an effect as a vector.
Eigen::VectorXd coordinates(const Effect& e) {
  Eigen::VectorXd v(parameterCount(e.kind));
  for (int c = 0; c < v.size(); ++c) v[c] = e.coordinate(c);
  return v;
}

/// The part of the prediction change of coordinates [off, off + p) of a fit that its other coordinates cannot take up
/// (the smallest over the block's columns, as a fraction of the column's squared norm; 0 when not linearised).
double ownShare(const FitResult& f, int off, int p) {
  const Eigen::MatrixXd& J = f.jacobian;
  if (J.cols() < off + p || J.rows() == 0) return 0.0;
  const Eigen::Index rest = J.cols() - off - p;
  Eigen::MatrixXd others(J.rows(), J.cols() - p);
  others << J.leftCols(off), J.rightCols(rest);
  Eigen::CompleteOrthogonalDecomposition<Eigen::MatrixXd> cod;
  if (others.cols() > 0) cod.compute(others);
  double share = 1.0;
  for (int c = 0; c < p; ++c) {
    const Eigen::VectorXd col = J.col(off + c);
    const double n2 = col.squaredNorm();
    if (!(n2 > 0) || !std::isfinite(n2)) return 0.0;
    Eigen::VectorXd g = col;
    if (others.cols() > 0) g -= others * cod.solve(col);
    share = std::min(share, g.squaredNorm() / n2);
  }
  return share;
}

/// A recording's value of a slot: its coordinates and their covariance (from the fit's full covariance).
struct Value {
  int recording = 0;
  Effect effect;
  Eigen::VectorXd x;
  Eigen::MatrixXd cov;
  EffectUncertainty u;
  bool valid = false;       ///< Compared: linearised, finite, and not confounded.
  bool confounded = false;  ///< The recording's other effects take up its prediction change.
};

/// Its prediction change taken up by the recording's other effects to within 1 % (the rule of detectionLimits): the
/// recording cannot tell its value (e.g. a drive's play and the sensor latency in a sweep at constant speed).
constexpr double kConfoundedShare = 1e-4;

/// The fit of a recording with every slot, started again from the values of the recordings that named the robot
/// slots and with its timing effects (sensor latency, tracker drift) at none. When it fits as well (twice its cost
/// difference, over the residual variance, below the 95 % point of chi-square with one degree of freedom) with
/// values of some effects beyond the first fit's 95 % intervals, the recording cannot tell those values: their labels
/// are returned (e.g. a sweep at constant speed fits a drive's play as well as a latency of half a row). When it fits
/// significantly better, it replaces `fit`.
std::vector<std::string> ambiguousLabels(const Robot& nominal, const Context& c, const std::vector<Slot>& robot,
                                         const FitOptions& fo, FitResult& fit, Workspace& ws) {
  std::vector<std::string> labels;
  if (fit.effects.empty() || fit.uncertainty.size() != fit.effects.size()) return labels;
  std::vector<Effect> start = fit.effects;
  bool moved = false;
  for (std::size_t j = 0; j < start.size(); ++j) {
    Effect& e = start[j];
    const int k = slotIndex(robot, e);
    const Effect to = k >= 0                           ? robot[static_cast<std::size_t>(k)].start
                      : detail::ofTheRecording(e.kind) ? nominalEffect(nominal, e.kind, e.tube)
                                                       : e;
    for (int q = 0; q < parameterCount(e.kind); ++q) {
      const auto& iv = fit.uncertainty[j].interval95;
      const double v = to.coordinate(q);
      if (q < static_cast<int>(iv.size()) &&
          (v < iv[static_cast<std::size_t>(q)][0] || v > iv[static_cast<std::size_t>(q)][1]))
        moved = true;
      e.setCoordinate(q, v);
    }
  }
  if (!moved) return labels;
  FitOptions o = fo;
  o.grid_search = false;
  FitResult other;
  try {
    other = fitEffects(nominal, c.rows, start, c.all, o, ws);
  } catch (const std::exception&) {
    return labels;
  }
  const int dof = std::max(1, static_cast<int>(fit.weighted_residuals.size()) - coordinateCount(fit.effects));
  const double s2 = std::max(1e-300, 2.0 * fit.cost / dof);
  const double lr = 2.0 * (other.cost - fit.cost) / s2;  // > 0: the first fit is better
  const double tie = stats::chiSquareQuantile(0.95, 1.0);
  if (lr < -tie) {  // the second start found a better optimum
    fit = std::move(other);
    return labels;
  }
  if (lr > tie || other.uncertainty.size() != other.effects.size()) return labels;
  for (std::size_t j = 0; j < fit.effects.size(); ++j)
    for (int q = 0; q < parameterCount(fit.effects[j].kind); ++q) {
      const auto& iv = fit.uncertainty[j].interval95;
      const double v = other.effects[j].coordinate(q);
      if (q < static_cast<int>(iv.size()) &&
          (v < iv[static_cast<std::size_t>(q)][0] || v > iv[static_cast<std::size_t>(q)][1])) {
        labels.push_back(fit.effects[j].label());
        break;
      }
    }
  return labels;
}

/// Common value of several recordings' values (weighted by their inverse covariances) and the chi-square of their
/// deviations from it.
struct Combined {
  Eigen::VectorXd x;
  Eigen::MatrixXd cov;
  double chi2 = 0.0;
  int dof = 0;
};

Combined combine(const std::vector<const Value*>& values) {
  Combined c;
  if (values.empty()) return c;
  const Eigen::Index p = values.front()->x.size();
  Eigen::MatrixXd W = Eigen::MatrixXd::Zero(p, p);
  Eigen::VectorXd b = Eigen::VectorXd::Zero(p);
  std::vector<Eigen::MatrixXd> Wi;
  for (const Value* v : values) {
    Wi.push_back(v->cov.completeOrthogonalDecomposition().pseudoInverse());
    W += Wi.back();
    b += Wi.back() * v->x;
  }
  c.cov = W.completeOrthogonalDecomposition().pseudoInverse();
  c.x = c.cov * b;
  for (std::size_t i = 0; i < values.size(); ++i) {
    const Eigen::VectorXd d = values[i]->x - c.x;
    c.chi2 += d.dot(Wi[i] * d);
  }
  c.dof = static_cast<int>((values.size() - 1) * static_cast<std::size_t>(p));
  return c;
}

/// 95 % intervals of an effect's coordinates from their covariance, within the search range.
EffectUncertainty uncertaintyOf(const Robot& nominal, const io::Recording& rec, const Effect& e,
                                const Eigen::MatrixXd& cov) {
  EffectUncertainty u;
  u.covariance = cov;
  for (int c = 0; c < parameterCount(e.kind); ++c) {
    const ParameterRange r = parameterRange(nominal, rec, e.kind, e.tube, c);
    const double half = 1.96 * std::sqrt(std::max(0.0, cov(c, c)));
    u.interval95.push_back({std::max(r.lo, e.coordinate(c) - half), std::min(r.hi, e.coordinate(c) + half)});
  }
  return u;
}

/// "0.1047 in A.csv, 0.0002 in B.csv" (one-coordinate kinds) or the parameters in words.
std::string valuesText(const JointEffect& j, const std::vector<std::string>& names) {
  std::string t;
  for (const RecordingValue& v : j.per_recording) {
    std::string words;
    for (const NamedParameter& p : v.parameters)
      if (p.name != "tube") words += (words.empty() ? "" : ", ") + detail::paramText(p);
    t += (t.empty() ? "" : "; ") + words + " in " + names[static_cast<std::size_t>(v.recording)];
  }
  return t;
}

}  // namespace

MultiDiagnosisReport diagnoseRecordings(const Robot& nominal, const std::vector<io::Recording>& recordings,
                                        const std::vector<std::string>& names, const MultiDiagnoseOptions& options) {
  const auto t0 = std::chrono::steady_clock::now();
  const std::size_t n = recordings.size();
  if (n < 2) throw std::invalid_argument("diagnoseRecordings: at least two recordings are needed");
  if (names.size() != n) throw std::invalid_argument("diagnoseRecordings: one name per recording is needed");
  const DiagnoseOptions& o = options.diagnose;
  MultiDiagnosisReport rep;
  rep.names = names;
  rep.frame = o.frame;
  rep.alpha = options.alpha;
  auto say = [&](const std::string& message) {
    if (!o.progress) return;
    DiagnoseProgress p;
    p.stage = DiagnoseProgress::Stage::Recordings;
    p.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    p.message = message;
    o.progress(p);
  };

  // 1. Each recording alone.
  for (std::size_t i = 0; i < n; ++i) {
    DiagnoseOptions oi = o;
    if (o.progress)
      oi.progress = [&, i](const DiagnoseProgress& p) {
        DiagnoseProgress q = p;
        q.message = names[i] + ": " + p.message;
        o.progress(q);
      };
    try {
      rep.recordings.push_back(diagnose(nominal, recordings[i], oi));
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument(names[i] + ": " + e.what());
    } catch (const std::runtime_error& e) {
      throw std::runtime_error(names[i] + ": " + e.what());
    }
  }
  std::deque<Context> ctx;  // (stable addresses: the fit options point at the histories)
  for (std::size_t i = 0; i < n; ++i) {
    const DiagnosisReport& r = rep.recordings[i];
    Context& c = ctx.emplace_back();
    c.rows = diagnosedRows(recordings[i], r.stride);
    c.history = diagnosedHistory(recordings[i], r.stride);
    c.fo = diagnosedFitOptions(r, o, c.history);
    c.fo.max_iterations = options.max_iterations;
    c.all.assign(static_cast<std::size_t>(c.rows.rows()), 1);
  }

  // 2. The slots: robot effects any recording names (its verdict), then the recordings' latencies.
  std::vector<Slot> robot, timing;
  for (std::size_t i = 0; i < n; ++i)
    for (const Effect& e : rep.recordings[i].final_effects) {
      const bool of_robot = detail::robotEffectOf(rep.recordings[i], e);
      if (!of_robot && e.kind != EffectKind::SensorLatency) continue;
      std::vector<Slot>& slots = of_robot ? robot : timing;
      int k = slotIndex(slots, e);
      if (k < 0) {
        slots.push_back({e, {}});
        k = static_cast<int>(slots.size()) - 1;
      }
      if (detail::namingFinding(rep.recordings[i], e))
        slots[static_cast<std::size_t>(k)].named_in.push_back(static_cast<int>(i));
    }

  // 3. Every recording refitted with its own final model and every slot (the ones it lacks scanned on their grid
  //    from the value of the recording that found them): each slot's value in each recording, with its covariance.
  std::vector<FitResult> fits(n);
  std::vector<std::vector<Value>> robot_values(robot.size()), timing_values(timing.size());
  Workspace ws;
  for (std::size_t i = 0; i < n; ++i) {
    say(names[i] + ": the robot effects of all recordings refitted in it");
    std::vector<Effect> start = rep.recordings[i].final_effects;
    const int grid_from = static_cast<int>(start.size());
    for (const std::vector<Slot>* slots : {&robot, &timing})
      for (const Slot& s : *slots) {
        if (s.start.kind == EffectKind::SensorLatency && !ctx[i].rows.hasTime()) continue;
        if (std::none_of(start.begin(), start.end(), [&](const Effect& e) { return e.sameSlot(s.start); }))
          start.push_back(s.start);
      }
    FitOptions fo = ctx[i].fo;
    fo.intervals = true;
    try {
      fits[i] = fitEffects(nominal, ctx[i].rows, start, ctx[i].all, fo, ws, grid_from);
    } catch (const std::exception& e) {
      rep.warnings.push_back(names[i] + ": the refit with the effects of all recordings failed (" + e.what() +
                             "); its values are left out of the comparison");
      continue;
    }
    // A second start: the robot slots at the values of the recordings that named them, the recording's own timing
    // effects at none. A recording that fits both as well with other values cannot tell those values.
    std::vector<std::string> ambiguous = ambiguousLabels(nominal, ctx[i], robot, fo, fits[i], ws);
    const FitResult& f = fits[i];
    for (std::size_t j = 0; j < f.effects.size(); ++j) {
      const Effect& e = f.effects[j];
      const bool of_robot = slotIndex(robot, e) >= 0;
      const int k = of_robot ? slotIndex(robot, e) : slotIndex(timing, e);
      if (k < 0) continue;
      Value v;
      v.recording = static_cast<int>(i);
      v.effect = e;
      v.x = coordinates(e);
      const int off = coordinateOffset(f.effects, j), p = parameterCount(e.kind);
      if (f.covariance.rows() >= off + p) v.cov = f.covariance.block(off, off, p, p);
      if (j < f.uncertainty.size()) v.u = f.uncertainty[j];
      v.valid = v.cov.size() > 0 && v.cov.allFinite() && v.x.allFinite() && v.cov.diagonal().minCoeff() > 0;
      v.confounded = v.valid && (ownShare(f, off, p) <= kConfoundedShare ||
                                 std::find(ambiguous.begin(), ambiguous.end(), e.label()) != ambiguous.end());
      v.valid = v.valid && !v.confounded;
      (of_robot ? robot_values : timing_values)[static_cast<std::size_t>(k)].push_back(v);
    }
  }

  // 4. Per slot: the consistency test of its values across the recordings and its agreement.
  const double per_test = options.alpha / static_cast<double>(std::max<std::size_t>(1, robot.size()));
  auto judge = [&](const Slot& slot, const std::vector<Value>& values, bool of_robot) {
    JointEffect j;
    j.effect = slot.start;
    std::vector<const Value*> valid;
    int supporting = 0;
    const Effect nominal_effect = nominalEffect(nominal, slot.start.kind, slot.start.tube);
    for (const Value& v : values) {
      RecordingValue rv;
      rv.recording = v.recording;
      rv.effect = v.effect;
      rv.parameters = namedParameters(v.effect, v.u.empty() ? nullptr : &v.u);
      rv.named = std::find(slot.named_in.begin(), slot.named_in.end(), v.recording) != slot.named_in.end();
      rv.confounded = v.confounded;
      if (v.valid) {
        valid.push_back(&v);
        const Eigen::VectorXd d = v.x - coordinates(nominal_effect);
        const Eigen::MatrixXd W = v.cov.completeOrthogonalDecomposition().pseudoInverse();
        rv.supports = d.dot(W * d) > stats::chiSquareQuantile(0.95, static_cast<double>(v.x.size()));
      }
      supporting += rv.supports ? 1 : 0;
      j.per_recording.push_back(rv);
    }
    const Combined c = combine(valid);
    j.chi2 = c.chi2;
    j.dof = c.dof;
    j.p = c.dof > 0 ? stats::chiSquareSf(c.chi2, c.dof) : 1.0;
    const std::string test =
        c.dof > 0 ? fmt("chi-square %.3g on %.0f degrees of freedom, p = %.3g", c.chi2, c.dof, j.p) : std::string();
    if (!of_robot) {
      j.agreement = Agreement::OfTheRecording;
      j.explanation = std::string("an effect of the recording's timing, not of the robot: fitted per recording") +
                      (c.dof == 0            ? std::string(" (one recording has a value)")
                       : j.p < options.alpha ? "; its values differ between the recordings (" + test + ")"
                                             : "; its values agree across the recordings (" + test + ")");
    } else if (c.dof > 0 && j.p < per_test) {
      j.agreement = Agreement::Differs;
      j.explanation = "its values differ between the recordings beyond their intervals (" + test +
                      fmt(", below %.3g): not physics of the robot, not applied", per_test);
    } else if (supporting < 2) {
      j.agreement = Agreement::OneRecording;
      j.explanation =
          fmt("%.0f of the recordings tell it from none (its 95 %% interval excludes the nominal value); "
              "two are needed to call it physics of the robot: not applied",
              supporting);
      if (c.dof > 0) j.explanation += " (" + test + ")";
    } else {
      j.agreement = Agreement::Shared;
      j.explanation =
          fmt("its values agree across the recordings and %.0f of them tell it from none; ", supporting) + test;
    }
    return j;
  };
  std::vector<Combined> alone(robot.size());  // each slot's common value on its own (the fallback below)
  for (std::size_t k = 0; k < robot.size(); ++k) {
    rep.effects.push_back(judge(robot[k], robot_values[k], true));
    std::vector<const Value*> valid;
    for (const Value& v : robot_values[k])
      if (v.valid) valid.push_back(&v);
    alone[k] = combine(valid);
  }

  // 5. The shared effects estimated once: all their coordinates together, each recording's values weighted by the
  //    inverse of their covariance (with every other effect of the recording free: the first-order joint estimate).
  std::vector<std::size_t> shared;
  for (std::size_t k = 0; k < robot.size(); ++k)
    if (rep.effects[k].agreement == Agreement::Shared) shared.push_back(k);
  std::vector<Effect> shared_effects;
  if (!shared.empty()) {
    std::vector<Value> stacked;  // per recording: the shared coordinates stacked, their joint covariance
    for (std::size_t i = 0; i < n; ++i) {
      const FitResult& f = fits[i];
      Value v;
      v.recording = static_cast<int>(i);
      std::vector<int> idx;
      v.valid = f.covariance.size() > 0;
      for (std::size_t k : shared) {
        const auto it = std::find_if(f.effects.begin(), f.effects.end(),
                                     [&](const Effect& e) { return e.sameSlot(robot[k].start); });
        if (it == f.effects.end()) {
          v.valid = false;
          break;
        }
        const int off = coordinateOffset(f.effects, static_cast<std::size_t>(it - f.effects.begin()));
        for (int c = 0; c < parameterCount(it->kind); ++c) idx.push_back(off + c);
      }
      if (!v.valid) continue;
      const Eigen::Index m = static_cast<Eigen::Index>(idx.size());
      v.x.resize(m);
      v.cov.resize(m, m);
      Eigen::VectorXd all = Eigen::VectorXd::Zero(f.covariance.rows());
      int at = 0;
      for (const Effect& e : f.effects)
        for (int c = 0; c < parameterCount(e.kind); ++c) all[at++] = e.coordinate(c);
      for (Eigen::Index a = 0; a < m; ++a) {
        v.x[a] = all[idx[static_cast<std::size_t>(a)]];
        for (Eigen::Index b = 0; b < m; ++b)
          v.cov(a, b) = f.covariance(idx[static_cast<std::size_t>(a)], idx[static_cast<std::size_t>(b)]);
      }
      v.valid = v.cov.allFinite() && v.x.allFinite();
      if (v.valid) stacked.push_back(v);
    }
    std::vector<const Value*> ptrs;
    for (const Value& v : stacked) ptrs.push_back(&v);
    const Combined joint = combine(ptrs);
    Eigen::Index at = 0;
    for (std::size_t k : shared) {
      Effect e = robot[k].start;
      const int p = parameterCount(e.kind);
      // (no recording with every shared slot's covariance: each slot's own common value)
      const bool stacked_ok = joint.x.size() >= at + p;
      const Eigen::VectorXd x = stacked_ok ? Eigen::VectorXd(joint.x.segment(at, p)) : alone[k].x;
      const Eigen::MatrixXd cov = stacked_ok ? Eigen::MatrixXd(joint.cov.block(at, at, p, p)) : alone[k].cov;
      for (int q = 0; q < p; ++q) {
        const ParameterRange r = parameterRange(nominal, ctx[0].rows, e.kind, e.tube, q);
        e.setCoordinate(q, std::clamp(x[q], r.lo, r.hi));
      }
      const EffectUncertainty u = uncertaintyOf(nominal, ctx[0].rows, e, cov);
      at += p;
      rep.effects[k].effect = e;
      rep.effects[k].parameters = namedParameters(e, &u);
      shared_effects.push_back(e);
    }
  }
  for (std::size_t k = 0; k < timing.size(); ++k) rep.effects.push_back(judge(timing[k], timing_values[k], false));

  // 6. Each recording with the shared values held and its own effects (the robot effects not shared, its latency,
  //    tracker frame, partial explanations) refitted.
  for (std::size_t i = 0; i < n; ++i) {
    RecordingFit rf;
    rf.own_fit_rmse = rep.recordings[i].final.fit_rmse;
    std::vector<Effect> start = shared_effects;
    const std::vector<Effect>& own = fits[i].effects.empty() ? rep.recordings[i].final_effects : fits[i].effects;
    for (const Effect& e : own)
      if (std::none_of(shared_effects.begin(), shared_effects.end(), [&](const Effect& s) { return s.sameSlot(e); }))
        start.push_back(e);
    FitOptions fo = ctx[i].fo;
    fo.grid_search = false;
    fo.intervals = false;
    fo.first_free = static_cast<int>(shared_effects.size());
    say(names[i] + ": its own effects refitted with the shared values held");
    try {
      const FitResult f = fitEffects(nominal, ctx[i].rows, start, ctx[i].all, fo, ws);
      rf.effects = f.effects;
      rf.registration = f.registration;
      rf.fit_rmse = rmse(ctx[i].rows, f.residuals, ctx[i].fo.rows);
    } catch (const std::exception& e) {
      rep.warnings.push_back(names[i] + ": the refit with the shared values held failed (" + e.what() + ")");
    }
    rep.fits.push_back(rf);
  }

  // 7. The verdict (each shared kind once) and the summary.
  std::vector<std::vector<EffectKind>> entries;
  for (std::size_t k : shared) entries.push_back({robot[k].start.kind});
  rep.verdict = verdictNames(entries);
  std::string shared_words, other_words, timing_words;
  for (const JointEffect& j : rep.effects) {
    if (j.agreement == Agreement::Shared) {
      std::string w;
      for (const NamedParameter& p : j.parameters)
        if (p.name != "tube")
          w += (w.empty() ? "" : ", ") + detail::paramText(p) + " (95 %: " + detail::intervalText(p) + ")";
      shared_words += (shared_words.empty() ? "" : "; ") + j.effect.label() + " " + w;
    } else if (j.agreement == Agreement::OfTheRecording) {
      timing_words += (timing_words.empty() ? "" : "; ") + j.effect.label() + " (" + valuesText(j, names) + ")";
    } else {
      other_words += (other_words.empty() ? "" : "; ") + j.effect.label() + " -- " + toString(j.agreement) + ": " +
                     valuesText(j, names);
    }
  }
  rep.summary = std::to_string(n) + " recordings of '" + nominal.name() + "' diagnosed together. ";
  rep.summary += shared_words.empty()
                     ? "No robot effect holds across the recordings."
                     : "Shared by the recordings (physics of the robot, one value each): " + shared_words + ".";
  if (!other_words.empty()) rep.summary += " Not shared (not physics of the robot, not applied): " + other_words + ".";
  if (!timing_words.empty()) rep.summary += " Effects of the recordings, per recording: " + timing_words + ".";
  if (o.frame == FrameMode::Unknown) rep.summary += " Each recording has its own tracker registration.";
  rep.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  say(fmt("done in %.1f s", rep.seconds));
  return rep;
}

Robot diagnosedRobot(const Robot& nominal, const MultiDiagnosisReport& report) {
  std::vector<Effect> applied;
  for (const JointEffect& j : report.effects)
    if (j.agreement == Agreement::Shared) applied.push_back(j.effect);
  return robotWithEffects(nominal, applied);
}

}  // namespace ctr::diagnosis
