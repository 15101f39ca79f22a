// The public entry points of the equilibrium solvers: solve() and solveWithContacts() dispatch to the torsion-only or
// the loaded solver.
#include <stdexcept>
#include <string>

#include "ctr/model/kinematics.hpp"
#include "solvers.hpp"
#include "workspace_impl.hpp"

namespace ctr {

const char* toString(SolveStatus s) {
  switch (s) {
    case SolveStatus::Converged:
      return "converged";
    case SolveStatus::NotConverged:
      return "not_converged";
    case SolveStatus::Inadmissible:
      return "inadmissible";
  }
  return "unknown";
}

Workspace::Workspace() : impl_(std::make_unique<Impl>()) {}
Workspace::~Workspace() = default;
Workspace::Workspace(Workspace&&) noexcept = default;
Workspace& Workspace::operator=(Workspace&&) noexcept = default;

namespace {

Solution dispatch(const Robot& robot, const Configuration& q, const std::vector<ContactCondition>* conditions,
                  Workspace& ws, const KinematicsOptions& options, const Solution* warm) {
  if (detail::useLoadedModel(robot, options)) return detail::solveLoaded(robot, q, conditions, ws, options, warm);
  return detail::solveTorsionOnly(robot, q, conditions, ws, options, warm);
}

}  // namespace

Solution solve(const Robot& robot, const Configuration& q, Workspace& ws, const KinematicsOptions& options,
               const Solution* warm) {
  return dispatch(robot, q, nullptr, ws, options, warm);
}

Solution solveWithContacts(const Robot& robot, const Configuration& q, const std::vector<ContactCondition>& conditions,
                           Workspace& ws, const KinematicsOptions& options, const Solution* warm) {
  const std::size_t k = contactSites(robot, q).size();
  if (conditions.size() != k && checkAdmissible(robot, q))
    throw std::invalid_argument("solveWithContacts: " + std::to_string(conditions.size()) + " conditions for " +
                                std::to_string(k) + " contact sites");
  return dispatch(robot, q, &conditions, ws, options, warm);
}

}  // namespace ctr
