// Exact tip Jacobians (jacobian.hpp): forward-mode derivatives of the discrete loaded map and the implicit function
// theorem over the shooting residuals.
#include "ctr/model/jacobian.hpp"

#include <Eigen/LU>
#include <stdexcept>
#include <string>

#include "loaded_map.hpp"
#include "solvers.hpp"
#include "workspace_impl.hpp"

namespace ctr {

TipJacobian tipJacobian(const Robot& robot, const Solution& solution, Workspace& ws, const KinematicsOptions& options,
                        bool with_compliance, bool polish) {
  if (!solution.converged()) throw std::invalid_argument("tipJacobian: the solution did not converge");
  const int n = robot.size();
  if (solution.q.size() != n || solution.base_twist_rate.size() != n)
    throw std::invalid_argument("tipJacobian: the solution does not belong to this robot (tube count)");
  std::vector<ContactCondition> cond;
  const std::vector<ContactCondition>* conditions = nullptr;
  if (!solution.contacts.empty()) {
    const std::size_t k = contactSites(robot, solution.q).size();
    if (solution.contacts.size() != k)
      throw std::invalid_argument("tipJacobian: the solution's contacts do not match the robot's contact sites");
    for (const ContactResult& c : solution.contacts) cond.push_back(c.condition);
    conditions = &cond;
  }
  detail::LoadedWork& W = detail::WorkspaceAccess::impl(ws).loaded;
  detail::LoadedProblem& L = W.L;
  detail::setupLoaded(L, robot, solution.q, conditions, options, 1.0);
  TipJacobian out;
  const int m = L.m;
  // The tip moment M enters the map only through the distal residuals, where the innermost tube ends at the tip:
  // there its columns are known in closed form (below) and are not carried as derivative directions.
  const bool analytic_m = with_compliance && !L.P.segments.empty() && L.P.end[n - 1] >= L.P.s_tip - detail::kSameS;
  const int nin = m + 2 * n + (with_compliance ? 6 : 0);
  const int carried = nin - (analytic_m ? 3 : 0);
  std::vector<int> dirs(static_cast<std::size_t>(carried));
  for (int i = 0; i < carried; ++i) dirs[static_cast<std::size_t>(i)] = i;
  // Polish: the equilibrium of exactly the map that is differentiated. A loaded solution solved with the same
  // options already is one (0 Newton iterations); the value part of the derivative pass shows it, so the pass is
  // tried first and repeated only after a polish. A torsion-only solution is polished first.
  Eigen::VectorXd z = detail::unknownsFrom(L, solution);
  double rn = 0.0;
  bool differentiated = false;
  if (polish && solution.loaded) {
    detail::evalDerivatives(W, z, dirs, true);
    rn = detail::maxAbs(W.r);
    differentiated = rn < options.tolerance;
  }
  if (polish && !differentiated) {
    int iters = 0;
    std::string why;
    if (!detail::newtonLoaded(W, z, options, iters, rn, why)) {
      out.message = "the equilibrium could not be re-established for differentiation: " + why;
      out.residual_norm = rn;
      return out;
    }
  }
  out.residual_norm = rn;
  if (!differentiated) detail::evalDerivatives(W, z, dirs, true);
  if (analytic_m) {
    // d r / d M: r_{n-1} -= (R e3 . M) / k_t,n at the innermost tube's end (the tip); r_{n,n+1} = (R^T (m - M))_xy
    // / K_tip. The tip pose and theta_n do not depend on M directly.
    W.D.conservativeResize(Eigen::NoChange, nin);
    W.D.rightCols(3).setZero();
    const Eigen::Matrix3d& Rt = W.tip_R;
    const double Ktip = L.P.segments.empty() ? L.K0 : L.P.segments.back().K;
    for (int c = 0; c < 3; ++c) {
      W.D(n - 1, nin - 3 + c) = -Rt(c, 2) / L.P.kt[n - 1];
      W.D(n, nin - 3 + c) = -Rt(c, 0) / Ktip;
      W.D(n + 1, nin - 3 + c) = -Rt(c, 1) / Ktip;
    }
  }
  // Tip rows: position, and the spatial angle w with [dw]x = dR R^T (skew part) of the Bishop frame R; the material
  // frame of the innermost tube, R R_z(theta_n), turns by w + t dtheta_n (t the tip tangent).
  Eigen::MatrixXd G(6, nin);
  G.topRows(3) = W.D.block(m, 0, 3, nin);
  const Eigen::Matrix3d R = W.tip_R;
  for (int j = 0; j < nin; ++j) {
    Eigen::Matrix3d dR;
    for (int c = 0; c < 9; ++c) dR(c / 3, c % 3) = W.D(m + 3 + c, j);
    const Eigen::Matrix3d Om = dR * R.transpose();
    G(3, j) = 0.5 * (Om(2, 1) - Om(1, 2));
    G(4, j) = 0.5 * (Om(0, 2) - Om(2, 0));
    G(5, j) = 0.5 * (Om(1, 0) - Om(0, 1));
  }
  Eigen::MatrixXd Gm = G;
  Gm.bottomRows(3) += R.col(2) * W.D.row(m + 12);
  const Eigen::MatrixXd Jz = W.D.topLeftCorner(m, m);
  const Eigen::MatrixXd Jx = W.D.block(0, m, m, nin - m);
  Eigen::FullPivLU<Eigen::MatrixXd> lu(Jz);
  if (!lu.isInvertible()) {
    out.message = "singular shooting Jacobian (at a fold): the tip Jacobian is not defined";
    return out;
  }
  const Eigen::MatrixXd dz = -lu.solve(Jx);
  const Eigen::MatrixXd total = Gm.rightCols(nin - m) + Gm.leftCols(m) * dz;
  out.actuation = total.leftCols(2 * n);
  if (with_compliance) out.compliance = total.rightCols(6);
  const Eigen::MatrixXd bishop = G.rightCols(nin - m) + G.leftCols(m) * dz;
  out.bishop_actuation = bishop.leftCols(2 * n);
  if (with_compliance) out.bishop_compliance = bishop.rightCols(6);
  out.ok = out.actuation.allFinite() && out.compliance.allFinite();
  if (!out.ok) out.message = "non-finite derivative";
  return out;
}

}  // namespace ctr
