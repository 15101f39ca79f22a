// `ctr view`: the interactive 3D viewer (self-contained HTML) of a path CSV written by `ctr plan --path`.
#include <iostream>

#include "commands.hpp"
#include "ctr/environments/collision.hpp"
#include "ctr/environments/environment_yaml.hpp"
#include "ctr/io/recording.hpp"
#include "ctr/io/robot_yaml.hpp"
#include "ctr/planner/planner.hpp"
#include "html_report.hpp"

namespace ctr::cli {

void registerView(CLI::App& app, Action& action) {
  struct Opts {
    std::string path, env, robot, html, query;
    double env_resolution = 0;
    int max_voxels = 60000, band_waypoints = 120;
  };
  auto o = std::make_shared<Opts>();
  CLI::App* sub = app.add_subcommand("view", "Write the interactive 3D viewer (HTML) of a path CSV in an anatomy");
  sub->add_option("path", o->path, "Path CSV (ctr plan --path: recording columns + hysteresis state)")->required();
  sub->add_option("--env", o->env, "Environment YAML")->required();
  sub->add_option("--robot", o->robot, "Robot description YAML")->required();
  sub->add_option("--html", o->html, "HTML file to write")->required()->type_name("FILE");
  sub->add_option("--query", o->query, "Query YAML: goal, friction override and base start pose of the plan");
  sub->add_option("--env-resolution", o->env_resolution, "Override the environment's octree resolution (m)")
      ->check(finitePositive());
  sub->add_option("--max-voxels", o->max_voxels, "Most anatomy surface voxels drawn (coarsened beyond)")
      ->check(CLI::Range(1000, 2000000));
  sub->add_option("--band-waypoints", o->band_waypoints, "Waypoints with a friction band (evenly spaced)")
      ->check(CLI::Range(0, 1000));
  sub->callback([o, &action]() {
    action = [o]() {
      requireHtmlReports(o->html);
      checkOutputPath("--html", o->html,
                      {{"path", o->path}, {"--env", o->env}, {"--robot", o->robot}, {"--query", o->query}});
      const Robot robot = io::loadRobot(o->robot);
      io::Recording rec = io::loadRecording(o->path, robot.size(), false);
      for (const auto& w : rec.warnings)
        if (w.find("unknown column") == std::string::npos) std::cerr << "warning: " << o->path << ": " << w << "\n";
      if (rec.rows() == 0) throw UsageError(o->path + ": the path has no rows");
      // Rows written with rounded values: violations up to kAdmissibilityTolerance are projected
      // (docs/formats.md "Admissibility tolerance"); larger ones name the file, line and row.
      for (int k = 0; k < rec.rows(); ++k) {
        const Admissibility a = projectAdmissible(robot, rec.commands[static_cast<std::size_t>(k)]);
        if (!a)
          throw io::InputError(o->path, rec.lineOf(k), "",
                               "row " + std::to_string(k + 1) + " is not admissible: " + a.message);
      }
      environments::BuildOptions bo;
      if (o->env_resolution > 0) bo.resolution = o->env_resolution;
      environments::Environment environment = environments::loadEnvironment(o->env, bo);
      std::optional<reports::ViewGoal> goal;
      std::shared_ptr<const planner::Context> ctx;
      std::unique_ptr<planner::CtrPlanner> planner;
      if (!o->query.empty()) {
        planner::Query q = planner::loadQuery(o->query);
        q.start = rec.commands.front();
        planner = std::make_unique<planner::CtrPlanner>(q, robot, std::move(environment));
        ctx = planner->context();
        goal = viewGoal(planner->query());
      } else {
        if (environment.targets().size() == 1) {
          reports::ViewGoal g;
          for (int d = 0; d < 3; ++d) g.position[static_cast<std::size_t>(d)] = environment.targets()[0].position[d];
          g.name = environment.targets()[0].name;
          goal = g;
        }
        auto e = std::make_shared<const environments::Environment>(std::move(environment));
        planner::ContextOptions co;
        co.friction.kinematics.record_backbone = true;
        ctx =
            std::make_shared<const planner::Context>(robot, e, co, environments::CollisionOptions::fromEnvironment(*e));
      }
      reports::PlanningViewOptions vo;
      if (planner) {
        // The query's start history (the path's first row is the start configuration).
        const auto start = planner::startCache(*ctx, rec.commands.front(), planner->query().history);
        if (start && start->physics_ok) vo.start = start->hysteresis;
      }
      vo.title = "Path: " + o->path;
      vo.max_voxels = o->max_voxels;
      vo.band_waypoints = o->band_waypoints;
      reports::writeHtml(o->html, reports::planningHtml(*ctx, rec.commands, goal, vo));
      std::cerr << "wrote " << o->html << " (" << rec.rows() << " waypoints)\n";
      return static_cast<int>(kOk);
    };
  });
}

}  // namespace ctr::cli
