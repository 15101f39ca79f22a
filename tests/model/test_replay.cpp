// The replay's branch rule: continuation along small moves, from rest after unknown paths; never an unstable
// equilibrium; the other stable equilibria listed; the failure rule.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "ctr/model/replay.hpp"
#include "tube_factory.hpp"

using namespace ctr;
using ctr::test::makeTube;

namespace {

/// A tube pair that snaps: strongly curved, long overlap, long straight transmissions.
Robot snappingPair() {
  return Robot("snapping_pair",
               {makeTube("outer", 0.10, 0.15, 14.0, 0.03, 0.3), makeTube("inner", 0.12, 0.15, 14.0, 0.03, 0.3)});
}

Configuration pose(double a2, double b = -0.05) {
  return Configuration(Eigen::Vector2d(0, a2), Eigen::Vector2d(b, b - 0.02 + 0.02));
}

}  // namespace

TEST(Replay, Explore) {
  const Robot r = snappingPair();
  Workspace ws;
  ReplayOptions o;
  o.find_alternatives = true;
  std::vector<Configuration> q;
  for (int k = 0; k <= 36; ++k) q.push_back(pose(k * 10.0 * M_PI / 180));
  o.branch = BranchRule::Rest;
  const auto rows = replay(r, q, ws, o);
  for (std::size_t k = 0; k < rows.size(); ++k) {
    std::printf("%3zu %5.0f ok=%d %s stab=%.3g tw=%.3f alts:", k, k * 10.0, rows[k].ok, rows[k].reason.c_str(),
                rows[k].result.solution.summary.stability,
                rows[k].result.solution.twist.size() ? rows[k].result.solution.twist[0] : 0.0);
    for (const Alternative& a : rows[k].alternatives) std::printf(" %.2f mm", a.tip_distance * 1e3);
    std::printf("\n");
  }
}
