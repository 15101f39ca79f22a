// Planner benchmarks in a Med-MPD lung (patient 1, 1 mm map): frictionless validity checks (cold and along a
// motion) and friction-aware quasi-static motion steps (stick-slip step + collision check), 3-tube lung robot.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <filesystem>

#include "ctr/environments/environment_yaml.hpp"
#include "ctr/io/data.hpp"
#include "ctr/io/robot_yaml.hpp"
#include "ctr/planner/goal.hpp"
#include "ctr/planner/planner.hpp"

namespace {

using namespace ctr;

// The planning context of Med-MPD lung patient `patient` with the lung robot (null without Med-MPD in the data folder).
std::shared_ptr<const planner::Context> makeLungContext(int patient) {
  const std::string envf =
      std::string(CTR_SOURCE_DIR) + "/examples/environments/medmpd_lung_patient" + std::to_string(patient) + ".yaml";
  if (!std::filesystem::exists(io::expandDataPath("${CTR_DATA}/med-mpd"))) return nullptr;
  auto env = std::make_shared<const environments::Environment>(environments::loadEnvironment(envf));
  Robot r = io::loadRobot(std::string(CTR_SOURCE_DIR) + "/examples/robots/medmpd_lung.yaml").withFriction({0.1, 0.0});
  planner::ContextOptions co;
  co.friction.kinematics.record_backbone = true;
  return std::make_shared<const planner::Context>(r, env, co, environments::CollisionOptions::fromEnvironment(*env));
}

std::shared_ptr<const planner::Context> lungContext() {
  static std::shared_ptr<const planner::Context> ctx = makeLungContext(1);
  return ctx;
}

// Checks per second and the fraction of them that were valid.
void reportValidity(benchmark::State& st, std::size_t valid) {
  st.counters["checks/s"] = benchmark::Counter(static_cast<double>(st.iterations()), benchmark::Counter::kIsRate);
  st.counters["valid_fraction"] = static_cast<double>(valid) / static_cast<double>(st.iterations());
}

void BM_ValidityCold(benchmark::State& st) {
  auto ctx = lungContext();
  if (!ctx) return st.SkipWithError(io::missingDataMessage("${CTR_DATA}/med-mpd").c_str());
  std::mt19937_64 g(1);
  std::vector<Configuration> qs;
  for (int k = 0; k < 512; ++k) qs.push_back(sampleConfiguration(ctx->robot(), ctx->translationSampler(), g));
  std::size_t k = 0, valid = 0;
  for (auto _ : st) valid += planner::checkFrictionless(*ctx, qs[k++ % qs.size()], planner::scratch()).ok;
  reportValidity(st, valid);
}

void BM_ValidityAlongMotion(benchmark::State& st) {
  auto ctx = lungContext();
  if (!ctx) return st.SkipWithError(io::missingDataMessage("${CTR_DATA}/med-mpd").c_str());
  std::mt19937_64 g(2);
  Configuration q = sampleConfiguration(ctx->robot(), ctx->translationSampler(), g);
  planner::ConfigurationCheck prev = planner::checkFrictionless(*ctx, q, planner::scratch());
  int k = 0;
  std::size_t valid = 0;
  for (auto _ : st) {
    const int i = k % q.size();
    q.alpha[i] += ((k / 200) % 2 ? -1 : 1) * 0.0087;  // 0.5 deg steps, as the motion validator
    ++k;
    prev = planner::checkFrictionless(*ctx, q, planner::scratch(), prev.shape.converged() ? &prev.shape : nullptr);
    valid += prev.ok;
  }
  reportValidity(st, valid);
}

// The same along a path the planner found (the motion above starts from a random configuration of lung 1, which
// collides at the first capsules: it measures the model and the first capsules only). Lung patient 2: the path
// RRT-Connect found in frictionless mode (`ctr plan examples/queries/medmpd_lung_patient2.yaml --mode frictionless
// --planner rrtconnect --seed 1`, simplified by OMPL to a straight line from the query's start to the goal
// configuration below), at 0.5 deg / 0.5 mm, checked forth and back, each check warm-started from the previous shape;
// every shape is collision-free, so the whole capsule chain is checked.
void BM_ValidityAlongPlannedPath(benchmark::State& st) {
  static std::shared_ptr<const planner::Context> ctx_holder = makeLungContext(2);
  if (!ctx_holder) return st.SkipWithError(io::missingDataMessage("${CTR_DATA}/med-mpd").c_str());
  const planner::Context& ctx = *ctx_holder;
  const Configuration a(Eigen::Vector3d(0.0, 0.0, 0.0), Eigen::Vector3d(-0.118, -0.218, -0.318));
  const Configuration b(Eigen::Vector3d(-0.537556, -1.836102, -2.506250),
                        Eigen::Vector3d(-0.096936, -0.150559, -0.250559));
  const double n = std::max(std::ceil((b.alpha - a.alpha).cwiseAbs().maxCoeff() / 0.0087),
                            std::ceil((b.beta - a.beta).cwiseAbs().maxCoeff() / 0.0005));
  std::vector<Configuration> qs;
  for (int k = 0; k <= static_cast<int>(n); ++k) {
    const double t = k / n;
    qs.emplace_back((1 - t) * a.alpha + t * b.alpha, (1 - t) * a.beta + t * b.beta);
  }
  planner::ConfigurationCheck prev = planner::checkFrictionless(ctx, qs[0], planner::scratch());
  std::size_t k = 0, valid = 0;
  const std::size_t period = 2 * (qs.size() - 1);
  for (auto _ : st) {
    const std::size_t j = k % period;
    const Configuration& q = qs[j < qs.size() ? j : period - j];
    ++k;
    prev = planner::checkFrictionless(ctx, q, planner::scratch(), prev.shape.converged() ? &prev.shape : nullptr);
    valid += prev.ok;
  }
  reportValidity(st, valid);
  st.counters["path_checks"] = static_cast<double>(qs.size());
}

void BM_FrictionMotionStep(benchmark::State& st) {
  auto ctx = lungContext();
  if (!ctx) return st.SkipWithError(io::missingDataMessage("${CTR_DATA}/med-mpd").c_str());
  const Configuration q0(Eigen::Vector3d(0.0, 0.5, -0.5), Eigen::Vector3d(-0.118, -0.218, -0.318));
  const std::shared_ptr<const planner::StateCache> start = planner::startCache(*ctx, q0, planner::StartHistory{});
  if (!start->physics_ok) return st.SkipWithError(("start not valid: " + start->message).c_str());
  std::shared_ptr<const planner::StateCache> cur = start;
  int k = 0;
  for (auto _ : st) {
    if (!cur->physics_ok) cur = start;
    Configuration q = cur->hysteresis.q;
    q.alpha[1] += ((k++ / 100) % 2 ? -1 : 1) * 0.0087;  // one 0.5 deg quasi-static step with collision check
    cur = planner::propagateCache(*ctx, *cur, q);
    benchmark::DoNotOptimize(planner::checkShape(*ctx, cur->solution, planner::scratch()).ok);
  }
  st.counters["steps/s"] = benchmark::Counter(static_cast<double>(st.iterations()), benchmark::Counter::kIsRate);
}

// Goal-pool inverse kinematics (damped least squares on the frictionless model): from a random admissible start to
// the tip of another random configuration (reachable targets), 40 iterations at most.
void BM_InverseKinematics(benchmark::State& st) {
  auto ctx = lungContext();
  if (!ctx) return st.SkipWithError(io::missingDataMessage("${CTR_DATA}/med-mpd").c_str());
  std::mt19937_64 g(4);
  Workspace ws;
  std::vector<std::pair<Configuration, Eigen::Vector3d>> cases;
  while (cases.size() < 64) {
    const Configuration target = sampleConfiguration(ctx->robot(), ctx->translationSampler(), g);
    const Solution s = solve(ctx->frictionlessRobot(), target, ws, ctx->options().friction.kinematics);
    if (!s.converged()) continue;
    cases.emplace_back(sampleConfiguration(ctx->robot(), ctx->translationSampler(), g),
                       ctx->basePose() * s.tip_position);
  }
  std::size_t k = 0, reached = 0;
  for (auto _ : st) {
    const auto& c = cases[k++ % cases.size()];
    Configuration q = c.first;
    reached += planner::inverseKinematics(*ctx, c.second, q, static_cast<int>(st.range(0))) < 1e-4;
  }
  st.counters["reached_fraction"] = static_cast<double>(reached) / static_cast<double>(st.iterations());
}

// Robust validity (every shape of the friction band of every robust corner, solved cold) along a planned motion of
// lung 2 (the motion of BM_ValidityAlongPlannedPath, 64 configurations): without ranges (one band), with a play range
// on tube 2's rotation (two corners), and with play ranges on tubes 2 and 3 (four corners); friction mu' in
// [0.05, 0.1] in the last two (0.1 without ranges).
void BM_RobustValidity(benchmark::State& st) {
  const int drives = static_cast<int>(st.range(0));
  static std::shared_ptr<const planner::Context> base = makeLungContext(2);
  if (!base) return st.SkipWithError(io::missingDataMessage("${CTR_DATA}/med-mpd").c_str());
  planner::ContextOptions co = base->options();
  co.mode = planner::Mode::Robust;
  using K = planner::RangeDimension::Kind;
  if (drives > 0) co.ranges.push_back({K::BoundaryFriction, 0, 0.05, 0.1});
  for (int t = 2; t < 2 + drives; ++t) co.ranges.push_back({K::RotationPlay, t, 0.02, 0.1});
  const planner::Context ctx(base->robot(), base->environmentPtr(), co, base->checker().options());
  const Configuration a(Eigen::Vector3d(0.0, 0.0, 0.0), Eigen::Vector3d(-0.118, -0.218, -0.318));
  const Configuration b(Eigen::Vector3d(-0.537556, -1.836102, -2.506250),
                        Eigen::Vector3d(-0.096936, -0.150559, -0.250559));
  std::vector<Configuration> qs;
  for (int k = 0; k < 64; ++k) qs.push_back(interpolate(a, b, k / 63.0));
  std::size_t k = 0, valid = 0;
  for (auto _ : st) valid += planner::checkRobust(ctx, qs[k++ % qs.size()], planner::scratch()).ok;
  reportValidity(st, valid);
  st.counters["corners"] = static_cast<double>(ctx.robustCorners().size());
}

}  // namespace

BENCHMARK(BM_RobustValidity)
    ->Name("planner/lung2/robust_validity_along_planned_path")
    ->Arg(0)
    ->Arg(1)
    ->Arg(2)
    ->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_ValidityCold)->Name("planner/lung1/frictionless_validity_cold")->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_ValidityAlongMotion)
    ->Name("planner/lung1/frictionless_validity_along_motion")
    ->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_ValidityAlongPlannedPath)
    ->Name("planner/lung2/frictionless_validity_along_planned_path")
    ->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_FrictionMotionStep)->Name("planner/lung1/friction_motion_step")->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_InverseKinematics)
    ->Name("planner/lung1/goal_inverse_kinematics")
    ->Arg(10)
    ->Arg(20)
    ->Arg(40)
    ->Unit(benchmark::kMicrosecond);
