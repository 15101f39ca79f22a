// `ctr plan`: friction-aware motion planning of a query, then the replay of its path (`ctr bench`: cmd_bench.cpp).
#include <filesystem>
#include <iostream>
#include <sstream>

#include "commands.hpp"
#include "ctr/io/file.hpp"
#include "ctr/planner/planner.hpp"
#include "ctr/planner/result_json.hpp"
#include "html_report.hpp"
#include "output.hpp"

namespace ctr::cli {

void registerPlan(CLI::App& app, Action& action) {
  struct Opts {
    std::string query, json, path, planner, mode, html;
    double time = 0;
    long seed = -1;
    bool cpu_time = false;
  };
  auto o = std::make_shared<Opts>();
  CLI::App* sub = app.add_subcommand("plan", "Plan a query (YAML) with friction-aware validity, then replay the path");
  sub->add_option("query", o->query, "Query YAML (docs/planning.md)")->required();
  addJsonOption(sub, o->json, "the result (also printed on standard output)");
  sub->add_option("--path", o->path, "Write the replayed path CSV (recording columns + hysteresis state)");
  sub->add_option("--html", o->html, "Write the interactive 3D viewer of the replayed path (self-contained HTML)")
      ->type_name("FILE");
  sub->add_option("--planner", o->planner, "Override the query's planner");
  sub->add_option("--mode", o->mode, "Override the mode: exact, robust, frictionless");
  sub->add_option("--time", o->time, "Override the time limit (s)")->check(finitePositive());
  sub->add_option("--seed", o->seed, "Override the seed")->check(CLI::NonNegativeNumber)->type_name("INT");
  sub->add_flag("--cpu-time", o->cpu_time,
                "Time limit and planning time in CPU seconds of the process (reproducible on a loaded machine)");
  sub->callback([o, &action]() {
    action = [o]() {
      checkOutputTarget("--json", o->json, {{"query", o->query}});
      checkOutputPath("--path", o->path, {{"query", o->query}, {"--json", o->json}});
      requireHtmlReports(o->html);
      checkOutputPath("--html", o->html, {{"query", o->query}, {"--json", o->json}, {"--path", o->path}});
      planner::Query q = planner::loadQuery(o->query);
      if (!o->mode.empty()) q.mode = planner::parseMode(o->mode);
      if (!o->planner.empty()) q.planner = o->planner;
      if (o->time > 0) q.time_limit = o->time;
      if (o->seed >= 0) q.seed = static_cast<std::uint64_t>(o->seed);
      if (o->cpu_time) q.cpu_time_limit = true;
      for (const std::string& e : q.uncertainty_skipped)
        std::cerr << "note: " << q.robot_uncertainty << ": " << e
                  << " is not a range the planner holds (friction and drives); planned at the robot's value\n";
      planner::CtrPlanner p(q);
      p.checkStart();
      p.makePlanner(q.planner);  // unknown planner: usage error before planning
      std::cerr << "planning '" << q.name << "' (" << planner::toString(q.mode) << ", " << q.planner << ", "
                << q.time_limit << " s)...\n";
      const planner::PlanResult r = p.solve();
      const std::string j = planner::resultJson(q, r);
      std::cout << j << "\n";
      if (o->json != kStandardOutput) writeOutput(o->json, j + "\n");
      if (!o->path.empty() && !r.replay.points.empty())
        io::writeFileAtomic(o->path, planner::replayCsv(p.context()->robot(), r.replay));
#ifdef CTR_WITH_REPORTS
      if (!o->html.empty()) {
        std::vector<Configuration> wps;
        for (const auto& pt : r.replay.points) wps.push_back(pt.q);
        if (wps.empty()) wps = r.path;
        if (wps.empty()) wps.push_back(p.query().start);  // projected onto the admissible set
        reports::PlanningViewOptions vo;
        vo.title = "Plan: " + q.name + " (" + planner::toString(q.mode) + ")";
        vo.info_json = planner::resultJson(q, r, -1);
        const auto start = planner::startCache(*p.context(), p.query().start, q.history);
        if (start && start->physics_ok) vo.start = start->hysteresis;
        // p.query(): the goal with a named target resolved to its position in the environment.
        reports::writeHtml(o->html, reports::planningHtml(*p.context(), wps, viewGoal(p.query()), vo));
        std::cerr << "wrote " << o->html << "\n";
      }
#endif
      if (r.range_replay)
        std::cerr << "replayed at " << r.range_replay->corners << " corners and " << r.range_replay->samples
                  << " samples of the ranges: " << r.range_replay->clean << " clean\n";
      if (r.final_approach) {
        std::cerr << "the path ends with a final approach (every contact slips; docs/planning.md \"Final approach\"): "
                     "tube rotations";
        for (int i = 0; i < r.final_approach->size(); ++i) std::cerr << " " << r.final_approach->alpha[i];
        std::cerr << " rad\n";
      }
      if (!r.solved) {
        std::cerr << "not solved: " << r.message << "\n";
        return static_cast<int>(kRuntimeFailure);
      }
      return static_cast<int>(kOk);
    };
  });
}

}  // namespace ctr::cli
