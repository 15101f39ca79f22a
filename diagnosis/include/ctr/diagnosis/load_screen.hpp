/// @file load_screen.hpp
/// @brief First-order screen of the load candidates (gravity, tip_load): the model's response to each load
/// coordinate at every row (central differences of warm loaded solves at the row's equilibrium, its contact laws
/// held), a linear least-squares estimate of the load on the current residuals (the sensor registration's
/// linearised rigid motion and tip offset profiled out in an unknown frame), and the BIC change it predicts. Full
/// loaded fits (whole-sequence replays with the slower loaded solver) are then run only for a load whose screen
/// predicts a real improvement.
#pragma once

#include <string>
#include <vector>

#include "ctr/diagnosis/effect.hpp"
#include "ctr/diagnosis/fit.hpp"
#include "ctr/io/recording.hpp"

namespace ctr::diagnosis {

/// @brief The first-order screen of one load candidate on top of a model.
struct LoadScreen {
  Effect effect;                    ///< The candidate at its first-order estimate (clamped to its fit ranges).
  double predicted_delta_bic = 0;   ///< Linear prediction of BIC(model + effect) - BIC(model) (same BIC as bic()).
  int rows = 0;                     ///< Rows with a sensitivity (the others are left out of the estimate).
  bool ok = false;                  ///< False when no row could be linearised (then `message` says why).
  std::string message;
};

/// @brief Screens each candidate of `candidates` (gravity and/or tip_load slots at their nominal values) on top
/// of `model`, whose full fit on the rows `use` is `model_fit` (its residuals and registration). Costs one replay
/// of `model` (keeping its equilibria) plus 6 warm loaded solves per row and candidate.
std::vector<LoadScreen> screenLoads(const Robot& nominal, const io::Recording& rec, const std::vector<Effect>& model,
                                    const FitResult& model_fit, const std::vector<Effect>& candidates,
                                    const std::vector<char>& use, const FitOptions& options, Workspace& ws);

}  // namespace ctr::diagnosis
