// Benchmarks of the inverse kinematics (docs/ik.md): reach rate and cold time over the example robots,
// the warm servo update, and the friction-aware tracking of a 10 mm circle with mu' = 0.1 (tip RMS of friction-blind
// vs friction-aware commands, replayed through the stateful model).
//
//   build/bench/bench_ik --benchmark_filter='ik/cold'            reach rate + cold time per robot
//   build/bench/bench_ik --benchmark_filter='ik/(warm|friction)'  servo updates and the circle
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <ctime>
#include <random>
#include <string>
#include <vector>

#include "ctr/io/robot_yaml.hpp"
#include "ctr/model/friction_ik.hpp"
#include "ctr/model/ik.hpp"
#include "ctr/model/sampling.hpp"

namespace {

const char* const kRobots[] = {"dupont_lab_3tube", "three_tube_generic", "tube_pair_A", "tube_pair_B",
                               "single_tube",      "proc_intracardiac",  "proc_airway", "proc_sinus",
                               "medmpd_brain",     "medmpd_liver",       "medmpd_lung"};

ctr::Robot loadExample(const std::string& name) {
  return ctr::io::loadRobot(std::string(CTR_SOURCE_DIR) + "/examples/robots/" + name + ".yaml");
}

// Targets made by forward kinematics of uniform random admissible configurations (stable equilibria only).
std::vector<Eigen::Vector3d> reachableTargets(const ctr::Robot& r, int count, std::uint64_t seed) {
  const ctr::TranslationSampler sampler(r);
  std::mt19937_64 rng(seed);
  ctr::Workspace ws;
  std::vector<Eigen::Vector3d> out;
  while (static_cast<int>(out.size()) < count) {
    const ctr::Solution s = ctr::solve(r, ctr::sampleConfiguration(r, sampler, rng), ws);
    if (s.converged() && s.summary.stable) out.push_back(s.tip_position);
  }
  return out;
}

constexpr int kTargets = 200;

// CPU time of the calling thread (the slowest call is measured in CPU time, like the benchmark's own time).
double threadCpuSeconds() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

// One cold IK per iteration, each iteration a new target; reached_fraction over the kTargets targets.
void BM_Cold(benchmark::State& st) {
  const ctr::Robot r = loadExample(kRobots[st.range(0)]);
  const std::vector<Eigen::Vector3d> targets = reachableTargets(r, kTargets, 2024);
  ctr::Workspace ws;
  ctr::IkOptions o;
  std::size_t k = 0, reached = 0, other_branch = 0, starts = 0, iterations = 0;
  int most_starts = 0, most_iterations = 0;
  double worst = 0.0;
  std::vector<double> cpu;
  for (auto _ : st) {
    o.seed = k + 1;
    const double t0 = threadCpuSeconds();
    const ctr::IkResult res = ctr::inverseKinematics(r, ctr::IkTarget(targets[k % targets.size()]), ws, o);
    cpu.push_back(threadCpuSeconds() - t0);
    // Reached with an equilibrium that a cold solve of the answer also gives (what `ctr fk` of it shows).
    reached += res.summary.reached() && !res.summary.branch_dependent;
    other_branch += res.summary.reached() && res.summary.branch_dependent;
    starts += static_cast<std::size_t>(res.summary.starts);
    iterations += static_cast<std::size_t>(res.summary.iterations);
    most_starts = std::max(most_starts, res.summary.starts);
    most_iterations = std::max(most_iterations, res.summary.iterations);
    if (!res.summary.reached()) worst = std::max(worst, res.summary.tip_error);
    ++k;
  }
  st.SetLabel(kRobots[st.range(0)]);
  st.counters["reached"] = static_cast<double>(reached);
  st.counters["reached_other_branch"] = static_cast<double>(other_branch);
  std::sort(cpu.begin(), cpu.end());
  st.counters["p95_cpu_ms"] = cpu[static_cast<std::size_t>(0.95 * static_cast<double>(cpu.size() - 1))] * 1e3;
  st.counters["p99_cpu_ms"] = cpu[static_cast<std::size_t>(0.99 * static_cast<double>(cpu.size() - 1))] * 1e3;
  st.counters["slowest_cpu_ms"] = cpu.back() * 1e3;
  st.counters["targets"] = static_cast<double>(k);
  st.counters["reached_fraction"] = static_cast<double>(reached) / static_cast<double>(k);
  st.counters["starts_per_ik"] = static_cast<double>(starts) / static_cast<double>(k);
  st.counters["starts_max"] = most_starts;
  st.counters["iterations_per_ik"] = static_cast<double>(iterations) / static_cast<double>(k);
  st.counters["iterations_max"] = most_iterations;
  st.counters["worst_miss_mm"] = worst * 1e3;
}

// The circle of the teleoperation example: 10 mm diameter in the plane z = const through the start tip.
const ctr::Configuration kDupontStart(Eigen::Vector3d(0.0, 0.5, -1.0), Eigen::Vector3d(0.0, -0.017, -0.09));

std::vector<ctr::IkTarget> circle(const Eigen::Vector3d& start, int points, double radius = 0.005) {
  const Eigen::Vector3d centre = start - Eigen::Vector3d(radius, 0.0, 0.0);
  std::vector<ctr::IkTarget> t;
  for (int k = 0; k <= points; ++k) {
    const double a = 2.0 * M_PI * k / points;
    t.emplace_back(centre + radius * Eigen::Vector3d(std::cos(a), std::sin(a), 0.0));
  }
  return t;
}

// One warm update per iteration: the next target a servo period away (a 10 mm circle in 2 s at 1 kHz: 16 um per
// update), from the previous result. The same at 0.5 s per turn (63 um per update) and 0.1 s (0.31 mm) via the
// argument (periods per turn).
void BM_WarmUpdate(benchmark::State& st) {
  const ctr::Robot r = loadExample("dupont_lab_3tube");
  ctr::Workspace ws;
  const int points = static_cast<int>(st.range(0));
  const std::vector<ctr::IkTarget> path = circle(ctr::solve(r, kDupontStart, ws).tip_position, points);
  ctr::IkResult cur = ctr::inverseKinematics(r, path[0], kDupontStart, ws);
  std::size_t k = 0, reached = 0, evaluations = 0, jacobians = 0;
  for (auto _ : st) {
    cur = ctr::inverseKinematics(r, path[++k % path.size()], cur, ws);
    reached += cur.summary.reached();
    evaluations += static_cast<std::size_t>(cur.summary.evaluations);
    jacobians += static_cast<std::size_t>(cur.summary.jacobians);
  }
  const double n = static_cast<double>(k);
  st.counters["reached_fraction"] = static_cast<double>(reached) / n;
  st.counters["solves_per_update"] = static_cast<double>(evaluations) / n;
  st.counters["jacobians_per_update"] = static_cast<double>(jacobians) / n;
}

// A warm IK from a configuration only (no previous result: a solve and a Jacobian first), the target one servo
// period away.
void BM_WarmFromConfiguration(benchmark::State& st) {
  const ctr::Robot r = loadExample("dupont_lab_3tube");
  ctr::Workspace ws;
  const std::vector<ctr::IkTarget> path = circle(ctr::solve(r, kDupontStart, ws).tip_position, 2000);
  std::vector<ctr::Configuration> qs;
  ctr::IkResult cur = ctr::inverseKinematics(r, path[0], kDupontStart, ws);
  for (std::size_t k = 1; k < path.size(); ++k) {
    qs.push_back(cur.q);
    cur = ctr::inverseKinematics(r, path[k], cur, ws);
  }
  std::size_t k = 0, reached = 0;
  for (auto _ : st) {
    const std::size_t i = k++ % qs.size();
    reached += ctr::inverseKinematics(r, path[i + 1], qs[i], ws).summary.reached();
  }
  st.counters["reached_fraction"] = static_cast<double>(reached) / static_cast<double>(k);
}

// The friction-aware servo update on the circle (mu' = 0.1): one target per iteration, from the state the previous
// command left. Argument 1: with the friction-blind comparison (a frictionless update and a stateful step more).
void BM_FrictionUpdate(benchmark::State& st) {
  const ctr::Robot r = loadExample("dupont_lab_3tube").withFriction({0.1, 0.0});
  ctr::Workspace ws;
  const std::vector<ctr::IkTarget> path = circle(ctr::solve(r, kDupontStart, ws).tip_position, 2000);
  ctr::FrictionIkOptions o;
  o.compare_blind = st.range(0) != 0;
  const ctr::IkResult first = ctr::inverseKinematics(r, path[0], kDupontStart, ws);
  const ctr::StepResult start = ctr::initialState(r, first.q, ws, o.friction);
  // One turn of the circle per iteration (2001 updates): the path function is the loop.
  std::size_t reached = 0, targets = 0;
  for (auto _ : st) {
    const auto res = ctr::frictionInverseKinematicsPath(r, start.state, path, ws, o);
    for (const auto& x : res) reached += x.summary.reached();
    targets += res.size();
  }
  st.counters["reached_fraction"] = static_cast<double>(reached) / static_cast<double>(targets);
  st.counters["time_per_target"] =
      benchmark::Counter(static_cast<double>(targets), benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}

// The whole circle (2000 targets + return) with mu' = 0.1, replayed through the stateful model: RMS tip error of the
// friction-blind commands (frictionless IK) and of the friction-aware ones, and their ratio.
void BM_FrictionCircle(benchmark::State& st) {
  const ctr::Robot r = loadExample("dupont_lab_3tube").withFriction({0.1, 0.0});
  ctr::Workspace ws;
  const std::vector<ctr::IkTarget> path = circle(ctr::solve(r, kDupontStart, ws).tip_position, 2000);
  const ctr::FrictionIkOptions o;
  const ctr::IkResult first = ctr::inverseKinematics(r, path[0], kDupontStart, ws);
  const ctr::StepResult start = ctr::initialState(r, first.q, ws, o.friction);
  double blind_rms = 0.0, aware_rms = 0.0, reached = 0.0;
  for (auto _ : st) {
    const auto res = ctr::frictionInverseKinematicsPath(r, start.state, path, ws, o);
    // Replay both command sequences through the stateful model (independently of the IK's own evaluations).
    ctr::HysteresisState h = start.state, hb = start.state;
    double a2 = 0.0, b2 = 0.0;
    reached = 0.0;
    for (std::size_t k = 0; k < res.size(); ++k) {
      const ctr::StepResult a = ctr::step(r, h, res[k].q, ws, o.friction);
      const ctr::StepResult b = ctr::step(r, hb, res[k].cost.blind_q, ws, o.friction);
      a2 += (a.solution.tip_position - path[k].position).squaredNorm();
      b2 += (b.solution.tip_position - path[k].position).squaredNorm();
      h = a.state;
      hb = b.state;
      reached += res[k].summary.reached();
    }
    aware_rms = std::sqrt(a2 / res.size());
    blind_rms = std::sqrt(b2 / res.size());
  }
  st.counters["blind_rms_mm"] = blind_rms * 1e3;
  st.counters["aware_rms_mm"] = aware_rms * 1e3;
  st.counters["rms_ratio"] = blind_rms / aware_rms;
  st.counters["reached_fraction"] = reached / static_cast<double>(path.size());
}

}  // namespace

BENCHMARK(BM_Cold)->Name("ik/cold")->DenseRange(0, 10)->Iterations(kTargets)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_WarmUpdate)->Name("ik/warm_update/dupont3")->Arg(2000)->Arg(500)->Arg(100)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_WarmFromConfiguration)->Name("ik/warm_from_configuration/dupont3")->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_FrictionUpdate)->Name("ik/friction_update/dupont3_mu0.1")->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_FrictionCircle)->Name("ik/friction_circle/dupont3_mu0.1")->Iterations(1)->Unit(benchmark::kSecond);
