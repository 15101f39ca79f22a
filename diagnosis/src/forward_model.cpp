// Forward model of a recording under a set of effects.
#include "ctr/diagnosis/forward_model.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace ctr::diagnosis {

Eigen::VectorXd playOperator(const Eigen::VectorXd& x, double width) {
  Eigen::VectorXd y = x;
  if (!(width > 0)) return y;
  Drive d;
  d.play = width;
  double position = std::numeric_limits<double>::quiet_NaN();
  for (Eigen::Index k = 0; k < x.size(); ++k) y[k] = d.joint(x[k], position);
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
      q[static_cast<std::size_t>(k)] = interpolate(a, b, w);
    }
  }
  // 2. The drives between the commands and the tubes (the model's Drive: play, then transmission errors, then the
  // offset), one per tube and joint, applied row by row in order (the plays remember it).
  std::vector<Drive> rotation(static_cast<std::size_t>(n)), translation(static_cast<std::size_t>(n));
  bool translated = false, driven = false;
  for (const Effect& e : effects) {
    if (e.tube < 1 || e.tube > n) continue;
    const auto t = static_cast<std::size_t>(e.tube - 1);
    if (!addDriveEffect(e, rotation[t], translation[t])) continue;
    driven = true;
    translated = translated || (e.kind == EffectKind::TranslationBacklash && e.value > 0) ||
                 e.kind == EffectKind::StageError || (e.kind == EffectKind::TranslationOffset && e.value != 0.0);
  }
  if (driven) {
    const double none = std::numeric_limits<double>::quiet_NaN();
    std::vector<double> rot_play(static_cast<std::size_t>(n), none), lin_play(static_cast<std::size_t>(n), none);
    for (auto& c : q)
      for (int i = 0; i < n; ++i) {
        const auto s = static_cast<std::size_t>(i);
        c.alpha[i] = rotation[s].joint(c.alpha[i], rot_play[s]);
        c.beta[i] = translation[s].joint(c.beta[i], lin_play[s]);
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

/// Per kept row of a decimated log: the full-rate commands since the previous kept row where a joint reverses (the
/// friction memory is set at reversals; a straight move between kept rows would miss a reversal in between).
std::vector<std::vector<Configuration>> reversalsBetween(const std::vector<Configuration>& t,
                                                         const std::vector<int>& rows) {
  const int m = static_cast<int>(t.size());
  const int n = m ? t[0].size() : 0;
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
  std::vector<std::vector<Configuration>> via(rows.size());
  for (std::size_t k = 1; k < rows.size(); ++k)
    for (int i = rows[k - 1] + 1; i < rows[k]; ++i)
      if (i >= 0 && i < m && turn[static_cast<std::size_t>(i)]) via[k].push_back(t[static_cast<std::size_t>(i)]);
  return via;
}
}  // namespace

Prediction predict(const Robot& nominal, const std::vector<Configuration>& commands0, const Eigen::VectorXd& time,
                   const std::vector<Effect>& effects, Workspace& ws, const PredictOptions& options) {
  const Robot robot = applyToRobot(nominal, effects);
  Prediction p;
  const int rows = static_cast<int>(commands0.size());
  const int n = robot.size();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const ReplayOptions& ro = options.replay;
  // Commands within the admissibility tolerance are projected; rows beyond it are not evaluated.
  std::vector<Configuration> commands = commands0;
  std::vector<char> inadmissible(static_cast<std::size_t>(rows), 0);
  for (int k = 0; k < rows; ++k)
    inadmissible[static_cast<std::size_t>(k)] = !projectAdmissible(robot, commands[static_cast<std::size_t>(k)]);
  const CommandHistory* h = options.history;
  ReplayPath known;
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
    if (friction) known.via = reversalsBetween(t, h->rows);
  } else {
    p.actuation = transformActuation(commands, time, effects, &robot);
  }
  // An inadmissible command stays inadmissible whatever the effects do to it (the replay then reports it).
  for (int k = 0; k < rows; ++k)
    if (inadmissible[static_cast<std::size_t>(k)])
      p.actuation[static_cast<std::size_t>(k)] = commands0[static_cast<std::size_t>(k)];
  p.twist.setConstant(rows, std::max(0, n - 1), nan);
  p.tip_position.setConstant(rows, 3, nan);
  p.tip_tangent.setConstant(rows, 3, nan);
  p.moment.setConstant(rows, nan);
  p.ok.assign(static_cast<std::size_t>(rows), 0);
  p.failure.assign(static_cast<std::size_t>(rows), Failure::None);
  p.message.assign(static_cast<std::size_t>(rows), std::string());
  p.reached.assign(static_cast<std::size_t>(rows), Reached::Path);
  p.alternatives.assign(static_cast<std::size_t>(rows), {});
  if (options.keep_solutions) p.solutions.assign(static_cast<std::size_t>(rows), Solution{});
  if (rows == 0) return p;
  std::vector<ReplayRow> r = replay(robot, p.actuation, ws, ro, known);
  for (int k = 0; k < rows; ++k) {
    ReplayRow& row = r[static_cast<std::size_t>(k)];
    p.reached[static_cast<std::size_t>(k)] = row.reached;
    p.restarts += row.reached == Reached::Restart;
    p.alternatives[static_cast<std::size_t>(k)] = std::move(row.alternatives);
    if (!row.ok) {
      ++p.failures;
      p.failure[static_cast<std::size_t>(k)] = row.failure != Failure::None ? row.failure : Failure::NotConverged;
      p.message[static_cast<std::size_t>(k)] = row.message.empty() ? "did not converge" : row.message;
      continue;
    }
    const Solution& s = row.result.solution;
    p.ok[static_cast<std::size_t>(k)] = 1;
    if (n > 1 && s.twist.size() == n - 1) p.twist.row(k) = s.twist.transpose();  // (no twist with one tube)
    p.tip_position.row(k) = s.tip_position.transpose();
    p.tip_tangent.row(k) = s.tipTangent().transpose();
    p.moment[k] = largestMoment(s);
    if (options.keep_solutions) p.solutions[static_cast<std::size_t>(k)] = std::move(row.result.solution);
  }
  // Measurement effects: a drift of the tracker with time (a generic model).
  for (const Effect& e : effects)
    if (e.kind == EffectKind::TrackerDrift && time.size() == rows)
      for (int k = 0; k < rows; ++k)
        for (int a = 0; a < 3; ++a) p.tip_position(k, a) += e.genericAt(time[k], a);
  return p;
}

}  // namespace ctr::diagnosis
