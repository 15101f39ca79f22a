// The drives between the commands and the tubes (actuation.hpp) and the joints of a command (configuration.hpp).
#include "ctr/model/actuation.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "ctr/model/configuration.hpp"

namespace ctr {

bool Drive::ideal() const {
  if (offset != 0.0 || play != 0.0 || ratio_error != 0.0) return false;
  for (double p : periodic)
    if (p != 0.0) return false;
  for (double c : stage)
    if (c != 0.0) return false;
  return true;
}

double Drive::transmit(double x) const {
  if (ratio_error != 0.0) x += ratio_error * (x - ratio_reference);
  if (periodic[0] != 0.0 || periodic[1] != 0.0 || periodic[2] != 0.0 || periodic[3] != 0.0)
    x += periodic[0] * std::cos(x) + periodic[1] * std::sin(x) + periodic[2] * std::cos(2 * x) +
         periodic[3] * std::sin(2 * x);
  if (stage[0] != 0.0 || stage[1] != 0.0 || stage[2] != 0.0) {
    const double u = (x - stage_reference) / stage_scale;
    x += u * (stage[0] + u * (stage[1] + u * stage[2]));
  }
  return x + offset;
}

double Drive::untransmit(double joint) const {
  double x = joint - offset;
  if (ratio_error == 0.0 && periodic == std::array<double, 4>{} && stage == std::array<double, 3>{}) return x;
  // Newton on transmit(x) - joint, with the derivative of each term; the transmission is monotone for the errors a
  // description accepts (|ratio_error| < 1 and small periodic / stage terms).
  for (int it = 0; it < 50; ++it) {
    const double r = x + ratio_error * (x - ratio_reference);
    double dr = 1.0 + ratio_error;
    double y = r, dy = 1.0;
    y += periodic[0] * std::cos(r) + periodic[1] * std::sin(r) + periodic[2] * std::cos(2 * r) +
         periodic[3] * std::sin(2 * r);
    dy += -periodic[0] * std::sin(r) + periodic[1] * std::cos(r) - 2 * periodic[2] * std::sin(2 * r) +
          2 * periodic[3] * std::cos(2 * r);
    const double u = (y - stage_reference) / stage_scale;
    const double z = y + u * (stage[0] + u * (stage[1] + u * stage[2]));
    const double dz = 1.0 + (stage[0] + u * (2 * stage[1] + 3 * u * stage[2])) / stage_scale;
    const double f = z + offset - joint, df = dz * dy * dr;
    if (std::abs(f) <= 1e-15 * std::max(1.0, std::abs(joint))) return x;
    if (!(df > 0.0)) break;
    x -= f / df;
  }
  const double check = transmit(x) - joint;
  return std::abs(check) <= 1e-12 * std::max(1.0, std::abs(joint)) ? x : std::numeric_limits<double>::quiet_NaN();
}

double Drive::command(double joint, double position) const {
  const double x = untransmit(joint);
  if (!(play > 0.0) || std::isnan(position) || x == position) return x;
  return x > position ? x + 0.5 * play : x - 0.5 * play;
}

double Drive::joint(double command, double& position) const {
  if (play > 0.0) {
    const double h = 0.5 * play;
    if (std::isnan(position))
      position = command;
    else if (command - position > h)
      position = command - h;
    else if (command - position < -h)
      position = command + h;
    return transmit(position);
  }
  return transmit(command);  // no play: nothing to remember
}

bool hasActuation(const Robot& robot) {
  for (const Tube& t : robot.tubes())
    if (!t.rotation_drive.ideal() || !t.translation_drive.ideal()) return true;
  return false;
}

Configuration commandsFor(const Robot& robot, const Configuration& joints, const DriveState& state) {
  const int n = robot.size();
  if (joints.size() != n || joints.beta.size() != n)
    throw std::invalid_argument("commandsFor: the joints have " + std::to_string(joints.size()) + " tubes, the robot " +
                                std::to_string(n));
  const double none = std::numeric_limits<double>::quiet_NaN();
  Configuration c = joints;
  for (int i = 0; i < n; ++i) {
    const Tube& t = robot.tube(i);
    c.alpha[i] = t.rotation_drive.command(joints.alpha[i], state.rotation.size() == n ? state.rotation[i] : none);
    c.beta[i] =
        t.translation_drive.command(joints.beta[i], state.translation.size() == n ? state.translation[i] : none);
  }
  return c;
}

Configuration jointsOf(const Robot& robot, const Configuration& command, DriveState& state) {
  const int n = robot.size();
  if (command.size() != n || command.beta.size() != n)
    throw std::invalid_argument("jointsOf: the command has " + std::to_string(command.size()) + " tubes, the robot " +
                                std::to_string(n));
  const double none = std::numeric_limits<double>::quiet_NaN();
  if (state.rotation.size() != n) state.rotation = Eigen::VectorXd::Constant(n, none);
  if (state.translation.size() != n) state.translation = Eigen::VectorXd::Constant(n, none);
  Configuration q = command;
  bool translated = false;
  for (int i = 0; i < n; ++i) {
    const Tube& t = robot.tube(i);
    q.alpha[i] = t.rotation_drive.joint(command.alpha[i], state.rotation[i]);
    q.beta[i] = t.translation_drive.joint(command.beta[i], state.translation[i]);
    translated = translated || !t.translation_drive.ideal();
  }
  // The stages cannot push a tube through the nesting order: project (any distance) onto the admissible set.
  if (translated) projectAdmissible(robot, q, std::numeric_limits<double>::infinity());
  return q;
}

}  // namespace ctr
