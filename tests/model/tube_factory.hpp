// Test helper: a tube from its lengths, precurvature, bending stiffness and Poisson ratio.
#pragma once

#include <string>

#include "ctr/model/robot.hpp"

namespace ctr::test {

inline Tube makeTube(const std::string& name, double ls, double lc, double kappa, double kb, double nu) {
  Tube t;
  t.name = name;
  t.straight_length = ls;
  t.curved_length = lc;
  t.curvature = kappa;
  t.bending_stiffness = kb;
  t.torsional_stiffness = kb / (1.0 + nu);
  t.poisson_ratio = nu;
  return t;
}

}  // namespace ctr::test
