// Internal: the loaded (Cosserat-rod) shooting map (loaded_map.cpp), its problem and its buffers.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "newton.hpp"
#include "problem.hpp"
#include "warm_start.hpp"

namespace ctr::detail {

/// The loaded (Cosserat-rod) problem: the segments of a Problem plus the loads.
struct LoadedProblem {
  Problem P;
  Eigen::VectorXd rho;                          // linear density per tube (kg/m)
  Eigen::VectorXd length, straight;             // tube lengths L_i and straight lengths (m)
  Eigen::Vector3d g = Eigen::Vector3d::Zero();  // gravity (scaled by the load parameter)
  Eigen::Vector3d F = Eigen::Vector3d::Zero();  // tip force (scaled)
  Eigen::Vector3d M = Eigen::Vector3d::Zero();  // tip moment (scaled)
  double K0 = 1.0;                              // scale of the base-moment unknowns (N m^2)
  int m = 0;                                    // unknowns: n - 1 twist rates, 3 base moments, contacts
  std::vector<int> bp_tube, bp_kind;            // source of each segment boundary: kind 0 s=0, 1 end, 2 disc
  std::vector<double> seg_rho;                  // sum of linear densities of the tubes on each segment
};

/// Recorded outputs of a loaded evaluation (double only).
struct LoadedOutputs {
  Eigen::VectorXd twist;
  std::vector<ConcentratedMoment> moments;
  std::vector<double> contacts_relative_twist, contacts_moment;
  std::vector<BackbonePoint> backbone;
  std::size_t nodes = 0;
};

struct LoadedWork {
  LoadedProblem L;
  LoadedOutputs out;
  Eigen::VectorXd r;  // residual at the last evaluation
  Eigen::MatrixXd J;  // its Jacobian w.r.t. the unknowns (when asked), or its Broyden update
  Eigen::Vector3d tip_p = Eigen::Vector3d::Zero();
  Eigen::Matrix3d tip_R = Eigen::Matrix3d::Identity();
  Eigen::MatrixXd D;  // derivatives of (r, tip p, tip R, theta_n) w.r.t. chosen inputs
  /// The Jacobian of the last converged solve: the starting Jacobian of the next nearby frictionless solve.
  JacobianCache cache;
  NewtonScratch newton;
  Eigen::VectorXd q_key, model_key;  ///< scratch of the cache look-ups
  Eigen::VectorXd recorded_z;        ///< unknowns of the last recorded value evaluation
  WarmHistory history;               ///< loaded solves following a path (KinematicsOptions::extrapolate_warm_start)
};

/// Sets up the loaded problem of q: the segments of Problem::setup (steps scaled by step_factor) and the full loads.
void setupLoaded(LoadedProblem& L, const Robot& robot, const Configuration& q,
                 const std::vector<ContactCondition>* conditions, const KinematicsOptions& opt, double step_factor);

/// The robot's loads scaled by `scale` (the load continuation).
void setLoadScale(LoadedProblem& L, const Robot& robot, double scale);

/// Residual W.r and tip pose W.tip_p, W.tip_R for unknowns z; with `rec` also the recorded outputs (backbone nodes
/// with `nodes`, their tube states with `tubes`).
void evalValue(LoadedWork& W, const Eigen::VectorXd& z, LoadedOutputs* rec, bool nodes, bool tubes);

/// Value and exact derivatives w.r.t. the listed inputs [z (m) | alpha (n) | beta (n) | F (3) | M (3)] into W.D
/// ((m + 13) x dirs.size(): r, tip p, tip R row-major, theta_n(tip)); the tip position rows only with want_position.
void evalDerivatives(LoadedWork& W, const Eigen::VectorXd& z, const std::vector<int>& dirs, bool want_position);

/// Residual W.r and its exact Jacobian W.J w.r.t. the unknowns.
void evalJacobian(LoadedWork& W, const Eigen::VectorXd& z);

/// Unknowns from a (loaded or load-free) solution: twist rates, base moment, contact torques.
Eigen::VectorXd unknownsFrom(const LoadedProblem& L, const Solution& s);

/// Stability of the loaded equilibrium from the Jacobian J of the unknowns (loaded_map.cpp).
double loadedStability(const LoadedProblem& L, const Eigen::MatrixXd& J);

}  // namespace ctr::detail
