// Benchmarks of the diagnosis: one replay of a public recording (frictionless and with boundary friction) and a
// full diagnosis of the null case.
#include <benchmark/benchmark.h>

#include "ctr/diagnosis/diagnose.hpp"
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
  const std::string base = std::string(CTR_SHARED_DIR) + "/data/recordings/" + name;
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
