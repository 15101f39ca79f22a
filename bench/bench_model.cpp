// Benchmarks of the kinematics model and the stick-slip friction step.
#include <benchmark/benchmark.h>

#include <cmath>

#include "ctr/io/robot_yaml.hpp"
#include "ctr/model/backbone.hpp"
#include "ctr/model/distributed_friction.hpp"
#include "ctr/model/friction.hpp"
#include "ctr/model/jacobian.hpp"
#include "ctr/model/kinematics.hpp"
#include "ctr/model/uniqueness.hpp"

namespace {

ctr::Robot loadExample(const char* name) {
  return ctr::io::loadRobot(std::string(CTR_SOURCE_DIR) + "/examples/robots/" + name);
}

ctr::Configuration pairConfig(double a2) {
  return ctr::Configuration(Eigen::Vector2d(0.0, a2), Eigen::Vector2d(-0.018, -0.018));
}

ctr::Configuration dupontConfig(double a2, double a3) {
  return ctr::Configuration(Eigen::Vector3d(0.0, a2, a3), Eigen::Vector3d(0.0, -0.017, -0.070));
}

// Warm start: the previous solution is a neighbour 0.5 deg away (a controller / planner step).
template <bool kThree, bool kShape>
void BM_SolveWarm(benchmark::State& st) {
  const ctr::Robot robot = loadExample(kThree ? "dupont_lab_3tube.yaml" : "tube_pair_B.yaml");
  ctr::Workspace ws;
  ctr::KinematicsOptions opt;
  opt.record_backbone = kShape;
  const double d = 0.5 * M_PI / 180.0;
  auto cfg = [&](double a) { return kThree ? dupontConfig(a, -2.0 + a) : pairConfig(a); };
  ctr::Solution prev = ctr::solve(robot, cfg(1.0), ws, opt);
  int k = 0;
  for (auto _ : st) {
    const double a = 1.0 + d * ((k++ % 2) ? 1 : 0);
    ctr::Solution s = ctr::solve(robot, cfg(a), ws, opt, &prev);
    if (kShape) benchmark::DoNotOptimize(ctr::resampleBackbone(s, s.tipArcLength() / 99.0));
    benchmark::DoNotOptimize(s.tip_position);
  }
}

template <bool kThree, bool kShape>
void BM_SolveCold(benchmark::State& st) {
  const ctr::Robot robot = loadExample(kThree ? "dupont_lab_3tube.yaml" : "tube_pair_B.yaml");
  ctr::Workspace ws;
  ctr::KinematicsOptions opt;
  opt.record_backbone = kShape;
  int k = 0;
  for (auto _ : st) {
    const double a = 0.3 + 0.01 * (k++ % 200);
    ctr::Solution s =
        kThree ? ctr::solve(robot, dupontConfig(a, -a), ws, opt) : ctr::solve(robot, pairConfig(a), ws, opt);
    if (kShape) benchmark::DoNotOptimize(ctr::resampleBackbone(s, s.tipArcLength() / 99.0));
    benchmark::DoNotOptimize(s.tip_position);
  }
}

// The planner's solver settings (ctr::planner::planningKinematicsOptions(); the planner is not linked here): RK4 steps
// of at most 40 mm and 0.3 rad of bending instead of the library default (10 mm / 0.12 rad), tolerance 1e-8 and the
// secant warm-start predictor.
// The planner's steps only (library tolerance, no predictor): what the planning settings gain from each part.
ctr::KinematicsOptions planningStepsOnly() {
  ctr::KinematicsOptions o;
  o.max_step = 0.04;
  o.max_bending_per_step = 0.3;  // per segment, like the library default
  return o;
}

ctr::KinematicsOptions planningSteps() {
  ctr::KinematicsOptions o = planningStepsOnly();
  o.tolerance = 1e-8;
  o.extrapolate_warm_start = true;
  return o;
}

// Tip-only solves of the Dupont-lab robot along a sweep (0.5 deg per solve of tubes 2 and 3), each warm-started from
// the previous one: a controller or a planner's motion check. (BM_SolveWarm above alternates between two fixed
// configurations, so its warm start never moves: 1 Newton iteration instead of 2.) A full turn restarts cold, untimed.
void sweepSolves(benchmark::State& st, const ctr::Robot& robot, ctr::KinematicsOptions opt) {
  ctr::Workspace ws;
  opt.record_backbone = false;
  const double d = 0.5 * M_PI / 180.0;
  auto cfg = [&](int k) { return dupontConfig(d * k, -2.0 + 1.3 * d * k); };
  int k = 0;
  ctr::Solution prev = ctr::solve(robot, cfg(k), ws, opt);
  double iterations = 0.0, solves = 0.0;
  for (auto _ : st) {
    if (++k == 720) {
      st.PauseTiming();
      k = 0;
      prev = ctr::solve(robot, cfg(k), ws, opt);
      st.ResumeTiming();
      continue;
    }
    ctr::Solution s = ctr::solve(robot, cfg(k), ws, opt, &prev);
    benchmark::DoNotOptimize(s.tip_position);
    iterations += s.summary.iterations;
    solves += 1.0;
    prev = std::move(s);
  }
  st.counters["newton_iterations"] = solves > 0 ? iterations / solves : 0.0;
}

// Cold tip-only solves of a 3-tube robot over 200 configurations (as BM_SolveCold<true, false>).
void coldSolves(benchmark::State& st, const ctr::Robot& robot, ctr::KinematicsOptions opt) {
  ctr::Workspace ws;
  opt.record_backbone = false;
  int k = 0;
  for (auto _ : st) {
    const double a = 0.3 + 0.01 * (k++ % 200);
    benchmark::DoNotOptimize(ctr::solve(robot, dupontConfig(a, -a), ws, opt).tip_position);
  }
}

// Cold solves of the Dupont-lab robot with the planner's settings.
void BM_SolveColdPlanning(benchmark::State& st) {
  coldSolves(st, loadExample("dupont_lab_3tube.yaml"), planningSteps());
}

// kPlanning: 0 library default, 1 the planner's settings, 2 the planner's steps only.
template <int kPlanning>
void BM_SolveSweep(benchmark::State& st) {
  sweepSolves(st, loadExample("dupont_lab_3tube.yaml"),
              kPlanning == 1   ? planningSteps()
              : kPlanning == 2 ? planningStepsOnly()
                               : ctr::KinematicsOptions{});
}

// One stick-slip step (1 deg) of the 3-tube robot with mu' = 0.1, warm (the state from the previous step).
// kPlanning: with the planner's integration settings (40 mm / 0.3 rad steps).
template <bool kPlanning>
void BM_StickSlipStep3(benchmark::State& st) {
  const ctr::Robot robot = loadExample("dupont_lab_3tube.yaml").withFriction({0.1, 0.0});
  ctr::Workspace ws;
  ctr::FrictionOptions fo;
  if (kPlanning) fo.kinematics = planningSteps();
  fo.kinematics.record_backbone = false;
  double a = 0.5;
  ctr::StepResult cur = ctr::initialState(robot, dupontConfig(a, -a), ws, fo);
  int k = 0;
  double trials = 0.0, iterations = 0.0;
  for (auto _ : st) {
    a += ((k++ / 90) % 2 ? -1.0 : 1.0) * M_PI / 180.0;
    cur = ctr::step(robot, cur.state, dupontConfig(a, -a), ws, fo);
    benchmark::DoNotOptimize(cur.solution.tip_position);
    trials += cur.summary.active_set_iterations;
    iterations += cur.solution.summary.iterations;
  }
  // Contact-mode trials (equilibrium solves) per step, Newton iterations of the accepted solve.
  st.counters["mode_trials"] = k > 0 ? trials / k : 0.0;
  st.counters["newton_iterations"] = k > 0 ? iterations / k : 0.0;
}

// External loads: the Dupont-lab robot with nitinol tubes (density 6450 kg/m^3 over its diameters),
// gravity across the robot and a 0.05 N tip force.
ctr::Robot loadedDupont() {
  const ctr::Robot r = loadExample("dupont_lab_3tube.yaml");
  std::vector<ctr::Tube> tubes = r.tubes();
  for (ctr::Tube& t : tubes)
    t.linear_density = 6450.0 * M_PI * (t.outer_diameter * t.outer_diameter - t.inner_diameter * t.inner_diameter) / 4;
  ctr::Loads l;
  l.gravity = Eigen::Vector3d(0.0, -9.81, 0.0);
  l.tip_force = Eigen::Vector3d(0.05, 0.0, 0.0);
  return ctr::Robot(r.name(), tubes, r.friction(), l);
}

// The sweep of BM_SolveSweep<false> (library default steps): kLoaded false = the same robot without loads.
template <bool kLoaded>
void BM_LoadedSweep(benchmark::State& st) {
  sweepSolves(st, kLoaded ? loadedDupont() : loadExample("dupont_lab_3tube.yaml"), ctr::KinematicsOptions{});
}

// The same loaded sweep with the planner's settings (a planning query with loads).
void BM_LoadedSweepPlanning(benchmark::State& st) {
  sweepSolves(st, loadedDupont(), planningSteps());
}

// The loaded sweep at library default integration and tolerance with the path predictor
// (KinematicsOptions::extrapolate_warm_start): what a controller following a path can ask for.
void BM_LoadedSweepPredictor(benchmark::State& st) {
  ctr::KinematicsOptions o;
  o.extrapolate_warm_start = true;
  sweepSolves(st, loadedDupont(), o);
}

void BM_LoadedCold(benchmark::State& st) {
  coldSolves(st, loadedDupont(), ctr::KinematicsOptions{});
}

// Exact tip Jacobian (6 x 6 actuation) with / without the 6 x 6 compliance at a loaded equilibrium.
template <bool kCompliance>
void BM_TipJacobian(benchmark::State& st) {
  const ctr::Robot robot = loadedDupont();
  ctr::Workspace ws;
  ctr::KinematicsOptions opt;
  opt.record_backbone = false;
  const ctr::Solution sol = ctr::solve(robot, dupontConfig(0.4, -1.5), ws, opt);
  for (auto _ : st) benchmark::DoNotOptimize(ctr::tipJacobian(robot, sol, ws, opt, kCompliance).actuation);
}

// One stick-slip step (1 deg, mu' = 0.1) under the loads.
void BM_LoadedStickSlipStep(benchmark::State& st) {
  const ctr::Robot robot = loadedDupont().withFriction({0.1, 0.0});
  ctr::Workspace ws;
  ctr::FrictionOptions fo;
  fo.kinematics.record_backbone = false;
  double a = 0.5;
  ctr::StepResult cur = ctr::initialState(robot, dupontConfig(a, -a), ws, fo);
  int k = 0;
  for (auto _ : st) {
    a += ((k++ / 90) % 2 ? -1.0 : 1.0) * M_PI / 180.0;
    cur = ctr::step(robot, cur.state, dupontConfig(a, -a), ws, fo);
    benchmark::DoNotOptimize(cur.solution.tip_position);
  }
}

}  // namespace

// The lung robot (mu' 0.1) at a planning configuration and its friction band (vertices; with the tubes' angles).
struct LungBand {
  ctr::Robot robot = loadExample("medmpd_lung.yaml").withFriction({0.1, 0.0});
  ctr::Configuration q{Eigen::Vector3d(0.0, 1.2, -0.7), Eigen::Vector3d(-0.06, -0.14, -0.2)};
  ctr::Workspace ws;
  ctr::FrictionBand band;
  LungBand() {
    ctr::FrictionBandOptions o;
    o.interior_samples = 0;
    o.kinematics.record_tube_states = true;
    band = ctr::frictionBand(robot, q, ws, o);
  }
};

// The certificate of one equilibrium per torque vector: for every rotation (translations only), and around the
// friction band of the lung robot at a planning configuration (the band itself not timed).
template <bool kBand>
void BM_Uniqueness(benchmark::State& st) {
  const LungBand l;
  if (!l.band.converged) {
    st.SkipWithError("band did not converge");
    return;
  }
  for (auto _ : st) {
    const ctr::UniquenessCertificate c =
        kBand ? ctr::uniquenessCertificate(l.robot, l.band) : ctr::uniquenessCertificate(l.robot, l.q);
    benchmark::DoNotOptimize(c.status);
  }
}

// A final approach checked for every history (robust mode's approach goals): from every shape of the lung robot's
// friction band (the band itself not timed), each contact stuck at its torque (stuckStateAt), the stick-slip step
// along a move that turns neighbouring tubes against each other by 0.5 rad.
void BM_FinalApproach(benchmark::State& st) {
  LungBand l;
  if (!l.band.converged) {
    st.SkipWithError("band did not converge");
    return;
  }
  const ctr::Configuration to(l.q.alpha + Eigen::Vector3d(0.5, 0.0, -0.5), l.q.beta);
  ctr::FrictionOptions fo;
  fo.kinematics.record_backbone = false;
  for (auto _ : st) {
    for (const ctr::Solution& shape : l.band.shapes) {
      const ctr::StepResult r = ctr::step(l.robot, ctr::stuckStateAt(l.robot, shape), to, l.ws, fo);
      benchmark::DoNotOptimize(r.solution.tip_position);
    }
  }
  st.counters["shapes"] = static_cast<double>(l.band.shapes.size());
}

BENCHMARK(BM_SolveWarm<false, false>)->Name("solve_warm/pairB/tip");
BENCHMARK(BM_FinalApproach)->Name("final_approach/lung/from_every_band_shape")->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Uniqueness<false>)->Name("uniqueness/lung/every_rotation");
BENCHMARK(BM_Uniqueness<true>)->Name("uniqueness/lung/around_band");
BENCHMARK(BM_SolveWarm<false, true>)->Name("solve_warm/pairB/shape100");
BENCHMARK(BM_SolveCold<false, false>)->Name("solve_cold/pairB/tip");
BENCHMARK(BM_SolveWarm<true, false>)->Name("solve_warm/dupont3/tip");
BENCHMARK(BM_SolveWarm<true, true>)->Name("solve_warm/dupont3/shape100");
BENCHMARK(BM_SolveCold<true, false>)->Name("solve_cold/dupont3/tip");
BENCHMARK(BM_SolveCold<true, true>)->Name("solve_cold/dupont3/shape100");
BENCHMARK(BM_SolveColdPlanning)->Name("solve_cold/dupont3/tip/planning");
// The distributed-friction solve (§II.B-C: mu 0.2, every interface rotating the same way) from its frictionless
// start, at configurations of the Dupont-lab robot around the one of BM_SolveCold.
void BM_DistributedFriction(benchmark::State& st) {
  const ctr::Robot robot = loadExample("dupont_lab_3tube.yaml");
  ctr::Workspace ws;
  ctr::DistributedFrictionOptions opt;
  opt.mu = 0.2;
  opt.direction = {1, 1};
  opt.kinematics.record_backbone = false;
  int k = 0;
  for (auto _ : st) {
    const double a = 0.3 + 0.01 * (k++ % 200);
    const ctr::DistributedFrictionSolution s = ctr::solveDistributedFriction(robot, dupontConfig(a, -a), ws, opt);
    benchmark::DoNotOptimize(s.solution.tip_position);
  }
}

BENCHMARK(BM_DistributedFriction)->Name("distributed_friction/dupont3/mu0.2");
BENCHMARK(BM_StickSlipStep3<false>)->Name("stick_slip_step/dupont3/1deg");
BENCHMARK(BM_StickSlipStep3<true>)->Name("stick_slip_step/dupont3/1deg/planning");
BENCHMARK(BM_SolveSweep<0>)->Name("solve_sweep/dupont3/tip/default");
BENCHMARK(BM_SolveSweep<1>)->Name("solve_sweep/dupont3/tip/planning");
BENCHMARK(BM_SolveSweep<2>)->Name("solve_sweep/dupont3/tip/planning_steps_only");
BENCHMARK(BM_LoadedSweep<false>)->Name("loads/solve_sweep/dupont3/no_load");
BENCHMARK(BM_LoadedSweep<true>)->Name("loads/solve_sweep/dupont3/gravity_tip_force");
BENCHMARK(BM_LoadedSweepPlanning)->Name("loads/solve_sweep/dupont3/gravity_tip_force/planning");
BENCHMARK(BM_LoadedSweepPredictor)->Name("loads/solve_sweep/dupont3/gravity_tip_force/predictor");
BENCHMARK(BM_LoadedCold)->Name("loads/solve_cold/dupont3/gravity_tip_force");
BENCHMARK(BM_TipJacobian<false>)->Name("loads/tip_jacobian/dupont3/actuation");
BENCHMARK(BM_TipJacobian<true>)->Name("loads/tip_jacobian/dupont3/actuation_compliance");
BENCHMARK(BM_LoadedStickSlipStep)->Name("loads/stick_slip_step/dupont3/1deg");
