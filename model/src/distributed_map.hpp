// Internal: the distributed-friction shooting map (distributed_friction.cpp), exposed for its Jacobian test.
#pragma once

#include <Eigen/Core>

#include "ctr/model/distributed_friction.hpp"

namespace ctr::detail {

/// Residual r(z) of the distributed-friction shooting problem of (robot, q, opt) at the unknowns z = (u_z(0), n_z(0),
/// scaled contact torques), size 2n + contacts, and with J its exact Jacobian (the integrator on dual numbers).
void distributedFrictionMap(const Robot& robot, const Configuration& q, const DistributedFrictionOptions& opt,
                            const Eigen::VectorXd& z, Eigen::VectorXd& r, Eigen::MatrixXd* J);

}  // namespace ctr::detail
