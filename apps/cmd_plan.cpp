// `ctr plan` and `ctr bench`: friction-aware motion planning of a query, and OMPL benchmarks of planners.
#include <ompl/tools/benchmark/Benchmark.h>

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

// Checks the start before planning: an invalid start is bad input (exit 2).
void checkStart(const plan::CtrPlanner& p) {
  const plan::Context& ctx = *p.context();
  plan::ThreadScratch& t = plan::scratch();
  const plan::Query& q = p.query();
  const std::shared_ptr<const plan::StateCache> c = plan::startCache(ctx, q.start, q.history);
  if (!c->solution.converged()) throw io::InputError(q.file, q.lineOf("start"), "start", "the model does not converge at the start: " + c->why);
  const plan::ShapeCheck sc = plan::checkShape(ctx, c->solution, t);
  if (!sc.ok) throw io::InputError(q.file, q.lineOf("start"), "start", "start configuration is invalid: " + sc.reason);
}

}  // namespace

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
      checkStart(p);
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

  struct BenchOpts {
    std::string query, planners, out, mode;
    int runs = 10;
    double time = 5;
  };
  auto b = std::make_shared<BenchOpts>();
  CLI::App* bs = app.add_subcommand("bench", "Benchmark planners on a query with ompl::tools::Benchmark (+ replay)");
  bs->add_option("query", b->query, "Query YAML")->required();
  bs->add_option("--mode", b->mode, "Override the mode: exact, robust, frictionless");
  bs->add_option("--planners", b->planners, "Comma-separated planner names (default: the query's)");
  bs->add_option("--runs", b->runs, "Runs per planner")->check(finitePositive());
  bs->add_option("--time", b->time, "Time limit per run (s)")->check(finitePositive());
  bs->add_option("--out", b->out, "Output folder (OMPL .log + summary.json)")->required();
  bs->callback([b, &action]() {
    action = [b]() {
      {
        std::error_code ec;
        if (std::filesystem::exists(b->out, ec) && !std::filesystem::is_directory(b->out, ec))
          throw UsageError("--out: '" + b->out + "' exists and is not a folder");
      }
      plan::Query q = plan::loadQuery(b->query);
      if (!b->mode.empty()) q.mode = plan::parseMode(b->mode);
      plan::CtrPlanner p(q);
      checkStart(p);
      std::vector<std::string> names;
      if (b->planners.empty()) {
        names.push_back(q.planner);
      } else {
        std::stringstream ss(b->planners);
        std::string x;
        while (std::getline(ss, x, ',')) names.push_back(x);
      }
      std::vector<ompl::base::PlannerPtr> planners;
      for (const auto& n : names) planners.push_back(p.makePlanner(n));  // throws for unknown names (exit 2)
      // Goal configurations for sampleable tip goals (RRTConnect, PRM, BIT* need them), found once before the runs.
      const std::size_t pool = p.prepareGoal(b->time);
      if (q.tip_goal && pool == 0) std::cerr << "warning: no goal configuration found by IK; planners can only reach the goal region by chance\n";
      std::filesystem::create_directories(b->out);
      nlohmann::json summary = nlohmann::json::array();
      std::map<std::string, nlohmann::json> per;
      auto post = [&p, &per](const ompl::base::PlannerPtr& planner, ompl::tools::Benchmark::RunProperties& run) {
        const bool has = run.count("solved BOOLEAN") && run["solved BOOLEAN"] == "1";
        auto& s = per[planner->getName()];
        if (s.is_null()) s = nlohmann::json::object();
        s["runs"] = s.value("runs", 0) + 1;
        if (!has) return;
        const plan::PlanResult r = p.replaySolution(planner->getName(), std::stod(run["time REAL"]), true);
        run["replay_solved BOOLEAN"] = r.solved ? "1" : "0";
        run["replay_collision_free BOOLEAN"] = r.replay.collision_free ? "1" : "0";
        run["replay_snaps INTEGER"] = std::to_string(r.replay.snaps);
        run["replay_tip_error REAL"] = std::to_string(r.replay.tip_error);
        run["replay_min_clearance REAL"] = std::to_string(r.replay.min_clearance);
        s["planner_solved"] = s.value("planner_solved", 0) + 1;
        s["replay_solved"] = s.value("replay_solved", 0) + (r.solved ? 1 : 0);
        s["replay_failures"] = s.value("replay_failures", 0) + (r.solved ? 0 : 1);
        s["time_sum"] = s.value("time_sum", 0.0) + std::stod(run["time REAL"]);
        s["path_length_sum"] = s.value("path_length_sum", 0.0) + r.path_length;
      };
      ompl::tools::Benchmark::Request req(b->time, 4096.0, static_cast<unsigned int>(b->runs), 0.5, true, false, false);
      std::string logfile = (std::filesystem::path(b->out) / (q.name + "_" + plan::toString(q.mode) + ".log")).string();
      if (p.geometricSetup()) {
        ompl::tools::Benchmark bench(*p.geometricSetup(), q.name);
        for (auto& pl : planners) bench.addPlanner(pl);
        bench.setPostRunEvent(post);
        bench.benchmark(req);
        bench.saveResultsToFile(logfile.c_str());
      } else {
        ompl::tools::Benchmark bench(*p.controlSetup(), q.name);
        for (auto& pl : planners) bench.addPlanner(pl);
        bench.setPostRunEvent(post);
        bench.benchmark(req);
        bench.saveResultsToFile(logfile.c_str());
      }
      for (auto& [name, s] : per) {
        const int runs = s.value("runs", 0), solved = s.value("planner_solved", 0);
        nlohmann::json row = {{"planner", name},
                              {"mode", plan::toString(q.mode)},
                              {"runs", runs},
                              {"planner_success_rate", runs ? double(solved) / runs : 0.0},
                              {"replay_success_rate", runs ? double(s.value("replay_solved", 0)) / runs : 0.0},
                              {"replay_failures", s.value("replay_failures", 0)},
                              {"mean_time_to_solution", solved ? s.value("time_sum", 0.0) / solved : 0.0},
                              {"mean_path_length", solved ? s.value("path_length_sum", 0.0) / solved : 0.0}};
        summary.push_back(row);
      }
      io::writeFileAtomic((std::filesystem::path(b->out) / "summary.json").string(), summary.dump(2) + "\n");
      std::cout << summary.dump(2) << "\n" << "OMPL log: " << logfile << "\n";
      return static_cast<int>(kOk);
    };
  });
}

}  // namespace ctr::cli
