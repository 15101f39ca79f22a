// `ctr fk`: forward kinematics of one configuration.
#include <nlohmann/json.hpp>
#include <cstdio>
#include <iostream>

#include "commands.hpp"
#include "ctr/io/recording.hpp"
#include "ctr/io/robot_yaml.hpp"
#include "ctr/model/backbone.hpp"
#include "ctr/model/kinematics.hpp"
#include "output.hpp"

namespace ctr::cli {

void registerFk(CLI::App& app, Action& action) {
  struct Opts {
    std::string robot, shape;
    ConfigOptions config;
    bool json = false;
    double ds = 1e-3;
  };
  auto o = std::make_shared<Opts>();
  CLI::App* sub = app.add_subcommand("fk", "Forward kinematics (frictionless torsionally compliant model)");
  sub->add_option("--robot", o->robot, "Robot description YAML")->required();
  o->config.add(sub);
  sub->add_flag("--json", o->json, "Print one JSON object");
  sub->add_option("--shape", o->shape, "Write the backbone (s,x,y,z) to this CSV");
  sub->add_option("--shape-step", o->ds, "Backbone resolution for --shape (m)")->check(finitePositive());
  sub->callback([o, &action]() {
    action = [o]() {
      checkOutputPath("--shape", o->shape, {{"--robot", o->robot}});
      const Robot robot = io::loadRobot(o->robot);
      const Configuration q = o->config.resolve(robot);
      Workspace ws;
      KinematicsOptions opt;
      opt.record_backbone = !o->shape.empty();
      const Solution sol = solve(robot, q, ws, opt);
      if (sol.summary.status == SolveStatus::Inadmissible)
        throw UsageError("configuration is not admissible: " + sol.summary.message);
      if (o->json) {
        std::cout << solutionJson(sol).dump() << "\n";
      } else {
        printSolution(std::cout, sol);
      }
      if (!sol.converged()) {
        std::cerr << "error: the model did not converge: " << sol.summary.message << "\n";
        return static_cast<int>(kRuntimeFailure);
      }
      if (!o->shape.empty()) io::writeFileAtomic(o->shape, backboneCsv(resampleBackbone(sol, o->ds)));
      return static_cast<int>(kOk);
    };
  });
}

}  // namespace ctr::cli
