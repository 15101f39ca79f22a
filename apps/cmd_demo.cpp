// `ctr demo`: the embedded default job -- the paper's tube pair B twist sweep, frictionless vs stick-slip friction.
#include <cmath>
#include <cstdio>
#include <iostream>

#include "commands.hpp"
#include "ctr/model/friction.hpp"

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

void registerDemo(CLI::App& app, Action& action) {
  auto mu = std::make_shared<double>(0.12);
  CLI::App* sub = app.add_subcommand("demo", "Embedded default job: tube pair B twist sweep (frictionless vs friction)");
  sub->add_option("--boundary-friction", *mu, "mu' of the friction branches")->check(CLI::NonNegativeNumber);
  sub->callback([mu, &action]() {
    action = [mu]() {
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
    };
  });
}

}  // namespace ctr::cli
