/// @file distributed_friction.hpp
/// @brief Coulomb friction from the distributed inter-tube contact forces (Lock & Dupont 2011 §II.B-C, eqs. 14-32).
///
/// The distributed force on each tube follows from its rod equations (eqs. 22-31); the interface friction torque
/// (eq. 19) enters the torsion equation (eq. 21), which becomes implicit in u_iz' and is solved by root finding at
/// every integration stage. The axial force n_iz is an extra state per tube (eq. 24) with n_iz = 0 at the free end.
/// The friction sign at each interface is the commanded direction of relative rotation (as in the paper).
#pragma once

#include <vector>

#include "ctr/model/kinematics.hpp"

namespace ctr {

/// @brief Options of the distributed-friction model.
struct DistributedFrictionOptions {
  double mu = 0.0;             ///< Coulomb coefficient (>= 0; may be very large, e.g. 1e5).
  std::vector<int> direction;  ///< Per interface j (tubes j|j+1, 0-based j): sign of inner-minus-outer rotation.
  double default_contact_radius = 1e-3;  ///< Used when the diameters are not given (m).
  int max_root_iterations = 60;          ///< Iterations of the implicit equation in u_z' per stage.
  double root_tolerance = 1e-12;         ///< On u_z' (1/m^2), relative to its size.
  KinematicsOptions kinematics;          ///< Step size, Newton tolerance, iterations.
  /// Lumped friction at the concentrated moments (§II.D) acting together with the distributed friction: one law per
  /// site of contactSites(robot, q), or empty for none. Torque laws use robot.friction().boundary as mu'.
  std::vector<ContactCondition> contacts;
};

/// @brief Distributed contact force at one arc length and interface.
struct DistributedForceSample {
  double s = 0.0;
  int interface = 0;             ///< Outer tube of the interface (0-based); the inner tube is interface + 1.
  double force = 0.0;            ///< |f| total distributed force on the inner tube (N/m).
  double normal_force = 0.0;     ///< |f_n| = |f| / sqrt(1 + mu^2) (N/m).
  double friction_torque = 0.0;  ///< mu / sqrt(1 + mu^2) r |f| (N m / m), acting against the relative rotation.
};

/// @brief A solution of the distributed-friction model with its force profile.
struct DistributedFrictionSolution {
  Solution solution;                            ///< Shape, twists, status (summary.message names failures).
  std::vector<DistributedForceSample> samples;  ///< At every integration node (if record_backbone).
  double integrated_friction_torque = 0.0;      ///< Max over interfaces of the integral of the friction torque (N m).
  int max_root_iterations = 0;                  ///< Largest iteration count of the implicit equation.
  bool used_default_radius = false;             ///< Diameters were missing: default_contact_radius was used.
};

/// @brief Equilibrium of the torsionally compliant model with distributed Coulomb friction (and, optionally, the
/// lumped friction torques of `options.contacts`; then Solution::contacts reports them as solveWithContacts does).
/// Throws std::invalid_argument if `direction` does not have n-1 entries or `contacts` has the wrong size.
/// `ws` is used for the start (the solution without distributed friction); `warm` warm-starts it.
DistributedFrictionSolution solveDistributedFriction(const Robot& robot, const Configuration& q, Workspace& ws,
                                                     const DistributedFrictionOptions& options,
                                                     const Solution* warm = nullptr);

}  // namespace ctr
