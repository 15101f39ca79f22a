/// @file model.hpp
/// @brief Umbrella header of the `ctr::model` CMake target (its API lives in namespace `ctr`).
#pragma once

#include "ctr/model/backbone.hpp"
#include "ctr/model/configuration.hpp"
#include "ctr/model/jacobian.hpp"
#include "ctr/model/kinematics.hpp"
#include "ctr/model/loads.hpp"
#include "ctr/model/robot.hpp"
#include "ctr/model/friction.hpp"
#include "ctr/model/replay.hpp"
#include "ctr/model/distributed_friction.hpp"
#include "ctr/model/sampling.hpp"
