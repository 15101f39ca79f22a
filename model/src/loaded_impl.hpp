// Internal: entry points of the loaded (Cosserat-rod) solver used by kinematics.cpp.
#pragma once

#include <vector>

#include "ctr/model/kinematics.hpp"

namespace ctr::detail {

/// True when solve()/solveWithContacts() must use the loaded solver.
inline bool useLoadedModel(const Robot& robot, const KinematicsOptions& opt) {
  return opt.loaded_model || !robot.loads().empty();
}

/// Equilibrium under the robot's external loads (loaded_kinematics.cpp).
Solution solveLoaded(const Robot& robot, const Configuration& q, const std::vector<ContactCondition>* conditions,
                     Workspace& ws, const KinematicsOptions& opt, const Solution* warm);

/// The load-free (torsion-only) solver, whatever the robot's loads (kinematics.cpp).
Solution solveTorsionOnly(const Robot& robot, const Configuration& q, const std::vector<ContactCondition>* conditions,
                          Workspace& ws, const KinematicsOptions& opt, const Solution* warm);

}  // namespace ctr::detail
