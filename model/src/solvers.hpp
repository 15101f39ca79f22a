// Internal: the equilibrium solvers behind solve() and solveWithContacts() (solve.cpp dispatches to one of them).
// The loaded solver starts its cold solves from the torsion-only one; neither calls the dispatcher.
#pragma once

#include <string>
#include <vector>

#include "ctr/model/kinematics.hpp"

namespace ctr::detail {

struct LoadedWork;

/// True when solve()/solveWithContacts() use the loaded solver.
inline bool useLoadedModel(const Robot& robot, const KinematicsOptions& opt) {
  return opt.loaded_model || !robot.loads().empty();
}

/// The load-free (torsion-only) equilibrium, whatever the robot's loads (torsion_solver.cpp).
Solution solveTorsionOnly(const Robot& robot, const Configuration& q, const std::vector<ContactCondition>* conditions,
                          Workspace& ws, const KinematicsOptions& opt, const Solution* warm);

/// The equilibrium under the robot's external loads (loaded_solver.cpp).
Solution solveLoaded(const Robot& robot, const Configuration& q, const std::vector<ContactCondition>* conditions,
                     Workspace& ws, const KinematicsOptions& opt, const Solution* warm);

/// Newton on the loaded problem set up in W from z, starting from the workspace's cached Jacobian when it is usable
/// (frictionless problems only); stores the Jacobian of a converged solve. With `record` value evaluations record the
/// outputs in W.out; *recorded (when given) tells whether W.out belongs to the returned z.
bool newtonLoaded(LoadedWork& W, Eigen::VectorXd& z, const KinematicsOptions& opt, int& iterations, double& res_norm,
                  std::string& why, bool record = false, bool* recorded = nullptr);

/// The result of a configuration that was not solved (status Inadmissible, the reason in the message).
Solution inadmissibleSolution(const Configuration& q, const std::string& why, int n, bool loaded);

}  // namespace ctr::detail
