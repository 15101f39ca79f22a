// Internal: the warm-start history of a workspace (a chain of solves following a path) and the continuation predictor
// of KinematicsOptions::extrapolate_warm_start.
#pragma once

#include <Eigen/Core>
#include <array>

#include "ctr/model/configuration.hpp"

namespace ctr::detail {

/// The last converged frictionless solves of a workspace (no contact laws) that form a chain, each warm-started from
/// the one before it (a path being followed): the continuation predictor of KinematicsOptions::extrapolate_warm_start.
/// Solves under contact laws (stick-slip steps) never use it: a step depends only on its HysteresisState and command.
struct WarmHistory {
  static constexpr int kDepth = 4;        ///< Solves kept: up to a cubic extrapolation.
  std::array<Eigen::VectorXd, kDepth> q;  ///< q[0] the last solve: its historyKey.
  std::array<Eigen::VectorXd, kDepth> z;  ///< Its unknowns.
  int count = 0;                          ///< Entries of the chain (0: none).
};

/// Translations count as this many radians per metre in the history key (2 cm ~ 1 rad).
constexpr double kHistoryBetaScale = 50.0;

/// Actuation as one vector for the warm-start history: alpha, then kHistoryBetaScale x beta.
Eigen::VectorXd historyKey(const Configuration& q);
/// The same into v (its storage reused).
void historyKey(const Configuration& q, Eigen::VectorXd& v);
/// The same from the rotations and translations.
void historyKey(const Eigen::VectorXd& alpha, const Eigen::VectorXd& beta, Eigen::VectorXd& v);

/// Continuation predictor: when q continues the straight line through the chain's last solves, z <- the extrapolation
/// of their unknowns along it; false when it does not apply.
bool continuationPredictor(const WarmHistory& H, const Eigen::VectorXd& q, Eigen::VectorXd& z);

/// Records a converged solve (q, z) in the chain: appended when it was warm-started from the chain's last solve
/// (`chained`), else the chain restarts with it.
void recordInChain(WarmHistory& H, bool chained, const Eigen::VectorXd& qv, const Eigen::VectorXd& z);

/// Whether a warm start (its configuration and unknowns) is the chain's last solve.
bool continuesChain(const WarmHistory& H, const Configuration& warm_q, const Eigen::VectorXd& q_key,
                    const Eigen::VectorXd& z);

}  // namespace ctr::detail
