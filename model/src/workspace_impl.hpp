// Internal: the solver's buffers (one per Workspace, i.e. per thread).
#pragma once

#include <Eigen/Core>

#include "access.hpp"
#include "ctr/model/kinematics.hpp"
#include "loaded_map.hpp"
#include "newton.hpp"
#include "problem.hpp"
#include "torsion_map.hpp"
#include "warm_start.hpp"

namespace ctr {

struct Workspace::Impl {
  detail::WarmHistory history;        ///< frictionless solves following a path
  detail::JacobianCache chain_chord;  ///< Jacobian of a recent frictionless solve of the chain
  detail::Problem problem;
  detail::Evaluator eval;
  detail::Outputs out;
  detail::NewtonScratch newton;
  detail::LoadedWork loaded;
  Eigen::VectorXd key, model_key, z_predicted, z_chord;  ///< scratch of a frictionless solve (storage reused)
};

namespace detail {
using WorkspaceImpl = WorkspaceAccess::Impl;
}  // namespace detail

}  // namespace ctr
