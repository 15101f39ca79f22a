// The replay's branch rule: continuation from the previous row (or from rest when asked); never an unstable
// equilibrium; the other stable equilibria listed; the failure rule; the observer.
#include <gtest/gtest.h>

#include <cmath>

#include "ctr/model/replay.hpp"
#include "tube_factory.hpp"

using namespace ctr;
using ctr::test::makeTube;

namespace {

constexpr double kDeg = M_PI / 180;

/// A strongly curved tube pair with long straight transmissions: two stable equilibria at every relative rotation
/// (the curved parts bent to one side or, after a turn of wind-up, to the other).
Robot bistablePair() {
  return Robot("bistable_pair",
               {makeTube("outer", 0.10, 0.15, 14.0, 0.03, 0.3), makeTube("inner", 0.12, 0.15, 14.0, 0.03, 0.3)});
}

Configuration pose(double relative) {
  return Configuration(Eigen::Vector2d(0, relative), Eigen::Vector2d(-0.05, -0.05));
}

}  // namespace

// Rows are in the order taken: every row after the first is reached by continuation along the move from the previous
// one, whatever its size. A 140-deg move lands where a sweep through it in 10-deg rows lands.
TEST(Replay, EveryRowFollowsTheMoveFromThePreviousWhateverItsSize) {
  for (const Robot& r : {bistablePair(), bistablePair().withFriction({0.1, 0.0})}) {
    Workspace ws;
    const std::vector<Configuration> q = {pose(0), pose(10 * kDeg), pose(150 * kDeg), pose(155 * kDeg)};
    std::vector<Configuration> sweep;
    for (int k = 0; k <= 15; ++k) sweep.push_back(pose(k * 10 * kDeg));
    sweep.push_back(pose(155 * kDeg));
    const std::vector<ReplayRow> rows = replay(r, q, ws), dense = replay(r, sweep, ws);
    ASSERT_EQ(rows.size(), q.size());
    EXPECT_EQ(rows[0].reached, Reached::Rest);
    for (std::size_t k = 1; k < rows.size(); ++k) EXPECT_EQ(rows[k].reached, Reached::Path) << k;
    for (const ReplayRow& row : rows) ASSERT_TRUE(row.ok) << row.message;
    ASSERT_TRUE(dense.back().ok) << dense.back().message;
    EXPECT_LT((rows.back().result.solution.tip_position - dense.back().result.solution.tip_position).norm(), 1e-6);
    EXPECT_FALSE(isLongMove(q[0], q[1], ReplayOptions{}));
    EXPECT_TRUE(isLongMove(q[1], q[2], ReplayOptions{}));
  }
  EXPECT_THROW(parseBranchRule("auto"), std::invalid_argument);
}

// A pose set whose long relative rotation winds the pair past the symmetric pose: the row is replayed by continuation
// (on the wound-up branch), and the equilibrium reached from rest (the short way) is listed among its alternatives,
// with and without friction; the rows after it follow both branches along their short moves.
TEST(Replay, ALongMovePastAnotherBranchListsTheOneReachedFromRest) {
  for (const Robot& r : {bistablePair(), bistablePair().withFriction({0.05, 0.0})}) {
    const Robot free = r.withFriction(FrictionCoefficients{});
    Workspace ws;
    ReplayOptions o;
    o.find_alternatives = true;
    const std::vector<Configuration> q = {pose(0), pose(200 * kDeg), pose(205 * kDeg)};
    const std::vector<ReplayRow> rows = replay(r, q, ws, o);
    for (std::size_t k = 1; k < rows.size(); ++k) {
      ASSERT_TRUE(rows[k].ok) << k << ": " << rows[k].message;
      EXPECT_EQ(rows[k].reached, Reached::Path);
      const StepResult rest = reachFromRest(free, q[k], ws);
      ASSERT_TRUE(rest.summary.converged) << rest.summary.message;
      EXPECT_GT((rows[k].result.solution.tip_position - rest.solution.tip_position).norm(), 0.05) << k;
      bool listed = false;
      for (const Alternative& a : rows[k].alternatives)
        listed = listed || (a.solution.tip_position - rest.solution.tip_position).norm() < 1e-6;
      EXPECT_TRUE(listed) << k << ": " << rows[k].alternatives.size() << " alternatives";
    }
  }
}

// The rest path (aligned tubes rotated the short way, stick-slip stepping code) lands on the equilibrium that an
// independent frictionless continuation from the aligned tubes (continueTo, kinematics solver) reaches.
TEST(Replay, RestIsTheContinuationFromTheAlignedTubes) {
  const Robot r = bistablePair();
  Workspace ws;
  KinematicsOptions ko;
  ko.record_backbone = false;
  for (double rel : {-170.0, -60.0, 100.0, 179.0, 250.0}) {
    const Configuration q = pose(rel * kDeg);
    const StepResult rest = reachFromRest(r, q, ws);
    ASSERT_TRUE(rest.summary.converged) << rel << ": " << rest.summary.message;
    const double wrapped = std::remainder(rel * kDeg, 2 * M_PI);
    const Solution aligned = solve(r, pose(rel * kDeg - wrapped), ws, ko);
    const Solution cont = continueTo(r, aligned, q, ws, ko);
    ASSERT_TRUE(cont.converged());
    EXPECT_FALSE(cont.summary.snapped);
    EXPECT_LT((rest.solution.tip_position - cont.tip_position).norm(), 1e-8) << rel;
    EXPECT_TRUE(rest.solution.summary.stable) << rel;
  }
}

// From rest, every row of this pair is on the short-way branch and stable; the other stable equilibrium (the long way
// round: the curved parts bent to the other side, ~0.2 m away) is listed at every row but the aligned one.
TEST(Replay, NeverAnUnstableEquilibriumAndTheOtherBranchIsListed) {
  const Robot r = bistablePair();
  Workspace ws;
  ReplayOptions o;
  o.branch = BranchRule::Rest;
  o.find_alternatives = true;
  KinematicsOptions ko;
  ko.record_backbone = false;
  std::vector<Configuration> q;
  for (int k = 0; k <= 12; ++k) q.push_back(pose(k * 30 * kDeg));
  const std::vector<ReplayRow> rows = replay(r, q, ws, o);
  for (std::size_t k = 0; k < rows.size(); ++k) {
    ASSERT_TRUE(rows[k].ok) << k << ": " << rows[k].message;
    EXPECT_TRUE(rows[k].result.solution.summary.stable) << k;
    const double rel = std::remainder(q[k].alpha[1], 2 * M_PI);
    if (std::abs(rel) < 1e-9) continue;
    ASSERT_FALSE(rows[k].alternatives.empty()) << k;
    const Alternative& alt = rows[k].alternatives.front();
    EXPECT_GT(alt.tip_distance, 0.1) << k;
    EXPECT_TRUE(alt.solution.summary.stable) << k;
    // It is the equilibrium reached the long way round from the aligned tubes.
    const double other = rel > 0 ? rel - 2 * M_PI : rel + 2 * M_PI;
    const Solution aligned = solve(r, pose(q[k].alpha[1] - rel), ws, ko);
    const Solution longway = continueTo(r, aligned, pose(q[k].alpha[1] - rel + other), ws, ko);
    EXPECT_LT((alt.solution.tip_position - longway.tip_position).norm(), 1e-6) << k;
  }
}

// Continuation along a path past the symmetric pose keeps the branch (or snaps); from rest the pose is reached the
// short way: the two rules give different equilibria there, and both are stable.
TEST(Replay, PathAndRestDifferWhereThePathWindsUp) {
  const Robot r = bistablePair();
  Workspace ws;
  std::vector<Configuration> q;
  for (int k = 0; k <= 20; ++k) q.push_back(pose(k * 10 * kDeg));  // 0 .. 200 deg in 10 deg steps
  ReplayOptions path, rest;
  path.branch = BranchRule::Path;
  rest.branch = BranchRule::Rest;
  const std::vector<ReplayRow> a = replay(r, q, ws, path), b = replay(r, q, ws, rest);
  ASSERT_TRUE(b.back().ok) << b.back().message;
  if (a.back().ok) {
    EXPECT_GT((a.back().result.solution.tip_position - b.back().result.solution.tip_position).norm(), 0.05);
    EXPECT_TRUE(a.back().result.solution.summary.stable);
  } else {
    bool snapped = false;
    for (const ReplayRow& row : a) snapped = snapped || row.failure == Failure::Snapped;
    EXPECT_TRUE(snapped) << a.back().message;
  }
}

// A failed row gets its reason and no output; the next row is reached from the last evaluated state, exactly as if
// the failed row were not there.
TEST(Replay, FailedRowIsReportedAndTheNextComesFromTheLastState) {
  const Robot r = bistablePair().withFriction({0.1, 0.0});
  Workspace ws;
  std::vector<Configuration> q, without;
  for (int k = 0; k <= 8; ++k) q.push_back(pose(k * 10 * kDeg));
  Configuration bad = pose(85 * kDeg);
  bad.beta[0] = 0.01;  // beta_1 > 0: inadmissible
  q.insert(q.begin() + 5, bad);
  for (const Configuration& c : q)
    if (c.beta[0] <= 0) without.push_back(c);
  const std::vector<ReplayRow> a = replay(r, q, ws), b = replay(r, without, ws);
  EXPECT_FALSE(a[5].ok);
  EXPECT_EQ(a[5].message.rfind("inadmissible command", 0), 0u) << a[5].message;
  for (std::size_t k = 6; k < a.size(); ++k) {
    ASSERT_TRUE(a[k].ok) << a[k].message;
    EXPECT_LT((a[k].result.solution.tip_position - b[k - 1].result.solution.tip_position).norm(), 1e-12);
  }
}

TEST(Replay, ObserverSeesEveryRowInOrderAndCanEndTheReplay) {
  const Robot r = bistablePair().withFriction({0.1, 0.0});
  Workspace ws;
  std::vector<Configuration> q;
  for (int k = 0; k <= 6; ++k) q.push_back(pose(k * 10 * kDeg));
  const std::vector<ReplayRow> all = replay(r, q, ws);
  std::vector<std::size_t> seen;
  std::vector<Eigen::Vector3d> tips;
  const std::vector<ReplayRow> part = replay(r, q, ws, {}, {}, [&](std::size_t k, ReplayRow& row) {
    seen.push_back(k);
    tips.push_back(row.result.solution.tip_position);
    row.result.solution.backbone.clear();  // the observer may take what it has checked
    return k < 3;
  });
  EXPECT_EQ(seen, (std::vector<std::size_t>{0, 1, 2, 3}));
  ASSERT_EQ(part.size(), 4u);
  // The rows it saw are those of the whole replay, bit for bit.
  for (std::size_t k = 0; k < part.size(); ++k) {
    EXPECT_EQ(part[k].reached, all[k].reached);
    EXPECT_EQ(tips[k], all[k].result.solution.tip_position);
  }
}
