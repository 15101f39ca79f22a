// `ctr demo`: the embedded default job -- a friction-aware planning query in a procedural intracardiac anatomy
// (no data download); `--paper` runs the paper's tube pair B twist sweep (frictionless vs stick-slip friction).
#include <cmath>
#include <cstdio>
#include <iostream>
#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "ctr/io/file.hpp"
#include "ctr/io/robot_yaml.hpp"
#include "ctr/model/friction.hpp"
#ifdef CTR_WITH_PLANNER
#include "ctr/environments/environment_yaml.hpp"
#include "ctr/planner/planner.hpp"
#include "demo_data.hpp"
#endif

namespace ctr::cli {

namespace {

Robot embeddedPairB() {
  // Lock & Dupont 2011, tube pair B (Tables 1-2); 150 mm curved length assumed; nu = 0.6 as the paper fitted.
  Tube outer;
  outer.name = "outer";
  outer.straight_length = 0.018;
  outer.curved_length = 0.150;
  outer.curvature = 1.0 / 0.154;
  outer.bending_stiffness = 0.0334;
  outer.poisson_ratio = 0.6;
  outer.torsional_stiffness = 0.0334 / 1.6;
  outer.outer_diameter = 2.77e-3;
  outer.inner_diameter = 2.55e-3;
  Tube inner = outer;
  inner.name = "inner";
  inner.bending_stiffness = 0.0511;
  inner.torsional_stiffness = 0.0511 / 1.6;
  inner.outer_diameter = 2.41e-3;
  inner.inner_diameter = 1.97e-3;
  return Robot("tube_pair_B", {outer, inner}, {0.12, 0.0});
}

}  // namespace

int paperSweep(double mu);
#ifdef CTR_WITH_PLANNER
int planningDemo(const std::string& path_csv);
#endif

void registerDemo(CLI::App& app, Action& action) {
  struct Opts {
    double mu = 0.12;
    bool paper = false;
    std::string path = "ctr_demo_path.csv";
  };
  auto o = std::make_shared<Opts>();
  CLI::App* sub = app.add_subcommand(
      "demo", "Embedded default job: plan from the vena cava to the tricuspid valve of a procedural heart");
  sub->add_flag("--paper", o->paper, "Instead: the paper's tube pair B twist sweep (frictionless vs friction)");
  sub->add_option("--boundary-friction", o->mu, "mu' of the --paper friction branches")->check(finiteNonNegative());
  sub->add_option("--path", o->path, "Where the demo writes the replayed path (CSV)");
  sub->callback([o, &action]() {
    action = [o]() {
#ifdef CTR_WITH_PLANNER
      if (!o->paper) checkOutputPath("--path", o->path);
      if (!o->paper) return planningDemo(o->path);
#endif
      return paperSweep(o->mu);
    };
  });
}

#ifdef CTR_WITH_PLANNER
int planningDemo(const std::string& path_csv) {
  const Robot robot = io::parseRobot(demo::kRobot, "embedded:robots/proc_intracardiac.yaml");
  const environments::EnvironmentDescription d = environments::parseEnvironmentDescription(
      demo::kEnvironment, "embedded:environments/proc_intracardiac.yaml", ".");
  const planner::Query q = planner::parseQuery(demo::kQuery, "embedded:queries/proc_intracardiac.yaml", ".", false);
  std::cout << "ctr demo: " << robot.size() << "-tube robot in a procedural right atrium, mode "
            << planner::toString(q.mode) << ", planner " << q.planner
            << ", mu' = " << (q.friction ? q.friction->boundary : robot.friction().boundary) << "\n";
  planner::CtrPlanner p(q, robot, environments::buildEnvironment(d));
  const planner::PlanResult r = p.solve();
  nlohmann::json j = {{"solved", r.solved},
                      {"mode", planner::toString(r.mode)},
                      {"planner", r.planner},
                      {"planning_time", r.planning_time},
                      {"path_length", r.path_length},
                      {"waypoints", r.path.size()},
                      {"replay",
                       {{"collision_free", r.replay.collision_free},
                        {"stable", r.replay.stable},
                        {"tip_error", r.replay.tip_error},
                        {"min_clearance", r.replay.min_clearance},
                        {"steps", r.replay.steps}}}};
  if (!r.message.empty()) j["message"] = r.message;
  std::cout << j.dump(2) << "\n";
  if (!r.replay.points.empty()) {
    io::writeFileAtomic(path_csv, planner::replayCsv(p.context()->robot(), r.replay));
    std::cout << "replayed path (" << r.replay.points.size() << " steps, with the hysteresis state) written to "
              << path_csv << "\n";
  }
  return r.solved ? static_cast<int>(kOk) : static_cast<int>(kRuntimeFailure);
}
#endif

int paperSweep(double mu0) {
  const double* mu = &mu0;
  {
    {
      const Robot fr = embeddedPairB().withFriction({*mu, 0.0});
      const Robot fl = fr.withFriction({0.0, 0.0});
      Workspace ws;
      FrictionOptions fo;
      fo.kinematics.record_backbone = false;
      auto cfg = [](double deg) {
        return Configuration(Eigen::Vector2d(0, deg * M_PI / 180), Eigen::Vector2d(-0.018, -0.018));
      };
      std::printf("Tube pair B (Lock & Dupont 2011), inner tube rotated 0..360 deg and back; mu' = %.3g\n", *mu);
      std::printf("%8s %14s %14s %14s %10s\n", "alpha2", "frictionless", "friction_up", "friction_down", "width");
      // Up branch, then the return branch; print both at each angle.
      std::vector<double> up(37), down(37), free(37);
      StepResult cur = initialState(fr, cfg(0), ws, fo);
      StepResult curf = initialState(fl, cfg(0), ws, fo);
      int failures = 0;
      for (int k = 0; k <= 36; ++k) {
        if (k) cur = step(fr, cur.state, cfg(10.0 * k), ws, fo);
        if (k) curf = step(fl, curf.state, cfg(10.0 * k), ws, fo);
        failures += !cur.summary.converged + !curf.summary.converged;
        up[static_cast<std::size_t>(k)] = cur.solution.twist[0];
        free[static_cast<std::size_t>(k)] = curf.solution.twist[0];
      }
      for (int k = 36; k >= 0; --k) {
        if (k < 36) cur = step(fr, cur.state, cfg(10.0 * k), ws, fo);
        failures += !cur.summary.converged;
        down[static_cast<std::size_t>(k)] = cur.solution.twist[0];
      }
      const double r2d = 180.0 / M_PI;
      for (std::size_t k = 0; k <= 36; ++k)
        std::printf("%8.0f %14.2f %14.2f %14.2f %10.2f\n", 10.0 * k, free[k] * r2d, up[k] * r2d, down[k] * r2d,
                    (down[k] - up[k]) * r2d);
      std::printf("(twist at the distal end of tube 1, deg; 'width' = envelope width from stick-slip friction)\n");
      if (failures) {
        std::cerr << "error: " << failures << " solves did not converge\n";
        return static_cast<int>(kRuntimeFailure);
      }
      return static_cast<int>(kOk);
    }
  }
}

}  // namespace ctr::cli
