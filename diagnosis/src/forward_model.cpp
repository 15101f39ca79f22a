// Forward model of a recording under a set of effects.
#include "ctr/diagnosis/forward_model.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace ctr::diagnosis {

Eigen::VectorXd playOperator(const Eigen::VectorXd& x, double width) {
  Eigen::VectorXd y = x;
  if (x.size() == 0 || !(width > 0)) return y;
  const double h = 0.5 * width;
  double state = x[0];
  for (Eigen::Index k = 0; k < x.size(); ++k) {
    if (x[k] - state > h) state = x[k] - h;
    else if (x[k] - state < -h) state = x[k] + h;
    y[k] = state;
  }
  return y;
}

std::vector<Configuration> transformActuation(const std::vector<Configuration>& commands, const Eigen::VectorXd& time,
                                              const std::vector<Effect>& effects) {
  std::vector<Configuration> q = commands;
  const int rows = static_cast<int>(commands.size());
  if (rows == 0) return q;
  const int n = commands[0].size();
  // 1. Sensor latency: the measurement at t shows the robot commanded at t - delay.
  for (const Effect& e : effects) {
    if (e.kind != EffectKind::SensorLatency || time.size() != rows || e.value == 0.0) continue;
    int j = 0;
    for (int k = 0; k < rows; ++k) {
      const double t = time[k] - e.value;
      if (t <= time[0]) {
        q[static_cast<std::size_t>(k)] = commands[0];
        continue;
      }
      if (t >= time[rows - 1]) {
        q[static_cast<std::size_t>(k)] = commands[static_cast<std::size_t>(rows - 1)];
        continue;
      }
      while (j + 1 < rows && time[j + 1] < t) ++j;
      while (j > 0 && time[j] > t) --j;
      const double t0 = time[j], t1 = time[std::min(j + 1, rows - 1)];
      const double w = t1 > t0 ? (t - t0) / (t1 - t0) : 0.0;
      const Configuration& a = commands[static_cast<std::size_t>(j)];
      const Configuration& b = commands[static_cast<std::size_t>(std::min(j + 1, rows - 1))];
      q[static_cast<std::size_t>(k)] = Configuration(a.alpha + w * (b.alpha - a.alpha), a.beta + w * (b.beta - a.beta));
    }
  }
  // 2. Backlash (play) per tube on the rotation.
  for (const Effect& e : effects) {
    if (e.kind != EffectKind::ActuatorBacklash || e.tube < 1 || e.tube > n) continue;
    Eigen::VectorXd x(rows);
    for (int k = 0; k < rows; ++k) x[k] = q[static_cast<std::size_t>(k)].alpha[e.tube - 1];
    const Eigen::VectorXd y = playOperator(x, e.value);
    for (int k = 0; k < rows; ++k) q[static_cast<std::size_t>(k)].alpha[e.tube - 1] = y[k];
  }
  // 3. Constant offsets.
  for (const Effect& e : effects) {
    if (e.kind != EffectKind::ActuatorOffset || e.tube < 1 || e.tube > n) continue;
    for (auto& c : q) c.alpha[e.tube - 1] += e.value;
  }
  return q;
}

namespace {
double largestMoment(const Solution& s) {
  double m = 0.0;
  for (const auto& cm : s.moments) m = std::max(m, std::abs(cm.magnitude));
  return m;
}
}  // namespace

Prediction predict(const Robot& nominal, const std::vector<Configuration>& commands, const Eigen::VectorXd& time,
                   const std::vector<Effect>& effects, Workspace& ws, const PredictOptions& options) {
  const Robot robot = applyToRobot(nominal, effects);
  Prediction p;
  p.actuation = transformActuation(commands, time, effects);
  const int rows = static_cast<int>(commands.size());
  const int n = robot.size();
  p.twist.setZero(rows, std::max(0, n - 1));
  p.tip_position.setZero(rows, 3);
  p.tip_tangent.setZero(rows, 3);
  p.moment.setZero(rows);
  p.ok.assign(static_cast<std::size_t>(rows), 0);
  if (rows == 0) return p;
  const bool friction = robot.friction().boundary > 0.0 || robot.friction().distributed > 0.0;
  auto store = [&](int k, const Solution& s) {
    if (s.converged()) {
      p.ok[static_cast<std::size_t>(k)] = 1;
      if (s.twist.size() == n - 1) p.twist.row(k) = s.twist.transpose();
      p.tip_position.row(k) = s.tip_position.transpose();
      p.tip_tangent.row(k) = s.tipTangent().transpose();
      p.moment[k] = largestMoment(s);
    } else {
      ++p.failures;
      if (k > 0) {
        p.twist.row(k) = p.twist.row(k - 1);
        p.tip_position.row(k) = p.tip_position.row(k - 1);
        p.tip_tangent.row(k) = p.tip_tangent.row(k - 1);
        p.moment[k] = p.moment[k - 1];
      }
    }
  };
  if (friction) {
    // Same semantics as ctr::replay(), with a coarse pass per row and the fine sub-steps as fallback.
    FrictionOptions coarse = options.friction;
    const bool try_coarse = options.coarse_rotation_step > options.friction.max_rotation_step;
    coarse.max_rotation_step = std::max(options.coarse_rotation_step, options.friction.max_rotation_step);
    // A snap is a twist jump much larger than the commanded sub-step: scale the detector with the sub-step (at most
    // 2 rad, below the ~pi jump of a real snap); a flagged coarse row is replayed with the fine sub-steps.
    coarse.snap_threshold = std::min(2.0, options.friction.snap_threshold * coarse.max_rotation_step /
                                              std::max(options.friction.max_rotation_step, 1e-9));
    StepResult last = initialState(robot, p.actuation[0], ws, options.friction);
    store(0, last.solution);
    for (int k = 1; k < rows; ++k) {
      const Configuration& q = p.actuation[static_cast<std::size_t>(k)];
      if (!last.state.valid) {
        last = initialState(robot, q, ws, options.friction);  // restart after a failure (reported per row)
      } else {
        StepResult r;
        bool done = false;
        // Coarse sub-steps reproduce the fine replay exactly only for a rotation-only row with at most one
        // friction site (the end state is then slip at the target or stick from the start); with several sites
        // or a translation the return mapping is path dependent and the fine sub-steps are the model.
        const Configuration& from = p.actuation[static_cast<std::size_t>(k - 1)];
        // (The sites depend on the translations only, so equal beta means the same sites at both ends.)
        if (try_coarse && q.beta == from.beta && contactSites(robot, q).size() <= 1) {
          r = step(robot, last.state, q, ws, coarse);
          done = r.summary.converged && !r.summary.snapped && r.summary.substeps > 0;
        }
        if (!done) r = step(robot, last.state, q, ws, options.friction);
        last = std::move(r);
      }
      store(k, last.solution);
    }
  } else {
    Solution prev;
    bool have_prev = false;
    for (int k = 0; k < rows; ++k) {
      const Configuration& q = p.actuation[static_cast<std::size_t>(k)];
      Solution s = solve(robot, q, ws, options.kinematics, have_prev ? &prev : nullptr);
      if (!s.converged() && have_prev) s = solve(robot, q, ws, options.kinematics, nullptr);
      store(k, s);
      if (s.converged()) {
        prev = std::move(s);
        have_prev = true;
      }
    }
  }
  // Rows failing before the first success take the first successful output.
  int first = -1;
  for (int k = 0; k < rows; ++k)
    if (p.ok[static_cast<std::size_t>(k)]) {
      first = k;
      break;
    }
  if (first > 0)
    for (int k = 0; k < first; ++k) {
      p.twist.row(k) = p.twist.row(first);
      p.tip_position.row(k) = p.tip_position.row(first);
      p.tip_tangent.row(k) = p.tip_tangent.row(first);
      p.moment[k] = p.moment[first];
    }
  return p;
}

}  // namespace ctr::diagnosis
