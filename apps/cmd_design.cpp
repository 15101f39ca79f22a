// `ctr design`: patient-specific robot design for one or several planning queries (docs/design.md); `ctr design
// merge` joins the shards of a run (--shard I/N, for Slurm job arrays and GNU parallel).
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <limits>
#include <memory>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <utility>
#include <vector>

#include "commands.hpp"
#include "ctr/design/output.hpp"
#include "ctr/design/search.hpp"
#include "ctr/io/file.hpp"
#include "ctr/io/recording.hpp"
#include "ctr/io/robot_yaml.hpp"
#include "html_report.hpp"
#include "progress.hpp"

#ifdef CTR_WITH_REPORTS
#include "ctr/planner/planner.hpp"
#include "ctr/planner/propagator.hpp"
#endif

namespace fs = std::filesystem;

namespace ctr::cli {
namespace {

/// `--html` without a value: the report in the output folder.
const std::string kOutReport = "OUT/report.html";

/// Checks an `--html FILE` value: an .html file name (`--html` takes an optional value, so a query file written after
/// it would otherwise be taken for the report and overwritten).
void checkReportFile(const std::string& html) {
  if (html.empty() || html == kOutReport) return;
  const std::string ext = fs::path(html).extension().string();
  if (ext != ".html" && ext != ".htm")
    throw UsageError("--html: '" + html +
                     "' is not an .html file name (give the queries before --html, or write --html=FILE)");
  checkOutputPath("--html", html);
}

struct DesignOpts {
  std::vector<std::string> queries;
  std::string out, space, shard, planner;
  long seed = 1;
  int starts = 1, evaluations = 40, population = 8, threads = 0, probe_goals = 3, probe_candidates = 400, confirm = 1;
  int finalists = 3, finalist_plans = 8;
  double time = 0.0, probe_time = 2.0, plan_time = 0.0, strain_limit = 0.06, finalist_rate = 0.8;
  bool quiet = false;
  std::string html;  // --html [FILE]: kOutReport without a value
  // merge
  std::vector<std::string> dirs;
  std::string merge_out;
  bool allow_incomplete = false;
};

std::string mm(double v) {
  std::ostringstream o;
  o << std::fixed << std::setprecision(2) << v * 1e3 << " mm";
  return o.str();
}

#ifdef CTR_WITH_REPORTS
/// The report file of `--html` for the output folder `dir`.
fs::path reportFile(const std::string& html, const std::string& dir) {
  return html == kOutReport ? fs::path(dir) / "report.html" : fs::path(html);
}

/// The clearance column of a replayed path (paths/STEM.csv, as `ctr plan --path` writes it: the recording columns
/// plus clearance), one value per row of `rec`, which was read from the same file: NaN where the cell is empty (not
/// computed) or the file has no such column.
std::vector<double> clearanceColumn(const std::string& file, const io::Recording& rec) {
  std::vector<std::string> lines;
  {
    std::istringstream in(io::readFile(file));
    for (std::string l; std::getline(in, l);)
      lines.push_back(!l.empty() && l.back() == '\r' ? l.substr(0, l.size() - 1) : l);
  }
  auto cells = [](const std::string& l) {
    std::vector<std::string> f;
    std::size_t a = 0;
    for (std::size_t b; (b = l.find(',', a)) != std::string::npos; a = b + 1) f.push_back(l.substr(a, b - a));
    f.push_back(l.substr(a));
    return f;
  };
  std::vector<double> out(static_cast<std::size_t>(rec.rows()), std::numeric_limits<double>::quiet_NaN());
  const std::vector<std::string> header = lines.empty() ? std::vector<std::string>{} : cells(lines.front());
  const auto col = std::find(header.begin(), header.end(), "clearance");
  if (col == header.end()) return out;
  const std::size_t c = static_cast<std::size_t>(col - header.begin());
  for (int r = 0; r < rec.rows(); ++r) {
    const int line = rec.lineOf(r);
    const std::vector<std::string> f = cells(lines.at(static_cast<std::size_t>(line - 1)));
    if (c >= f.size() || f[c].empty()) continue;
    char* end = nullptr;
    const double v = std::strtod(f[c].c_str(), &end);
    if (end != f[c].c_str() + f[c].size())
      throw io::InputError(file, line, "clearance", "'" + f[c] + "' is not a number");
    out[static_cast<std::size_t>(r)] = v;
  }
  return out;
}

/// `report` (the design report of the design written in DIR) and viewers/STEM.html beside it (the planning viewer of
/// each designed plan). Every page is built before any is written: a report that fails (a path or query file the
/// result refers to is unreadable) writes none and says that the design result itself was kept.
void buildDesignReport(const std::string& dir, const fs::path& report,
                       std::vector<std::pair<fs::path, std::string>>& pages) {
  const std::string result_file = (fs::path(dir) / "result.json").string();
  const std::string result = io::readFile(result_file);
  const nlohmann::json j = nlohmann::json::parse(result);
  std::vector<reports::DesignPathPlot> plots;
  for (const auto& q : j["queries"]) {
    const std::string name = q.value("query", std::string());
    const std::string stem = design::queryFileStem(name);
    const fs::path csv = fs::path(dir) / "paths" / (stem + ".csv");
    if (!fs::exists(csv)) continue;
    // The path's rows through the recording reader (docs/formats.md "Planned path"; file, line and column in its
    // errors).
    const fs::path qfile = fs::path(dir) / "queries" / (stem + ".yaml");
    std::unique_ptr<planner::CtrPlanner> designed;
    if (fs::exists(qfile)) designed = std::make_unique<planner::CtrPlanner>(planner::loadQuery(qfile.string()));
    io::Recording rec = io::loadRecording(csv.string(), designed ? designed->context()->robot().size() : -1, false);
    if (!rec.hasTipPosition()) throw io::InputError(csv.string(), 1, "tip_x", "missing (not a replayed path)");
    reports::DesignPathPlot p;
    p.query = name;
    p.clearance = clearanceColumn(csv.string(), rec);
    double travel = 0.0;
    for (int k = 0; k < rec.rows(); ++k) {
      if (k > 0) travel += (rec.tip_position.row(k) - rec.tip_position.row(k - 1)).norm();
      p.tip_travel.push_back(travel);
    }
    // The viewer: the designed query (queries/STEM.yaml) and the path's joint values (rounded values projected onto
    // the admissible set as `ctr view` does; larger violations name the row).
    if (designed) {
      const planner::Query& pq = designed->query();
      for (int k = 0; k < rec.rows(); ++k) {
        const Admissibility a =
            projectAdmissible(designed->context()->robot(), rec.commands[static_cast<std::size_t>(k)]);
        if (!a)
          throw io::InputError(csv.string(), rec.lineOf(k), "",
                               "row " + std::to_string(k + 1) + " is not admissible: " + a.message);
      }
      reports::PlanningViewOptions vo;
      vo.title = "Design: " + name + " (" + planner::toString(pq.mode) + ")";
      if (q.contains("plan") && !q["plan"].is_null()) vo.info_json = q["plan"].dump();
      const auto start = planner::startCache(*designed->context(), pq.start, pq.history);
      if (start && start->physics_ok) vo.start = start->hysteresis;
      pages.emplace_back(report.parent_path() / "viewers" / (stem + ".html"),
                         reports::planningHtml(*designed->context(), rec.commands, viewGoal(pq), vo));
      p.viewer = "viewers/" + stem + ".html";
    }
    plots.push_back(std::move(p));
  }
  std::string title = "Robot design";
  for (const auto& q : j["queries"]) title += (&q == &j["queries"].front() ? ": " : ", ") + q.value("query", "");
  pages.emplace_back(report, reports::designHtml(result, plots, title));
}

void writeDesignReport(const std::string& dir, const fs::path& report) {
  std::vector<std::pair<fs::path, std::string>> pages;
  const std::string kept = " (" + (fs::path(dir) / "result.json").string() + " and the paths were written; no report)";
  try {
    buildDesignReport(dir, report, pages);
  } catch (const io::InputError& e) {
    throw io::InputError(e.file(), e.line(), e.key(), e.message() + kept);
  } catch (const std::exception& e) {
    throw std::runtime_error(std::string("design report: ") + e.what() + kept);
  }
  for (const auto& [path, html] : pages) {
    if (path.has_parent_path()) fs::create_directories(path.parent_path());
    reports::writeHtml(path.string(), html);
  }
  std::cerr << "wrote " << report.string() << "\n";
}
#endif

int runDesign(const DesignOpts& o, const CLI::App* sub) {
  if (o.queries.empty()) throw UsageError("design: one or more query files are required (or `ctr design merge`)");
  if (o.out.empty()) throw UsageError("--out is required");
  {
    std::error_code ec;
    if (fs::exists(o.out, ec) && !fs::is_directory(o.out, ec))
      throw UsageError("--out: '" + o.out + "' exists and is not a folder");
    for (const std::string& q : o.queries)
      if (fs::exists(o.out, ec) && fs::equivalent(q, o.out, ec)) throw UsageError("--out: is the query " + q);
  }
  if (sub->count("--strain-limit") && !o.space.empty())
    throw UsageError("--strain-limit: set strain_limit in the design space file (" + o.space + ")");
  if (o.strain_limit > 0.2) throw UsageError("--strain-limit: must be a fraction (0.06 is 6 %)");
  if (!o.html.empty()) {
    if (!o.shard.empty()) throw UsageError("--html: a shard has no report of its own; use `ctr design merge --html`");
    requireHtmlReports(o.html);
    checkReportFile(o.html);
  }
  design::DesignOptions d;
  d.seed = static_cast<std::uint64_t>(o.seed);
  d.starts = o.starts;
  d.evaluations = o.evaluations;
  d.population = o.population;
  d.time_limit = o.time;
  d.threads = o.threads;
  d.probe_time = o.probe_time;
  d.probe_goals = o.probe_goals;
  d.probe_candidates = o.probe_candidates;
  d.plan_time = o.plan_time;
  d.planner = o.planner;
  d.confirm_seeds = o.confirm;
  d.finalists = o.finalists;
  d.finalist_plans = o.finalist_plans;
  d.finalist_rate = o.finalist_rate;
  campaign::Shard shard;
  if (!o.shard.empty()) {
    shard = parseShardOption(o.shard);
    for (int s = static_cast<int>(shard.index); s < o.starts; s += static_cast<int>(shard.count))
      d.start_indices.push_back(s);
    if (d.start_indices.empty())
      throw UsageError("--shard " + o.shard + ": no start for this shard (--starts " + std::to_string(o.starts) +
                       " < shard count)");
  }
  const std::string shard_label = shard.label();
  // Every input is checked before any work or output.
  std::vector<planner::Query> queries;
  std::set<std::string> names;
  for (const std::string& f : o.queries) {
    planner::Query q = planner::loadQuery(f);
    if (!names.insert(q.name).second)
      throw io::InputError(f, q.lineOf("name"), "name", "two queries are named '" + q.name + "'");
    if (!o.planner.empty()) {
      const auto known = planner::plannerNames(q.mode);
      if (o.planner != "default" && std::find(known.begin(), known.end(), o.planner) == known.end())
        throw UsageError("--planner: unknown planner '" + o.planner + "' for mode " + planner::toString(q.mode) +
                         " of " + f);
    }
    queries.push_back(std::move(q));
  }
  std::optional<design::DesignSpace> space;
  if (!o.space.empty()) space = design::loadSpace(o.space);
  std::cerr << "design: loading " << queries.size() << " quer" << (queries.size() > 1 ? "ies" : "y") << "...\n";
  std::optional<design::Designer> designer;
  if (space) {
    designer.emplace(queries, space);
  } else {
    const Robot base = io::loadRobot(queries.front().robot);
    try {
      designer.emplace(queries, design::defaultSpace(base, o.strain_limit));
    } catch (const std::invalid_argument& e) {
      throw io::InputError(queries.front().robot, 0, "", e.what());
    }
  }
  const auto& sp = designer->space();
  std::cerr << "design: space '" << sp.name << "': " << sp.tubes.size() << " tubes, " << sp.size_combinations().size()
            << " size combination(s), strain limit " << sp.strain_limit * 100 << " %; "
            << d.start_indices.size() + (d.start_indices.empty() ? static_cast<std::size_t>(o.starts) : 0)
            << " start(s) x " << o.evaluations << " candidates, " << o.population << " per generation"
            << (o.time > 0 ? ", time limit " + Progress::duration(o.time) : std::string()) << "\n";
  const std::size_t nstarts = d.start_indices.empty() ? static_cast<std::size_t>(o.starts) : d.start_indices.size();
  Progress progress("design" + (shard.count > 1 ? " shard " + shard_label : std::string()),
                    nstarts * static_cast<std::size_t>(o.evaluations), "candidates", o.quiet);
  d.progress = [&progress](std::size_t done, std::size_t total, const std::string& detail) {
    if (total != progress.total()) progress.setTotal(total);  // the finalists' independent plans follow the search
    progress.setDetail(detail);
    progress.set(done);
  };
  const design::DesignResult r = designer->run(d);
  progress.finish();
  const std::string dir = shard.count > 1
                              ? (fs::path(o.out) / "shards" /
                                 ("shard-" + std::to_string(shard.index) + "-of-" + std::to_string(shard.count)))
                                    .string()
                              : o.out;
  design::writeDesign(*designer, r, d, shard_label, dir);
#ifdef CTR_WITH_REPORTS
  if (!o.html.empty()) writeDesignReport(dir, reportFile(o.html, dir));
#endif
  // Summary on stdout.
  std::cout << (r.solved ? "solved" : "not solved") << ": " << r.message << "\n";
  std::cout << r.evaluations.size() << " candidates evaluated in " << Progress::duration(r.wall_time)
            << (r.budget_exhausted ? " (time limit reached)" : "") << "\n";
  if (r.best) {
    for (std::size_t i = 0; i < r.best->candidate.tubes.size(); ++i) {
      const auto& t = r.best->candidate.tubes[i];
      std::cout << "  tube '" << sp.tubes[i].name << "': straight " << mm(t.straight_length) << ", curved "
                << mm(t.curved_length) << ", curvature " << t.curvature << " 1/m, size "
                << sp.catalogue[static_cast<std::size_t>(t.size)].name << ", strain " << std::setprecision(3)
                << design::strain(sp, r.best->candidate, static_cast<int>(i)) * 100 << " %\n";
    }
    for (std::size_t k = 0; k < r.best->queries.size(); ++k) {
      const auto& q = r.best->queries[k];
      std::cout << "  query '" << designer->queries()[k].name << "': " << design::toString(q.stage);
      if (q.stage == design::QueryOutcome::Stage::Solved)
        std::cout << " (" << q.plans_solved << "/" << q.plans << " plans clean, min clearance " << mm(q.min_clearance)
                  << ")";
      else
        std::cout << " (" << q.message << ")";
      if (!q.confirmation.empty())
        std::cout << "; independent plans: " << q.confirmationSolved() << "/" << q.confirmation.size()
                  << " solved with a clean replay";
      std::cout << "\n";
    }
    if (r.best->score.confirmed())
      std::cout << "  success rate of the independent plans: " << std::lround(r.best->score.success_rate * 100)
                << " % (" << r.confirmation_seeds.size() << " seeds per query; required "
                << std::lround(d.finalist_rate * 100) << " %), best of " << r.finalists.size() << " finalist(s)\n";
  }
  std::cout << "wrote " << dir << "/result.json" << (r.best ? ", robot.yaml, queries/, paths/" : "") << "\n";
  return r.solved ? kOk : kRuntimeFailure;
}

}  // namespace

void registerDesign(CLI::App& app, Action& action) {
  auto o = std::make_shared<DesignOpts>();
  CLI::App* sub = app.add_subcommand(
      "design",
      "Design a robot for one or several queries (docs/design.md): search a design space, scoring each candidate by "
      "a goal probe and a friction-aware plan whose replay must be clean; `ctr design merge` joins --shard outputs");
  sub->add_option("queries", o->queries, "Query YAML files (one design for all)");
  sub->add_option("--out", o->out, "Output folder: robot.yaml, result.json, queries/, paths/, space.yaml")
      ->type_name("DIR");
  sub->add_option("--space", o->space, "Design space YAML (default: derived from the first query's robot)");
  sub->add_option("--strain-limit", o->strain_limit, "Default space: largest precurvature x outer radius (0.06)")
      ->check(finitePositive());
  sub->add_option("--seed", o->seed, "Seed of the search (default 1)")->check(CLI::NonNegativeNumber)->type_name("INT");
  sub->add_option("--starts", o->starts, "Independent searches (restarts); --shard splits them (default 1)")
      ->check(CLI::Range(1, 100000));
  sub->add_option("--evaluations", o->evaluations, "Candidates per start (default 40)")->check(CLI::Range(1, 1000000));
  sub->add_option("--population", o->population,
                  "Candidates (gaco's ants) per generation, evaluated in parallel (default 8)")
      ->check(CLI::Range(2, 10000));
  sub->add_option("--time", o->time, "Wall-clock budget of the run in s (default: none)")->check(finitePositive());
  sub->add_option("--threads", o->threads, "Candidates evaluated at once (default: the machine's cores)")
      ->type_name("INT")
      ->check(CLI::Range(1, 1024));
  sub->add_option("--probe-time", o->probe_time, "Goal probe per query and candidate, s (default 2)")
      ->check(finitePositive());
  sub->add_option("--probe-goals", o->probe_goals, "The probe stops after this many valid goals (default 3)")
      ->check(CLI::Range(1, 100000));
  sub->add_option("--probe-candidates", o->probe_candidates,
                  "Inverse-kinematics attempts of the probe at most (default 400)")
      ->check(CLI::Range(1, 10000000));
  sub->add_option("--plan-time", o->plan_time, "Planning time limit per query, s (default: the query's)")
      ->check(finitePositive());
  sub->add_option("--planner", o->planner, "Override the queries' planner");
  sub->add_option("--confirm", o->confirm, "Further plans (other seeds) a solved candidate must pass (default 1)")
      ->check(CLI::Range(0, 100));
  sub->add_option("--finalists", o->finalists,
                  "Best candidates planned again with independent seeds after the search, ranked by their success "
                  "rate; the design kept is the best of them (default 3, 0: none)")
      ->check(CLI::Range(0, 1000));
  sub->add_option("--finalist-plans", o->finalist_plans,
                  "Independent plans per finalist and query, with the written query's settings (default 8)")
      ->check(CLI::Range(0, 1000));
  sub->add_option("--finalist-rate", o->finalist_rate,
                  "Success rate of the independent plans the kept design needs to count as solved (default 0.8)")
      ->check(CLI::Range(0.0, 1.0));
  sub->add_option("--shard", o->shard, "Run starts I, I+N, ... of --starts (0 <= I < N) into OUT/shards/");
  sub->add_flag("--quiet", o->quiet, "No progress on stderr");
  sub->add_option("--html", o->html,
                  "Write the report (the design against the query's robot, the search, clearance along the paths) to "
                  "FILE (without a value: OUT/report.html) and the viewer of each designed plan to viewers/QUERY.html "
                  "beside it")
      ->expected(0, 1)
      ->default_str(kOutReport)
      ->type_name("[FILE]");
  CLI::App* ms = sub->add_subcommand(
      "merge", "Join the shards of a design run: the best design over every shard, with its robot, plans and paths");
  ms->add_option("dirs", o->dirs, "Output folders of `ctr design ... --shard I/N --out DIR`")->required();
  ms->add_option("--out", o->merge_out, "Folder for robot.yaml, result.json, queries/, paths/")
      ->required()
      ->type_name("DIR");
  ms->add_flag("--allow-incomplete", o->allow_incomplete, "Merge the shards that are there (missing ones listed)");
  ms->add_option("--html", o->html,
                 "Write the report to FILE (without a value: OUT/report.html), as `ctr design --html`")
      ->expected(0, 1)
      ->default_str(kOutReport)
      ->type_name("[FILE]");
  ms->callback([o, &action]() {
    action = [o]() {
      std::error_code ec;
      if (fs::exists(o->merge_out, ec) && !fs::is_directory(o->merge_out, ec))
        throw UsageError("--out: '" + o->merge_out + "' exists and is not a folder");
      if (!o->html.empty()) requireHtmlReports(o->html);
      checkReportFile(o->html);
      const std::string text = design::mergeDesigns(o->dirs, o->merge_out, o->allow_incomplete);
#ifdef CTR_WITH_REPORTS
      if (!o->html.empty()) writeDesignReport(o->merge_out, reportFile(o->html, o->merge_out));
#endif
      const auto j = nlohmann::json::parse(text);
      std::cout << (j.value("solved", false) ? "solved" : "not solved") << ": " << j.value("message", "") << "\n";
      std::cout << j["evaluations"].size() << " candidates from " << j["shards"].size() << " shard(s); wrote "
                << o->merge_out << "/result.json\n";
      return j.value("solved", false) ? static_cast<int>(kOk) : static_cast<int>(kRuntimeFailure);
    };
  });
  sub->callback([o, sub, ms, &action]() {
    if (ms->parsed()) return;
    action = [o, sub]() { return runDesign(*o, sub); };
  });
}

}  // namespace ctr::cli
