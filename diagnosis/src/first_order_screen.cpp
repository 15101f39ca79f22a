// First-order screen of candidates that are costly to fit by replays (loads, generic models): per-row sensitivities of
// the model to their coordinates and the linear least-squares estimate (registration profiled out) with the BIC change
// it predicts.
#include "ctr/diagnosis/first_order_screen.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>

#include "parallel.hpp"

namespace ctr::diagnosis {

std::vector<FirstOrderScreen> screenFirstOrder(const Robot& nominal, const io::Recording& rec,
                                               const std::vector<Effect>& model, const FitResult& model_fit,
                                               const std::vector<Effect>& candidates, const std::vector<char>& use,
                                               const FitOptions& o, Workspace& ws) {
  std::vector<FirstOrderScreen> out(candidates.size());
  for (std::size_t i = 0; i < candidates.size(); ++i) out[i].effect = candidates[i];
  if (candidates.empty()) return out;
  const int rows = rec.rows();
  // The model's equilibria (with their contact laws) at every row.
  PredictOptions po = o.predict;
  po.keep_solutions = true;
  const Prediction p = predict(nominal, rec.commands, rec.time, model, ws, po);
  const KinematicsOptions kin = po.replay.friction.kinematics;
  const std::vector<Quantity> qs = presentQuantities(rec);
  const int n = rec.tubes;
  int comps = 0;
  for (Quantity q : qs) comps += q == Quantity::Twist ? n - 1 : 3;
  const Registration& reg = model_fit.registration;
  std::vector<int> used;
  for (int k = 0; k < rows; ++k) {
    const auto at = static_cast<std::size_t>(k);
    if (at < use.size() && use[at] && (o.rows.empty() || (at < o.rows.size() && o.rows[at])) && p.ok[at] &&
        at < model_fit.prediction.ok.size() && model_fit.prediction.ok[at])
      used.push_back(k);
  }
  // The model's outputs of an equilibrium as measured (sensor frame), in the component order of a row.
  auto outputs = [&](const Solution& s) {
    Eigen::VectorXd v(comps);
    int i = 0;
    for (Quantity q : qs) {
      if (q == Quantity::Twist) {
        for (int j = 0; j < n - 1; ++j) v[i++] = j < s.twist.size() ? s.twist[j] : std::nan("");
      } else {
        const Eigen::Vector3d t = s.tipTangent();
        const Eigen::Vector3d x = q == Quantity::TipPosition ? reg.mapPosition(s.tip_position, t) : reg.mapTangent(t);
        for (int j = 0; j < 3; ++j) v[i++] = x[j];
      }
    }
    return v;
  };
  // Perturbations of each candidate coordinate by +- h: a robot-side effect (a load) changes the robot; a generic
  // input-side model (drive or stage error) moves the row's actuation by h times its basis function at the joint's
  // value; a tracker drift adds h times its basis (in time) to the measured position directly.
  struct Side {
    Robot plus, minus;
    double h;
  };
  std::vector<std::vector<Side>> sides(candidates.size());
  for (std::size_t i = 0; i < candidates.size(); ++i) {
    const Effect& c = candidates[i];
    for (int j = 0; j < parameterCount(c.kind); ++j) {
      const ParameterRange r = parameterRange(nominal, rec, c.kind, c.tube, j);
      const double h = 0.01 * (r.hi - r.lo);
      if (isGeneric(c.kind)) {
        sides[i].push_back({nominal, nominal, h});
        continue;
      }
      std::vector<Effect> ep = model, em = model;
      Effect a = c, b = c;
      a.setCoordinate(j, c.coordinate(j) + h);
      b.setCoordinate(j, c.coordinate(j) - h);
      ep.push_back(a);
      em.push_back(b);
      sides[i].push_back({applyToRobot(nominal, ep), applyToRobot(nominal, em), h});
    }
  }
  const Robot base = applyToRobot(nominal, model);
  // Sensitivities d(outputs)/d(coordinate) per used row (NaN when a perturbed solve failed).
  std::vector<Eigen::MatrixXd> S(candidates.size());
  for (std::size_t i = 0; i < candidates.size(); ++i)
    S[i] = Eigen::MatrixXd::Constant(static_cast<Eigen::Index>(used.size()) * comps, parameterCount(candidates[i].kind),
                                     std::numeric_limits<double>::quiet_NaN());
  detail::parallelFor(static_cast<int>(used.size()), std::max(1, o.threads), ws, [&](int u, Workspace& w) {
    const int row = used[static_cast<std::size_t>(u)];
    const Solution& s0 = p.solutions[static_cast<std::size_t>(row)];
    std::vector<ContactCondition> laws;
    for (const ContactResult& c : s0.contacts) laws.push_back(c.condition);
    auto solveAt = [&](const Robot& r, const Configuration& q) {
      if (laws.empty() || laws.size() != contactSites(r, q).size()) return solve(r, q, w, kin, &s0);
      return solveWithContacts(r, q, laws, w, kin, &s0);
    };
    for (std::size_t i = 0; i < candidates.size(); ++i) {
      const Effect& e = candidates[i];
      for (std::size_t j = 0; j < sides[i].size(); ++j) {
        const double h = sides[i][j].h;
        Eigen::VectorXd d;
        if (e.kind == EffectKind::TrackerDrift) {
          // d(measured position)/d(coefficient): the basis in time along one base axis, seen through the sensor
          // frame's rotation.
          if (!rec.hasTime()) continue;
          Effect unit = e;
          unit.coef.setZero();
          unit.coef[static_cast<Eigen::Index>(j)] = 1.0;
          d = Eigen::VectorXd::Zero(comps);
          int at = 0;
          for (Quantity q : qs) {
            if (q == Quantity::TipPosition) {
              Eigen::Vector3d v;
              for (int a = 0; a < 3; ++a) v[a] = unit.genericAt(rec.time[row], a);
              d.segment(at, 3) = reg.rotation * v * (2 * h);
            }
            at += q == Quantity::Twist ? n - 1 : 3;
          }
        } else if (isGeneric(e.kind)) {
          // The actuation of this row moved by +-h times the basis function at the joint's value.
          Effect unit = e;
          unit.coef.setZero();
          unit.coef[static_cast<Eigen::Index>(j)] = 1.0;
          Configuration qp = s0.q, qm = s0.q;
          const bool rot = e.kind == EffectKind::DriveRatio || e.kind == EffectKind::DrivePeriodic;
          Eigen::VectorXd& xp = rot ? qp.alpha : qp.beta;
          Eigen::VectorXd& xm = rot ? qm.alpha : qm.beta;
          const double step = h * unit.genericAt(xp[e.tube - 1]);
          xp[e.tube - 1] += step;
          xm[e.tube - 1] -= step;
          if (std::abs(step) < 1e-15) {
            d = Eigen::VectorXd::Zero(comps);
          } else {
            if (!rot && (!projectAdmissible(base, qp, 1e-3) || !projectAdmissible(base, qm, 1e-3))) continue;
            const Solution sp = solveAt(base, qp), sm = solveAt(base, qm);
            if (!sp.converged() || !sm.converged() || sp.summary.snapped || sm.summary.snapped) continue;
            d = outputs(sp) - outputs(sm);
          }
        } else {
          const Solution sp = solveAt(sides[i][j].plus, s0.q), sm = solveAt(sides[i][j].minus, s0.q);
          if (!sp.converged() || !sm.converged() || sp.summary.snapped || sm.summary.snapped) continue;
          d = outputs(sp) - outputs(sm);
        }
        for (int c = 0, at = 0; c < static_cast<int>(qs.size()); ++c) {
          const int m = qs[static_cast<std::size_t>(c)] == Quantity::Twist ? n - 1 : 3;
          if (qs[static_cast<std::size_t>(c)] == Quantity::Twist)
            for (int k = at; k < at + m; ++k) d[k] = std::remainder(d[k], 2 * M_PI);
          at += m;
        }
        S[i].block(static_cast<Eigen::Index>(u) * comps, static_cast<Eigen::Index>(j), comps, 1) = d / (2 * h);
      }
    }
  });
  // Weighted least squares per candidate: residual ~ nuisance (registration) + S dx.
  const bool unknown = o.frame == FrameMode::Unknown && (rec.hasTipPosition() || rec.hasTipTangent());
  const int nn = unknown ? 7 : 0;  // rotation (3), translation (3), tip offset (1)
  for (std::size_t i = 0; i < candidates.size(); ++i) {
    FirstOrderScreen& ls = out[i];
    const int kc = parameterCount(candidates[i].kind);
    std::vector<Eigen::VectorXd> A_rows;
    std::vector<double> y;
    std::vector<int> qi;  // quantity index of each entry
    std::vector<char> row_used(used.size(), 0);
    for (std::size_t u = 0; u < used.size(); ++u) {
      const int k = used[u];
      if (!S[i].block(static_cast<Eigen::Index>(u) * comps, 0, comps, kc).allFinite()) continue;
      row_used[u] = 1;
      const Eigen::Vector3d ps = model_fit.prediction.tip_position.row(k).transpose();
      const Eigen::Vector3d ts = model_fit.prediction.tip_tangent.row(k).transpose();
      int at = 0;
      for (std::size_t c = 0; c < qs.size(); ++c) {
        const Quantity q = qs[c];
        const Eigen::MatrixXd& R = model_fit.residuals.of(q);
        const double sigma = o.noise.of(q) > 0 ? o.noise.of(q) : 1.0;
        const int m = q == Quantity::Twist ? n - 1 : 3;
        for (int j = 0; j < m; ++j, ++at) {
          const double r = R(k, j);
          if (!std::isfinite(r)) continue;
          Eigen::VectorXd a = Eigen::VectorXd::Zero(nn + kc);
          if (unknown && q != Quantity::Twist) {
            const Eigen::Vector3d ej = Eigen::Vector3d::Unit(j);
            for (int ax = 0; ax < 3; ++ax)  // small extra rotation of the sensor frame: (e_ax x x)_j
              a[ax] = Eigen::Vector3d::Unit(ax).cross(q == Quantity::TipPosition ? ps : ts).dot(ej);
            if (q == Quantity::TipPosition) {
              a[3 + j] = 1.0;
              a[6] = ts[j];
            }
          }
          for (int c2 = 0; c2 < kc; ++c2) a[nn + c2] = S[i](static_cast<Eigen::Index>(u) * comps + at, c2);
          A_rows.push_back(a / sigma);
          y.push_back(r / sigma);
          qi.push_back(static_cast<int>(c));
        }
      }
    }
    ls.rows = static_cast<int>(std::count(row_used.begin(), row_used.end(), 1));
    const int m = static_cast<int>(y.size());
    if (ls.rows == 0 || m <= nn + kc) {
      ls.ok = false;
      ls.message = "no row could be linearised (the loaded solves did not converge)";
      continue;
    }
    Eigen::MatrixXd A(m, nn + kc);
    Eigen::VectorXd Y(m);
    for (int r = 0; r < m; ++r) {
      A.row(r) = A_rows[static_cast<std::size_t>(r)].transpose();
      Y[r] = y[static_cast<std::size_t>(r)];
    }
    Eigen::VectorXd e0 = Y;
    if (nn > 0) e0 = Y - A.leftCols(nn) * A.leftCols(nn).completeOrthogonalDecomposition().solve(Y);
    const Eigen::VectorXd coef = A.completeOrthogonalDecomposition().solve(Y);
    const Eigen::VectorXd e1 = Y - A * coef;
    // Predicted BIC change, per quantity as bic(): N_q ln(RSS1_q / RSS0_q) + k ln N.
    std::vector<double> rss0(qs.size(), 0.0), rss1(qs.size(), 0.0);
    std::vector<int> cnt(qs.size(), 0);
    for (int r = 0; r < m; ++r) {
      const auto q = static_cast<std::size_t>(qi[static_cast<std::size_t>(r)]);
      rss0[q] += e0[r] * e0[r];
      rss1[q] += e1[r] * e1[r];
      ++cnt[q];
    }
    double d = 0.0;
    for (std::size_t q = 0; q < qs.size(); ++q)
      if (cnt[q] > 0 && rss0[q] > 0) d += cnt[q] * std::log(std::max(1e-300, rss1[q]) / rss0[q]);
    ls.predicted_delta_bic = d + kc * std::log(std::max(1, m));
    for (int c2 = 0; c2 < kc; ++c2) {
      const ParameterRange r = parameterRange(nominal, rec, candidates[i].kind, candidates[i].tube, c2);
      const double v = candidates[i].coordinate(c2) + (std::isfinite(coef[nn + c2]) ? coef[nn + c2] : 0.0);
      ls.effect.setCoordinate(c2, std::clamp(v, r.lo, r.hi));
    }
    ls.ok = true;
  }
  return out;
}

}  // namespace ctr::diagnosis
