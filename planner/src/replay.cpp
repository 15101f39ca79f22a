#include "ctr/planner/replay.hpp"

#include <cmath>
#include <cstdio>
#include <sstream>

namespace ctr::plan {
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

const char* modeName(ContactMode m) {
  switch (m) {
    case ContactMode::Stick: return "stick";
    case ContactMode::SlipPositive: return "slip+";
    case ContactMode::SlipNegative: return "slip-";
  }
  return "";
}

}  // namespace

ReplayReport replayPath(const Context& ctx, const std::vector<Configuration>& waypoints, const StartHistory& history,
                        const GoalTest& goal, double rotation_step, double translation_step) {
  ReplayReport R;
  if (waypoints.empty()) {
    R.first_failure = "empty path";
    return R;
  }
  ThreadScratch& t = scratch();
  FrictionOptions fo = ctx.options().friction;
  fo.kinematics.record_backbone = true;
  const Robot& robot = ctx.robot();
  R.min_clearance = std::numeric_limits<double>::infinity();
  auto record = [&](const Configuration& q, const Solution& sol, const HysteresisState& h, bool snapped) {
    ReplayPoint p;
    p.q = q;
    p.hysteresis = h;
    const ShapeCheck c = checkShape(ctx, sol, t);
    p.valid = c.ok && !snapped;
    if (snapped) {
      ++R.snaps;
      R.stable = false;
    }
    if (sol.converged() && !sol.summary.stable) {
      ++R.unstable;
      R.stable = false;
    }
    if (!c.ok && c.reason.rfind("collision", 0) == 0) {
      ++R.collisions;
      R.collision_free = false;
    }
    if (!p.valid && R.first_failure.empty())
      R.first_failure = "step " + std::to_string(R.steps) + ": " + (snapped ? std::string("snap") : c.reason);
    if (sol.converged() && ctx.checker().distanceField()) {
      p.clearance = ctx.checker().clearance(sol, t.query).clearance;
      R.min_clearance = std::min(R.min_clearance, p.clearance);
    }
    p.solution = sol;
    p.solution.backbone.clear();
    R.points.push_back(std::move(p));
    ++R.steps;
  };
  const std::shared_ptr<const StateCache> start = startCache(ctx, waypoints[0], history);
  if (!start->solution.converged()) {
    R.first_failure = "start: " + start->why;
    return R;
  }
  HysteresisState state = start->hysteresis;
  Solution last = start->solution;
  record(waypoints[0], last, state, false);
  for (std::size_t k = 0; k + 1 < waypoints.size(); ++k) {
    const Configuration d(waypoints[k + 1].alpha - waypoints[k].alpha, waypoints[k + 1].beta - waypoints[k].beta);
    const double a = d.alpha.cwiseAbs().maxCoeff(), b = d.beta.cwiseAbs().maxCoeff();
    const int steps = std::max(1, static_cast<int>(std::ceil(std::max(a / rotation_step, b / translation_step) - 1e-9)));
    for (int j = 1; j <= steps; ++j) {
      const double s = static_cast<double>(j) / steps;
      // As the propagator: the last sub-step ends exactly at the waypoint.
      const Configuration q = j == steps ? waypoints[k + 1]
                                         : Configuration(waypoints[k].alpha + s * d.alpha, waypoints[k].beta + s * d.beta);
      const StepResult r = step(robot, state, q, t.ws, fo);
      if (!r.summary.converged) {
        if (R.first_failure.empty()) R.first_failure = "step " + std::to_string(R.steps) + ": " + r.summary.message;
        R.stable = false;
        return R;
      }
      state = r.state;
      last = r.solution;
      record(q, last, state, r.summary.snapped);
    }
  }
  R.completed = true;
  const auto [tip_err, dir_err, reached] = goal(last);
  R.tip_error = tip_err;
  R.direction_error = dir_err;
  R.goal_reached = reached;
  if (!reached && R.first_failure.empty()) R.first_failure = "goal missed by " + num(tip_err) + " m";
  if (!std::isfinite(R.min_clearance)) R.min_clearance = 0.0;
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
    for (const auto& s : sites) {
      const ContactMemory* m = nullptr;
      for (const auto& c : p.hysteresis.contacts)
        if (siteName(c.site) == s) m = &c;
      if (m) {
        os << ',' << modeName(m->mode) << ',' << num(m->torque) << ',' << num(m->relative_twist);
      } else {
        os << ",,,";
      }
    }
    os << '\n';
  }
  return os.str();
}

}  // namespace ctr::plan
