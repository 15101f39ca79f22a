/// @file backbone.hpp
/// @brief Backbone output at a requested resolution.
#pragma once

#include <vector>

#include "ctr/model/kinematics.hpp"

namespace ctr {

/// @brief The backbone of a solved shape resampled every ds metres from s = 0 to the tip (inclusive),
/// positions by cubic Hermite interpolation of the integration nodes, frames by slerp.
/// Requires a solution solved with record_backbone = true.
std::vector<BackbonePoint> resampleBackbone(const Solution& sol, double ds);

/// @brief Bending moment of every tube at a backbone point, in the backbone frame F0 (x, y components, N m):
/// m_i = k_ib (u0 - R_z(theta_i) û_i) for tubes present at p.s (curved part: û_i = (0, kappa_i)), zero for absent
/// tubes. Exact at integration nodes (at a segment boundary, on the side the node was recorded); at resampled points
/// only to interpolation accuracy. Without external load they sum to zero (paper eq. 6). Column i is tube i.
/// Throws std::invalid_argument for a point without tube states (KinematicsOptions::record_tube_states = false).
Eigen::Matrix2Xd tubeBendingMoments(const Robot& robot, const Configuration& q, const BackbonePoint& p);

}  // namespace ctr
