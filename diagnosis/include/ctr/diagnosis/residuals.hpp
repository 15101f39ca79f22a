/// @file residuals.hpp
/// @brief Residuals between a recording and a model prediction per measured quantity, the measurement model
/// (base frame or unknown sensor frame), noise levels and error summaries (RMSE, BIC).
#pragma once

#include <Eigen/Core>
#include <array>
#include <map>
#include <string>
#include <vector>

#include "ctr/diagnosis/forward_model.hpp"
#include "ctr/diagnosis/registration.hpp"
#include "ctr/io/recording.hpp"

namespace ctr::diagnosis {

/// @brief A measured quantity of a recording.
enum class Quantity { Twist, TipPosition, TipTangent };

/// @brief JSON name: "twist", "tip_position", "tip_tangent".
const char* quantityName(Quantity q);
/// @brief The quantities present in a recording.
std::vector<Quantity> presentQuantities(const io::Recording& rec);

/// @brief Frame of the measured tip positions/tangents.
enum class FrameMode {
  Base,     ///< Already in the robot base frame.
  Unknown,  ///< Unknown sensor frame: a rigid registration (+ tip offset) is estimated in every model.
};

/// @brief Noise standard deviation per scalar component of each quantity (rad, m, unit).
struct NoiseLevels {
  double twist = 0.0;
  double tip_position = 0.0;
  double tip_tangent = 0.0;
  double of(Quantity q) const;
};

/// @brief Measured minus predicted, rows x components (NaN where not measured). Twist differences are wrapped
/// to (-pi, pi].
struct Residuals {
  Eigen::MatrixXd twist, tip_position, tip_tangent;
  const Eigen::MatrixXd& of(Quantity q) const;
  Eigen::MatrixXd& of(Quantity q);
};

/// @brief Residuals of a prediction (already mapped to the sensor frame when needed).
Residuals computeResiduals(const io::Recording& rec, const Prediction& p);

/// @brief Maps the prediction to the sensor frame: for FrameMode::Unknown a registration is fitted on the rows
/// flagged in `use` (weighted by the noise levels) and applied to all rows. Returns the registration.
Registration mapToSensor(const io::Recording& rec, Prediction& p, FrameMode frame, const std::vector<char>& use,
                         const NoiseLevels& noise);

/// @brief Noise levels estimated from residuals whose model error is smooth: the robust spread of differences
/// between consecutive rows and between nearest neighbours in configuration space (the smaller of the two).
NoiseLevels estimateNoise(const io::Recording& rec, const Residuals& r);

/// @brief Sum of squares and count of scalar residuals of one quantity over the flagged rows.
struct SumSquares {
  double ss = 0.0;
  int count = 0;  ///< scalar components
  int rows = 0;   ///< rows with a measurement
};
SumSquares sumSquares(const Eigen::MatrixXd& r, const std::vector<char>& use);

/// @brief RMSE per quantity over the flagged rows: twist per component (rad), tip position and tangent as the RMS
/// of the per-row Euclidean error (m, unit-vector norm).
std::map<std::string, double> rmse(const io::Recording& rec, const Residuals& r, const std::vector<char>& use);

/// @brief Per-row noise-normalised squared error summed over the present quantities (NaN where nothing is
/// measured or the model could not evaluate the row).
Eigen::VectorXd rowScores(const io::Recording& rec, const Residuals& r, const NoiseLevels& noise);

/// @brief Mean of the finite entries (0 when none).
double finiteMean(const Eigen::VectorXd& v);
/// @brief Means of a and b over the rows where both are finite (compares two models on the same rows).
std::array<double, 2> commonMeans(const Eigen::VectorXd& a, const Eigen::VectorXd& b);
/// @brief Rows flagged in `use` where both residual sets have a finite value (both models evaluated the row).
std::vector<char> commonRows(const Residuals& a, const Residuals& b, const std::vector<char>& use);

/// @brief Gaussian BIC with an unknown variance per quantity: sum_q N_q ln(RSS_q / N_q) + k ln(N).
double bic(const io::Recording& rec, const Residuals& r, const std::vector<char>& use, int parameters);

}  // namespace ctr::diagnosis
