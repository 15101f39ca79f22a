// The replays' integration steps: coarser than the library's default (about half the cost of a replay), kept only when
// their error on the nominal replay is far below the noise of the recording.
#include <algorithm>
#include <cmath>

#include "diagnosis_state.hpp"

namespace ctr::diagnosis::detail {

bool checkDiscretisation(State& s) {
  KinematicsOptions& k = s.fo.predict.replay.friction.kinematics;
  const KinematicsOptions library;
  ReplayDiscretisation& d = s.rep.discretisation;
  d.max_step = k.max_step;
  d.max_bending_per_step = k.max_bending_per_step;
  d.error_over_noise = 0.0;
  if (k.max_step <= library.max_step && k.max_bending_per_step <= library.max_bending_per_step) return false;
  PredictOptions fine = s.fo.predict;
  fine.replay.friction.kinematics.max_step = library.max_step;
  fine.replay.friction.kinematics.max_bending_per_step = library.max_bending_per_step;
  const Prediction a = predict(s.nominal, s.rec.commands, s.rec.time, {}, s.ws, s.fo.predict);
  const Prediction b = predict(s.nominal, s.rec.commands, s.rec.time, {}, s.ws, fine);
  s.count(2);
  for (Quantity q : presentQuantities(s.rec)) {
    const double sigma = s.fo.noise.of(q);
    if (!(sigma > 0)) continue;
    const Eigen::MatrixXd& pa = predicted(a, q);
    const Eigen::MatrixXd& pb = predicted(b, q);
    for (int r = 0; r < s.rec.rows(); ++r) {
      if (!s.evaluable[static_cast<std::size_t>(r)]) continue;
      for (Eigen::Index c = 0; c < pa.cols(); ++c) {
        const bool fa = std::isfinite(pa(r, c)), fb = std::isfinite(pb(r, c));
        if (fa != fb)  // a row evaluated at one step size and not at the other
          d.error_over_noise = HUGE_VAL;
        else if (fa)
          d.error_over_noise = std::max(d.error_over_noise, std::abs(pa(r, c) - pb(r, c)) / sigma);
      }
    }
  }
  if (d.error_over_noise <= s.o.max_discretisation_error) return false;
  d.refined = true;
  k = fine.replay.friction.kinematics;
  d.max_step = k.max_step;
  d.max_bending_per_step = k.max_bending_per_step;
  s.rep.warnings.push_back(
      fmt("the replays' integration steps differ from the library's default steps by %.2g x the "
          "noise on the nominal model: the default steps are used (slower)",
          d.error_over_noise));
  s.say(DiagnoseProgress::Stage::Baseline, s.rep.warnings.back());
  return true;
}

}  // namespace ctr::diagnosis::detail
