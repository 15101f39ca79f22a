// `ctr diagnose`: locate where a recording differs from the nominal model, name and fit the left-out physics.
#include <algorithm>
#include <cstdio>
#include <iostream>
#include <sstream>

#include "commands.hpp"
#include "ctr/diagnosis/diagnose.hpp"
#include "ctr/io/file.hpp"
#include "ctr/io/recording.hpp"
#include "ctr/io/robot_yaml.hpp"
#include "ctr/model/replay.hpp"
#include "html_report.hpp"
#include "progress.hpp"

namespace ctr::cli {

void registerDiagnose(CLI::App& app, Action& action) {
  struct Opts {
    std::vector<std::string> recordings;
    std::string robot, frame = toString(diagnosis::FrameMode::Base), json, report, plot, candidates, html, noise,
                       branch = toString(BranchRule::Path), robot_out;
    int folds = 4, threads = 2, max_effects = diagnosis::DiagnoseOptions{}.max_effects,
        max_rows = diagnosis::DiagnoseOptions{}.max_rows;
    double bic_threshold = 10.0;
    bool quiet = false, calibrate = false;
  };
  auto o = std::make_shared<Opts>();
  CLI::App* sub =
      app.add_subcommand("diagnose",
                         "Locate where a recording and the nominal model differ, name the left-out physics, fit it and "
                         "score it on held-out blocks");
  sub->add_option("--robot", o->robot, "Nominal robot description YAML")->required();
  sub->add_option("--recording", o->recordings,
                  "Recording CSV (docs/formats.md), rows in the order taken; repeat it for several recordings of one "
                  "robot, diagnosed together: robot effects shared across them, latency and tracker per recording "
                  "(docs/diagnosis.md)")
      ->required()
      ->type_name("FILE");
  sub->add_option("--frame", o->frame,
                  "Frame of measured tips: base, or unknown (registration estimated in every model)")
      ->check(CLI::IsMember({toString(diagnosis::FrameMode::Base), toString(diagnosis::FrameMode::Unknown)}));
  addJsonOption(sub, o->json, "the diagnosis (docs/formats.md)")->required();
  sub->add_option("--report", o->report, "Plain-language Markdown report to write");
  sub->add_option("--plot-data", o->plot, "Plot data JSON to write (measured/nominal/fitted curves, binned residuals)");
  sub->add_option("--html", o->html, "Self-contained HTML report to write (plots, candidates; docs/reports.md)")
      ->type_name("FILE");
  sub->add_option("--robot-out", o->robot_out,
                  "Write the robot the diagnosis found: the nominal description with every named effect applied "
                  "(drives in the tubes' actuation blocks), commented with each value's 95 % interval and finding; "
                  "the recording's own effects (latency, tracker) listed, not applied (docs/diagnosis.md)")
      ->type_name("FILE.yaml");
  sub->add_option("--candidates", o->candidates, "Comma-separated effect names to try (default: all)");
  sub->add_option("--noise", o->noise,
                  "The tracker's noise, 1 sigma per component (tangent: per direction normal to it), e.g. "
                  "tip_position=0.5mm,tip_tangent=1deg,twist=2deg; quantities not given are estimated from the "
                  "recording (repeated poses, else neighbouring rows)");
  sub->add_option("--branch", o->branch,
                  "How the replay reaches each row's equilibrium: path (default: continuation along the move from the "
                  "previous row, whatever its size -- rows are in the order taken; other equilibria after long "
                  "moves are listed in branch_ambiguous_rows), rest (from rest: the robot was re-homed between rows)")
      ->check(branchRuleValidator());
  sub->add_option("--folds", o->folds, "Contiguous held-out blocks")->check(CLI::Range(2, 20));
  sub->add_option("--threads", o->threads, "Candidates fitted in parallel")->check(CLI::Range(1, 64))->type_name("INT");
  sub->add_option("--max-effects", o->max_effects, "Largest combination of effects")->check(CLI::Range(0, 6));
  sub->add_option("--max-rows", o->max_rows,
                  "Longer recordings are decimated to every k-th distinct row (the replay still follows the whole "
                  "path); 0: use every row (slower; docs/diagnosis.md)")
      ->check(CLI::NonNegativeNumber);
  sub->add_option("--bic-threshold", o->bic_threshold, "BIC decrease needed to accept an effect");
  sub->add_flag("--calibrate", o->calibrate,
                "When the selected effects leave a remainder, calibrate the robot's description (precurvatures, "
                "stiffness ratios, torsional stiffness, drive zeros) as a block and select again on top; costs "
                "minutes on a long log (docs/diagnosis.md)");
  sub->add_flag("--quiet", o->quiet, "No progress on stderr");
  sub->callback([o, &action]() {
    action = [o]() {
      requireHtmlReports(o->html);
      const bool several = o->recordings.size() > 1;
      if (several)
        for (const auto& [opt, path] : {std::pair<std::string, std::string>{"--report", o->report},
                                        {"--plot-data", o->plot},
                                        {"--html", o->html}})
          if (!path.empty()) throw UsageError(opt + " takes one --recording (several: --json and --robot-out)");
      std::vector<std::pair<std::string, std::string>> inputs{{"--robot", o->robot}};
      for (const std::string& r : o->recordings) inputs.emplace_back("--recording", r);
      for (std::size_t i = 0; i < o->recordings.size(); ++i)
        for (std::size_t k = 0; k < i; ++k)
          if (o->recordings[i] == o->recordings[k])
            throw UsageError("--recording " + o->recordings[i] + " is given twice");
      checkOutputTarget("--json", o->json, inputs);
      for (const auto& [opt, path] : {std::pair<std::string, std::string>{"--report", o->report},
                                      {"--plot-data", o->plot},
                                      {"--html", o->html},
                                      {"--robot-out", o->robot_out}})
        checkOutputPath(opt, path, inputs);
      const Robot robot = io::loadRobot(o->robot);
      std::vector<io::Recording> recs;
      for (const std::string& file : o->recordings) {
        recs.push_back(io::loadRecording(file, robot.size(), true));
        for (const auto& w : recs.back().warnings) std::cerr << "warning: " << file << ": " << w << "\n";
        if (recs.back().rows() < 8)  // diagnosis::diagnose needs 8 rows (held-out blocks); say which file is short
          throw io::InputError(file, 0, "",
                               "the recording has " + std::to_string(recs.back().rows()) +
                                   " data row(s); the diagnosis needs at least 8");
      }
      const io::Recording& rec = recs.front();
      const std::string& rec_name = o->recordings.front();
      diagnosis::DiagnoseOptions d;
      d.frame = o->frame == toString(diagnosis::FrameMode::Unknown) ? diagnosis::FrameMode::Unknown
                                                                    : diagnosis::FrameMode::Base;
      d.folds = o->folds;
      d.threads = o->threads;
      d.max_effects = o->max_effects;
      d.max_rows = o->max_rows;
      d.bic_threshold = o->bic_threshold;
      d.calibrate_description = o->calibrate;
      if (!o->candidates.empty()) {
        std::stringstream ss(o->candidates);
        std::string item;
        while (std::getline(ss, item, ',')) {
          try {
            d.candidates.push_back(diagnosis::parseEffectKind(item));
          } catch (const std::invalid_argument& e) {
            throw UsageError(std::string("--candidates: ") + e.what());
          }
        }
      }
      if (!o->noise.empty()) {
        try {
          d.noise = diagnosis::parseGivenNoise(o->noise);
        } catch (const std::invalid_argument& e) {
          throw UsageError(std::string("--noise: ") + e.what());
        }
      }
      d.predict.replay.branch = parseBranchRule(o->branch);
      // Progress: every message of the diagnosis, and a status line counting the selection rounds run (at most
      // --max-effects) and the candidates screened in the current one.
      Progress progress("diagnose", static_cast<std::size_t>(std::max(1, o->max_effects)), "rounds", o->quiet);
      if (!o->quiet)
        d.progress = [&progress](const diagnosis::DiagnoseProgress& p) {
          char t[32];
          std::snprintf(t, sizeof t, "[%6.1f s] ", p.seconds);
          progress.note(t + p.message);
          progress.set(static_cast<std::size_t>(p.rounds));
          const bool in_round = p.stage == diagnosis::DiagnoseProgress::Stage::Screening ||
                                p.stage == diagnosis::DiagnoseProgress::Stage::Finalists ||
                                p.stage == diagnosis::DiagnoseProgress::Stage::LookAlikes;
          progress.setDetail(in_round ? "round " + std::to_string(p.round) + ": " + std::to_string(p.screened) + "/" +
                                            std::to_string(p.candidates) + " candidates screened"
                                      : std::string(diagnosis::toString(p.stage)));
        };
      std::ostream& words = o->json == kStandardOutput ? std::cerr : std::cout;
      if (several) {
        diagnosis::MultiDiagnoseOptions m;
        m.diagnose = d;
        const diagnosis::MultiDiagnosisReport rep = diagnosis::diagnoseRecordings(robot, recs, o->recordings, m);
        progress.finish();
        const std::string robot_out = o->robot_out.empty() ? std::string() : diagnosis::diagnosedRobotYaml(robot, rep);
        writeOutput(o->json, diagnosis::reportToJson(rep));
        if (!o->robot_out.empty()) io::writeFileAtomic(o->robot_out, robot_out);
        words << "shared verdict: [";
        for (std::size_t k = 0; k < rep.verdict.size(); ++k) words << (k ? ", " : "") << rep.verdict[k];
        words << "]\n" << rep.summary << "\n";
        return kOk;
      }
      const diagnosis::DiagnosisReport rep = diagnosis::diagnose(robot, rec, d);
      // The rounds actually run (the selection stops when no candidate passes).
      progress.setTotal(static_cast<std::size_t>(std::max(1, rep.rounds)));
      progress.set(static_cast<std::size_t>(rep.rounds));
      progress.setDetail(std::to_string(rep.final_effects.size()) + " effect(s) in the final model, " +
                         std::to_string(rep.evaluations) + " replays");
      progress.finish();
      // The robot first: a description it cannot be written as fails before any output is written.
      const std::string robot_out =
          o->robot_out.empty() ? std::string() : diagnosis::diagnosedRobotYaml(robot, rep, rec_name);
      writeOutput(o->json, diagnosis::reportToJson(rep));
      if (!o->report.empty()) io::writeFileAtomic(o->report, diagnosis::reportToMarkdown(rep, rec));
      if (!o->plot.empty()) io::writeFileAtomic(o->plot, diagnosis::plotDataJson(rep, rec));
      if (!o->robot_out.empty()) io::writeFileAtomic(o->robot_out, robot_out);
#ifdef CTR_WITH_REPORTS
      if (!o->html.empty()) reports::writeHtml(o->html, reports::diagnosisHtml(rep, rec, "Diagnosis: " + rec_name));
#endif
      // The verdict and summary in words: on standard output, or on the error stream when the JSON goes there.
      words << "verdict: [";
      for (std::size_t k = 0; k < rep.verdict.size(); ++k) words << (k ? ", " : "") << rep.verdict[k];
      words << "]\n" << rep.summary << "\n";
      return kOk;
    };
  });
}

}  // namespace ctr::cli
