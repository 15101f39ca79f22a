/// @file fit.hpp
/// @brief Fitting effect parameters to a recording by nonlinear least squares (Ceres, numeric Jacobians of full
/// replays) on a subset of rows, and held-out scoring on contiguous time blocks (cross-validation).
#pragma once

#include <array>
#include <limits>
#include <map>
#include <string>
#include <vector>

#include "ctr/diagnosis/effect.hpp"
#include "ctr/diagnosis/forward_model.hpp"
#include "ctr/diagnosis/residuals.hpp"
#include "ctr/io/recording.hpp"

namespace ctr::diagnosis {

/// @brief Search range of one effect's parameter and the coarse grid used to start the fit.
struct ParameterRange {
  double lo = 0.0, hi = 1.0;
  std::vector<double> grid;
};

/// @brief Range of fitted coordinate `coordinate` of (kind, tube) for a robot and recording (the vector kinds:
/// each component of the force, or of scale * direction, around its nominal value).
ParameterRange parameterRange(const Robot& nominal, const io::Recording& rec, EffectKind kind, int tube,
                              int coordinate = 0);

/// @brief Fitted coordinates of a model: the sum of parameterCount over its effects (the k of its BIC).
int coordinateCount(const std::vector<Effect>& effects);

/// @brief Options of fitEffects().
struct FitOptions {
  FrameMode frame = FrameMode::Base;
  NoiseLevels noise;              ///< Residual weights 1/sigma per quantity (must be > 0 for present quantities).
  int max_iterations = 20;        ///< Ceres iterations.
  bool grid_search = true;        ///< Scan the grid of the effects flagged `free` whose start is not trusted.
  bool intervals = true;          ///< 95 % intervals from the Gauss-Newton covariance.
  double difference_step = 2e-3;  ///< Difference step in units of the parameter range.
  /// One-sided differences in the optimiser's iterations (one replay per parameter); the intervals always use
  /// central differences.
  bool forward_differences = true;
  /// Screening gate (0 = off): after the grid scan, skip the iterations when the Gauss-Newton model predicts a BIC
  /// drop below this (N ln(RSS/RSS_predicted); the candidate could not pass the selection threshold).
  double gate_bic = 0.0;
  double function_tolerance = 1e-5;  ///< Ceres relative cost-change tolerance.
  int first_free = 0;                ///< Effects before this index keep their start values (not fitted).
  /// Threads replaying the difference points of a Jacobian and the grid points concurrently (the result does not
  /// depend on it). Leave 1 when fits already run in parallel.
  int threads = 1;
  /// Rows any fit or registration may use (empty = all): the diagnosis leaves out the rows the nominal model could
  /// not evaluate (failed rows). Intersected with the `use` / training rows of each call.
  std::vector<char> rows;
  PredictOptions predict;
};

/// @brief A fitted model evaluated on every row.
struct FitResult {
  std::vector<Effect> effects;  ///< Fitted values.
  /// Per effect (empty when not computed; an effect held in the fit has an empty entry): 95 % intervals of its
  /// coordinates and their covariance, Gauss-Newton with the pre-whitened HAC covariance over rows (serial
  /// correlation).
  std::vector<EffectUncertainty> uncertainty;
  /// The covariance of all fitted coordinates (effect by effect, parameterCount each; coordinate units), of which
  /// `uncertainty` holds the diagonal blocks: the HAC covariance with each variance raised to at least the classical
  /// one (the classical covariance when a HAC variance is not positive). Empty when intervals are not computed.
  Eigen::MatrixXd covariance;
  double interval_serial_correlation = 0.0;  ///< AR(1) coefficient of the row scores behind the intervals.
  Registration registration;                 ///< Sensor registration (FrameMode::Unknown).
  Prediction prediction;                     ///< All rows, in the sensor frame.
  Residuals residuals;                       ///< All rows.
  double cost = 0.0;                         ///< 0.5 * weighted sum of squares on the fit rows.
  int evaluations = 0;                       ///< Replays of the whole sequence.
  bool converged = true;
  std::string message;
  /// Linearisation at the optimum (filled when intervals are computed): Jacobian of the noise-normalised residuals
  /// of the fit rows (row blocks of `components` entries, rows listed in `jacobian_rows`) with respect to the
  /// fitted coordinates (effect by effect, parameterCount each) scaled to [0, 1] over their ranges (`x`). Used by
  /// the one-step cross-validation.
  Eigen::MatrixXd jacobian;
  Eigen::VectorXd weighted_residuals;
  std::vector<int> jacobian_rows;
  int components = 0;
  std::vector<double> x;
};

/// @brief Evaluates a model (no fitting): replay, registration on the rows in `use`, residuals on all rows.
FitResult evaluateModel(const Robot& nominal, const io::Recording& rec, const std::vector<Effect>& effects,
                        const std::vector<char>& use, const FitOptions& options, Workspace& ws);

/// @brief Fits the values of the effects (all of them; `grid_from` and later effects are first scanned on their
/// grid) on the rows in `use`. Stateful effects are always replayed over the whole sequence.
FitResult fitEffects(const Robot& nominal, const io::Recording& rec, const std::vector<Effect>& start,
                     const std::vector<char>& use, const FitOptions& options, Workspace& ws, int grid_from = 0);

/// @brief Evaluates a model at the given values (no fitting) with its linearisation (FitResult::jacobian, central
/// differences) and the 95 % intervals it implies: 2k + 1 replays for k effects.
FitResult linearizeModel(const Robot& nominal, const io::Recording& rec, const std::vector<Effect>& effects,
                         const std::vector<char>& use, const FitOptions& options, Workspace& ws);

/// @brief detectionLimits() of one candidate.
struct DetectionLimit {
  /// The smallest size (distance from its value in `candidates`) the recording can tell from that value, in the
  /// parameter's units; infinity when no size can be told.
  double value = std::numeric_limits<double>::infinity();
  /// Infinite because its prediction change is a combination of the model's effects' (confounded), not because no
  /// output depends on it.
  bool confounded = false;
};

/// @brief How small an effect this recording can tell from none on top of a fitted model, per candidate (first
/// order, at the model's values): the larger of
/// - the half-width of the 95 % interval of the candidate's parameter at its value in `candidates` (its nominal value),
///   fitted jointly with the model's effects (Gauss-Newton; the HAC covariance over rows, never narrower than the
///   classical one, as the intervals of linearizeModel), and
/// - the size at which the candidate, were it present, would lower BIC by `bic_threshold` when fitted (its prediction
///   change with the model's effects refitted, against the model's residuals).
/// Only candidates with one coordinate (parameterCount 1). 2k + 1 replays for the model's k coordinates, plus one per
/// candidate.
std::vector<DetectionLimit> detectionLimits(const Robot& nominal, const io::Recording& rec,
                                            const std::vector<Effect>& model, const std::vector<Effect>& candidates,
                                            const std::vector<char>& use, const FitOptions& options,
                                            double bic_threshold, Workspace& ws);

/// @brief Held-out evaluation: for each of `folds` contiguous blocks of rows, the effects are refitted (from
/// `start`, no grid) on the other blocks and the residuals of the block are kept.
struct CrossValidation {
  Residuals heldout;                              ///< Each row's residual from the fold that held it out.
  std::map<std::string, double> rmse;             ///< Held-out RMSE per quantity.
  Eigen::VectorXd row_score;                      ///< Noise-normalised squared error per row (held out).
  double score = 0.0;                             ///< Mean of row_score.
  std::vector<std::vector<Effect>> fold_effects;  ///< Fitted values per fold.
  int evaluations = 0;
};

/// @brief Contiguous fold index of each row (0..folds-1).
std::vector<int> foldOfRows(int rows, int folds);

/// @brief Cross-validates a model. With no effects (baseline) only the registration is refitted per fold.
/// With threads > 1 the folds are fitted concurrently (one workspace each; the result does not depend on it).
/// When `full` is the full-data fit of `start` with its linearisation (FitResult::jacobian), each fold's refit is
/// one Gauss-Newton step from the full-data optimum on the fold's training rows (the one-step estimator,
/// asymptotically equal to the fold's own optimum) and costs one replay per fold; otherwise each fold runs up to
/// `max_iterations` Levenberg-Marquardt iterations.
CrossValidation crossValidate(const Robot& nominal, const io::Recording& rec, const std::vector<Effect>& start,
                              int folds, const FitOptions& options, Workspace& ws, int max_iterations = 6,
                              int threads = 1, const FitResult* full = nullptr);

}  // namespace ctr::diagnosis
