// Backward elimination: greedy forward steps can accept an effect that later ones make redundant.
#include <algorithm>

#include "diagnosis_state.hpp"
#include "parallel.hpp"

namespace ctr::diagnosis::detail {

std::vector<Effect> withoutEffects(const State& s, const std::vector<std::size_t>& drop) {
  std::vector<Effect> reduced;
  for (std::size_t j = 0; j < s.cur.fit.effects.size(); ++j)
    if (std::find(drop.begin(), drop.end(), j) == drop.end()) reduced.push_back(s.cur.fit.effects[j]);
  return reduced;
}

void refitEachWithout(State& s) {
  s.without.assign(s.cur.fit.effects.size(), FitResult{});
  parallelFor(static_cast<int>(s.without.size()), s.o.threads, s.ws, [&](int j, Workspace& tws) {
    const std::vector<Effect> reduced = withoutEffects(s, {static_cast<std::size_t>(j)});
    FitOptions bo = s.fo;  // warm start: a few iterations, no intervals (recomputed if the reduced model is kept)
    bo.intervals = false;
    bo.max_iterations = 4;
    s.without[static_cast<std::size_t>(j)] =
        fitEffects(s.nominal, s.rec, reduced, s.all, bo, tws, coordinateCount(reduced));
  });
  for (const FitResult& f : s.without) s.count(f.evaluations);
}

void backwardElimination(State& s, const char* why) {
  Candidate& cur = s.cur;
  while (cur.fit.effects.size() >= 2) {
    int drop = -1;
    double best_d = 0;
    refitEachWithout(s);
    for (std::size_t j = 0; j < cur.fit.effects.size(); ++j) {
      const FitResult& f = s.without[j];
      const double d =
          s.deltaBic(cur.fit.residuals, coordinateCount(cur.fit.effects), f.residuals, coordinateCount(f.effects));
      if (d < s.o.bic_threshold && (drop < 0 || d < best_d)) {
        drop = static_cast<int>(j);
        best_d = d;
      }
    }
    if (drop < 0) break;
    const std::string lab = cur.fit.effects[static_cast<std::size_t>(drop)].label();
    s.removed[lab] = fmt(why, best_d);
    s.say(DiagnoseProgress::Stage::Elimination, "backward elimination: removed " + lab);
    cur.bic += best_d;
    const std::vector<Effect> reduced = s.without[static_cast<std::size_t>(drop)].effects;
    cur.fit = fitEffects(s.nominal, s.rec, reduced, s.all, s.fo_alone, s.ws, coordinateCount(reduced));
    s.count(cur.fit.evaluations);
    s.without.clear();
    cur.cv = crossValidate(s.nominal, s.rec, cur.fit.effects, s.o.folds, s.fo, s.ws, s.o.cv_iterations, s.o.threads,
                           s.o.one_step_cv ? &cur.fit : nullptr);
    s.count(cur.cv.evaluations);
  }
}

}  // namespace ctr::diagnosis::detail
