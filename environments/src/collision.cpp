#include "ctr/environments/collision.hpp"

#include <fcl/config.h>
#if !FCL_HAVE_OCTOMAP
#error "ctr_environments needs FCL built with OctoMap support"
#endif
#include <fcl/geometry/octree/octree.h>
#include <fcl/geometry/shape/capsule.h>
#include <fcl/geometry/shape/sphere.h>
#include <fcl/narrowphase/collision.h>
#include <octomap/OcTree.h>

#include <algorithm>
#include <cmath>
#include <mutex>
#include <stdexcept>
#include <vector>

#include "ctr/environments/voxel_grid.hpp"

namespace ctr::environments {

CollisionOptions CollisionOptions::fromEnvironment(const Environment& env) {
  CollisionOptions o;
  o.geometry.safety_margin = env.collisionDefaults().safety_margin;
  o.unknown_space = env.collisionDefaults().unknown_space;
  o.geometry.exclude_proximal = env.collisionDefaults().exclude_proximal;
  return o;
}

struct CollisionChecker::Fcl {
  std::shared_ptr<fcl::OcTree<double>> tree;
};

namespace {
// A parameter interval [t0, t1] of a capsule axis that the distance field could not decide.
struct Run {
  double t0, t1;
};
}  // namespace

struct CollisionChecker::Query::Impl {
  std::vector<Run> runs;
  fcl::Capsule<double> capsule{1e-3, 1e-3};
  fcl::Sphere<double> sphere{1e-3};
  fcl::CollisionRequest<double> request;
  fcl::CollisionResult<double> result;
  Impl() {
    request.num_max_contacts = 1;  // early exit at the first contact
    request.enable_contact = false;
    request.enable_cost = false;
  }
};

namespace {
// Distance fields shared by the checkers built on the same octree with the same region and options (a design search
// builds one checker per candidate robot; the field, by far their most expensive part, depends on the robot only
// through the region). Entries hold weak references: a field lives as long as some checker uses it.
struct FieldEntry {
  std::weak_ptr<const octomap::OcTree> tree;
  Aabb region;
  double max_distance;
  UnknownSpace unknown;
  std::size_t max_cells;
  std::weak_ptr<const DistanceField> field;
};
std::mutex g_fields_mutex;
std::vector<FieldEntry> g_fields;

std::shared_ptr<const DistanceField> sharedField(const std::shared_ptr<const octomap::OcTree>& tree, const Aabb& region,
                                                 const DistanceFieldOptions& fo) {
  std::lock_guard<std::mutex> lock(g_fields_mutex);
  g_fields.erase(std::remove_if(g_fields.begin(), g_fields.end(),
                                [](const FieldEntry& e) { return e.field.expired() || e.tree.expired(); }),
                 g_fields.end());
  for (const FieldEntry& e : g_fields)
    if (e.tree.lock() == tree && e.region.min == region.min && e.region.max == region.max &&
        e.max_distance == fo.max_distance && e.unknown == fo.unknown_space && e.max_cells == fo.max_cells)
      if (auto f = e.field.lock()) return f;
  // Built under the lock: concurrent checkers of the same map wait for one build instead of doing several.
  auto f = std::make_shared<const DistanceField>(*tree, region, fo);
  g_fields.push_back({tree, region, fo.max_distance, fo.unknown_space, fo.max_cells, f});
  return f;
}
}  // namespace

CollisionChecker::Query::Query() : impl_(std::make_unique<Impl>()) {}
CollisionChecker::Query::~Query() = default;
CollisionChecker::Query::Query(Query&&) noexcept = default;
CollisionChecker::Query& CollisionChecker::Query::operator=(Query&&) noexcept = default;

CollisionChecker::CollisionChecker(std::shared_ptr<const Environment> env, Robot robot, CollisionOptions options)
    : env_(std::move(env)), robot_(std::move(robot)), options_(std::move(options)) {
  if (!env_) throw std::invalid_argument("CollisionChecker: null environment");
  if (options_.unknown_space == UnknownSpace::Occupied)
    tree_ = fillUnknown(env_->tree(), env_->bounds());
  else
    tree_ = env_->treePtr();
  // The octree stays owned by a shared_ptr that outlives FCL's (never wrap an object with automatic storage:
  // fcl#602). Thresholds: FCL's "occupied" test equals OctoMap's (log-odds >= the tree's threshold); FCL prunes
  // inner nodes whose (max-of-children) log-odds is <= its free threshold, so that threshold is set just below the
  // occupancy threshold (FCL's default of 0.5 would hide occupied nodes of trees with a threshold < 0.5).
  fcl_ = std::make_unique<Fcl>();
  fcl_->tree = std::make_shared<fcl::OcTree<double>>(tree_);
  const double occ_lo = tree_->getOccupancyThresLog();
  fcl_->tree->setOccupancyThres(octomap::probability(occ_lo));
  fcl_->tree->setFreeThres(octomap::probability(occ_lo - 1e-4));
  fcl_->tree->computeLocalAABB();

  // Longest possible extension beyond s = 0: L_i + the largest admissible beta_i (0, or the translation limit).
  for (int i = 0; i < robot_.size(); ++i) {
    const Tube& t = robot_.tube(i);
    const double beta_max = t.translation_limits ? std::min((*t.translation_limits)[1], 0.0) : 0.0;
    reach_ = std::max(reach_, t.length() + beta_max);
  }
  if (options_.distance_field) {
    Aabb region = options_.field_region;
    if (region.empty()) {
      double rmax = 0.0;
      for (int i = 0; i < robot_.size(); ++i) rmax = std::max(rmax, tubeRadius(robot_, i, options_.geometry));
      const double R = reach_ + options_.max_distance + rmax + 2.0 * env_->resolution();
      const Eigen::Vector3d c = env_->basePose().translation();
      region = Aabb(c.array() - R, c.array() + R);
    }
    region = region.intersection(env_->bounds().inflated(options_.max_distance + env_->resolution()));
    if (!region.empty()) {
      DistanceFieldOptions fo;
      fo.max_distance = options_.max_distance;
      fo.unknown_space = options_.unknown_space;
      fo.max_cells = options_.max_field_cells;
      field_ = sharedField(tree_, region, fo);
    }
  }
}

CollisionChecker::~CollisionChecker() = default;

bool CollisionChecker::capsuleCollidesFcl(const Capsule& c, Query& query) const {
  Query::Impl& q = *query.impl_;
  const Eigen::Vector3d ab = c.b - c.a;
  const double L = ab.norm();
  fcl::Transform3<double> tf = fcl::Transform3<double>::Identity();
  tf.translation() = 0.5 * (c.a + c.b);
  const fcl::CollisionGeometry<double>* shape = nullptr;
  if (L < 1e-12) {
    q.sphere.radius = c.radius;
    q.sphere.computeLocalAABB();
    shape = &q.sphere;
  } else {
    const Eigen::Vector3d z = ab / L;
    Eigen::Vector3d x = std::abs(z.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
    x = (x - x.dot(z) * z).normalized();
    Eigen::Matrix3d R;
    R.col(0) = x;
    R.col(1) = z.cross(x);
    R.col(2) = z;
    tf.linear() = R;
    q.capsule.radius = c.radius;
    q.capsule.lz = L;
    q.capsule.computeLocalAABB();
    shape = &q.capsule;
  }
  q.result.clear();
  fcl::collide(fcl_->tree.get(), fcl::Transform3<double>::Identity(), shape, tf, q.request, q.result);
  return q.result.isCollision();
}

namespace {

// Conservative decisions from the distance field along the capsule axis (sphere tracing). The true distance to the
// anatomy is 1-Lipschitz, so a sample p with margin m = lowerBound(p) - radius >= h / 2 proves every axis point
// closer than m to p free, and the next sample can be m further on. A sample whose cell is occupied proves a
// collision (the capsule contains that axis point). Other samples are undecided and cover [t - h/2, t + h/2] with
// h = half a cell; runs of them become sub-capsules (same radius) for FCL. Proven and undecided parts together
// cover the whole axis.
// Outside the distance field, the distance to the map bounds is a lower bound (the map holds no obstacle beyond
// its bounds) when unknown space is free.
// An undecided sample also proves a collision when the box of its cell's nearest occupied cell reaches into the
// capsule by more than `deep` (a twentieth of a cell, far beyond FCL's tolerance: FCL would report this capsule too).
bool decide(const DistanceField& f, const Aabb* map_bounds, const Capsule& c, std::vector<Run>& runs) {
  runs.clear();
  const Eigen::Vector3d d = c.b - c.a;
  const double L = d.norm();
  const Eigen::Vector3d u = L > 0.0 ? Eigen::Vector3d(d / L) : Eigen::Vector3d::Zero();
  const double h = 0.5 * f.resolution();
  const double deep = c.radius - 0.05 * f.resolution();
  double t = 0.0;
  double run0 = -1.0, run1 = -1.0;  // current undecided run (arc length along the axis)
  while (true) {
    const Eigen::Vector3d p = c.a + u * t;
    double lb = 0.0;
    bool occ = false;
    const bool inside = f.probe(p, lb, occ);
    if (inside && occ) return true;
    double m = inside ? lb - c.radius : -1.0;
    if (!inside && map_bounds != nullptr) m = distance(*map_bounds, p) - c.radius;
    double step;
    if (m >= 0.5 * h) {
      if (run0 >= 0.0) {
        runs.push_back({run0 / std::max(L, 1e-300), std::min(run1, L) / std::max(L, 1e-300)});
        run0 = -1.0;
      }
      step = m;
    } else {
      Eigen::Vector3d o;
      if (inside && deep > 0.0 && f.nearestObstacle(p, o)) {
        const Aabb box(o.array() - h, o.array() + h);  // h: half a cell
        if (distance(box, p) < deep) return true;
      }
      if (run0 < 0.0) run0 = std::max(0.0, t - 0.5 * h);
      run1 = t + 0.5 * h;
      step = h;
    }
    if (t >= L) break;
    t = std::min(L, t + step);
  }
  if (run0 >= 0.0) {
    if (L <= 0.0)
      runs.push_back({0.0, 1.0});
    else
      runs.push_back({run0 / L, std::min(run1, L) / L});
  }
  return false;
}

}  // namespace

CollisionResult CollisionChecker::checkCapsules(const std::vector<Capsule>& capsules, Query& query) const {
  CollisionResult r;
  r.capsules = static_cast<int>(capsules.size());
  const bool unknown_occ = options_.unknown_space == UnknownSpace::Occupied;
  const Aabb& bounds = env_->bounds();
  auto report = [&](const Capsule& c, bool outside) {
    r.collision = true;
    r.section = c.section;
    r.tube = c.tube;
    r.s0 = c.s0;
    r.s1 = c.s1;
    r.outside_map = outside;
    return r;
  };
  std::vector<Run>& runs = query.impl_->runs;
  for (const Capsule& c : capsules) {
    if (unknown_occ) {
      Aabb box;
      box.extend(c.a);
      box.extend(c.b);
      if (!bounds.contains(box.inflated(c.radius))) return report(c, true);
    }
    if (field_ && options_.prefilter) {
      if (decide(*field_, unknown_occ ? nullptr : &bounds, c, runs)) return report(c, false);
      for (const Run& run : runs) {
        Capsule sub = c;
        sub.a = c.a + (c.b - c.a) * run.t0;
        sub.b = c.a + (c.b - c.a) * run.t1;
        ++r.narrowphase_calls;
        if (capsuleCollidesFcl(sub, query)) return report(c, false);
      }
      continue;
    }
    ++r.narrowphase_calls;
    if (capsuleCollidesFcl(c, query)) return report(c, false);
  }
  return r;
}

CollisionResult CollisionChecker::check(const Solution& solution, Query& query) const {
  robotCapsules(robot_, solution, env_->basePose(), options_.geometry, query.capsules_);
  return checkCapsules(query.capsules_, query);
}

ClearanceResult CollisionChecker::clearanceCapsules(const std::vector<Capsule>& capsules) const {
  if (!field_) throw std::logic_error("clearance needs the distance field (CollisionOptions::distance_field)");
  ClearanceResult r;
  const DistanceField& f = *field_;
  const double spacing = 0.5 * f.resolution();
  for (const Capsule& c : capsules) {
    const double L = (c.b - c.a).norm();
    const int n = std::max(1, static_cast<int>(std::ceil(L / spacing)));
    for (int i = 0; i <= n; ++i) {
      const double t = static_cast<double>(i) / n;
      const Eigen::Vector3d p = c.a + (c.b - c.a) * t;
      Eigen::Vector3d obs = Eigen::Vector3d::Zero();
      const double d = f.pointDistance(p, &obs);
      if (d < 0.0) {
        r.complete = false;
        continue;
      }
      const double cl = d - c.radius;
      if (cl < r.clearance) {
        r.clearance = cl;
        r.section = c.section;
        r.tube = c.tube;
        r.s = c.s0 + t * (c.s1 - c.s0);
        r.robot_point = p;
        r.saturated = d >= f.maxDistance();
        r.obstacle_point = r.saturated ? p : obs;
      }
    }
  }
  return r;
}

ClearanceResult CollisionChecker::clearance(const Solution& solution, Query& query) const {
  robotCapsules(robot_, solution, env_->basePose(), options_.geometry, query.capsules_);
  return clearanceCapsules(query.capsules_);
}

}  // namespace ctr::environments
