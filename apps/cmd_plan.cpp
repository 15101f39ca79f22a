// `ctr plan`: friction-aware motion planning of a query, then the replay of its path (`ctr bench`: cmd_bench.cpp).
#include <filesystem>
#include <iostream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "commands.hpp"
#include "ctr/io/recording.hpp"
#include "ctr/planner/planner.hpp"
#include "html_report.hpp"
#include "output.hpp"

namespace ctr::cli {
namespace {

nlohmann::json resultJson(const plan::Query& q, const plan::PlanResult& r) {
  nlohmann::json j;
  j["query"] = q.name;
  j["solved"] = r.solved;
  j["planner_solved"] = r.planner_solved;
  j["mode"] = plan::toString(r.mode);
  j["planner"] = r.planner;
  j["planning_time"] = r.planning_time;
  j["planning_wall_time"] = r.planning_wall_time;
  j["time_limit_clock"] = q.cpu_time_limit ? "cpu" : "wall";
  j["replay_time"] = r.replay_time;
  j["path_length"] = r.path_length;
  j["waypoints"] = r.path.size();
  j["goal_pool"] = r.goal_pool;
  j["replay"] = {{"completed", r.replay.completed},
                 {"collision_free", r.replay.collision_free},
                 {"stable", r.replay.stable},
                 {"goal_reached", r.replay.goal_reached},
                 {"tip_error", r.replay.tip_error},
                 {"direction_error", r.replay.direction_error},
                 {"min_clearance", r.replay.min_clearance},
                 {"steps", r.replay.steps},
                 {"collisions", r.replay.collisions},
                 {"snaps", r.replay.snaps},
                 {"first_failure", r.replay.first_failure}};
  if (!r.message.empty()) j["message"] = r.message;
  return j;
}

}  // namespace

// Checks the start before planning: an invalid start is bad input (exit 2).
void checkPlanStart(const plan::CtrPlanner& p) {
  const plan::Context& ctx = *p.context();
  plan::ThreadScratch& t = plan::scratch();
  const plan::Query& q = p.query();
  const std::shared_ptr<const plan::StateCache> c = plan::startCache(ctx, q.start, q.history);
  if (!c->solution.converged()) throw io::InputError(q.file, q.lineOf("start"), "start", "the model does not converge at the start: " + c->why);
  const plan::ShapeCheck sc = plan::checkShape(ctx, c->solution, t);
  if (!sc.ok) throw io::InputError(q.file, q.lineOf("start"), "start", "start configuration is invalid: " + sc.reason);
}

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
  sub->add_option("--json", o->json, "Write the result as JSON");
  sub->add_option("--path", o->path, "Write the replayed path CSV (recording columns + hysteresis state)");
  sub->add_option("--html", o->html, "Write the interactive 3D viewer of the replayed path (self-contained HTML)");
  sub->add_option("--planner", o->planner, "Override the query's planner");
  sub->add_option("--mode", o->mode, "Override the mode: exact, robust, frictionless");
  sub->add_option("--time", o->time, "Override the time limit (s)")->check(finitePositive());
  sub->add_option("--seed", o->seed, "Override the seed")->check(finiteNonNegative());
  sub->add_flag("--cpu-time", o->cpu_time, "Time limit and planning time in CPU seconds of the process (reproducible on a loaded machine)");
  sub->callback([o, &action]() {
    action = [o]() {
      checkOutputPath("--json", o->json, {{"query", o->query}});
      checkOutputPath("--path", o->path, {{"query", o->query}, {"--json", o->json}});
      requireHtmlReports(o->html);
      checkOutputPath("--html", o->html, {{"query", o->query}, {"--json", o->json}, {"--path", o->path}});
      plan::Query q = plan::loadQuery(o->query);
      if (!o->mode.empty()) q.mode = plan::parseMode(o->mode);
      if (!o->planner.empty()) q.planner = o->planner;
      if (o->time > 0) q.time_limit = o->time;
      if (o->seed >= 0) q.seed = static_cast<std::uint64_t>(o->seed);
      if (o->cpu_time) q.cpu_time_limit = true;
      plan::CtrPlanner p(q);
      checkPlanStart(p);
      p.makePlanner(q.planner);  // unknown planner: usage error before planning
      std::cerr << "planning '" << q.name << "' (" << plan::toString(q.mode) << ", " << q.planner << ", "
                << q.time_limit << " s)...\n";
      const plan::PlanResult r = p.solve();
      const nlohmann::json j = resultJson(q, r);
      std::cout << j.dump(2) << "\n";
      if (!o->json.empty()) io::writeFileAtomic(o->json, j.dump(2) + "\n");
      if (!o->path.empty() && !r.replay.points.empty())
        io::writeFileAtomic(o->path, plan::replayCsv(p.context()->robot(), r.replay));
#ifdef CTR_WITH_REPORTS
      if (!o->html.empty()) {
        std::vector<Configuration> wps;
        for (const auto& pt : r.replay.points) wps.push_back(pt.q);
        if (wps.empty()) wps = r.path;
        if (wps.empty()) wps.push_back(p.query().start);  // projected onto the admissible set
        reports::PlanningViewOptions vo;
        vo.title = "Plan: " + q.name + " (" + plan::toString(q.mode) + ")";
        vo.info_json = j.dump();
        const auto start = plan::startCache(*p.context(), p.query().start, q.history);
        if (start && start->physics_ok) vo.start = start->hysteresis;
        reports::writeHtml(o->html, reports::planningHtml(*p.context(), wps, viewGoal(q), vo));
        std::cerr << "wrote " << o->html << "\n";
      }
#endif
      if (!r.solved) {
        std::cerr << "not solved: " << r.message << "\n";
        return static_cast<int>(kRuntimeFailure);
      }
      return static_cast<int>(kOk);
    };
  });
}

}  // namespace ctr::cli
