// The remainder: what the final model leaves, located and tested against the noise (docs/formats.md `unexplained`).
#include <algorithm>
#include <cmath>
#include <set>

#include "ctr/diagnosis/statistics.hpp"
#include "diagnosis_state.hpp"

namespace ctr::diagnosis::detail {

std::string remainderWords(const MismatchReport& m, double ratio, const NoiseReport& noise) {
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
  std::string s = noise.supported()
                      ? fmt("the held-out residuals are %.2f x the noise variance", ratio)
                      : fmt("the held-out residuals are %.2f x the variance of the differences between neighbouring "
                            "rows (an upper bound of the noise)",
                            ratio);
  if (parts.empty()) return s + " without a located structure";
  return s + " and the remainder " + join(parts);
}

double State::heldoutRatio(const CrossValidation& cv, double& p) const {
  const NoiseTest t = testAgainstNoise(rec, cv.heldout, fo.noise, evaluable);
  p = t.p_value;
  return t.ratio;
}

void assessRemainder(State& s) {
  Unexplained& u = s.rep.unexplained;
  // The remainder's tests share the false-alarm rate: half for the held-out test, half for the locate tests.
  MismatchOptions mo = s.o.mismatch;
  mo.alpha = 0.5 * s.o.mismatch.alpha;
  s.final_mismatch = locateMismatch(s.rec, s.cur.fit.prediction, s.cur.fit.residuals, s.fo.noise, mo);
  u = Unexplained{};
  u.heldout_ratio = s.heldoutRatio(s.cur.cv, u.heldout_p);
  u.heldout_rmse = s.cur.cv.rmse;
  u.mismatch = s.final_mismatch.findings;
  const bool above = u.heldout_p < 0.5 * s.o.mismatch.alpha && u.heldout_ratio > 1.3;
  u.present = above || !s.final_mismatch.findings.empty();
  u.fraction_explained = s.base_ratio > 1.0
                             ? std::clamp((s.base_ratio - u.heldout_ratio) / (s.base_ratio - 1.0), 0.0, 1.0)
                             : (u.present ? 0.0 : 1.0);
  u.where = remainderWords(s.final_mismatch, u.heldout_ratio, s.rep.noise);
}

}  // namespace ctr::diagnosis::detail
