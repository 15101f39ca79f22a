// Links ctr::ctr from an installed tree and solves tube pair B at 90 deg.
#include <cmath>
#include <iostream>

#include <ctr/model.hpp>

int main() {
  ctr::Tube outer;
  outer.name = "outer";
  outer.straight_length = 0.018;
  outer.curved_length = 0.150;
  outer.curvature = 1 / 0.154;
  outer.bending_stiffness = 0.0334;
  outer.torsional_stiffness = 0.0334 / 1.6;
  ctr::Tube inner = outer;
  inner.name = "inner";
  inner.bending_stiffness = 0.0511;
  inner.torsional_stiffness = 0.0511 / 1.6;
  const ctr::Robot robot("tube_pair_B", {outer, inner});
  ctr::Workspace ws;
  const ctr::Solution s =
      ctr::solve(robot, ctr::Configuration(Eigen::Vector2d(0, M_PI / 2), Eigen::Vector2d(-0.018, -0.018)), ws);
  std::cout << "converged " << s.converged() << " twist " << s.twist[0] << " tip " << s.tip_position.transpose()
            << "\n";
  return s.converged() && s.summary.stable && std::abs(s.twist[0] - 0.8206) < 1e-3 ? 0 : 1;
}
