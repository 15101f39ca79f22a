// Internal: the solver's access to the non-public parts of Solution and Workspace (kinematics.hpp).
#pragma once

#include <Eigen/Core>

#include "ctr/model/kinematics.hpp"

namespace ctr::detail {

/// The solver's buffers of a workspace (their type is defined in workspace_impl.hpp).
struct WorkspaceAccess {
  using Impl = Workspace::Impl;
  static Impl& impl(Workspace& ws) { return *ws.impl_; }
};

/// The scaled torques of a solution's contacts (the Newton unknowns after the branch), kept for warm starts.
struct SolutionAccess {
  static Eigen::VectorXd& contactUnknowns(Solution& s) { return s.contact_unknowns_; }
  static const Eigen::VectorXd& contactUnknowns(const Solution& s) { return s.contact_unknowns_; }
};

}  // namespace ctr::detail
