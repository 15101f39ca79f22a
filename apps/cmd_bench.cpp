// `ctr bench`: OMPL benchmarks of planners (ompl::tools::Benchmark) with every solution replayed through the
// friction model. Input: one query (planners / runs / time on the command line), or a campaign file (queries x
// planners x modes x seeds; `--shard i/N` runs a deterministic part, for Slurm job arrays and GNU parallel).
// `ctr bench merge DIR... --out OUT` checks that a campaign is complete and writes the Planner Arena database
// (OMPL's ompl_benchmark_statistics), summary.json and an HTML report. The work is done by ctr::campaign
// (campaign/); this file is its command line.
#include <filesystem>
#include <iostream>
#include <memory>
#include <sstream>
#include <stdexcept>

#include "commands.hpp"
#include "ctr/campaign/campaign.hpp"
#include "ctr/campaign/merge.hpp"
#include "ctr/campaign/run.hpp"
#include "ctr/planner/query.hpp"
#include "html_report.hpp"
#include "progress.hpp"

namespace fs = std::filesystem;

namespace ctr::cli {
namespace {

struct BenchOpts {
  std::string input, planners, out, mode, shard;
  int runs = 10;
  double time = 5;
  bool quiet = false;
  // merge
  std::vector<std::string> dirs;
  std::string merge_out, html;
  bool allow_incomplete = false;
};

// The progress line of `ctr bench` (stderr), driven by the library's observer calls.
class ProgressObserver : public campaign::RunObserver {
 public:
  ProgressObserver(std::string what, bool quiet) : what_(std::move(what)), quiet_(quiet) {}
  void started(std::size_t runs, std::size_t kept_runs) override {
    progress_ = std::make_unique<Progress>(what_, runs, "runs", quiet_);
    progress_->advance(kept_runs);
  }
  void unitStarted(const campaign::CampaignUnit& unit) override {
    if (progress_) progress_->setDetail(unit.id());
  }
  void runFinished() override {
    if (progress_) progress_->advance();
  }
  void warning(const std::string& text) override { std::cerr << "warning: " << text << "\n"; }
  void finish() {
    if (!progress_) return;
    progress_->setDetail("");
    progress_->finish();
  }

 private:
  std::string what_;
  bool quiet_;
  std::unique_ptr<Progress> progress_;
};

int benchQuery(const BenchOpts& b) {
  planner::Query q = planner::loadQuery(b.input);
  if (!b.mode.empty()) q.mode = planner::parseMode(b.mode);
  campaign::BenchmarkOptions options;
  if (!b.planners.empty()) {
    std::stringstream ss(b.planners);
    std::string x;
    while (std::getline(ss, x, ',')) options.planners.push_back(x);
  }
  options.runs = b.runs;
  options.time_limit = b.time;
  options.out = b.out;
  ProgressObserver progress("bench " + q.name, b.quiet);
  options.observer = &progress;
  const campaign::BenchmarkSummary summary = campaign::benchmarkQuery(q, options);
  progress.finish();
  std::cout << summary.toJson() << "\n"
            << "OMPL log: " << summary.log << "\n";
  return kOk;
}

int benchCampaign(const BenchOpts& b) {
  for (const auto& [opt, given] :
       {std::pair<std::string, bool>{"--planners", !b.planners.empty()}, {"--mode", !b.mode.empty()}})
    if (given) throw UsageError(opt + ": not used with a campaign file (set it in " + b.input + ")");
  const campaign::Campaign c = campaign::loadCampaign(b.input);
  campaign::RunOptions options;
  if (!b.shard.empty()) options.shard = parseShardOption(b.shard);
  options.out = b.out;
  const std::string shard_label = options.shard.label();
  class Announcing : public ProgressObserver {
   public:
    Announcing(const campaign::Campaign& c, const BenchOpts& b, const std::string& label)
        : ProgressObserver("bench shard " + label, b.quiet), c_(c), b_(b), label_(label) {}
    void started(std::size_t runs, std::size_t kept_runs) override {
      if (!b_.quiet) {
        const auto per_unit = static_cast<std::size_t>(c_.runs_per_seed);
        const std::size_t units = runs / per_unit, kept = kept_runs / per_unit;
        std::cerr << "campaign '" << c_.name << "' (" << c_.units().size() << " units x " << c_.runs_per_seed
                  << " runs): shard " << label_ << " has " << units << " units, " << runs << " runs of "
                  << c_.time_limit << " s (" << (c_.cpu_time ? "CPU" : "wall") << ")"
                  << (kept ? ", " + std::to_string(kept) + " units already recorded in " + b_.out : std::string())
                  << "\n";
      }
      ProgressObserver::started(runs, kept_runs);
    }

   private:
    const campaign::Campaign& c_;
    const BenchOpts& b_;
    std::string label_;
  } progress(c, b, shard_label);
  options.observer = &progress;
  const campaign::RunSummary s = campaign::runCampaign(c, options);
  progress.finish();
  std::cout << "shard " << s.shard << ": " << s.units << " units (" << s.units_run.size() << " run, " << s.units_kept
            << " already recorded) in " << Progress::duration(s.seconds) << "; records in " << s.records << "\n";
  return kOk;
}

int benchMerge(const BenchOpts& b) {
  const std::string& html = b.html;
  const std::string& out = b.merge_out;
  requireHtmlReports(html);
  // --html OUT/report.html is fine while OUT does not exist yet (the merge makes it).
  const bool html_in_out = !html.empty() && fs::weakly_canonical(fs::absolute(html).parent_path()) ==
                                                fs::weakly_canonical(fs::absolute(out));
  if (!html_in_out) checkOutputPath("--html", html);
  if (html_in_out && fs::is_directory(html)) throw UsageError("--html: '" + html + "' is a folder");
  {
    std::error_code ec;
    if (fs::exists(out, ec) && !fs::is_directory(out, ec))
      throw UsageError("--out: '" + out + "' exists and is not a folder");
  }
  campaign::MergeOptions options;
  options.allow_incomplete = b.allow_incomplete;
  const campaign::MergeSummary s = campaign::mergeCampaign(b.dirs, out, options);
  for (const auto& m : s.missing) std::cerr << "warning: missing " << m << " (--allow-incomplete)\n";
#ifdef CTR_WITH_REPORTS
  if (!html.empty()) reports::writeHtml(html, reports::benchHtml(s.summary_json, "Benchmark campaign: " + s.campaign));
#endif
  std::cout << "campaign '" << s.campaign << "': " << s.runs << " of " << s.expected_runs << " runs (" << s.units
            << " of " << s.expected_units << " units) from " << b.dirs.size() << " folder(s)\n"
            << "  " << s.database << " (Planner Arena; " << s.experiments.size() << " experiment(s))\n"
            << "  " << s.summary_file << "\n";
  if (!html.empty()) std::cout << "  " << html << "\n";
  return kOk;
}

}  // namespace

void registerBench(CLI::App& app, Action& action) {
  auto b = std::make_shared<BenchOpts>();
  CLI::App* bs = app.add_subcommand(
      "bench",
      "Benchmark planners with ompl::tools::Benchmark (+ replay of every solution): one query, or a campaign file "
      "(queries x planners x modes x seeds; --shard i/N for Slurm arrays / GNU parallel); `ctr bench merge` joins "
      "the shards into a Planner Arena database");
  bs->add_option("input", b->input, "Query YAML, or campaign YAML (docs/planning.md \"Benchmark campaigns\")");
  bs->add_option("--mode", b->mode, "Query only: override the mode (exact, robust, frictionless)");
  bs->add_option("--planners", b->planners, "Query only: comma-separated planner names (default: the query's)");
  bs->add_option("--runs", b->runs, "Query only: runs per planner")->check(finitePositive());
  bs->add_option("--time", b->time, "Query only: time limit per run (s)")->check(finitePositive());
  bs->add_option("--out", b->out, "Output folder (OMPL logs + run records; query: .log + summary.json)")
      ->type_name("DIR");
  bs->add_option("--shard", b->shard,
                 "Campaign only: run part I of N (0 <= I < N), e.g. $SLURM_ARRAY_TASK_ID/$SLURM_ARRAY_TASK_COUNT");
  bs->add_flag("--quiet", b->quiet, "No progress on stderr");
  CLI::App* ms = bs->add_subcommand(
      "merge",
      "Check that a campaign's runs are complete (every run once) and write OUT/benchmark.db (Planner Arena, "
      "via OMPL's ompl_benchmark_statistics), OUT/summary.json and optionally an HTML report");
  ms->add_option("dirs", b->dirs, "Output folders of `ctr bench CAMPAIGN.yaml --out DIR` (one or several)")->required();
  ms->add_option("--out", b->merge_out, "Folder for benchmark.db, summary.json and logs/")
      ->required()
      ->type_name("DIR");
  ms->add_option("--html", b->html, "Write the campaign report (success rates, time to solution, replay outcomes)")
      ->type_name("FILE");
  ms->add_flag("--allow-incomplete", b->allow_incomplete,
               "Merge what is there and list the missing runs as warnings (duplicates are always an error)");
  ms->add_flag("--quiet", b->quiet, "No progress on stderr");
  ms->callback([b, &action]() { action = [b]() { return benchMerge(*b); }; });
  bs->callback([b, bs, ms, &action]() {
    if (ms->parsed()) return;
    action = [b, bs]() {
      if (b->input.empty()) throw UsageError("bench: a query or campaign file is required (or `ctr bench merge`)");
      if (b->out.empty()) throw UsageError("--out is required");
      {
        std::error_code ec;
        if (fs::exists(b->out, ec) && !fs::is_directory(b->out, ec))
          throw UsageError("--out: '" + b->out + "' exists and is not a folder");
      }
      if (campaign::isCampaignFile(b->input)) {
        for (const char* opt : {"--runs", "--time"})
          if (bs->count(opt))
            throw UsageError(std::string(opt) + ": not used with a campaign file (set it in " + b->input + ")");
        return benchCampaign(*b);
      }
      if (!b->shard.empty()) throw UsageError("--shard: only for campaign files (" + b->input + " is a query)");
      return benchQuery(*b);
    };
  });
}

}  // namespace ctr::cli
