/// @file first_order_screen.hpp
/// @brief First-order screen of candidates that are costly to fit by replays -- the loads (gravity, tip_load) and the
/// generic models of physics outside the library (drive_error, stage_error, tracker_drift): the model's response to
/// each coordinate at every row (central differences of warm solves at the row's equilibrium, its contact laws held:
/// a perturbed robot for a load, a perturbed actuation for a drive or stage error; a tracker drift adds to the
/// measurement directly), a linear least-squares estimate on the current residuals (the sensor registration's
/// linearised rigid motion and tip offset profiled out in an unknown frame), and the BIC change it predicts. Full
/// fits (whole-sequence replays) are then run only for a candidate whose screen predicts a real improvement.
#pragma once

#include <string>
#include <vector>

#include "ctr/diagnosis/effect.hpp"
#include "ctr/diagnosis/fit.hpp"
#include "ctr/io/recording.hpp"

namespace ctr::diagnosis {

/// @brief The first-order screen of one candidate on top of a model.
struct FirstOrderScreen {
  Effect effect;                   ///< The candidate at its first-order estimate (clamped to its fit ranges).
  double predicted_delta_bic = 0;  ///< Linear prediction of BIC(model + effect) - BIC(model) (same BIC as bic()).
  int rows = 0;                    ///< Rows with a sensitivity (the others are left out of the estimate).
  bool ok = false;                 ///< False when no row could be linearised (then `message` says why).
  std::string message;
};

/// @brief Screens each candidate of `candidates` (load slots at their nominal values, generic slots at zero) on top
/// of `model`, whose full fit on the rows `use` is `model_fit` (its residuals and registration). Costs one replay
/// of `model` (keeping its equilibria) plus 2 warm solves per row and coordinate (none for a tracker drift).
std::vector<FirstOrderScreen> screenFirstOrder(const Robot& nominal, const io::Recording& rec,
                                               const std::vector<Effect>& model, const FitResult& model_fit,
                                               const std::vector<Effect>& candidates, const std::vector<char>& use,
                                               const FitOptions& options, Workspace& ws);

}  // namespace ctr::diagnosis
