// One round of the forward selection: every remaining candidate screened on top of the current model, the best
// linearised and cross-validated, the winner tested against its look-alikes (lookalikes.cpp) and refined jointly.
#include <algorithm>
#include <atomic>
#include <cmath>
#include <functional>
#include <limits>

#include "ctr/diagnosis/first_order_screen.hpp"
#include "ctr/diagnosis/statistics.hpp"
#include "diagnosis_state.hpp"
#include "parallel.hpp"

namespace ctr::diagnosis::detail {

namespace {
/// Candidates screened at first order before any replay fit: the loads (slow loaded replays) and the generic models
/// (many coordinates).
bool screenedFirst(EffectKind k) {
  return k == EffectKind::Gravity || k == EffectKind::TipLoad || isGeneric(k);
}
}  // namespace

HeldOutComparison compareHeldOut(const Eigen::VectorXd& before, const Eigen::VectorXd& after, int chunks) {
  HeldOutComparison h;
  h.p = stats::chunkedBootstrapTest(before, after, chunks);
  const auto means = commonMeans(before, after);
  h.gain = means[0] > 0 ? 1.0 - means[1] / means[0] : 0.0;
  return h;
}

// Held-out test of a candidate's model against the current one, on the rows both evaluated: cross-validation
// (one-step from its linearisation when asked and available), bootstrap p and gain. Returns the replays used.
int heldOut(State& S, Candidate& c, Workspace& tws, int threads, bool one_step) {
  const Robot& nominal = S.nominal;
  const io::Recording& rec = S.rec;
  const DiagnoseOptions& o = S.o;
  const FitOptions& fo = S.fo;
  const Candidate& cur = S.cur;
  const int chunks = S.chunks;
  c.cv = crossValidate(nominal, rec, c.fit.effects, o.folds, fo, tws, o.cv_iterations, threads,
                       one_step ? &c.fit : nullptr);
  c.cv_done = true;
  const HeldOutComparison h = compareHeldOut(cur.cv.row_score, c.cv.row_score, chunks);
  c.heldout_p = h.p;
  c.gain = h.gain;
  return c.cv.evaluations;
}

void guarded(State& S, Candidate& c, Workspace& tws, const std::function<void(Candidate&, Workspace&)>& fn) {
  try {
    fn(c, tws);
  } catch (const std::exception& ex) {
    // E.g. a model the kinematics layer cannot evaluate: the candidate cannot be tried.
    c.pass = false;
    c.failed = true;
    c.delta_bic = std::numeric_limits<double>::quiet_NaN();
    c.reason = std::string("it could not be evaluated (") + ex.what() + ")";
    S.say(DiagnoseProgress::Stage::Screening, "  " + c.slot.label() + ": not evaluated: " + ex.what());
  }
}

// Phase 2 (finalists): the linearisation of the screened model in all its parameters (intervals, and the
// one-step held-out test from it). The winner alone is then refined jointly (below).
void refineCandidate(State& S, Candidate& c, Workspace& tws) {
  const Robot& nominal = S.nominal;
  const io::Recording& rec = S.rec;
  const DiagnoseOptions& o = S.o;
  const FitOptions& fo = S.fo;
  c.fit = linearizeModel(nominal, rec, c.fit.effects, S.all, fo, tws);
  S.count(c.fit.evaluations);
  S.count(heldOut(S, c, tws, 1, o.one_step_cv));
  // Near the decision the one-step folds (a linearisation) are not trusted: the folds are refitted iteratively.
  if (o.one_step_cv && c.gain > 0 && c.heldout_p > 0.2 * o.heldout_p && c.heldout_p < 5 * o.heldout_p)
    S.count(heldOut(S, c, tws, 1, false));
  c.pass = c.heldout_p < o.heldout_p && c.gain > o.min_heldout_gain;
  if (!c.pass)
    c.reason = fmt("it lowers BIC by %.1f but does not improve the held-out error enough (%.1f %% lower, p = %.2g)",
                   -c.delta_bic, 100 * c.gain, c.heldout_p);
  S.say(DiagnoseProgress::Stage::Finalists, "  " + c.slot.label() + ": " + c.fit.effects.back().valueText() +
                                                fmt(", dBIC = %+.1f", c.delta_bic) +
                                                fmt(", held-out gain %.1f %%, p = %.2g", 100 * c.gain, c.heldout_p));
}

bool selectionRound(State& S, int round) {
  const Robot& nominal = S.nominal;
  const io::Recording& rec = S.rec;
  const DiagnoseOptions& o = S.o;
  DiagnosisReport& rep = S.rep;
  const FitOptions& fo = S.fo;
  const FitOptions& fo_alone = S.fo_alone;
  const std::vector<char>& all = S.all;
  Workspace& ws = S.ws;
  Candidate& cur = S.cur;
  const int chunks = S.chunks;
  auto deltaBic = [&](const Residuals& a, int ka, const Residuals& b, int kb) { return S.deltaBic(a, ka, b, kb); };
  auto nparams = [](const std::vector<Effect>& e) { return coordinateCount(e); };
  std::vector<Effect> todo;
  for (const Effect& slot : S.slots) {
    bool in = S.inModel(slot);
    // Distributed friction is expensive; once its probe showed no effect it is not retried on top.
    const auto seen = S.last.find(slot.label());
    if (slot.kind == EffectKind::DistributedFriction && seen != S.last.end() && seen->second.heldout_rmse.empty() &&
        seen->second.explanation.find("even mu") != std::string::npos)
      in = true;
    if (!in) todo.push_back(slot);
  }
  if (todo.empty()) return false;
  rep.rounds = round;
  S.progress.round = round;
  S.progress.rounds = round - 1;
  S.progress.candidates = static_cast<int>(todo.size());
  S.progress.screened = 0;
  S.say(DiagnoseProgress::Stage::Screening, "round " + std::to_string(round) + ": fitting " +
                                                std::to_string(todo.size()) + " candidates on top of " +
                                                modelName(cur.fit.effects));
  std::vector<Candidate> cands(todo.size());
  std::vector<FirstOrderScreen> load_screens;
  {
    // First-order screen of the loads on top of the current model (shared by the load candidates of the round).
    std::vector<Effect> loads;
    for (const Effect& s : todo)
      if (screenedFirst(s.kind)) loads.push_back(s);
    if (!loads.empty()) {
      try {
        load_screens = screenFirstOrder(nominal, rec, cur.fit.effects, cur.fit, loads, all, fo_alone, ws);
      } catch (const std::exception& ex) {
        load_screens.clear();
        S.say(DiagnoseProgress::Stage::Screening, std::string("  loads: first-order screen failed: ") + ex.what());
      }
      S.count(1);
    }
  }
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
      S.count(pr.evaluations);
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
        S.say(DiagnoseProgress::Stage::Screening,
              "  " + c.slot.label() + fmt(": probe mu = 0.3, dBIC = %+.1f; not fitted", pb));
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
    if (screenedFirst(c.slot.kind)) {
      // Loads: the first-order screen (one replay per round for all loads, then warm loaded solves per row)
      // decides whether the loaded fit is worth its replays, and gives its start (no grid, no gate).
      const FirstOrderScreen* ls = nullptr;
      for (const FirstOrderScreen& x : load_screens)
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
        S.say(DiagnoseProgress::Stage::Screening,
              "  " + c.slot.label() + ": first-order " + ls->effect.valueText() +
                  fmt(", predicted dBIC = %+.1f; not fitted", ls->predicted_delta_bic));
        return;
      }
      S.say(DiagnoseProgress::Stage::Screening, "  " + c.slot.label() + ": first-order " + ls->effect.valueText() +
                                                    fmt(", predicted dBIC = %+.1f; fitting", ls->predicted_delta_bic));
      so.gate_bic = 0.0;
      grid_from = static_cast<int>(start.size());
    }
    c.fit = fitEffects(nominal, rec, start, all, so, tws, grid_from);
    S.count(c.fit.evaluations);
    c.delta_bic = deltaBic(cur.fit.residuals, nparams(cur.fit.effects), c.fit.residuals, nparams(start));
    c.bic = cur.bic + c.delta_bic;
    if (c.delta_bic >= -o.bic_threshold)
      c.reason =
          fmt("it does not lower BIC by more than %.0f (change %+.1f): the fit does not improve beyond "
              "what one more parameter buys by chance",
              o.bic_threshold, c.delta_bic);
    S.say(DiagnoseProgress::Stage::Screening, "  " + c.slot.label() + ": " + c.fit.effects.back().valueText() +
                                                  fmt(", screening dBIC = %+.1f", c.delta_bic));
  };
  auto refine = [&](Candidate& c, Workspace& w) { refineCandidate(S, c, w); };
  detail::parallelFor(static_cast<int>(todo.size()), o.threads, ws, [&](int i, Workspace& tws) {
    Candidate& c = cands[static_cast<std::size_t>(i)];
    c.slot = todo[static_cast<std::size_t>(i)];
    guarded(S, c, tws, screenCandidate);
    S.progressScreened();
  });
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
    guarded(S, cands[static_cast<std::size_t>(finalists[static_cast<std::size_t>(i)])], tws, refine);
  });
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
      S.say(DiagnoseProgress::Stage::Finalists,
            "held-out: " + c.slot.label() + " predicts the held-out rows better than " + W.slot.label() +
                fmt(" (gain %.1f %% vs %.1f %%, p = %.2g) though its BIC is %.1f higher; it wins the round",
                    100 * c.gain, 100 * W.gain, better_p, c.bic - W.bic));
      best = better;
    }
  }
  // Library physics before a generic description: a generic model (drive_error, stage_error, tracker_drift) wins the
  // round only if it predicts the held-out rows significantly better than the best passing library candidate -- a
  // description can stand in for any physics, so when the library explains the data as well, its physics is named.
  if (best >= 0 && isGeneric(cands[static_cast<std::size_t>(best)].slot.kind)) {
    int lib = -1;
    for (std::size_t i = 0; i < cands.size(); ++i)
      if (cands[i].pass && cands[i].cv_done && !isGeneric(cands[i].slot.kind) &&
          (lib < 0 || cands[i].bic < cands[static_cast<std::size_t>(lib)].bic))
        lib = static_cast<int>(i);
    if (lib >= 0) {
      Candidate& G = cands[static_cast<std::size_t>(best)];
      const Candidate& L = cands[static_cast<std::size_t>(lib)];
      const double p = stats::chunkedBootstrapTest(L.cv.row_score, G.cv.row_score, chunks);
      if (p < o.heldout_p && G.gain > L.gain) {
        S.replaced_by[G.slot.label()].push_back(L.slot.label());
        S.say(DiagnoseProgress::Stage::Finalists,
              "generic: " + G.slot.label() + " predicts the held-out rows better than the library's best, " +
                  L.slot.label() +
                  fmt(" (gain %.1f %% vs %.1f %%, p = %.2g): physics outside the library", 100 * G.gain, 100 * L.gain,
                      p));
      } else {
        G.reason = "the library's " + L.slot.label() +
                   fmt(" explains the data as well (held-out gain %.1f %% vs %.1f %%, p = %.2g that this description "
                       "predicts better): the library's physics is preferred",
                       100 * L.gain, 100 * G.gain, p);
        S.say(DiagnoseProgress::Stage::Finalists, "generic: " + G.slot.label() + " does not predict better than " +
                                                      L.slot.label() + "; the library's physics is preferred");
        best = lib;
      }
    }
  }
  LookAlikes la = best >= 0 ? resolveLookAlikes(S, cands, best, ranked) : jointPair(S, cands, ranked);
  best = la.best;
  std::map<int, std::string>& rival_note = la.rival_note;
  std::vector<Rival>& ties = la.ties;
  std::vector<int>& partners = la.partners;
  Candidate& pair = la.pair;
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
    S.count(joint.evaluations);
    if (deltaBic(W.fit.residuals, k, joint.residuals, k) <= 1e-9) {
      W.fit = std::move(joint);
      W.delta_bic = deltaBic(cur.fit.residuals, nparams(cur.fit.effects), W.fit.residuals, k);
      W.bic = cur.bic + W.delta_bic;
      S.count(heldOut(S, W, ws, o.threads, o.one_step_cv));
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
      f.explanation =
          std::string(la.look_alikes ? "accepted together with its look-alike(s) " : "accepted together with ") +
          others + ": " + describePhysics(c.slot.kind) + ". " +
          (note != rival_note.end() ? note->second + ". " : std::string()) +
          fmt("Fitted together on top of the previous model they lower BIC by %.1f and the held-out "
              "error by %.1f %% (one-sided p = %.2g).",
              -c.delta_bic, 100 * c.gain, c.heldout_p);
    } else if (f.accepted) {
      f.explanation = "accepted: " + describePhysics(c.slot.kind) + ". " +
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
      f.explanation = "rejected: " + describePhysics(c.slot.kind) + "; " + note->second + ".";
    } else if (c.pass && best >= 0) {
      const Candidate& w = cands[static_cast<std::size_t>(best)];
      f.explanation = "rejected: " + describePhysics(c.slot.kind) + " explains less than the accepted " +
                      w.slot.label() +
                      fmt(" (BIC %.1f vs %.1f higher; held-out gain %.1f %% vs %.1f %%).", c.bic - cur.bic,
                          w.bic - cur.bic, 100 * c.gain, 100 * w.gain);
    } else {
      f.explanation = "rejected: " + describePhysics(c.slot.kind) + "; " + c.reason + ".";
    }
    const std::string key = c.slot.label();
    if (!S.last.count(key)) S.order.push_back(key);
    S.last[key] = f;
  }
  S.progress.rounds = round;
  if (best < 0) {
    S.say(DiagnoseProgress::Stage::Accepted,
          "round " + std::to_string(round) + ": no candidate improves held-out error and BIC; stopping");
    return false;
  }
  if (!partners.empty()) {
    for (int x : partners) S.rivals_of[cands[static_cast<std::size_t>(x)].slot.label()] = {};
    cur = std::move(pair);
  } else {
    cur = std::move(cands[static_cast<std::size_t>(best)]);
  }
  S.rivals_of[cur.slot.label()] = ties;
  S.progress.accepted = static_cast<int>(cur.fit.effects.size());
  S.say(DiagnoseProgress::Stage::Accepted,
        "round " + std::to_string(round) + ": accepted " + cur.slot.label() +
            (ties.empty() ? std::string() : " (tied with " + std::to_string(ties.size()) + " look-alike(s))"));
  return true;
}

}  // namespace ctr::diagnosis::detail
