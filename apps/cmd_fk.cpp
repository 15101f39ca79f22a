// `ctr fk`: forward kinematics of one configuration.
#include <nlohmann/json.hpp>
#include <cstdio>
#include <iostream>

#include "commands.hpp"
#include "ctr/io/file.hpp"
#include "ctr/io/robot_yaml.hpp"
#include "ctr/model/backbone.hpp"
#include "ctr/model/jacobian.hpp"
#include "ctr/model/kinematics.hpp"
#include "output.hpp"

namespace ctr::cli {

void registerFk(CLI::App& app, Action& action) {
  struct Opts {
    std::string robot, shape, json;
    ConfigOptions config;
    LoadsCli loads;
    bool jacobian = false;
    double ds = 1e-3;
  };
  auto o = std::make_shared<Opts>();
  CLI::App* sub = app.add_subcommand(
      "fk", "Forward kinematics (frictionless torsionally compliant model; Cosserat rods under external loads)");
  sub->add_option("--robot", o->robot, "Robot description YAML")->required();
  o->config.add(sub);
  addJsonOption(sub, o->json, "the solution (one object)");
  o->loads.add(sub);
  sub->add_flag("--jacobian", o->jacobian,
                "Also give the exact tip Jacobian (6 x 2n: position, rotation w.r.t. alpha then beta) and the 6 x 6 "
                "compliance (w.r.t. tip force then moment), base frame; JSON keys jacobian, compliance");
  sub->add_option("--shape", o->shape, "Write the backbone (s,x,y,z) to this CSV");
  sub->add_option("--shape-step", o->ds, "Backbone resolution for --shape (m)")->check(finitePositive());
  sub->callback([o, &action]() {
    action = [o]() {
      checkOutputTarget("--json", o->json, {{"--robot", o->robot}});
      checkOutputPath("--shape", o->shape, {{"--robot", o->robot}, {"--json", o->json}});
      const Robot described = o->loads.apply(io::loadRobot(o->robot));
      const Configuration command = o->config.resolve(described);
      // With drives (the robot's actuation block) the tubes are at the joints of the command: offsets and
      // transmission errors applied, plays centred (a play needs a history of commands: ctr simulate has one).
      const bool driven = hasActuation(described);
      DriveState drives;
      const Configuration q = driven ? jointsOf(described, command, drives) : command;
      const Robot robot = driven ? described.withoutActuation() : described;
      if (driven) {
        bool play = false;
        for (const Tube& t : described.tubes())
          play = play || t.rotation_drive.play > 0 || t.translation_drive.play > 0;
        std::cerr << "note: the robot's drives put the tubes at the joints of the command (offsets and transmission "
                     "errors applied"
                  << (play ? "; plays taken as centred: a play needs a history, which `ctr simulate` gives" : "")
                  << "); the JSON's \"command\" is the command, its configuration the joints"
                  << (o->jacobian ? ", and the Jacobian is with respect to the joints" : "") << "\n";
      }
      Workspace ws;
      KinematicsOptions opt;
      opt.record_backbone = !o->shape.empty();
      const Solution sol = solve(robot, q, ws, opt);
      if (sol.summary.status == SolveStatus::Inadmissible)
        throw UsageError("configuration is not admissible: " + sol.summary.message);
      TipJacobian jac;
      if (o->jacobian && sol.converged()) {
        jac = tipJacobian(robot, sol, ws, opt);
        if (!jac.ok) {
          std::cerr << "error: the tip Jacobian is not defined here: " << jac.message << "\n";
          return static_cast<int>(kRuntimeFailure);
        }
      }
      auto rows = [](const Eigen::MatrixXd& M) {
        nlohmann::json a = nlohmann::json::array();
        for (int r = 0; r < M.rows(); ++r) {
          nlohmann::json row = nlohmann::json::array();
          for (int c = 0; c < M.cols(); ++c) row.push_back(M(r, c));
          a.push_back(row);
        }
        return a;
      };
      if (!o->json.empty()) {
        nlohmann::json j = solutionJson(sol);
        if (driven)
          j["command"] = {{"alpha", std::vector<double>(command.alpha.data(), command.alpha.data() + command.size())},
                          {"beta", std::vector<double>(command.beta.data(), command.beta.data() + command.size())}};
        if (jac.ok) {
          j["jacobian"] = rows(jac.actuation);
          j["compliance"] = rows(jac.compliance);
        }
        writeOutput(o->json, j.dump() + "\n");
      }
      if (o->json != kStandardOutput) {
        printSolution(std::cout, sol);
        if (jac.ok) {
          const Eigen::IOFormat fmt(6, 0, " ", "\n", "  ", "");
          std::cout << "jacobian (rows p_x p_y p_z w_x w_y w_z; columns alpha_1..n, beta_1..n):\n"
                    << jac.actuation.format(fmt) << "\n";
          std::cout << "compliance (columns F_x F_y F_z M_x M_y M_z):\n" << jac.compliance.format(fmt) << "\n";
        }
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
