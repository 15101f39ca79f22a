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

}  // namespace ctr
