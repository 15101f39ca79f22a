// Bindings of recordings (ctr::io) and ctr::diagnosis: diagnose(...) returns the dict of the diagnosis JSON.
#include <cstdio>
#include <sstream>

#include "common.hpp"
#include "ctr/diagnosis/diagnose.hpp"
#include "ctr/io/file.hpp"
#include "ctr/io/recording.hpp"
#include "ctr/model/replay.hpp"

namespace ctr::py {

namespace {

using pyb::arg;

io::Recording recordingFrom(const pyb::object& obj, int tubes) {
  if (pyb::isinstance<io::Recording>(obj)) return obj.cast<io::Recording>();
  const std::string path = pyb::str(pyb::module_::import("os").attr("fspath")(obj)).cast<std::string>();
  pyb::gil_scoped_release release;
  return io::loadRecording(path, tubes, true);
}

}  // namespace

void registerDiagnosis(pyb::module_& m) {
  pyb::class_<io::Recording>(m, "Recording",
                             "A recording (docs/formats.md): commanded actuation and measured twist / tip position / "
                             "tip tangent per row, NaN where not measured.")
      .def_readonly("tubes", &io::Recording::tubes)
      .def_property_readonly("rows", &io::Recording::rows)
      .def("__len__", &io::Recording::rows)
      .def_property_readonly(
          "alpha", [](const io::Recording& r) { return pyb::object(configurationArrays(r.commands, r.tubes)[0]); },
          "(rows, n)")
      .def_property_readonly(
          "beta", [](const io::Recording& r) { return pyb::object(configurationArrays(r.commands, r.tubes)[1]); },
          "(rows, n)")
      .def_property_readonly(
          "twist", [](const io::Recording& r) { return r.twist; }, "(rows, n-1), or (rows, 0) when absent.")
      .def_property_readonly(
          "tip_position", [](const io::Recording& r) { return r.tip_position; }, "(rows, 3), or (rows, 0) when absent.")
      .def_property_readonly("tip_tangent", [](const io::Recording& r) { return r.tip_tangent; })
      .def_property_readonly(
          "time", [](const io::Recording& r) { return r.time; }, "(rows,), or empty.")
      .def_readonly("warnings", &io::Recording::warnings)
      .def("to_csv", &io::recordingToCsv, "CSV text with the docs/formats.md columns.")
      .def(
          "save",
          [](const io::Recording& r, const std::filesystem::path& path) { io::saveRecording(r, path.string()); },
          arg("path"))
      .def("__repr__", [](const io::Recording& r) {
        return "<ctr.Recording " + std::to_string(r.rows()) + " rows, " + std::to_string(r.tubes) + " tubes>";
      });

  m.def(
      "load_recording",
      [](const std::filesystem::path& path, int tubes, bool require_measurement) {
        pyb::gil_scoped_release release;
        return io::loadRecording(path.string(), tubes, require_measurement);
      },
      arg("path"), arg("tubes") = -1, arg("require_measurement") = true,
      "Reads a recording CSV (tubes < 0: inferred from the alpha_* columns). Raises ctr.InputError naming the file, "
      "line and column.");

  m.def(
      "diagnose",
      [](const Robot& robot, const pyb::object& recording, const std::string& frame, int folds, int threads,
         int max_effects, double bic_threshold, const std::optional<std::vector<std::string>>& candidates,
         const pyb::object& progress, bool with_report, const std::optional<std::string>& noise,
         const std::string& branch, bool calibrate, int max_rows,
         const std::optional<std::filesystem::path>& robot_out) {
        // One recording (a path or a ctr.Recording), or a list of them: diagnosed together (diagnoseRecordings).
        const bool several = pyb::isinstance<pyb::list>(recording) || pyb::isinstance<pyb::tuple>(recording);
        std::vector<pyb::object> items;
        if (several)
          for (const pyb::handle& h : recording) items.push_back(pyb::reinterpret_borrow<pyb::object>(h));
        else
          items.push_back(recording);
        if (several && items.size() < 2)
          throw pyb::value_error("recording: a list needs at least two recordings (or pass one recording)");
        if (several && with_report) throw pyb::value_error("with_report: takes one recording");
        std::vector<io::Recording> recs;
        std::vector<std::string> names;
        for (std::size_t i = 0; i < items.size(); ++i) {
          const pyb::object& item = items[i];
          names.push_back(pyb::isinstance<io::Recording>(item)
                              ? (several ? "<recording " + std::to_string(i + 1) + ">" : std::string("<recording>"))
                              : pyb::str(item).cast<std::string>());
          recs.push_back(recordingFrom(item, robot.size()));
          if (recs.back().rows() < 8)
            throw io::InputError(names.back(), 0, "",
                                 "the recording has " + std::to_string(recs.back().rows()) +
                                     " data row(s); the diagnosis needs at least 8");
        }
        const io::Recording& rec = recs.front();
        diagnosis::DiagnoseOptions d;
        if (frame == "base")
          d.frame = diagnosis::FrameMode::Base;
        else if (frame == "unknown")
          d.frame = diagnosis::FrameMode::Unknown;
        else
          throw pyb::value_error("frame: '" + frame + "': expected 'base' or 'unknown'");
        if (folds < 2 || folds > 20) throw pyb::value_error("folds: must be in 2..20");
        if (threads < 1 || threads > 64) throw pyb::value_error("threads: must be in 1..64");
        if (max_effects < 0 || max_effects > 6) throw pyb::value_error("max_effects: must be in 0..6");
        if (max_rows < 0) throw pyb::value_error("max_rows: must be >= 0 (0: every row)");
        d.folds = folds;
        d.threads = threads;
        d.max_effects = max_effects;
        d.max_rows = max_rows;
        d.calibrate_description = calibrate;
        d.bic_threshold = bic_threshold;
        if (candidates)
          for (const auto& c : *candidates) {
            try {
              d.candidates.push_back(diagnosis::parseEffectKind(c));
            } catch (const std::invalid_argument& e) {
              throw pyb::value_error(std::string("candidates: ") + e.what());
            }
          }
        if (noise) {
          try {
            d.noise = diagnosis::parseGivenNoise(*noise);
          } catch (const std::invalid_argument& e) {
            throw pyb::value_error(std::string("noise: ") + e.what());
          }
        }
        try {
          d.predict.replay.branch = parseBranchRule(branch);
        } catch (const std::invalid_argument& e) {
          throw pyb::value_error(std::string("branch: ") + e.what());
        }
        if (!progress.is_none()) {
          // Called from the diagnosis's threads: take the GIL for the Python callback (one line per step).
          auto cb = std::make_shared<pyb::object>(progress);
          d.progress = [cb](const diagnosis::DiagnoseProgress& p) {
            char t[32];
            std::snprintf(t, sizeof t, "[%6.1f s] ", p.seconds);
            pyb::gil_scoped_acquire acquire;
            (*cb)(std::string(t) + p.message);
          };
        }
        std::string json, markdown;
        const std::string& recording_name = names.front();
        if (several) {
          pyb::gil_scoped_release release;
          diagnosis::MultiDiagnoseOptions mo;
          mo.diagnose = d;
          const diagnosis::MultiDiagnosisReport rep = diagnosis::diagnoseRecordings(robot, recs, names, mo);
          const std::string robot_yaml = robot_out ? diagnosis::diagnosedRobotYaml(robot, rep) : std::string();
          json = diagnosis::reportToJson(rep);
          if (robot_out) io::writeFileAtomic(robot_out->string(), robot_yaml);
        } else {
          pyb::gil_scoped_release release;
          const diagnosis::DiagnosisReport rep = diagnosis::diagnose(robot, rec, d);
          const std::string robot_yaml =
              robot_out ? diagnosis::diagnosedRobotYaml(robot, rep, recording_name) : std::string();
          json = diagnosis::reportToJson(rep);
          if (with_report) markdown = diagnosis::reportToMarkdown(rep, rec);
          if (robot_out) io::writeFileAtomic(robot_out->string(), robot_yaml);
        }
        d.progress = nullptr;  // drops the callback while holding the GIL
        pyb::object out = jsonLoads(json);
        if (with_report) return pyb::object(pyb::make_tuple(out, markdown));
        return out;
      },
      arg("robot"), arg("recording"), arg("frame") = "base", arg("folds") = 4, arg("threads") = 2,
      arg("max_effects") = diagnosis::DiagnoseOptions{}.max_effects, arg("bic_threshold") = 10.0,
      arg("candidates") = pyb::none(), arg("progress") = pyb::none(), arg("with_report") = false,
      arg("noise") = pyb::none(), arg("branch") = toString(BranchRule::Path), arg("calibrate") = false,
      arg("max_rows") = diagnosis::DiagnoseOptions{}.max_rows, arg("robot_out") = pyb::none(),
      "`ctr diagnose`: where the recording (a path or a ctr.Recording) and the nominal robot differ, and which "
      "left-out physics explains it. Returns the dict of the diagnosis JSON (docs/formats.md; the same object as "
      "--json writes). A list of recordings of one robot is diagnosed together (`--recording A --recording B`): "
      "returns the dict of docs/formats.md 'Diagnosis of several recordings'; with_report=True returns (dict, Markdown "
      "report). progress: a callable taking a str. "
      "noise: the tracker's noise as `--noise` takes it ('tip_position=0.5mm,tip_tangent=1deg'); branch: 'path' "
      "(default) or 'rest' (docs/diagnosis.md); calibrate: `--calibrate`; max_rows: `--max-rows`; robot_out: a "
      "path, `--robot-out` (the robot the diagnosis found, as a description). Runs without the GIL.");
}

}  // namespace ctr::py
