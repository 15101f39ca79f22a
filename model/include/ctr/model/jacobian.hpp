/// @file jacobian.hpp
/// @brief Exact tip Jacobians: tip pose with respect to the actuators (alpha, beta) and to the tip wrench
/// (compliance), from forward-mode derivatives of the discrete loaded-kinematics map and the implicit function
/// theorem over the shooting residuals (docs/model.md "Exact Jacobians").
#pragma once

#include <Eigen/Core>
#include <string>

#include "ctr/model/kinematics.hpp"

namespace ctr {

/// @brief Derivatives of the tip pose at an equilibrium. Rows are (p_x, p_y, p_z, w_x, w_y, w_z): the tip position
/// and a small rotation of a tip frame as a spatial angle w in the base frame (dR = [dw]x R).
///
/// `actuation` and `compliance` use the material frame of the innermost tube at the tip, R_tip R_z(theta_n(tip))
/// (what a tool fixed to the tip sees); it is work-conjugate to the tip moment, so the compliance is symmetric for
/// conservative loads. `bishop_*` use Solution::tip_frame (the Bishop frame F0, whose rotation about the tangent
/// differs by the tip twist of the innermost tube: w_material = w_bishop + t dtheta_n(tip)).
struct TipJacobian {
  /// 6 x 2n: columns alpha_1..alpha_n (per rad), then beta_1..beta_n (per m).
  Eigen::MatrixXd actuation;
  /// 6 x 6 compliance: columns tip force (F_x, F_y, F_z; per N) then tip moment (M_x, M_y, M_z; per N m), dead
  /// loads in the base frame. Symmetric (to discretisation accuracy) for conservative loads (see docs/model.md).
  Eigen::Matrix<double, 6, 6> compliance = Eigen::Matrix<double, 6, 6>::Zero();
  Eigen::MatrixXd bishop_actuation;  ///< As `actuation`, orientation rows for Solution::tip_frame.
  Eigen::Matrix<double, 6, 6> bishop_compliance = Eigen::Matrix<double, 6, 6>::Zero();  ///< Likewise.
  double residual_norm = 0.0;  ///< Scaled shooting residual at the differentiated point (after polishing).
  std::string message;         ///< Why it failed, when it failed.
  bool ok = false;             ///< False when the equilibrium could not be re-established or J is singular.
};

/// @brief Tip Jacobian and compliance at `solution` (a converged result of solve / solveWithContacts / continueTo /
/// step for `robot`, with or without loads). Contact laws of the solution are held (Stick: relative twist fixed;
/// Torque: value * mu' * |m| with |m| varying). `options` must be the discretisation used to solve (the map that is
/// differentiated). `with_compliance = false` skips the compliance (6 fewer derivative directions; it stays zero).
/// `polish = false` differentiates at the solution's own values without first re-establishing the equilibrium of
/// the differentiated (loaded) map: about half the cost for a solution of the torsion-only solver, whose
/// discretisation differs from the loaded map's by a scaled residual of ~1e-5, so the derivatives are then accurate
/// to about that (relative) — enough for iterative uses such as inverse-kinematics steps, not for validation.
/// (`residual_norm` is then 0.) Throws std::invalid_argument for a solution that did not converge or does not match
/// the robot.
TipJacobian tipJacobian(const Robot& robot, const Solution& solution, Workspace& ws,
                        const KinematicsOptions& options = {}, bool with_compliance = true, bool polish = true);

}  // namespace ctr
