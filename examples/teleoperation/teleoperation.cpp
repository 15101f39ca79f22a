// Resolved-rate teleoperation of a 3-tube robot with boundary friction (docs/ik.md): the tip follows a 10 mm circle
// at a 1 kHz servo rate (2 s per turn, 2000 periods). Each period takes one warm inverse-kinematics update: a
// resolved-rate step dq = J^+ dx with the exact tip Jacobian, repeated only when the tip would stay off by more than
// 10 um. The "robot" is the stateful stick-slip model (mu' = 0.1): every command is stepped through it from the state
// the previous command left, and the tip it reaches is the measurement.
//
//   1. friction-blind: the controller inverts the frictionless model;
//   2. friction-aware: it inverts the stateful step from the robot's hysteresis state (ctr::frictionInverseKinematics);
//   then the same loop with a tip force F (the tool pressing sideways on tissue):
//   3. force-blind: the friction-aware controller of the load-free model;
//   4. compliance: the same aiming at p* - C F, C the tip compliance of the load-free start shape (tipJacobian);
//   5. loaded model: the friction-aware controller of the robot under F.
//
// Usage: teleoperation OUT_DIR [ROBOTS_DIR] [POINTS]   writes OUT_DIR/teleoperation.csv (errors per period) and
// OUT_DIR/teleoperation_friction.svg, teleoperation_force.svg; prints the RMS errors. Exit 1 if the friction-aware
// commands are not at least 5x better (RMS) than the friction-blind ones.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "../paper/svg_plot.hpp"
#include "ctr/io/robot_yaml.hpp"
#include "ctr/model/friction_ik.hpp"
#include "ctr/model/ik.hpp"
#include "ctr/model/jacobian.hpp"

using namespace ctr;

namespace {

// Tip errors (m) of commands stepped one after the other through the stateful model of `robot` from `start`.
std::vector<double> replayErrors(const Robot& robot, const HysteresisState& start, const std::vector<Configuration>& q,
                                 const std::vector<IkTarget>& targets, Workspace& ws, const FrictionOptions& fo) {
  std::vector<double> e;
  HysteresisState h = start;
  for (std::size_t k = 0; k < q.size(); ++k) {
    const StepResult r = step(robot, h, q[k], ws, fo);
    e.push_back(r.summary.converged ? (r.solution.tip_position - targets[k].position).norm() : NAN);
    if (r.state.valid) h = r.state;
  }
  return e;
}

double rms(const std::vector<double>& v) {
  double s = 0.0;
  for (double x : v) s += x * x;
  return std::sqrt(s / static_cast<double>(v.size()));
}

std::vector<Configuration> commandsOf(const std::vector<FrictionIkResult>& r) {
  std::vector<Configuration> q;
  for (const FrictionIkResult& x : r) q.push_back(x.q);
  return q;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: teleoperation OUT_DIR [ROBOTS_DIR] [POINTS]\n");
    return 2;
  }
  const std::filesystem::path out = argv[1];
  const std::string robots = argc > 2 ? argv[2] : std::string(CTR_SOURCE_DIR) + "/examples/robots";
  const int points = argc > 3 ? std::atoi(argv[3]) : 2000;
  std::filesystem::create_directories(out);
  const Robot free = io::loadRobot(robots + "/dupont_lab_3tube.yaml");
  const Robot robot = free.withFriction({0.1, 0.0});
  Workspace ws;

  // The circle: 10 mm diameter in the plane z = const through the tip of the start configuration.
  const Configuration start_q(Eigen::Vector3d(0.0, 0.5, -1.0), Eigen::Vector3d(0.0, -0.017, -0.09));
  const Solution start_shape = solve(free, start_q, ws);
  const double radius = 0.005, period = 1e-3;
  const Eigen::Vector3d centre = start_shape.tip_position - Eigen::Vector3d(radius, 0.0, 0.0);
  std::vector<IkTarget> targets;
  for (int k = 0; k <= points; ++k) {
    const double a = 2.0 * M_PI * k / points;
    targets.emplace_back(centre + radius * Eigen::Vector3d(std::cos(a), std::sin(a), 0.0));
  }
  // The robot starts at rest on the circle's first point.
  const IkResult first = inverseKinematics(free, targets[0], start_q, ws);
  FrictionIkOptions o;
  const StepResult rest = initialState(robot, first.q, ws, o.friction);

  // 1 + 2: friction-blind and friction-aware (the path function follows the blind commands too).
  const std::vector<FrictionIkResult> aware = frictionInverseKinematicsPath(robot, rest.state, targets, ws, o);
  std::vector<Configuration> blind_q;
  for (const FrictionIkResult& r : aware) blind_q.push_back(r.cost.blind_q);
  const std::vector<double> e_blind = replayErrors(robot, rest.state, blind_q, targets, ws, o.friction);
  const std::vector<double> e_aware = replayErrors(robot, rest.state, commandsOf(aware), targets, ws, o.friction);

  // 3-5: a tip force of 50 mN along -x (toward the circle's centre side), base frame.
  Loads loads;
  loads.tip_force = Eigen::Vector3d(-0.05, 0.0, 0.0);
  const Robot pressed = robot.withLoads(loads);
  const StepResult rest_pressed = initialState(pressed, first.q, ws, o.friction);
  FrictionIkOptions aware_only = o;
  aware_only.compare_blind = false;
  const auto force_blind = frictionInverseKinematicsPath(robot, rest.state, targets, ws, aware_only);
  const TipJacobian J = tipJacobian(free, solve(free, first.q, ws), ws);
  const Eigen::Vector3d deflection = J.compliance.topLeftCorner<3, 3>() * loads.tip_force;
  std::vector<IkTarget> shifted = targets;
  for (IkTarget& t : shifted) t.position -= deflection;
  const auto compliance = frictionInverseKinematicsPath(robot, rest.state, shifted, ws, aware_only);
  const auto loaded = frictionInverseKinematicsPath(pressed, rest_pressed.state, targets, ws, aware_only);
  const std::vector<double> e_force_blind =
      replayErrors(pressed, rest_pressed.state, commandsOf(force_blind), targets, ws, o.friction);
  const std::vector<double> e_compliance =
      replayErrors(pressed, rest_pressed.state, commandsOf(compliance), targets, ws, o.friction);
  const std::vector<double> e_loaded =
      replayErrors(pressed, rest_pressed.state, commandsOf(loaded), targets, ws, o.friction);

  std::ofstream csv(out / "teleoperation.csv");
  csv << "time,target_x,target_y,target_z,friction_blind,friction_aware,force_blind,compliance,loaded_model\n";
  examples::Series sb{"friction-blind", {}, {}, "#d62728"}, sa{"friction-aware", {}, {}, "#2ca02c"};
  examples::Series fb{"force-blind", {}, {}, "#d62728"}, fc{"compliance C F", {}, {}, "#ff7f0e", true},
      fl{"loaded model", {}, {}, "#2ca02c"};
  for (std::size_t k = 0; k < targets.size(); ++k) {
    const double t = period * static_cast<double>(k);
    const Eigen::Vector3d& p = targets[k].position;
    csv << t << ',' << p.x() << ',' << p.y() << ',' << p.z() << ',' << e_blind[k] << ',' << e_aware[k] << ','
        << e_force_blind[k] << ',' << e_compliance[k] << ',' << e_loaded[k] << '\n';
    for (auto [s, e] :
         {std::pair{&sb, &e_blind}, {&sa, &e_aware}, {&fb, &e_force_blind}, {&fc, &e_compliance}, {&fl, &e_loaded}}) {
      s->x.push_back(t);
      s->y.push_back((*e)[k] * 1e3);
    }
  }
  examples::writeSvg((out / "teleoperation_friction.svg").string(),
                     "10 mm circle at 1 kHz, mu' = 0.1: tip error through the stick-slip model", "time (s)",
                     "tip error (mm)", {sb, sa});
  examples::writeSvg((out / "teleoperation_force.svg").string(),
                     "same loop with a 50 mN tip force (friction-aware controllers)", "time (s)", "tip error (mm)",
                     {fb, fc, fl});

  int reached = 0;
  for (const FrictionIkResult& r : aware) reached += r.summary.reached();
  std::printf("circle: %zu targets, 10 mm diameter, mu' = 0.1\n", targets.size());
  std::printf("friction-blind commands: tip RMS %.4f mm (max %.4f mm)\n", rms(e_blind) * 1e3,
              *std::max_element(e_blind.begin(), e_blind.end()) * 1e3);
  std::printf("friction-aware commands: tip RMS %.4f mm (max %.4f mm), %d of %zu reached; ratio %.0fx\n",
              rms(e_aware) * 1e3, *std::max_element(e_aware.begin(), e_aware.end()) * 1e3, reached, aware.size(),
              rms(e_blind) / rms(e_aware));
  std::printf("tip force %.0f mN: compliance C F = %.3f mm at the start\n", loads.tip_force.norm() * 1e3,
              deflection.norm() * 1e3);
  std::printf("  force-blind: tip RMS %.4f mm; compliance-compensated: %.4f mm; loaded-model IK: %.4f mm\n",
              rms(e_force_blind) * 1e3, rms(e_compliance) * 1e3, rms(e_loaded) * 1e3);
  std::printf("wrote %s\n", (out / "teleoperation.csv").string().c_str());
  return rms(e_aware) * 5.0 < rms(e_blind) ? 0 : 1;
}
