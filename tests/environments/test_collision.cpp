// Collision (FCL + distance-field pre-filter) and clearance (dynamicEDT3D) against brute force on small scenes:
// no false "free" ever; false "collision" only within one voxel of contact; clearance within a voxel.
#include <gtest/gtest.h>
#include <octomap/OcTree.h>

#include <random>
#include <thread>

#include "ctr/environments/collision.hpp"
#include "ctr/environments/voxel_grid.hpp"
#include "ctr/model/kinematics.hpp"
#include "env_test_util.hpp"

namespace ctr::environments {
namespace {

constexpr double kRes = 0.001;

// A 40 mm cube with random balls and scattered single voxels (occupied), free elsewhere.
std::shared_ptr<const Environment> randomScene(unsigned seed, bool mark_free = true) {
  const Aabb region(Eigen::Vector3d::Constant(-0.0199), Eigen::Vector3d::Constant(0.0199));
  VoxelGrid g(kRes, region);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-0.02, 0.02), rr(0.001, 0.004);
  std::vector<std::pair<Eigen::Vector3d, double>> balls;
  for (int b = 0; b < 14; ++b) balls.emplace_back(Eigen::Vector3d(u(rng), u(rng), u(rng)), rr(rng));
  for (int k = 0; k < g.dims().z(); ++k)
    for (int j = 0; j < g.dims().y(); ++j)
      for (int i = 0; i < g.dims().x(); ++i) {
        const Eigen::Vector3d c = g.centre(i, j, k);
        for (const auto& b : balls)
          if ((c - b.first).norm() < b.second) g.set(i, j, k, VoxelGrid::kOccupied);
      }
  for (int s = 0; s < 60; ++s) {
    const Eigen::Vector3d p(u(rng), u(rng), u(rng));
    g.fillBox(Aabb(p, p), VoxelGrid::kOccupied);
  }
  return std::make_shared<const Environment>("random", gridToOcTree(g, mark_free), g.bounds());
}

Robot straightRobot(double od = 1e-3) {
  Tube t;
  t.name = "t";
  t.straight_length = 0.05;
  t.bending_stiffness = 1.0;
  t.torsional_stiffness = 1.0;
  t.outer_diameter = od;
  return Robot("straight", {t});
}

Capsule randomCapsule(std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-0.018, 0.018), len(0.0, 0.015), rad(0.0002, 0.002);
  Capsule c;
  c.a = Eigen::Vector3d(u(rng), u(rng), u(rng));
  c.b = c.a + Eigen::Vector3d::Random().normalized() * len(rng);
  c.radius = rad(rng);
  return c;
}

TEST(Collision, CapsulesAgainstBruteForce) {
#ifdef CTR_SANITIZED
  const int capsules = 300;  // the brute-force reference is ~100x slower under ASan; the Release run keeps 1,500
#else
  const int capsules = 1500;
#endif
  for (unsigned seed : {1u, 2u}) {
    auto env = randomScene(seed);
    CollisionOptions opt;
    opt.field_region = env->bounds();
    CollisionChecker checker(env, straightRobot(), opt);
    CollisionOptions nofield = opt;
    nofield.distance_field = false;
    CollisionChecker fcl_only(env, straightRobot(), nofield);
    auto q = checker.query();
    auto q2 = fcl_only.query();
    const auto boxes = test::occupiedBoxes(env->tree());
    ASSERT_GT(boxes.size(), 500u);
    std::mt19937 rng(seed + 10);
    const double step = kRes / 20;
    int colliding = 0, free = 0, false_collision = 0, fcl_calls = 0;
    for (int n = 0; n < capsules; ++n) {
      const Capsule c = randomCapsule(rng);
      const double truth = test::bruteClearance(c, boxes, step);  // exact to step / 2
      const CollisionResult r = checker.checkCapsules({c}, q);
      const bool f = fcl_only.capsuleCollidesFcl(c, q2);
      fcl_calls += r.narrowphase_calls;
      if (truth < -step) {
        ++colliding;
        EXPECT_TRUE(r.collision) << "false free (pre-filter path), brute clearance " << truth;
        EXPECT_TRUE(f) << "false free (FCL), brute clearance " << truth;
      } else if (truth > step) {
        ++free;
        if (r.collision) ++false_collision;
        EXPECT_TRUE(!r.collision || truth <= kRes) << "collision reported " << truth << " m from contact";
        EXPECT_TRUE(!f || truth <= kRes) << "FCL collision reported " << truth << " m from contact";
      }
    }
    EXPECT_GT(colliding, capsules * 2 / 15);
    EXPECT_GT(free, capsules * 2 / 15);
    EXPECT_LT(fcl_calls, capsules);  // the distance field decided part of the capsules
    RecordProperty("false_collisions_seed" + std::to_string(seed), false_collision);
  }
}

TEST(Clearance, DistanceFieldAgainstBruteForce) {
  auto env = randomScene(3);
  DistanceFieldOptions fo;
  fo.max_distance = 0.008;
  DistanceField field(env->tree(), env->bounds(), fo);
  const auto boxes = test::occupiedBoxes(env->tree());
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> u(-0.0195, 0.0195);
  int violations = 0;
  for (int n = 0; n < 3000; ++n) {
    const Eigen::Vector3d p(u(rng), u(rng), u(rng));
    double truth = std::numeric_limits<double>::infinity();
    for (const Aabb& b : boxes) truth = std::min(truth, distance(b, p));
    const double lb = field.lowerBound(p);
    ASSERT_GE(lb, 0.0);
    if (lb > truth + 1e-12) ++violations;
    const double d = field.pointDistance(p);
    if (truth < fo.max_distance - 2 * kRes) {
      EXPECT_NEAR(d, truth, std::sqrt(3.0) * kRes) << p.transpose();
      EXPECT_GE(d, truth - 1e-12);  // the distance to a real obstacle box is never below the true minimum
    } else {
      EXPECT_GE(d, fo.max_distance - 2 * std::sqrt(3.0) * kRes);
    }
    EXPECT_EQ(field.occupied(p), env->occupancy(p) == Occupancy::Occupied);
  }
  EXPECT_EQ(violations, 0);
  EXPECT_LT(field.pointDistance(Eigen::Vector3d(1, 1, 1)), 0.0);  // outside the field
}

TEST(Clearance, CapsulesAgainstBruteForce) {
  auto env = randomScene(5);
  CollisionOptions opt;
  opt.field_region = env->bounds();
  opt.max_distance = 0.008;
  CollisionChecker checker(env, straightRobot(), opt);
  const auto boxes = test::occupiedBoxes(env->tree());
  std::mt19937 rng(6);
  for (int n = 0; n < 400; ++n) {
    const Capsule c = randomCapsule(rng);
    const double truth = test::bruteClearance(c, boxes, kRes / 20);
    const ClearanceResult r = checker.clearanceCapsules({c});
    if (truth + c.radius < opt.max_distance - 2 * kRes) {
      EXPECT_NEAR(r.clearance, truth, std::sqrt(3.0) * kRes + kRes / 4) << n;
      EXPECT_FALSE(r.saturated);
    } else {
      EXPECT_GE(r.clearance, opt.max_distance - c.radius - 2 * std::sqrt(3.0) * kRes);
    }
    // A shape in contact has (nearly) non-positive clearance, a clear one positive clearance.
    if (truth < -kRes) {
      EXPECT_LE(r.clearance, 0.0);
    }
  }
}

Robot threeTubes() {
  auto tube = [](const char* n, double ls, double lc, double k, double ei, double od, double id) {
    Tube t;
    t.name = n;
    t.straight_length = ls;
    t.curved_length = lc;
    t.curvature = k;
    t.bending_stiffness = ei;
    t.torsional_stiffness = ei / 1.3;
    t.outer_diameter = od;
    t.inner_diameter = id;
    return t;
  };
  return Robot("three", {tube("outer", 0.02, 0.02, 10, 0.03, 2.0e-3, 1.6e-3),
                         tube("middle", 0.03, 0.02, 20, 0.01, 1.4e-3, 1.0e-3),
                         tube("inner", 0.04, 0.02, 40, 0.002, 0.8e-3, 0.5e-3)});
}

TEST(RobotGeometry, CapsulesContainTheBackboneAndSkipTheActuationUnit) {
  const Robot robot = threeTubes();
  Workspace ws;
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> a(-3, 3), f(0, 1);
  for (int n = 0; n < 40; ++n) {
    Configuration q = Configuration::zeros(3);
    q.alpha << a(rng), a(rng), a(rng);
    q.beta[0] = -0.02 * f(rng);
    q.beta[1] = q.beta[0] - 0.01 * f(rng);
    q.beta[2] = q.beta[1] - 0.01 * f(rng);
    if (!checkAdmissible(robot, q)) continue;
    const Solution sol = solve(robot, q, ws);
    ASSERT_TRUE(sol.converged());
    RobotGeometryOptions go;
    go.safety_margin = 1e-4;
    std::vector<Capsule> caps;
    std::vector<Section> sections;
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.translation() = Eigen::Vector3d(0.1, 0.2, 0.3);
    T.linear() = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 1, 0).normalized()).toRotationMatrix();
    robotCapsules(robot, sol, T, go, caps, &sections);
    ASSERT_FALSE(caps.empty());
    EXPECT_GE(caps.front().s0, 0.0);
    EXPECT_NEAR(caps.back().s1, sol.tipArcLength(), 1e-12);
    // Sections in order, one tube each, outermost first; every capsule at least its tube's radius + margin.
    for (std::size_t k = 1; k < sections.size(); ++k) EXPECT_GT(sections[k].tube, sections[k - 1].tube);
    for (const auto& c : caps) EXPECT_GE(c.radius, tubeRadius(robot, c.tube, go) - 1e-15);
    // Every point of the converged backbone (0.1 mm steps) at s >= 0 is within (capsule radius - tube radius) of the
    // axis of a capsule of its section: the chain contains the swept tube. Allowance: the default solve's own error at
    // its nodes (below 2e-9 m here, checked at the tip).
    KinematicsOptions fine;
    fine.max_step = 1e-4;
    fine.max_bending_per_step = 0.002;
    const Solution ref = solve(robot, q, ws, fine);
    ASSERT_TRUE(ref.converged());
    EXPECT_LT((ref.tip_position - sol.tip_position).norm(), 2e-9);
    for (const BackbonePoint& bp : ref.backbone) {
      if (bp.s < 0.0) continue;
      const Eigen::Vector3d p = T * bp.position;
      double best = 1e9;
      for (const auto& c : caps)
        if (bp.s >= c.s0 - 1e-4 && bp.s <= c.s1 + 1e-4)
          best = std::min(best,
                          (p - closestPointOnSegment(c.a, c.b, p)).norm() - (c.radius - tubeRadius(robot, c.tube, go)));
      EXPECT_LE(best, 2e-9) << "s = " << bp.s;
    }
    // Excluding the proximal part.
    go.exclude_proximal = 0.005;
    robotCapsules(robot, sol, T, go, caps);
    if (!caps.empty()) {
      EXPECT_GE(caps.front().s0, 0.005 - 1e-12);
    }
  }
}

TEST(Collision, RobotShapeAgainstBruteForce) {
  auto scene = randomScene(9);
  const Robot robot = threeTubes();
  Workspace ws;
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> a(-3, 3), f(0, 1), u(-0.015, 0.015);
  const auto boxes = test::occupiedBoxes(scene->tree());
  int hits = 0, clear = 0;
  for (int n = 0; n < 60; ++n) {
    Environment e = *scene;
    e.setBasePose(poseFromDirection(Eigen::Vector3d(u(rng), u(rng), -0.019), Eigen::Vector3d(u(rng), u(rng), 0.03)));
    auto env = std::make_shared<const Environment>(e);
    CollisionChecker checker(env, robot);
    auto q = checker.query();
    Configuration c = Configuration::zeros(3);
    c.alpha << a(rng), a(rng), a(rng);
    c.beta[0] = -0.02 * f(rng);
    c.beta[1] = c.beta[0] - 0.01 * f(rng);
    c.beta[2] = c.beta[1] - 0.01 * f(rng);
    if (!checkAdmissible(robot, c)) continue;
    const Solution sol = solve(robot, c, ws);
    ASSERT_TRUE(sol.converged());
    const CollisionResult r = checker.check(sol, q);
    double truth = std::numeric_limits<double>::infinity();
    int first = -1;
    for (const auto& cap : q.capsules()) {
      const double d = test::bruteClearance(cap, boxes, kRes / 20);
      truth = std::min(truth, d);
      if (first < 0 && d < -kRes / 20) first = cap.section;
    }
    if (truth < -kRes / 20) {
      ++hits;
      EXPECT_TRUE(r.collision);
      EXPECT_LE(r.section, first);  // first colliding section (up to one voxel of tolerance it can be earlier)
    } else if (r.collision) {
      EXPECT_LE(truth, kRes);
    } else {
      ++clear;
    }
    if (!r.collision) {
      const ClearanceResult cl = checker.clearance(sol, q);
      if (cl.complete && !cl.saturated) {
        EXPECT_NEAR(cl.clearance, truth, std::sqrt(3.0) * kRes + kRes / 4);
      }
    }
  }
  EXPECT_GT(hits, 5);
  EXPECT_GT(clear, 5);
}

TEST(Collision, UnknownSpaceAndBounds) {
  auto env = randomScene(12, /*mark_free=*/false);  // only occupied cells are known
  Capsule c;                                        // in the middle of the map, away from obstacles?
  c.a = Eigen::Vector3d(0.0, 0.0, 0.0);
  c.b = c.a;
  c.radius = 1e-4;
  const bool occupied_here = env->occupancy(c.a) == Occupancy::Occupied;
  CollisionOptions free_opt;
  free_opt.field_region = env->bounds();
  CollisionOptions occ_opt = free_opt;
  occ_opt.unknown_space = UnknownSpace::Occupied;
  CollisionChecker free_checker(env, straightRobot(), free_opt), occ_checker(env, straightRobot(), occ_opt);
  auto q = free_checker.query();
  EXPECT_EQ(free_checker.checkCapsules({c}, q).collision, occupied_here);
  EXPECT_TRUE(occ_checker.checkCapsules({c}, q).collision);  // unknown or occupied: an obstacle either way
  // Leaving the map: free with unknown = free, a collision "outside the map" otherwise.
  Capsule out;
  out.a = Eigen::Vector3d(0.0, 0.0, 0.019);
  out.b = Eigen::Vector3d(0.0, 0.0, 0.05);
  out.radius = 1e-4;
  const CollisionResult r = occ_checker.checkCapsules({out}, q);
  EXPECT_TRUE(r.collision);
  EXPECT_TRUE(r.outside_map);
}

TEST(Collision, RespectsTheOccupancyThreshold) {
  // Leaves below 0.5 that OctoMap counts as occupied (threshold 0.3): FCL's default free threshold would prune them.
  for (double thres : {0.3, 0.7}) {
    auto tree = std::make_shared<octomap::OcTree>(0.001);
    tree->setOccupancyThres(thres);
    const float lo = octomap::logodds(0.4);
    for (int i = 0; i < 5; ++i) tree->setNodeValue(0.0005 + 0.001 * i, 0.0005, 0.0005, lo);
    tree->setNodeValue(-0.0105, -0.0105, -0.0105, octomap::logodds(0.1));  // free
    tree->updateInnerOccupancy();
    auto env = std::make_shared<const Environment>("thr", tree);
    for (bool field : {false, true}) {
      CollisionOptions o;
      o.distance_field = field;
      o.field_region = Aabb(Eigen::Vector3d::Constant(-0.02), Eigen::Vector3d::Constant(0.02));
      CollisionChecker checker(env, straightRobot(), o);
      auto q = checker.query();
      Capsule c;
      c.a = Eigen::Vector3d(0.002, 0.0005, 0.0005);
      c.b = c.a + Eigen::Vector3d(0, 0, 0.001);
      c.radius = 2e-4;
      EXPECT_EQ(checker.checkCapsules({c}, q).collision, thres < 0.4) << "threshold " << thres << " field " << field;
    }
  }
}

TEST(Collision, ThreadsShareOneChecker) {
  auto env = randomScene(13);
  CollisionOptions opt;
  opt.field_region = env->bounds();
  const CollisionChecker checker(env, straightRobot(), opt);
  std::vector<Capsule> caps;
  std::mt19937 rng(14);
  for (int i = 0; i < 400; ++i) caps.push_back(randomCapsule(rng));
  std::vector<int> expected(caps.size());
  {
    auto q = checker.query();
    for (std::size_t i = 0; i < caps.size(); ++i) expected[i] = checker.checkCapsules({caps[i]}, q).collision;
  }
  std::vector<int> got1(caps.size()), got2(caps.size());
  auto run = [&](std::vector<int>& out) {
    auto q = checker.query();
    for (int rep = 0; rep < 3; ++rep)
      for (std::size_t i = 0; i < caps.size(); ++i) out[i] = checker.checkCapsules({caps[i]}, q).collision;
  };
  std::thread t1(run, std::ref(got1)), t2(run, std::ref(got2));
  t1.join();
  t2.join();
  EXPECT_EQ(got1, expected);
  EXPECT_EQ(got2, expected);
}

}  // namespace
}  // namespace ctr::environments
