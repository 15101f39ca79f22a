/// @file residuals.hpp
/// @brief Residuals between a recording and a model prediction per measured quantity, the measurement model
/// (base frame or unknown sensor frame), noise levels and error summaries (RMSE, BIC).
#pragma once

#include <Eigen/Core>
#include <array>
#include <limits>
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
const char* toString(Quantity q);
/// @brief The quantities present in a recording.
std::vector<Quantity> presentQuantities(const io::Recording& rec);

/// @brief Frame of the measured tip positions/tangents.
enum class FrameMode {
  Base,     ///< Already in the robot base frame.
  Unknown,  ///< Unknown sensor frame: a rigid registration (+ tip offset) is estimated in every model.
};

/// @brief "base" / "unknown".
const char* toString(FrameMode mode);

/// @brief Noise standard deviation of each quantity: per scalar component for twist (rad) and tip position (m), per
/// direction normal to the measured tangent for the tip tangent (its residual has 2 degrees of freedom per row).
/// With the degrees of freedom of each level's estimate (infinity when the level is given), which the tests against
/// the noise account for (noise.hpp).
struct NoiseLevels {
  double twist = 0.0;
  double tip_position = 0.0;
  double tip_tangent = 0.0;
  double twist_dof = std::numeric_limits<double>::infinity();
  double tip_position_dof = std::numeric_limits<double>::infinity();
  double tip_tangent_dof = std::numeric_limits<double>::infinity();
  double of(Quantity q) const;
  double dof(Quantity q) const;
};

/// @brief Independent scalar noise components per row of a quantity with `columns` columns: the twist's columns,
/// 3 for a position, 2 for a unit tangent.
int rowDof(Quantity q, Eigen::Index columns);

/// @brief Measured minus predicted, rows x components (NaN where not measured). Twist differences are wrapped
/// to (-pi, pi].
struct Residuals {
  Eigen::MatrixXd twist, tip_position, tip_tangent;
  const Eigen::MatrixXd& of(Quantity q) const;
  Eigen::MatrixXd& of(Quantity q);
};

/// @brief The recording's values of a quantity, rows x components.
const Eigen::MatrixXd& measured(const io::Recording& rec, Quantity q);
/// @brief A prediction's values of a quantity, rows x components.
const Eigen::MatrixXd& predicted(const Prediction& p, Quantity q);

/// @brief Residuals of a prediction (already mapped to the sensor frame when needed).
Residuals computeResiduals(const io::Recording& rec, const Prediction& p);

/// @brief Sets the residuals of the rows not flagged in `rows` to NaN (rows excluded from every residual, test and
/// score); an empty `rows` keeps all.
void excludeRows(Residuals& r, const std::vector<char>& rows);

/// @brief Maps the prediction to the sensor frame: for FrameMode::Unknown a registration is fitted on the rows
/// flagged in `use` (weighted by the noise levels) and applied to all rows. Returns the registration.
Registration mapToSensor(const io::Recording& rec, Prediction& p, FrameMode frame, const std::vector<char>& use,
                         const NoiseLevels& noise);

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

/// @brief Gaussian BIC with an unknown variance per quantity: sum_q N_q ln(RSS_q / N_q) + k ln(N), N_q counting the
/// independent components (rowDof) of the rows used.
double bic(const io::Recording& rec, const Residuals& r, const std::vector<char>& use, int parameters);

}  // namespace ctr::diagnosis
