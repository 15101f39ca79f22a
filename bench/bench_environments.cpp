// Benchmarks of ctr_environments: building a Med-MPD lung from its NIfTI at 1 mm, collision and clearance of full
// 3-tube shapes against it, the distance field, and the procedural intracardiac demo.
//
// Per-check statistics (median, p90 in microseconds) are reported as counters: each benchmark iteration checks one
// shape of a fixed set of random admissible configurations, and the individual call times are kept.
#include <benchmark/benchmark.h>
#include <octomap/OcTree.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <memory>
#include <random>

#include "ctr/environments/collision.hpp"
#include "ctr/environments/environment_yaml.hpp"
#include "ctr/io/data.hpp"
#include "ctr/io/robot_yaml.hpp"
#include "ctr/model/kinematics.hpp"

namespace {

using namespace ctr;
using Clock = std::chrono::steady_clock;

const std::string kExamples = std::string(CTR_SOURCE_DIR) + "/examples";
const std::string kLung = kExamples + "/environments/medmpd_lung_patient1.yaml";
const std::string kHeart = kExamples + "/environments/proc_intracardiac.yaml";

const std::string kLungData = "${CTR_DATA}/med-mpd/Lungs/Patient1/vessels.nii.gz";

bool haveLung() {
  return std::filesystem::exists(io::expandDataPath(kLungData));
}

struct Scene {
  std::shared_ptr<const environments::Environment> env;
  std::unique_ptr<Robot> robot;
  std::unique_ptr<environments::CollisionChecker> checker;
  std::vector<Solution> shapes;
  double checker_seconds = 0.0;
};

// Random admissible configurations (within the translation limits), solved with the backbone recorded.
std::vector<Solution> randomShapes(const Robot& robot, int count, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  Workspace ws;
  std::vector<Solution> out;
  while (static_cast<int>(out.size()) < count) {
    Configuration q = Configuration::zeros(robot.size());
    for (int i = 0; i < robot.size(); ++i) {
      const Tube& t = robot.tube(i);
      double lo = -t.length(), hi = 0.0;
      if (t.translation_limits) {
        lo = std::max(lo, (*t.translation_limits)[0]);
        hi = (*t.translation_limits)[1];
      }
      q.alpha[i] = (2.0 * u(rng) - 1.0) * M_PI;
      q.beta[i] = lo + u(rng) * (hi - lo);
    }
    if (!checkAdmissible(robot, q)) continue;
    Solution s = solve(robot, q, ws);
    if (s.converged()) out.push_back(std::move(s));
  }
  return out;
}

Scene& lungScene() {
  static Scene scene = [] {
    Scene s;
    environments::Environment e = environments::loadEnvironment(kLung);
    e.useStart("start3");  // a start pose with room around it (see docs/environments.md)
    s.env = std::make_shared<const environments::Environment>(std::move(e));
    s.robot = std::make_unique<Robot>(io::loadRobot(kExamples + "/robots/medmpd_lung.yaml"));
    const auto t0 = Clock::now();
    s.checker = std::make_unique<environments::CollisionChecker>(
        s.env, *s.robot, environments::CollisionOptions::fromEnvironment(*s.env));
    s.checker_seconds = std::chrono::duration<double>(Clock::now() - t0).count();
    s.shapes = randomShapes(*s.robot, 500, 1);
    return s;
  }();
  return scene;
}

Scene& heartScene() {
  static Scene scene = [] {
    Scene s;
    s.env = std::make_shared<const environments::Environment>(environments::loadEnvironment(kHeart));
    s.robot = std::make_unique<Robot>(io::loadRobot(kExamples + "/robots/proc_intracardiac.yaml"));
    const auto t0 = Clock::now();
    s.checker = std::make_unique<environments::CollisionChecker>(
        s.env, *s.robot, environments::CollisionOptions::fromEnvironment(*s.env));
    s.checker_seconds = std::chrono::duration<double>(Clock::now() - t0).count();
    s.shapes = randomShapes(*s.robot, 500, 2);
    return s;
  }();
  return scene;
}

void reportTimes(benchmark::State& state, std::vector<double>& us) {
  if (us.empty()) return;
  std::sort(us.begin(), us.end());
  state.counters["median_us"] = us[us.size() / 2];
  state.counters["p90_us"] = us[us.size() * 9 / 10];
}

// Collision of full 3-tube shapes (random admissible configurations) vs the Med-MPD lung at 1 mm.
void BM_LungCollision(benchmark::State& state, bool prefilter) {
  if (!haveLung()) {
    state.SkipWithError(io::missingDataMessage(kLungData).c_str());
    return;
  }
  Scene& s = lungScene();
  environments::CollisionOptions opt = s.checker->options();
  std::unique_ptr<environments::CollisionChecker> own;
  const environments::CollisionChecker* checker = s.checker.get();
  if (!prefilter) {
    opt.distance_field = false;
    own = std::make_unique<environments::CollisionChecker>(s.env, *s.robot, opt);
    checker = own.get();
  }
  auto q = checker->query();
  std::vector<double> us;
  std::size_t i = 0, collisions = 0, calls = 0;
  for (auto _ : state) {
    const Solution& sol = s.shapes[i++ % s.shapes.size()];
    const auto t0 = Clock::now();
    const environments::CollisionResult r = checker->check(sol, q);
    us.push_back(std::chrono::duration<double, std::micro>(Clock::now() - t0).count());
    benchmark::DoNotOptimize(r.collision);
    collisions += r.collision;
    calls += static_cast<std::size_t>(r.narrowphase_calls);
  }
  reportTimes(state, us);
  state.counters["colliding_fraction"] = static_cast<double>(collisions) / static_cast<double>(state.iterations());
  state.counters["fcl_calls"] = static_cast<double>(calls) / static_cast<double>(state.iterations());
}
BENCHMARK_CAPTURE(BM_LungCollision, fcl_with_prefilter, true)->Unit(benchmark::kMicrosecond)->Iterations(5000);
BENCHMARK_CAPTURE(BM_LungCollision, fcl_only, false)->Unit(benchmark::kMicrosecond)->Iterations(5000);

// Collision-free shapes only (every capsule has to be cleared, no early exit).
void BM_LungCollisionFreeShapes(benchmark::State& state) {
  if (!haveLung()) {
    state.SkipWithError(io::missingDataMessage(kLungData).c_str());
    return;
  }
  Scene& s = lungScene();
  auto q = s.checker->query();
  std::vector<const Solution*> free_shapes;
  for (const auto& sol : s.shapes)
    if (!s.checker->check(sol, q).collision) free_shapes.push_back(&sol);
  std::vector<double> us;
  std::size_t i = 0;
  for (auto _ : state) {
    const Solution& sol = *free_shapes[i++ % free_shapes.size()];
    const auto t0 = Clock::now();
    benchmark::DoNotOptimize(s.checker->check(sol, q).collision);
    us.push_back(std::chrono::duration<double, std::micro>(Clock::now() - t0).count());
  }
  reportTimes(state, us);
  state.counters["shapes"] = static_cast<double>(free_shapes.size());
}
BENCHMARK(BM_LungCollisionFreeShapes)->Unit(benchmark::kMicrosecond)->Iterations(5000);

void BM_LungClearance(benchmark::State& state) {
  if (!haveLung()) {
    state.SkipWithError(io::missingDataMessage(kLungData).c_str());
    return;
  }
  Scene& s = lungScene();
  auto q = s.checker->query();
  std::vector<double> us;
  std::size_t i = 0;
  for (auto _ : state) {
    const Solution& sol = s.shapes[i++ % s.shapes.size()];
    const auto t0 = Clock::now();
    benchmark::DoNotOptimize(s.checker->clearance(sol, q).clearance);
    us.push_back(std::chrono::duration<double, std::micro>(Clock::now() - t0).count());
  }
  reportTimes(state, us);
}
BENCHMARK(BM_LungClearance)->Unit(benchmark::kMicrosecond)->Iterations(5000);

// Environment build from the lung NIfTI at 1 mm (read + decompress, select, rasterise, octree).
void BM_LungBuild1mm(benchmark::State& state) {
  if (!haveLung()) {
    state.SkipWithError(io::missingDataMessage(kLungData).c_str());
    return;
  }
  for (auto _ : state) {
    const environments::Environment e = environments::loadEnvironment(kLung);
    benchmark::DoNotOptimize(e.tree().size());
    state.counters["nodes"] = static_cast<double>(e.tree().size());
  }
}
BENCHMARK(BM_LungBuild1mm)->Unit(benchmark::kMillisecond)->Iterations(3);

// Collision checker construction for the lung (FCL octree + distance field over the robot's reach).
void BM_LungCheckerBuild(benchmark::State& state) {
  if (!haveLung()) {
    state.SkipWithError(io::missingDataMessage(kLungData).c_str());
    return;
  }
  Scene& s = lungScene();
  for (auto _ : state) {
    environments::CollisionChecker c(s.env, *s.robot, environments::CollisionOptions::fromEnvironment(*s.env));
    state.counters["field_cells"] = static_cast<double>(c.distanceField()->cells());
  }
}
BENCHMARK(BM_LungCheckerBuild)->Unit(benchmark::kMillisecond)->Iterations(2);

void BM_IntracardiacBuild(benchmark::State& state) {
  for (auto _ : state) {
    const environments::Environment e = environments::loadEnvironment(kHeart);
    benchmark::DoNotOptimize(e.tree().size());
  }
}
BENCHMARK(BM_IntracardiacBuild)->Unit(benchmark::kMillisecond)->Iterations(10);

void BM_IntracardiacChecker(benchmark::State& state) {
  auto e = std::make_shared<const environments::Environment>(environments::loadEnvironment(kHeart));
  const Robot robot = io::loadRobot(kExamples + "/robots/proc_intracardiac.yaml");
  for (auto _ : state) {
    environments::CollisionChecker c(e, robot, environments::CollisionOptions::fromEnvironment(*e));
    benchmark::DoNotOptimize(c.distanceField());
  }
}
BENCHMARK(BM_IntracardiacChecker)->Unit(benchmark::kMillisecond)->Iterations(5);

void BM_IntracardiacCollisionAndClearance(benchmark::State& state) {
  Scene& s = heartScene();
  auto q = s.checker->query();
  std::vector<double> us;
  std::size_t i = 0;
  for (auto _ : state) {
    const Solution& sol = s.shapes[i++ % s.shapes.size()];
    const auto t0 = Clock::now();
    benchmark::DoNotOptimize(s.checker->check(sol, q).collision);
    benchmark::DoNotOptimize(s.checker->clearance(sol, q).clearance);
    us.push_back(std::chrono::duration<double, std::micro>(Clock::now() - t0).count());
  }
  reportTimes(state, us);
}
BENCHMARK(BM_IntracardiacCollisionAndClearance)->Unit(benchmark::kMicrosecond)->Iterations(5000);

}  // namespace
