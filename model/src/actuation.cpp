// The drives between the commands and the tubes (actuation.hpp) and the joints of a command (configuration.hpp).
#include "ctr/model/actuation.hpp"

#include <cmath>
#include <limits>

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
