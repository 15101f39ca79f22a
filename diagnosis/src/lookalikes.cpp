// Look-alikes (effects a recording may not tell apart): before the best of a group is accepted it is tested against
// the best screened rivals of its group with encompassing fits -- both together, then does each add on top of the
// other? Only the one that adds is named; when neither adds, the recording cannot tell them apart; when both add,
// both are present and are accepted together from their joint fit (a look-alike accepted alone absorbs part of the
// other -- e.g. latency absorbing one joint's backlash -- and the other then screens too small on top of it).
#include <algorithm>
#include <atomic>
#include <cmath>

#include "ctr/diagnosis/statistics.hpp"
#include "diagnosis_state.hpp"
#include "parallel.hpp"

namespace ctr::diagnosis::detail {

namespace {

// A partner adds on top of the winner in-sample, but it may stand in for physics outside the group (a stage offset
// for a tip load, say): it is kept only if it still adds on top of the winner and the strongest candidate outside the
// group (by BIC, passing or not: a load too weak to pass alone may be what the partner takes up; library physics
// only, since a generic description can stand in for anything). A partner that does not is left to
// the next round, which compares it with that candidate on equal terms.
void dropProxyPartners(State& S, std::vector<Candidate>& cands, int best, int group_start, std::vector<int>& partners,
                       std::map<int, std::string>& rival_note) {
  const DiagnoseOptions& o = S.o;
  const Candidate& W = cands[static_cast<std::size_t>(best)];
  int x = -1;
  for (std::size_t i = 0; i < cands.size(); ++i) {
    const Candidate& c = cands[i];
    if (static_cast<int>(i) == best || c.failed || c.probed_only || !(c.delta_bic < -o.bic_threshold) ||
        c.fit.effects.empty() || isGeneric(c.slot.kind) || areLookAlikes(c.slot.kind, W.slot.kind))
      continue;
    if (x < 0 || c.bic < cands[static_cast<std::size_t>(x)].bic) x = static_cast<int>(i);
  }
  if (x < 0) return;
  const Candidate& X = cands[static_cast<std::size_t>(x)];
  FitOptions jo = S.fo;
  jo.intervals = false;
  jo.first_free = group_start;  // as in the encompassing fits: the accepted effects outside the group are held
  std::vector<Effect> wx = W.fit.effects;
  wx.push_back(X.fit.effects.back());
  FitResult WX;
  try {
    WX = fitEffects(S.nominal, S.rec, wx, S.all, jo, S.ws, static_cast<int>(wx.size()));
  } catch (const std::exception&) {
    return;  // the check cannot be made; the partners stand on their encompassing fits
  }
  S.count(WX.evaluations);
  const int kwx = coordinateCount(WX.effects);
  std::vector<double> adds(partners.size(), 0.0);
  std::vector<char> ok(partners.size(), 0);
  parallelFor(static_cast<int>(partners.size()), o.threads, S.ws, [&](int j, Workspace& tws) {
    std::vector<Effect> wxp = WX.effects;
    wxp.push_back(cands[static_cast<std::size_t>(partners[static_cast<std::size_t>(j)])].fit.effects.back());
    try {
      const FitResult F = fitEffects(S.nominal, S.rec, wxp, S.all, jo, tws, static_cast<int>(wxp.size()));
      S.count(F.evaluations);
      adds[static_cast<std::size_t>(j)] = S.deltaBic(F.residuals, coordinateCount(wxp), WX.residuals, kwx);
      ok[static_cast<std::size_t>(j)] = 1;
    } catch (const std::exception&) {
    }
  });
  std::vector<int> kept;
  for (std::size_t j = 0; j < partners.size(); ++j) {
    const Candidate& P = cands[static_cast<std::size_t>(partners[j])];
    if (!ok[j] || adds[j] > o.bic_threshold) {
      kept.push_back(partners[j]);
      continue;
    }
    S.say(DiagnoseProgress::Stage::LookAlikes, "look-alikes: " + P.slot.label() + " adds on top of " + W.slot.label() +
                                                   " but not on top of " + W.slot.label() + " and " + X.slot.label() +
                                                   fmt(" (BIC %+.1f); left to the next round", -adds[j]));
    rival_note[partners[j]] = "it adds on top of " + W.slot.label() + " but not on top of " + W.slot.label() + " and " +
                              X.slot.label() + fmt(" (BIC %+.1f): it may stand in for ", -adds[j]) + X.slot.label() +
                              ", so it was not accepted with " + W.slot.label();
  }
  partners = kept;
}

}  // namespace

LookAlikes resolveLookAlikes(State& S, std::vector<Candidate>& cands, int best, const std::vector<int>& ranked) {
  const Robot& nominal = S.nominal;
  const io::Recording& rec = S.rec;
  const DiagnoseOptions& o = S.o;
  const FitOptions& fo = S.fo;
  Candidate& cur = S.cur;
  auto deltaBic = [&](const Residuals& a, int ka, const Residuals& b, int kb) { return S.deltaBic(a, ka, b, kb); };
  auto nparams = [](const std::vector<Effect>& e) { return coordinateCount(e); };
  auto refine = [&](Candidate& c, Workspace& w) { refineCandidate(S, c, w); };
  LookAlikes out;
  std::map<int, std::string>& rival_note = out.rival_note;
  std::vector<Rival>& ties = out.ties;
  std::vector<int>& partners = out.partners;
  Candidate& pair = out.pair;
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
    const Candidate& W = cands[static_cast<std::size_t>(best)];
    // W's screening model lists the accepted effects outside its group first (screenCandidate).
    int group_start = 0;
    for (const Effect& e : cur.fit.effects) group_start += !areLookAlikes(e.kind, W.slot.kind);
    detail::parallelFor(static_cast<int>(rv.size()), o.threads, S.ws, [&](int j, Workspace& tws) {
      const Candidate& R = cands[static_cast<std::size_t>(rv[static_cast<std::size_t>(j)])];
      std::vector<Effect> both = W.fit.effects;
      both.push_back(R.fit.effects.back());
      FitOptions jo = fo;
      jo.intervals = false;
      // As in screening: the accepted effects outside the group are held (W's and R's screening fits held them
      // too, so the BIC comparisons are like for like); the group's accepted members, W and R are fitted.
      jo.first_free = group_start;
      try {
        const FitResult J = fitEffects(nominal, rec, both, S.all, jo, tws, static_cast<int>(both.size()));
        S.count(J.evaluations);
        const int k = nparams(both);
        enc[static_cast<std::size_t>(j)] = {deltaBic(J.residuals, k, R.fit.residuals, nparams(R.fit.effects)),
                                            deltaBic(J.residuals, k, W.fit.residuals, nparams(W.fit.effects)), true, J};
      } catch (const std::exception&) {
        enc[static_cast<std::size_t>(j)].ok = false;
      }
    });
    // Rivals that may tie or win need their own held-out scores.
    detail::parallelFor(static_cast<int>(rv.size()), o.threads, S.ws, [&](int j, Workspace& tws) {
      Candidate& R = cands[static_cast<std::size_t>(rv[static_cast<std::size_t>(j)])];
      const Encompassing& e = enc[static_cast<std::size_t>(j)];
      if (!R.cv_done && e.ok && e.add_winner <= o.bic_threshold) guarded(S, R, tws, refine);
    });
    int switch_to = -1;
    std::vector<int> both_add;  // rivals that each add on top of the winner and the winner on top of them
    for (std::size_t j = 0; j < rv.size(); ++j) {
      const int i = rv[j];
      const Candidate& R = cands[static_cast<std::size_t>(i)];
      const Encompassing& e = enc[j];
      if (!e.ok) continue;
      const bool w_adds = e.add_winner > o.bic_threshold, r_adds = e.add_rival > o.bic_threshold;
      const std::string wl = W.slot.label(), rl = R.slot.label();
      S.say(DiagnoseProgress::Stage::LookAlikes,
            "look-alikes: " + wl + " vs " + rl +
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
        r.heldout_p = stats::chunkedBootstrapTest(R.cv.row_score, W.cv.row_score, S.chunks);
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
          S.say(DiagnoseProgress::Stage::LookAlikes,
                "look-alikes: " + cands[static_cast<std::size_t>(rv[static_cast<std::size_t>(top)])].slot.label() +
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
    if (switch_to < 0 && !partners.empty()) dropProxyPartners(S, cands, best, group_start, partners, rival_note);
    if (switch_to >= 0) {
      S.say(DiagnoseProgress::Stage::LookAlikes,
            "look-alikes: " + cands[static_cast<std::size_t>(switch_to)].slot.label() + " explains what " +
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
      P.fit = fitEffects(nominal, rec, start, S.all, S.fo_alone, S.ws, k);  // + intervals, linearisation
      S.count(P.fit.evaluations);
      P.delta_bic = deltaBic(cur.fit.residuals, nparams(cur.fit.effects), P.fit.residuals, k);
      P.bic = cur.bic + P.delta_bic;
      S.count(heldOut(S, P, S.ws, o.threads, o.one_step_cv));
      P.pass = P.delta_bic < -(1.0 + partners.size()) * o.bic_threshold && P.heldout_p < o.heldout_p &&
               P.gain > o.min_heldout_gain;
      std::string names = W.slot.label();
      for (int i : partners) names += " + " + cands[static_cast<std::size_t>(i)].slot.label();
      if (P.pass) {
        S.say(DiagnoseProgress::Stage::LookAlikes,
              "look-alikes: " + names + " each add on top of the other; accepted together" +
                  fmt(" (dBIC %+.1f, held-out gain %.1f %%)", P.delta_bic, 100 * P.gain));
        pair = std::move(P);
      } else {
        partners.clear();
      }
    }
  }
  out.best = best;
  return out;
}

}  // namespace ctr::diagnosis::detail
