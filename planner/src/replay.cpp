#include "ctr/planner/replay.hpp"

#include <cmath>
#include <cstdio>
#include <iterator>
#include <limits>
#include <sstream>

namespace ctr::planner {
namespace {

std::string siteName(const ContactSite& s) {
  return (s.kind == MomentKind::TubeEnd ? "end" : "disc") + std::to_string(s.tube + 1);
}

std::string num(double v) {
  if (!std::isfinite(v)) return "";
  char b[40];
  std::snprintf(b, sizeof b, "%.10g", v);
  return b;
}

}  // namespace

std::vector<Configuration> replayCommands(const std::vector<Configuration>& waypoints, double rotation_step,
                                          double translation_step) {
  std::vector<Configuration> commands;
  if (waypoints.empty()) return commands;
  commands.push_back(waypoints[0]);
  for (std::size_t k = 0; k + 1 < waypoints.size(); ++k) {
    const int n = subdivisions(waypoints[k], waypoints[k + 1], rotation_step, translation_step);
    for (int j = 1; j <= n; ++j)
      commands.push_back(interpolate(waypoints[k], waypoints[k + 1], static_cast<double>(j) / n));
  }
  return commands;
}

std::string RangeReplay::describe(const Point& p) const {
  std::string out;
  for (std::size_t i = 0; i < names.size() && i < p.values.size(); ++i)
    out += (out.empty() ? "" : ", ") + names[i] + " " + num(p.values[i]);
  return out;
}

ReplayReport replayPath(const Context& ctx, const std::vector<Configuration>& waypoints, const StartHistory& history,
                        const GoalTest& goal, double rotation_step, double translation_step) {
  return replayPath(ctx, ctx.robot(), waypoints, history, goal, rotation_step, translation_step);
}

ReplayReport replayPath(const Context& ctx, const Robot& robot, const std::vector<Configuration>& waypoints,
                        const StartHistory& history, const GoalTest& goal, double rotation_step,
                        double translation_step) {
  ReplayReport R;
  if (waypoints.empty()) {
    R.failure = Failure::NotConverged;
    R.message = "empty path";
    return R;
  }
  ThreadScratch& t = scratch();
  // The start history, then the path: the start row is the last of the history.
  std::vector<Configuration> commands = startCommands(waypoints[0], history);
  const std::size_t start = commands.size() - 1;
  std::vector<Configuration> path = replayCommands(waypoints, rotation_step, translation_step);
  commands.insert(commands.end(), std::make_move_iterator(path.begin() + 1), std::make_move_iterator(path.end()));
  R.min_clearance = std::numeric_limits<double>::infinity();
  Solution last;
  bool completed = true;
  // The planner's checks on top of the replay's rule: every state from the start on converged, stable, snap-free,
  // collision-free; the replay ends at the first move that does not converge.
  auto observe = [&](std::size_t k, ReplayRow& row) {
    if (k < start) {
      const std::string why = historyFailure(k, row);
      if (!why.empty()) {
        R.failure = row.failure != Failure::None ? row.failure : Failure::NotConverged;
        R.message = "start: " + why;
      }
      completed = why.empty();
      return completed;
    }
    StepResult& r = row.result;
    if (k == start && !r.solution.converged()) {
      R.failure = row.failure != Failure::None ? row.failure : Failure::NotConverged;
      R.message = "start: " + row.message;
      completed = false;
      return false;
    }
    if (k > start && !(r.summary.converged && r.state.valid)) {
      if (R.failure == Failure::None) {
        R.failure = row.failure != Failure::None ? row.failure : Failure::NotConverged;
        R.message = "step " + std::to_string(R.steps) + ": " + row.message;
      }
      R.stable = false;
      completed = false;
      return false;
    }
    // A snap on the way to the start (in its history) is where the history put the robot, not a failure of the path.
    const bool snapped = k > start && r.summary.snapped;
    ReplayPoint p;
    p.q = commands[k];
    const ShapeCheck c = checkShape(ctx, r.solution, t);
    p.valid = c.ok && !snapped;
    if (snapped) {
      ++R.snaps;
      R.stable = false;
    }
    if (r.solution.converged() && !r.solution.summary.stable) {
      ++R.unstable;
      R.stable = false;
    }
    if (c.failure == Failure::Collision) {
      ++R.collisions;
      R.collision_free = false;
    }
    if (!p.valid && R.failure == Failure::None) {
      R.failure = snapped ? Failure::Snapped : c.failure;
      R.message = "step " + std::to_string(R.steps) + ": " + (snapped ? std::string("snap") : c.message);
    }
    if (r.solution.converged() && ctx.checker().distanceField()) {
      p.clearance = ctx.checker().clearance(r.solution, t.query).clearance;
      R.min_clearance = std::min(R.min_clearance, p.clearance);
    }
    if (k + 1 == commands.size()) last = r.solution;
    p.solution = std::move(r.solution);
    p.solution.backbone.clear();
    p.hysteresis = std::move(r.state);
    R.points.push_back(std::move(p));
    ++R.steps;
    return true;
  };
  replay(robot, commands, t.ws, replayOptions(ctx), {}, observe);
  if (!std::isfinite(R.min_clearance)) R.min_clearance = 0.0;
  if (!completed) return R;
  R.completed = true;
  const auto [tip_err, dir_err, reached] = goal(last, commands.back());
  R.tip_error = tip_err;
  R.direction_error = dir_err;
  R.goal_reached = reached;
  if (!reached && R.message.empty()) {
    R.failure = Failure::GoalMissed;
    R.message = "goal missed by " + num(tip_err) + " m";
  }
  return R;
}

std::string replayCsv(const Robot& robot, const ReplayReport& r) {
  const int n = robot.size();
  std::vector<std::string> sites;
  for (const auto& p : r.points)
    for (const auto& c : p.hysteresis.contacts) {
      const std::string s = siteName(c.site);
      if (std::find(sites.begin(), sites.end(), s) == sites.end()) sites.push_back(s);
    }
  std::ostringstream os;
  for (int i = 1; i <= n; ++i) os << "alpha_" << i << ',';
  for (int i = 1; i <= n; ++i) os << "beta_" << i << ',';
  for (int i = 2; i <= n; ++i) os << "twist_" << i << ',';
  os << "tip_x,tip_y,tip_z,tip_tx,tip_ty,tip_tz,clearance,valid";
  const bool drives = hasActuation(robot);  // then also the tubes' joints and the plays' positions
  if (drives) {
    for (int i = 1; i <= n; ++i) os << ",joint_alpha_" << i;
    for (int i = 1; i <= n; ++i) os << ",joint_beta_" << i;
    for (int i = 1; i <= n; ++i) os << ",play_alpha_" << i;
    for (int i = 1; i <= n; ++i) os << ",play_beta_" << i;
  }
  for (const auto& s : sites) os << ',' << s << "_mode," << s << "_torque," << s << "_relative_twist";
  os << '\n';
  for (const auto& p : r.points) {
    for (int i = 0; i < n; ++i) os << num(p.q.alpha[i]) << ',';
    for (int i = 0; i < n; ++i) os << num(p.q.beta[i]) << ',';
    const bool ok = p.solution.converged();
    for (int i = 0; i + 1 < n; ++i) os << (ok ? num(p.solution.twist[i]) : "") << ',';
    const Eigen::Vector3d t = p.solution.tipTangent();
    for (int d = 0; d < 3; ++d) os << (ok ? num(p.solution.tip_position[d]) : "") << ',';
    for (int d = 0; d < 3; ++d) os << (ok ? num(t[d]) : "") << ',';
    os << num(p.clearance) << ',' << (p.valid ? 1 : 0);
    if (drives) {
      for (int i = 0; i < n; ++i) os << ',' << (ok ? num(p.solution.q.alpha[i]) : "");
      for (int i = 0; i < n; ++i) os << ',' << (ok ? num(p.solution.q.beta[i]) : "");
      const DriveState& d = p.hysteresis.drives;
      for (int i = 0; i < n; ++i) os << ',' << (i < d.rotation.size() ? num(d.rotation[i]) : "");
      for (int i = 0; i < n; ++i) os << ',' << (i < d.translation.size() ? num(d.translation[i]) : "");
    }
    for (const auto& s : sites) {
      const ContactMemory* m = nullptr;
      for (const auto& c : p.hysteresis.contacts)
        if (siteName(c.site) == s) m = &c;
      if (m) {
        os << ',' << toString(m->mode) << ',' << num(m->torque) << ',' << num(m->relative_twist);
      } else {
        os << ",,,";
      }
    }
    os << '\n';
  }
  return os.str();
}

}  // namespace ctr::planner
