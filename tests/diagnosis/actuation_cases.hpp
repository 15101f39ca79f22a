// Actuation set-ups shared by the diagnosis tests.
#pragma once

#include "ctr/diagnosis/simulate.hpp"

namespace ctr::diagnosis::test {

/// A random walk of `rows` commands (with translations when asked), `dt` apart (0: no time column).
inline ActuationOptions randomWalk(int rows, bool translate, double dt, unsigned seed) {
  ActuationOptions a;
  a.pattern = ActuationPattern::RandomWalk;
  a.rows = rows;
  a.translate = translate;
  a.dt = dt;
  a.seed = seed;
  return a;
}

}  // namespace ctr::diagnosis::test
