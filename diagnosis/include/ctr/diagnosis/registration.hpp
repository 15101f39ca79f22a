/// @file registration.hpp
/// @brief Rigid registration between the robot base frame and an unknown sensor frame, with a sensor offset
/// along the tip tangent: p_sensor = R (p_tip + d t_tip) + c, t_sensor = R t_tip. Estimated in closed form
/// (weighted Kabsch + linear offset, alternated) as a nuisance parameter of every model.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <vector>

namespace ctr::diagnosis {

/// @brief A rigid transform plus a sensor offset along the tip tangent.
struct Registration {
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();
  double tip_offset = 0.0;  ///< Sensor point = tip + tip_offset * tangent (m), before the rigid transform.

  /// @brief Position measured in the sensor frame for a model tip position and tangent.
  Eigen::Vector3d mapPosition(const Eigen::Vector3d& p, const Eigen::Vector3d& t) const {
    return rotation * (p + tip_offset * t) + translation;
  }
  /// @brief Tangent in the sensor frame.
  Eigen::Vector3d mapTangent(const Eigen::Vector3d& t) const { return rotation * t; }
};

/// @brief Options of the registration estimate.
struct RegistrationOptions {
  double position_weight = 1.0;  ///< Weight of position residuals (1 / sigma_p^2).
  double tangent_weight = 1.0;   ///< Weight of tangent residuals (1 / sigma_t^2).
  bool estimate_offset = true;   ///< Estimate the offset along the tangent (needs tangents varying).
  int iterations = 12;           ///< Alternations between rotation and offset.
};

/// @brief Weighted least-squares registration of model tips (positions P, tangents T; rows x 3) onto measured
/// ones (MP, MT; rows x 3 or 0 cols), over the rows flagged in `use`. Rows with NaN measurements are skipped.
Registration fitRegistration(const Eigen::MatrixXd& P, const Eigen::MatrixXd& T, const Eigen::MatrixXd& MP,
                             const Eigen::MatrixXd& MT, const std::vector<char>& use,
                             const RegistrationOptions& options = {});

/// @brief Applies a registration to model positions and tangents in place.
void applyRegistration(const Registration& reg, Eigen::MatrixXd& P, Eigen::MatrixXd& T);

}  // namespace ctr::diagnosis
