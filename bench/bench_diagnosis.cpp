// Benchmarks of the diagnosis: one replay of a public recording (frictionless and with boundary friction) and a
// full diagnosis of the null case, of a 150-row random-order friction recording and of the real Dupont-lab recording.
#include <benchmark/benchmark.h>

#include <sys/resource.h>

#include <fstream>

#include "ctr/diagnosis/diagnose.hpp"
#include "ctr/diagnosis/import.hpp"
#include "ctr/diagnosis/simulate.hpp"
#include "ctr/io/data.hpp"
#include "ctr/io/recording.hpp"
#include "ctr/io/robot_yaml.hpp"

using namespace ctr;
using namespace ctr::diagnosis;

namespace {
struct Data {
  Robot robot;
  io::Recording rec;
};
Data load(const char* name) {
  const std::string base = io::expandDataPath(std::string("${CTR_DATA}/recordings/") + name);
  Robot r = io::loadRobot(base + ".robot.yaml");
  return {r, io::loadRecording(base + ".csv", r.size(), true)};
}
}  // namespace

static void BM_ReplayFrictionless(benchmark::State& st) {
  const Data d = load("pub_friction_sweep_B");
  Workspace ws;
  for (auto _ : st) benchmark::DoNotOptimize(predict(d.robot, d.rec.commands, d.rec.time, {}, ws));
}
BENCHMARK(BM_ReplayFrictionless)->Unit(benchmark::kMillisecond);

static void BM_ReplayBoundaryFriction(benchmark::State& st) {
  const Data d = load("pub_friction_sweep_B");
  Workspace ws;
  for (auto _ : st)
    benchmark::DoNotOptimize(predict(d.robot, d.rec.commands, d.rec.time, {{EffectKind::BoundaryFriction, 0, 0.12}}, ws));
}
BENCHMARK(BM_ReplayBoundaryFriction)->Unit(benchmark::kMillisecond);

static void BM_DiagnoseNull(benchmark::State& st) {
  const Data d = load("pub_null_sweep_A");
  for (auto _ : st) benchmark::DoNotOptimize(diagnose(d.robot, d.rec, DiagnoseOptions{}));
}
BENCHMARK(BM_DiagnoseNull)->Unit(benchmark::kSecond)->Iterations(1);

namespace {
// Process CPU time (all threads), s: the diagnosis fits candidates on several threads.
double processCpuSeconds() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return u.ru_utime.tv_sec + 1e-6 * u.ru_utime.tv_usec + u.ru_stime.tv_sec + 1e-6 * u.ru_stime.tv_usec;
}
}  // namespace

// Issue target: <= 30 s for a 150-sample 2-tube recording with the full candidate library. The hardest kind seen:
// random actuation order (every row a large jump), boundary friction injected, twice the public noise.
static void BM_DiagnoseRandomOrderFriction150(benchmark::State& st) {
  const Robot robot = io::loadRobot(std::string(CTR_SOURCE_DIR) + "/examples/robots/tube_pair_B.yaml");
  ActuationOptions ao;
  ao.pattern = ActuationPattern::Random;
  ao.rows = 150;
  ao.seed = 3;
  std::vector<Configuration> cmd;
  Eigen::VectorXd time;
  makeActuation(robot, ao, cmd, time);
  SimulationOptions so;
  so.twist_sd *= 2;
  so.position_sd *= 2;
  so.tangent_sd *= 2;
  const io::Recording rec = simulateRecording(robot, cmd, time, {{EffectKind::BoundaryFriction, 0, 0.12}}, so);
  bool right = false;
  const double c0 = processCpuSeconds();
  for (auto _ : st) {
    const DiagnosisReport rep = diagnose(robot, rec, DiagnoseOptions{});
    right = rep.verdict == std::vector<std::string>{"boundary_friction"};
  }
  st.counters["process_cpu_s"] = processCpuSeconds() - c0;
  st.counters["verdict_right"] = right;
}
BENCHMARK(BM_DiagnoseRandomOrderFriction150)->Unit(benchmark::kSecond)->Iterations(1)->UseRealTime();

// The real 1,307-sample Dupont-lab recording (imported as `ctr recording import` does), in an unknown tracker frame,
// with the given noise (none: estimated from the recording).
static void diagnoseDupontRecording(benchmark::State& st, const GivenNoise& noise) {
  const std::string path =
      io::expandDataPath("${CTR_DATA}/dupont-lab-ctr-trajectory-hjhdog1/jointTipTrajectory_measured_short.txt");
  if (!std::ifstream(path)) {
    st.SkipWithError(io::missingDataMessage(path).c_str());
    return;
  }
  const Robot robot = io::loadRobot(std::string(CTR_SOURCE_DIR) + "/examples/robots/dupont_lab_3tube.yaml");
  const io::Recording rec = importTable(path, dupontLabImportOptions());
  DiagnoseOptions o;
  o.frame = FrameMode::Unknown;
  o.noise = noise;
  const double c0 = processCpuSeconds();
  for (auto _ : st) benchmark::DoNotOptimize(diagnose(robot, rec, o));
  st.counters["process_cpu_s"] = processCpuSeconds() - c0;
}

// Target: <= 60 s. Without --noise the log's neighbouring differences are serially correlated: nothing is
// established (docs/diagnosis.md).
static void BM_DiagnoseDupontRecording(benchmark::State& st) { diagnoseDupontRecording(st, {}); }
BENCHMARK(BM_DiagnoseDupontRecording)->Unit(benchmark::kSecond)->Iterations(1)->UseRealTime();

// The same against its EM tracker's noise (`--noise tip_position=0.5mm,tip_tangent=0.3deg`), as a lab gives it.
static void BM_DiagnoseDupontRecordingTrackerNoise(benchmark::State& st) {
  diagnoseDupontRecording(st, parseGivenNoise("tip_position=0.5mm,tip_tangent=0.3deg"));
}
BENCHMARK(BM_DiagnoseDupontRecordingTrackerNoise)->Unit(benchmark::kSecond)->Iterations(1)->UseRealTime();
