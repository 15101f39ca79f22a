// Two effects that are each too weak to pass alone: when no candidate of a round predicts the held-out rows
// significantly better on its own, the two strongest candidates of different kinds may still do so together (each
// absorbs the other's signature while it is left out: friction and a torsional stiffness on a sweep, say). They are
// fitted jointly and accepted together only when each adds on top of the other in BIC and the pair passes the
// held-out test against the current model.
#include <algorithm>

#include "diagnosis_state.hpp"

namespace ctr::diagnosis::detail {

LookAlikes jointPair(State& S, std::vector<Candidate>& cands, const std::vector<int>& ranked) {
  const DiagnoseOptions& o = S.o;
  LookAlikes out;
  if (o.max_effects - static_cast<int>(S.cur.fit.effects.size()) < 2) return out;
  // The two strongest refined library candidates (by BIC) of different kinds with a held-out gain of their own.
  std::vector<int> top;
  for (int i : ranked) {
    const Candidate& c = cands[static_cast<std::size_t>(i)];
    if (c.failed || c.probed_only || !c.cv_done || isGeneric(c.slot.kind) || !(c.gain > o.min_heldout_gain) ||
        c.fit.effects.empty())
      continue;
    if (!top.empty() && cands[static_cast<std::size_t>(top[0])].slot.kind == c.slot.kind) continue;
    top.push_back(i);
    if (top.size() == 2) break;
  }
  if (top.size() < 2) return out;
  Candidate& A = cands[static_cast<std::size_t>(top[0])];
  Candidate& B = cands[static_cast<std::size_t>(top[1])];
  Candidate P;
  P.slot = A.slot;
  std::vector<Effect> start = A.fit.effects;
  start.push_back(B.fit.effects.back());
  const int k = coordinateCount(start);
  try {
    P.fit = fitEffects(S.nominal, S.rec, start, S.all, S.fo_alone, S.ws, k);
  } catch (const std::exception& ex) {
    S.say(DiagnoseProgress::Stage::Finalists,
          "joint pair: " + A.slot.label() + " + " + B.slot.label() + " could not be evaluated (" + ex.what() + ")");
    return out;
  }
  S.count(P.fit.evaluations);
  const double add_a = S.deltaBic(P.fit.residuals, k, B.fit.residuals, coordinateCount(B.fit.effects));
  const double add_b = S.deltaBic(P.fit.residuals, k, A.fit.residuals, coordinateCount(A.fit.effects));
  const std::string names = A.slot.label() + " + " + B.slot.label();
  if (!(add_a > o.bic_threshold && add_b > o.bic_threshold)) {
    S.say(DiagnoseProgress::Stage::Finalists,
          "joint pair: " + names +
              fmt(": on top of each other they lower BIC by %.1f and %.1f; not a pair", add_a, add_b));
    return out;
  }
  P.delta_bic = S.deltaBic(S.cur.fit.residuals, coordinateCount(S.cur.fit.effects), P.fit.residuals, k);
  P.bic = S.cur.bic + P.delta_bic;
  S.count(heldOut(S, P, S.ws, o.threads, o.one_step_cv));
  P.pass = P.delta_bic < -2 * o.bic_threshold && P.heldout_p < o.heldout_p && P.gain > o.min_heldout_gain;
  S.say(DiagnoseProgress::Stage::Finalists,
        "joint pair: " + names +
            fmt(": dBIC %+.1f, held-out gain %.1f %%, p = %.2g", P.delta_bic, 100 * P.gain, P.heldout_p) +
            (P.pass ? "; accepted together" : "; not significant"));
  if (!P.pass) return out;
  const std::string note = fmt("alone neither predicts the held-out rows significantly better (p = %.2g and %.2g); ",
                               A.heldout_p, B.heldout_p) +
                           fmt("together they do (p = %.2g), and each lowers BIC on top of the other (by %.1f and "
                               "%.1f)",
                               P.heldout_p, add_a, add_b);
  out.best = top[0];
  out.partners = {top[1]};
  out.rival_note[top[0]] = note;
  out.rival_note[top[1]] = note;
  out.look_alikes = false;
  out.pair = std::move(P);
  return out;
}

}  // namespace ctr::diagnosis::detail
