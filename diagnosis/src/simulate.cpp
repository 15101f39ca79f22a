// Generated actuation patterns and effect injection (the fit's forward model run forwards, plus noise).
#include "ctr/diagnosis/simulate.hpp"

#include <algorithm>
#include <cmath>
#include <random>
#include <stdexcept>

namespace ctr::diagnosis {

namespace {

/// Admissible interval of the innermost tube's translation with the others at q (shrunk by a margin).
std::pair<double, double> innerRange(const Robot& robot, const Configuration& q) {
  const int n = robot.size();
  const int i = n - 1;
  double lo = -robot.tube(i).length() + 1e-3, hi = 0.0;
  if (n >= 2) {
    hi = q.beta[i - 1];
    lo = std::max(lo, q.beta[i - 1] + robot.tube(i - 1).length() - robot.tube(i).length());
  }
  if (robot.tube(i).translation_limits) {
    lo = std::max(lo, (*robot.tube(i).translation_limits)[0]);
    hi = std::min(hi, (*robot.tube(i).translation_limits)[1]);
  }
  const double m = 0.1 * (hi - lo);
  return {lo + m, hi - m};
}

}  // namespace

const char* toString(ActuationPattern pattern) {
  switch (pattern) {
    case ActuationPattern::Sweep:
      return "sweep";
    case ActuationPattern::Random:
      return "random";
    case ActuationPattern::RandomWalk:
      return "random-walk";
  }
  return "?";
}

void makeActuation(const Robot& robot, const ActuationOptions& o, std::vector<Configuration>& commands,
                   Eigen::VectorXd& time) {
  const int n = robot.size();
  commands.clear();
  const Configuration q0 = defaultConfiguration(robot);
  const auto range = innerRange(robot, q0);
  std::mt19937_64 rng(o.seed);
  std::uniform_real_distribution<double> U(0.0, 1.0);
  const double deg = M_PI / 180.0;
  // Lowest rotation used for tube i: 0, or the lower rotation limit when 0 .. 2 pi would leave the limits.
  auto rotLo = [&](int i) {
    if (!robot.tube(i).rotation_limits) return 0.0;
    const auto& l = *robot.tube(i).rotation_limits;
    return l[1] >= 2 * M_PI - 1e-9 && l[0] <= 0 ? 0.0 : l[0];
  };
  if (o.pattern == ActuationPattern::Sweep) {
    const int steps = std::max(1, static_cast<int>(std::lround(o.sweep_range_deg / o.step_deg)));
    for (int k = 1; k < n || (n == 1 && k == 1); ++k) {
      const int tube = std::min(k, n - 1);
      for (int s = 0; s <= 2 * steps; ++s) {
        if (k > 1 && s == 0) continue;
        const int j = s <= steps ? s : 2 * steps - s;
        Configuration q = q0;
        q.alpha[tube] = rotLo(tube) + j * o.step_deg * deg;
        if (robot.tube(tube).rotation_limits)
          q.alpha[tube] = std::min(q.alpha[tube], (*robot.tube(tube).rotation_limits)[1]);
        commands.push_back(q);
      }
      if (n == 1) break;
    }
    if (o.translate && n >= 2) {
      const int rows = static_cast<int>(commands.size());
      for (int r = 0; r < rows; ++r) {
        const double ph = static_cast<double>(r) / std::max(1, rows - 1);
        const double tri = ph < 0.5 ? 2 * ph : 2 - 2 * ph;
        commands[static_cast<std::size_t>(r)].beta[n - 1] = range.second + tri * (range.first - range.second);
      }
    }
  } else if (o.pattern == ActuationPattern::Random) {
    for (int r = 0; r < o.rows; ++r) {
      if (r > 0 && o.returns > 0 && U(rng) < o.returns) {
        commands.push_back(commands[static_cast<std::size_t>(U(rng) * r) % static_cast<std::size_t>(r)]);
        continue;
      }
      Configuration q = q0;
      for (int i = 1; i < n; ++i) {
        const double lo = rotLo(i), hi = robot.tube(i).rotation_limits
                                             ? std::min(lo + 2 * M_PI, (*robot.tube(i).rotation_limits)[1])
                                             : lo + 2 * M_PI;
        q.alpha[i] = lo + (hi - lo) * U(rng);
      }
      if (o.translate && n >= 2) q.beta[n - 1] = range.first + U(rng) * (range.second - range.first);
      commands.push_back(q);
    }
  } else {
    // Random walk: each rotating tube moves at a random speed, reversing at random times, within [-pi, pi].
    const double dt = o.dt > 0 ? o.dt : 0.1;
    std::vector<double> v(static_cast<std::size_t>(n), 0.0);
    double vb = 0.0;
    Configuration q = q0;
    for (int i = 1; i < n; ++i)
      v[static_cast<std::size_t>(i)] = (U(rng) < 0.5 ? -1 : 1) * o.max_speed * (0.3 + 0.7 * U(rng));
    vb = (range.second - range.first) / 8.0;
    for (int r = 0; r < o.rows; ++r) {
      commands.push_back(q);
      for (int i = 1; i < n; ++i) {
        double& vi = v[static_cast<std::size_t>(i)];
        if (U(rng) < 0.06) vi = (vi > 0 ? -1 : 1) * o.max_speed * (0.3 + 0.7 * U(rng));
        double a = q.alpha[i] + vi * dt;
        if (a > M_PI) {
          a = 2 * M_PI - a;
          vi = -std::abs(vi);
        }
        if (a < -M_PI) {
          a = -2 * M_PI - a;
          vi = std::abs(vi);
        }
        q.alpha[i] = a;
      }
      if (o.translate && n >= 2) {
        if (U(rng) < 0.04) vb = -vb;
        double b = q.beta[n - 1] + vb * dt;
        if (b > range.second) {
          b = range.second;
          vb = -std::abs(vb);
        }
        if (b < range.first) {
          b = range.first;
          vb = std::abs(vb);
        }
        q.beta[n - 1] = b;
      }
    }
  }
  if (o.frames > 1) {
    std::vector<Configuration> repeated;
    for (const Configuration& q : commands)
      for (int f = 0; f < o.frames; ++f) repeated.push_back(q);
    commands = std::move(repeated);
  }
  const int rows = static_cast<int>(commands.size());
  if (o.dt > 0) {
    time.resize(rows);
    for (int r = 0; r < rows; ++r) time[r] = r * o.dt;
  } else {
    time.resize(0);
  }
}

io::Recording simulateRecording(const Robot& nominal, const std::vector<Configuration>& commands,
                                const Eigen::VectorXd& time, const std::vector<Effect>& effects,
                                const SimulationOptions& o) {
  Workspace ws;
  Prediction p = predict(nominal, commands, time, effects, ws, o.predict);
  const int rows = p.rows();
  // Rows the model cannot evaluate are written empty (never another row's output). Rows reached through a snap are
  // expected in random-order recordings; other failures beyond 10 % mean the model cannot simulate this path.
  int hard = 0;
  for (int k = 0; k < rows; ++k)
    hard += !p.ok[static_cast<std::size_t>(k)] && p.failure[static_cast<std::size_t>(k)] != Failure::Snapped;
  if (hard > rows / 10)
    throw std::runtime_error("simulateRecording: " + std::to_string(hard) + " of " + std::to_string(rows) +
                             " rows could not be evaluated");
  if (o.sensor_frame) applyRegistration(*o.sensor_frame, p.tip_position, p.tip_tangent);
  std::mt19937_64 rng(o.seed);
  std::normal_distribution<double> N(0.0, 1.0);
  io::Recording rec;
  rec.tubes = nominal.size();
  rec.commands = commands;
  rec.time = time;
  if (o.twist && nominal.size() > 1) {
    rec.twist = p.twist;
    for (Eigen::Index k = 0; k < rec.twist.size(); ++k) rec.twist.data()[k] += o.twist_sd * N(rng);
  }
  // Repeatability: one error per visit (consecutive rows with the same command), the same for all its frames.
  Eigen::MatrixXd visit_p = Eigen::MatrixXd::Zero(rows, 3), visit_t = Eigen::MatrixXd::Zero(rows, 3);
  if (o.repeatability_position_sd > 0 || o.repeatability_tangent_sd > 0)
    for (int k = 0; k < rows; ++k) {
      const bool same =
          k > 0 && commands[static_cast<std::size_t>(k)].alpha == commands[static_cast<std::size_t>(k - 1)].alpha &&
          commands[static_cast<std::size_t>(k)].beta == commands[static_cast<std::size_t>(k - 1)].beta;
      for (int c = 0; c < 3; ++c) {
        visit_p(k, c) = same ? visit_p(k - 1, c) : o.repeatability_position_sd * N(rng);
        visit_t(k, c) = same ? visit_t(k - 1, c) : o.repeatability_tangent_sd * N(rng);
      }
    }
  if (o.tip_position) {
    rec.tip_position = p.tip_position + visit_p;
    for (Eigen::Index k = 0; k < rec.tip_position.size(); ++k) rec.tip_position.data()[k] += o.position_sd * N(rng);
  }
  if (o.tip_tangent) {
    rec.tip_tangent = p.tip_tangent + visit_t;
    for (Eigen::Index k = 0; k < rows; ++k) {
      for (int c = 0; c < 3; ++c) rec.tip_tangent(k, c) += o.tangent_sd * N(rng);
      rec.tip_tangent.row(k).normalize();
    }
  }
  return rec;
}

}  // namespace ctr::diagnosis
