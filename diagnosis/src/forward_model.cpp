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
    if (x[k] - state > h)
      state = x[k] - h;
    else if (x[k] - state < -h)
      state = x[k] + h;
    y[k] = state;
  }
  return y;
}

std::vector<Configuration> transformActuation(const std::vector<Configuration>& commands, const Eigen::VectorXd& time,
                                              const std::vector<Effect>& effects, const Robot* robot) {
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
  // 2. Backlash (play) per tube on the rotation or the translation.
  bool translated = false;
  for (const Effect& e : effects) {
    const bool rot = e.kind == EffectKind::ActuatorBacklash, lin = e.kind == EffectKind::TranslationBacklash;
    if ((!rot && !lin) || e.tube < 1 || e.tube > n) continue;
    translated = translated || (lin && e.value > 0);
    Eigen::VectorXd x(rows);
    for (int k = 0; k < rows; ++k) {
      const Configuration& c = q[static_cast<std::size_t>(k)];
      x[k] = rot ? c.alpha[e.tube - 1] : c.beta[e.tube - 1];
    }
    const Eigen::VectorXd y = playOperator(x, e.value);
    for (int k = 0; k < rows; ++k)
      (rot ? q[static_cast<std::size_t>(k)].alpha : q[static_cast<std::size_t>(k)].beta)[e.tube - 1] = y[k];
  }
  // 3. Constant offsets.
  for (const Effect& e : effects) {
    if (e.tube < 1 || e.tube > n) continue;
    if (e.kind == EffectKind::ActuatorOffset)
      for (auto& c : q) c.alpha[e.tube - 1] += e.value;
    if (e.kind == EffectKind::TranslationOffset && e.value != 0.0) {
      translated = true;
      for (auto& c : q) c.beta[e.tube - 1] += e.value;
    }
  }
  // 4. The stages cannot push a tube through the nesting order: project (any distance) onto the admissible set.
  if (translated && robot)
    for (auto& c : q) projectAdmissible(*robot, c, std::numeric_limits<double>::infinity());
  return q;
}

namespace {
double largestMoment(const Solution& s) {
  double m = 0.0;
  for (const auto& cm : s.moments) m = std::max(m, std::abs(cm.magnitude));
  return m;
}
}  // namespace

Prediction predict(const Robot& nominal, const std::vector<Configuration>& commands0, const Eigen::VectorXd& time,
                   const std::vector<Effect>& effects, Workspace& ws, const PredictOptions& options) {
  const Robot robot = applyToRobot(nominal, effects);
  Prediction p;
  const int rows = static_cast<int>(commands0.size());
  const int n = robot.size();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  // Commands within the admissibility tolerance are projected; rows beyond it are not evaluated.
  std::vector<Configuration> commands = commands0;
  std::vector<std::string> inadmissible(static_cast<std::size_t>(rows));
  for (int k = 0; k < rows; ++k) {
    const Admissibility a = projectAdmissible(robot, commands[static_cast<std::size_t>(k)]);
    if (!a) inadmissible[static_cast<std::size_t>(k)] = "inadmissible command: " + a.message;
  }
  const CommandHistory* h = options.history;
  // Of a decimated recording's stateful replay: for each row, the full-rate commands between the previous kept row
  // and it where a joint reverses (the friction memory is set at reversals; a straight move between kept rows would
  // miss a reversal in between and look like play).
  std::vector<std::vector<Configuration>> via;
  const bool friction = robot.friction().boundary > 0.0 || robot.friction().distributed > 0.0;
  if (h && static_cast<int>(h->rows.size()) == rows && !h->commands.empty()) {
    // Decimated recording: the actuation effects act on the full-rate log (a latency interpolates between logged
    // commands 0.1 s apart, not between the kept rows; a backlash sees every reversal), then each row takes its own.
    std::vector<Configuration> full = h->commands;
    for (Configuration& q : full) projectAdmissible(robot, q);
    const std::vector<Configuration> t = transformActuation(full, h->time, effects, &robot);
    p.actuation.resize(static_cast<std::size_t>(rows));
    for (int k = 0; k < rows; ++k)
      p.actuation[static_cast<std::size_t>(k)] = t[static_cast<std::size_t>(h->rows[static_cast<std::size_t>(k)])];
    if (friction && !t.empty()) {
      const int m = static_cast<int>(t.size());
      std::vector<char> turn(static_cast<std::size_t>(m), 0);
      for (int j = 0; j < 2 * n; ++j) {
        auto x = [&](int i) {
          const Configuration& c = t[static_cast<std::size_t>(i)];
          return j < n ? c.alpha[j] : c.beta[j - n];
        };
        int dir = 0;  // last non-zero direction of motion of joint j
        for (int i = 1; i < m; ++i) {
          const double d = x(i) - x(i - 1);
          const int di = d > 1e-12 ? 1 : (d < -1e-12 ? -1 : 0);
          if (di != 0 && dir != 0 && di != dir) turn[static_cast<std::size_t>(i - 1)] = 1;
          if (di != 0) dir = di;
        }
      }
      via.resize(static_cast<std::size_t>(rows));
      for (int k = 1; k < rows; ++k)
        for (int i = h->rows[static_cast<std::size_t>(k - 1)] + 1; i < h->rows[static_cast<std::size_t>(k)]; ++i)
          if (i >= 0 && i < m && turn[static_cast<std::size_t>(i)])
            via[static_cast<std::size_t>(k)].push_back(t[static_cast<std::size_t>(i)]);
    }
  } else {
    p.actuation = transformActuation(commands, time, effects, &robot);
  }
  p.twist.setConstant(rows, std::max(0, n - 1), nan);
  p.tip_position.setConstant(rows, 3, nan);
  p.tip_tangent.setConstant(rows, 3, nan);
  p.moment.setConstant(rows, nan);
  p.ok.assign(static_cast<std::size_t>(rows), 0);
  p.reason.assign(static_cast<std::size_t>(rows), std::string());
  if (options.keep_solutions) p.solutions.assign(static_cast<std::size_t>(rows), Solution{});
  if (rows == 0) return p;
  auto fail = [&](int k, const std::string& why) {
    ++p.failures;
    p.reason[static_cast<std::size_t>(k)] = why.empty() ? "did not converge" : why;
  };
  // A row is evaluated when its solution converged without a snap; failed rows keep NaN outputs.
  auto store = [&](int k, const Solution& s, bool snapped) {
    if (!s.converged())
      return fail(k, "did not converge" + (s.summary.message.empty() ? "" : ": " + s.summary.message));
    if (snapped)
      return fail(k, "snapped (the equilibrium branch ended; the quasi-static model cannot follow the jump)");
    p.ok[static_cast<std::size_t>(k)] = 1;
    if (options.keep_solutions) p.solutions[static_cast<std::size_t>(k)] = s;
    if (s.twist.size() == n - 1) p.twist.row(k) = s.twist.transpose();
    p.tip_position.row(k) = s.tip_position.transpose();
    p.tip_tangent.row(k) = s.tipTangent().transpose();
    p.moment[k] = largestMoment(s);
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
    HysteresisState good;  // last evaluated state (invalid until the first one)
    bool previous_failed = false;
    for (int k = 0; k < rows; ++k) {
      if (!inadmissible[static_cast<std::size_t>(k)].empty()) {
        fail(k, inadmissible[static_cast<std::size_t>(k)]);
        previous_failed = true;
        continue;
      }
      const Configuration& q = p.actuation[static_cast<std::size_t>(k)];
      StepResult r;
      if (!good.valid) {
        r = initialState(robot, q, ws, options.friction);
      } else {
        // Through the reversals since the previous kept row (outputs not kept; a failed one is skipped).
        if (!via.empty())
          for (const Configuration& v : via[static_cast<std::size_t>(k)]) {
            StepResult rv = step(robot, good, v, ws, options.friction);
            if (rv.summary.converged && rv.state.valid && !rv.summary.snapped) good = std::move(rv.state);
          }
        bool done = false;
        // Coarse sub-steps reproduce the fine replay exactly only for a rotation-only move with at most one
        // friction site (the end state is then slip at the target or stick from the start); with several sites
        // or a translation the return mapping is path dependent and the fine sub-steps are the model.
        // (The sites depend on the translations only, so equal beta means the same sites at both ends.)
        if (try_coarse && q.beta == good.q.beta && contactSites(robot, q).size() <= 1) {
          r = step(robot, good, q, ws, coarse);
          done = r.summary.converged && !r.summary.snapped && r.summary.substeps > 0;
        }
        if (!done) r = step(robot, good, q, ws, options.friction);
        if (!(r.summary.converged && r.state.valid) && previous_failed) {
          // Two failures in a row: the memory cannot be carried on; restart at rest here.
          StepResult rest = initialState(robot, q, ws, options.friction);
          if (rest.summary.converged && rest.state.valid) {
            r = std::move(rest);
            ++p.restarts;
          }
        }
      }
      const bool ok = r.summary.converged && r.state.valid;
      if (!ok && r.solution.converged())
        fail(k, "no consistent stick/slip contact set" + (r.summary.message.empty() ? "" : ": " + r.summary.message));
      else
        store(k, r.solution, r.summary.snapped);
      if (ok) good = std::move(r.state);  // after a snap the replay goes on from the new branch
      previous_failed = !p.ok[static_cast<std::size_t>(k)] && !ok;
    }
  } else {
    Solution prev;
    bool have_prev = false;
    for (int k = 0; k < rows; ++k) {
      if (!inadmissible[static_cast<std::size_t>(k)].empty()) {
        fail(k, inadmissible[static_cast<std::size_t>(k)]);
        continue;
      }
      const Configuration& q = p.actuation[static_cast<std::size_t>(k)];
      Solution s = solve(robot, q, ws, options.kinematics, have_prev ? &prev : nullptr);
      if (!s.converged() && have_prev) s = solve(robot, q, ws, options.kinematics, nullptr);
      store(k, s, s.summary.snapped);
      if (s.converged()) {
        prev = std::move(s);
        have_prev = true;
      }
    }
  }
  return p;
}

}  // namespace ctr::diagnosis
