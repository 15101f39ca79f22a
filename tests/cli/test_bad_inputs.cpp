// Bad-input catalogue: every case runs the real `ctr` binary on a bad input written into a fresh temporary
// folder and checks (1) the documented exit code (2 = bad input or usage, 1 = runtime failure), (2) that standard
// error names the file, the line and/or the key where applicable and says what is wrong, and (3) that no output file
// (nor a temporary file) is left behind: the folder holds exactly the inputs the case wrote, unchanged.
// Inputs are derived from examples/ by editing text. The table in docs/reliability.md ("Bad-input catalogue") is
// generated from kCases (test BadInputCatalogue.DocsTableIsUpToDate; CTR_UPDATE_CATALOGUE=1 rewrites it).
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <sstream>
#include <string>
#include <vector>

namespace fs = std::filesystem;

namespace {

const std::string kEx = std::string(CTR_SOURCE_DIR) + "/examples";

std::string readText(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// `text` with the first occurrence of `from` replaced by `to` (the example must contain `from`).
std::string edit(std::string text, const std::string& from, const std::string& to) {
  const std::size_t at = text.find(from);
  if (at == std::string::npos) throw std::runtime_error("example text changed: '" + from + "' not found");
  return text.replace(at, from.size(), to);
}

// 1-based line of the first occurrence of `what` in `text`.
int lineOf(const std::string& text, const std::string& what) {
  const std::size_t at = text.find(what);
  if (at == std::string::npos) throw std::runtime_error("'" + what + "' not found");
  return 1 + static_cast<int>(std::count(text.begin(), text.begin() + static_cast<long>(at), '\n'));
}

// The temporary folder of one case: inputs are written here, outputs are directed here.
struct Dir {
  fs::path path;
  std::map<std::string, std::string> expect;  // extra message excerpts computed from the inputs (e.g. line numbers)
  explicit Dir(const std::string& id) {
    path = fs::temp_directory_path() / ("ctr_bad_" + std::to_string(::getpid()) + "_" + id);
    fs::remove_all(path);
    fs::create_directories(path);
  }
  ~Dir() {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
  std::string file(const std::string& name) const { return (path / name).string(); }
  void write(const std::string& name, const std::string& text) const {
    std::ofstream(path / name, std::ios::binary) << text;
  }
};

// Example inputs, derived by editing text.
std::string pairB() { return readText(kEx + "/robots/tube_pair_B.yaml"); }
std::string recordingB() { return readText(kEx + "/recordings/friction_masked_B.csv"); }
std::string latencyA() { return readText(kEx + "/recordings/latency_walk_A.csv"); }
// The intracardiac query with absolute robot / environment paths and a coarse map (fast), written as q.yaml.
std::string heartQuery() {
  std::string q = readText(kEx + "/queries/proc_intracardiac.yaml");
  q = edit(q, "robot: ../robots/", "robot: " + kEx + "/robots/");
  q = edit(q, "environment: ../environments/", "environment: " + kEx + "/environments/");
  return q + "environment_resolution: 0.002\n";
}
std::string firstLines(const std::string& text, int n) {
  std::size_t at = 0;
  for (int k = 0; k < n && at != std::string::npos; ++k) at = text.find('\n', at) + 1;
  return text.substr(0, at);
}
// An actuation CSV for pair B (alpha_1,alpha_2,beta_1,beta_2) with the given rows.
std::string actuation(const std::vector<std::string>& rows, const std::string& header = "alpha_1,alpha_2,beta_1,beta_2") {
  std::string s = header + "\n";
  for (const auto& r : rows) s += r + "\n";
  return s;
}
const std::vector<std::string> kRows = {"0,0,-0.018,-0.018", "0,0.1,-0.018,-0.018", "0,0.2,-0.018,-0.018"};

struct Case {
  std::string id;       // test name
  std::string command;  // subcommand (for the table)
  std::string what;     // the bad input (for the table)
  std::string needs;    // "", "env", "diag", "plan": the part of the build the command needs
  std::function<void(Dir&)> setup;
  std::string args;  // {d} = the case's folder, {ex} = examples/
  int code;
  std::vector<std::string> expect;  // excerpts of standard error ({d} replaced; {line} = Dir::expect["line"])
  std::string unchanged = {};       // an input file that must be left unchanged (output = input cases)
};

void PrintTo(const Case& c, std::ostream* os) { *os << c.id; }

void none(Dir&) {}

// clang-format off
const std::vector<Case> kCases = {
  // ---- robot description (through fk) ----
  {"FkRobotMissing", "fk", "robot file does not exist", "", none,
   "fk --robot {d}/nope.yaml --json", 2, {"{d}/nope.yaml", "not found"}},
  {"FkRobotIsDirectory", "fk", "a directory instead of the robot file", "", none,
   "fk --robot {d} --json", 2, {"{d}", "is a directory"}},
  {"FkRobotEmpty", "fk", "empty robot file", "", [](Dir& d) { d.write("r.yaml", ""); },
   "fk --robot {d}/r.yaml", 2, {"r.yaml", "empty"}},
  {"FkRobotGarbage", "fk", "garbage bytes instead of YAML", "", [](Dir& d) { d.write("r.yaml", std::string("\x7f" "ELF\x02\x01\x01\0\0\0\xff\xfe{[:,\n\x01\x02", 20)); },
   "fk --robot {d}/r.yaml", 2, {"r.yaml"}},
  {"FkRobotTruncated", "fk", "truncated YAML (file cut inside a flow list)", "", [](Dir& d) {
     d.write("r.yaml", edit(pairB(), "friction:                        # nominal", "friction: {boundary: [0.1,\n# nominal")); },
   "fk --robot {d}/r.yaml", 2, {"r.yaml:", "not valid YAML"}},
  {"FkRobotNaN", "fk", "NaN curvature", "", [](Dir& d) {
     const std::string t = edit(pairB(), "curvature: 6.493506494       # 1 / 0.154 m\n    bending_stiffness: 0.0511", "curvature: .nan\n    bending_stiffness: 0.0511");
     d.write("r.yaml", t); d.expect["line"] = std::to_string(lineOf(t, ".nan")); },
   "fk --robot {d}/r.yaml", 2, {"r.yaml:{line}", "curvature", "finite"}},
  {"FkRobotInf", "fk", "infinite bending stiffness", "", [](Dir& d) {
     const std::string t = edit(pairB(), "bending_stiffness: 0.0511", "bending_stiffness: .inf");
     d.write("r.yaml", t); d.expect["line"] = std::to_string(lineOf(t, ".inf")); },
   "fk --robot {d}/r.yaml", 2, {"r.yaml:{line}", "bending_stiffness", "finite"}},
  {"FkRobotNotNesting", "fk", "non-nesting tubes (inner tube wider than the outer tube's bore)", "", [](Dir& d) {
     const std::string t = edit(pairB(), "outer_diameter: 2.41e-3", "outer_diameter: 2.6e-3");
     d.write("r.yaml", t); d.expect["line"] = std::to_string(lineOf(t, "2.6e-3")); },
   "fk --robot {d}/r.yaml", 2, {"r.yaml:{line}", "outer_diameter", "does not fit inside"}},
  {"FkRobotUnknownKey", "fk", "misspelt key in a tube", "", [](Dir& d) {
     const std::string t = edit(pairB(), "bending_stiffness: 0.0511", "bending_stifness: 0.0511");
     d.write("r.yaml", t); d.expect["line"] = std::to_string(lineOf(t, "stifness")); },
   "fk --robot {d}/r.yaml", 2, {"r.yaml:{line}", "bending_stifness", "did you mean"}},
  {"FkRobotMillimetres", "fk", "wrong units: lengths and diameters in mm", "", [](Dir& d) {
     std::string t = pairB();
     for (int k = 0; k < 2; ++k) {
       t = edit(t, "straight_length: 0.018", "straight_length: 18");
       t = edit(t, "curved_length: 0.150", "curved_length: 150");
     }
     t = edit(t, "outer_diameter: 2.77e-3", "outer_diameter: 2.77");
     d.write("r.yaml", t); d.expect["line"] = std::to_string(lineOf(t, "straight_length: 18")); },
   "fk --robot {d}/r.yaml", 2, {"r.yaml:{line}", "straight_length", "metres"}},
  {"FkRobotNegativePlay", "fk", "a drive's play < 0 in the actuation block", "", [](Dir& d) {
     const std::string t = edit(pairB(), "    inner_diameter: 1.97e-3\n", "    inner_diameter: 1.97e-3\n    actuation:\n      rotation: {offset: 0.05, play: -0.01}\n");
     d.write("r.yaml", t); d.expect["line"] = std::to_string(lineOf(t, "play: -0.01")); },
   "fk --robot {d}/r.yaml", 2, {"r.yaml:{line}", "actuation.rotation.play", ">= 0"}},
  {"FkRobotPlayWiderThanATurn", "fk", "a rotation play wider than a turn", "", [](Dir& d) {
     const std::string t = edit(pairB(), "    inner_diameter: 1.97e-3\n", "    inner_diameter: 1.97e-3\n    actuation:\n      rotation:\n        play: 7\n");
     d.write("r.yaml", t); d.expect["line"] = std::to_string(lineOf(t, "play: 7")); },
   "fk --robot {d}/r.yaml", 2, {"r.yaml:{line}", "actuation.rotation.play", "less than a turn"}},
  {"FkRobotActuationUnknownKey", "fk", "a misspelt drive key (backlash for play)", "", [](Dir& d) {
     const std::string t = edit(pairB(), "    inner_diameter: 1.97e-3\n", "    inner_diameter: 1.97e-3\n    actuation:\n      translation:\n        backlash: 0.001\n");
     d.write("r.yaml", t); d.expect["line"] = std::to_string(lineOf(t, "backlash")); },
   "fk --robot {d}/r.yaml", 2, {"r.yaml:{line}", "backlash", "unknown key"}},
  {"FkRobotOffsetPastHalfATurn", "fk", "a rotation offset past half a turn", "", [](Dir& d) {
     const std::string t = edit(pairB(), "    inner_diameter: 1.97e-3\n", "    inner_diameter: 1.97e-3\n    actuation:\n      rotation: {offset: 4}\n");
     d.write("r.yaml", t); d.expect["line"] = std::to_string(lineOf(t, "offset: 4")); },
   "fk --robot {d}/r.yaml", 2, {"r.yaml:{line}", "actuation.rotation.offset", "half a turn"}},
  {"FkAlphaWrongCount", "fk", "wrong number of joints in --alpha", "", none,
   "fk --robot {ex}/robots/tube_pair_B.yaml --alpha 0,1,2", 2, {"--alpha", "3 values", "2 tubes"}},
  {"FkBetaNaN", "fk", "NaN in --beta", "", none,
   "fk --robot {ex}/robots/tube_pair_B.yaml --beta nan,-0.018", 2, {"--beta", "not a finite number"}},
  {"FkAlphaInf", "fk", "inf in --alpha", "", none,
   "fk --robot {ex}/robots/tube_pair_B.yaml --alpha 0,inf", 2, {"--alpha", "not a finite number"}},
  {"FkBetaMillimetres", "fk", "wrong units: --beta in mm (not admissible)", "", none,
   "fk --robot {ex}/robots/tube_pair_B.yaml --beta -18,-18", 2, {"not admissible"}},
  {"FkBetaBeyondTolerance", "fk", "--beta with the inner tube end 1 mm behind the outer end (beyond the admissibility tolerance)", "", none,
   "fk --robot {ex}/robots/tube_pair_B.yaml --beta -0.018,-0.019", 2, {"--beta", "not admissible", "distal end of tube 2"}},
  {"FkShapeDirMissing", "fk", "--shape into a folder that does not exist", "", none,
   "fk --robot {ex}/robots/tube_pair_B.yaml --shape {d}/no/such/dir/shape.csv", 2, {"{d}/no/such/dir/shape.csv", "cannot write"}},
  {"FkShapeStepZero", "fk", "--shape-step 0", "", none,
   "fk --robot {ex}/robots/tube_pair_B.yaml --shape {d}/s.csv --shape-step 0", 2, {"--shape-step", "must be > 0"}},
  {"FkShapeIsInput", "fk", "--shape equal to the robot file (output = input)", "", [](Dir& d) { d.write("r.yaml", pairB()); },
   "fk --robot {d}/r.yaml --shape {d}/r.yaml", 2, {"r.yaml", "input"}, "r.yaml"},
  // ---- sweep ----
  {"SweepTubeOutOfRange", "sweep", "--tube 3 on a 2-tube robot", "", none,
   "sweep --robot {ex}/robots/tube_pair_B.yaml --tube 3 --from 0 --to 1 --step 0.1 --csv {d}/o.csv", 2, {"--tube", "1..2"}},
  {"SweepStepZero", "sweep", "--step 0", "", none,
   "sweep --robot {ex}/robots/tube_pair_B.yaml --tube 2 --from 0 --to 1 --step 0 --csv {d}/o.csv", 2, {"--step", "non-zero"}},
  {"SweepFromNaN", "sweep", "--from nan", "", none,
   "sweep --robot {ex}/robots/tube_pair_B.yaml --tube 2 --from nan --to 1 --step 0.1 --csv {d}/o.csv", 2, {"--from", "not a finite number"}},
  {"SweepUnknownFrictionMode", "sweep", "unknown --friction-mode", "", none,
   "sweep --robot {ex}/robots/tube_pair_B.yaml --tube 2 --from 0 --to 1 --step 0.1 --friction-mode sticky --csv {d}/o.csv", 2, {"--friction-mode", "sticky"}},
  {"SweepNegativeFriction", "sweep", "negative --boundary-friction", "", none,
   "sweep --robot {ex}/robots/tube_pair_B.yaml --tube 2 --from 0 --to 1 --step 0.1 --boundary-friction -0.1 --csv {d}/o.csv", 2, {"--boundary-friction", "must not be negative"}},
  {"SweepCsvIsDirectory", "sweep", "--csv is an existing directory", "", [](Dir& d) { fs::create_directories(d.path / "sub"); },
   "sweep --robot {ex}/robots/tube_pair_B.yaml --tube 2 --from 0 --to 0.2 --step 0.1 --csv {d}/sub", 2, {"{d}/sub"}},
  {"SweepCsvDirMissing", "sweep", "--csv into a folder that does not exist", "", none,
   "sweep --robot {ex}/robots/tube_pair_B.yaml --tube 2 --from 0 --to 0.2 --step 0.1 --csv {d}/none/o.csv", 2, {"{d}/none/o.csv", "cannot write"}},
  {"SweepInadmissibleStart", "sweep", "--beta outside the nesting rules", "", none,
   "sweep --robot {ex}/robots/tube_pair_B.yaml --tube 2 --from 0 --to 0.2 --step 0.1 --beta 0.01,0.01 --csv {d}/o.csv", 2, {"not admissible"}},
  // ---- simulate (actuation CSV) ----
  // ---- ik ----
  {"IkNoTarget", "ik", "neither --target nor --targets", "", none,
   "ik --robot {ex}/robots/tube_pair_B.yaml --json out.json", 2, {"--target", "--targets"}},
  {"IkTargetTwoNumbers", "ik", "--target with two numbers", "", none,
   "ik --robot {ex}/robots/tube_pair_B.yaml --target 0.01,0.1 --json out.json", 2, {"--target", "three numbers"}},
  {"IkTargetNotANumber", "ik", "--target item that is not a number", "", none,
   "ik --robot {ex}/robots/tube_pair_B.yaml --target 0.01,abc,0.1 --json out.json", 2, {"--target item 2", "abc"}},
  {"IkDirectionZero", "ik", "--direction of length zero", "", none,
   "ik --robot {ex}/robots/tube_pair_B.yaml --target 0.01,0,0.1 --direction 0,0,0 --json out.json", 2,
   {"--direction", "zero"}},
  {"IkFromAlphaCount", "ik", "--from-alpha with the wrong number of values", "", none,
   "ik --robot {ex}/robots/tube_pair_B.yaml --target 0.01,0,0.1 --from-alpha 0 --json out.json", 2,
   {"--from-alpha", "1 values given", "2 tubes"}},
  {"IkHistoryUnknown", "ik", "--history that is not rest/positive/negative", "", none,
   "ik --robot {ex}/robots/tube_pair_B.yaml --target 0.01,0,0.1 --history sideways --json out.json", 2,
   {"--history", "sideways"}},
  {"IkTargetsMissingColumn", "ik", "targets CSV without tip_z", "", [](Dir& d) {
     d.write("t.csv", "tip_x,tip_y\n0.01,0.0\n"); },
   "ik --robot {ex}/robots/tube_pair_B.yaml --targets t.csv --out cmd.csv", 2, {"t.csv:1", "tip_z", "missing column"}},
  {"IkTargetsBadCell", "ik", "targets CSV with a cell that is not a number", "", [](Dir& d) {
     d.write("t.csv", "tip_x,tip_y,tip_z\n0.01,0.0,0.1\n# comment\n0.01,x,0.1\n"); },
   "ik --robot {ex}/robots/tube_pair_B.yaml --targets t.csv --out cmd.csv", 2, {"t.csv:4", "tip_y", "not a number"}},
  {"IkOutIsTheTargets", "ik", "--out naming the targets file", "", [](Dir& d) {
     d.write("t.csv", "tip_x,tip_y,tip_z\n0.01,0.0,0.1\n"); },
   "ik --robot {ex}/robots/tube_pair_B.yaml --targets t.csv --out t.csv", 2, {"--out", "input file of --targets"},
   "t.csv"},
  {"SimulateActuationMissing", "simulate", "actuation file does not exist", "", none,
   "simulate --robot {ex}/robots/tube_pair_B.yaml --actuation {d}/act.csv --out {d}/rec.csv", 2, {"{d}/act.csv", "not found"}},
  {"SimulateActuationEmpty", "simulate", "empty actuation file (0 bytes)", "", [](Dir& d) { d.write("act.csv", ""); },
   "simulate --robot {ex}/robots/tube_pair_B.yaml --actuation {d}/act.csv --out {d}/rec.csv", 2, {"act.csv", "empty"}},
  {"SimulateHeaderOnly", "simulate", "actuation with a header and no rows", "", [](Dir& d) { d.write("act.csv", actuation({})); },
   "simulate --robot {ex}/robots/tube_pair_B.yaml --actuation {d}/act.csv --out {d}/rec.csv", 2, {"act.csv:1", "no data rows"}},
  {"SimulateWrongJoints", "simulate", "actuation for 3 tubes, robot has 2", "", [](Dir& d) {
     d.write("act.csv", actuation({"0,0,0,-0.018,-0.018,-0.018"}, "alpha_1,alpha_2,alpha_3,beta_1,beta_2,beta_3")); },
   "simulate --robot {ex}/robots/tube_pair_B.yaml --actuation {d}/act.csv --out {d}/rec.csv", 2, {"act.csv:1", "alpha_3", "2 tubes"}},
  {"SimulateNaN", "simulate", "NaN actuation value in row 2", "", [](Dir& d) {
     d.write("act.csv", actuation({kRows[0], "0,nan,-0.018,-0.018", kRows[2]})); },
   "simulate --robot {ex}/robots/tube_pair_B.yaml --actuation {d}/act.csv --out {d}/rec.csv", 2, {"act.csv:3", "alpha_2", "not a finite number"}},
  {"SimulateInf", "simulate", "infinite translation", "", [](Dir& d) {
     d.write("act.csv", actuation({kRows[0], "0,0.1,-inf,-0.018"})); },
   "simulate --robot {ex}/robots/tube_pair_B.yaml --actuation {d}/act.csv --out {d}/rec.csv", 2, {"act.csv:3", "beta_1", "not a finite number"}},
  {"SimulateUnsortedTime", "simulate", "time column not increasing", "", [](Dir& d) {
     d.write("act.csv", actuation({kRows[0] + ",0", kRows[1] + ",0.2", kRows[2] + ",0.1"}, "alpha_1,alpha_2,beta_1,beta_2,time")); },
   "simulate --robot {ex}/robots/tube_pair_B.yaml --actuation {d}/act.csv --out {d}/rec.csv", 2, {"act.csv:4", "time", "not after"}},
  {"SimulateDuplicateColumn", "simulate", "duplicate column", "", [](Dir& d) {
     d.write("act.csv", actuation({kRows[0] + ",0"}, "alpha_1,alpha_2,beta_1,beta_2,alpha_2")); },
   "simulate --robot {ex}/robots/tube_pair_B.yaml --actuation {d}/act.csv --out {d}/rec.csv", 2, {"act.csv:1", "alpha_2", "duplicate column"}},
  {"SimulateMisspeltColumn", "simulate", "unknown column instead of a required one (alpha2)", "", [](Dir& d) {
     d.write("act.csv", actuation(kRows, "alpha_1,alpha2,beta_1,beta_2")); },
   "simulate --robot {ex}/robots/tube_pair_B.yaml --actuation {d}/act.csv --out {d}/rec.csv", 2, {"act.csv:1", "alpha_2", "missing column"}},
  {"SimulateRaggedRow", "simulate", "row with a missing cell", "", [](Dir& d) {
     d.write("act.csv", actuation({kRows[0], "0,0.1,-0.018"})); },
   "simulate --robot {ex}/robots/tube_pair_B.yaml --actuation {d}/act.csv --out {d}/rec.csv", 2, {"act.csv:3", "3 cells"}},
  {"SimulateMillimetres", "simulate", "wrong units: translations in mm (row not admissible)", "", [](Dir& d) {
     d.write("act.csv", actuation({kRows[0], "0,0.1,-18,-18"})); },
   "simulate --robot {ex}/robots/tube_pair_B.yaml --actuation {d}/act.csv --out {d}/rec.csv", 2, {"act.csv:3", "not admissible"}},
  {"SimulateRowBeyondTolerance", "simulate", "row 2 with the inner tube end 1 mm behind (beyond the admissibility tolerance)", "", [](Dir& d) {
     d.write("act.csv", actuation({kRows[0], "0,0.1,-0.018,-0.019", kRows[2]})); },
   "simulate --robot {ex}/robots/tube_pair_B.yaml --actuation {d}/act.csv --out {d}/rec.csv", 2, {"act.csv:3", "row 2", "distal end of tube 2"}},
  {"SimulateOutDirMissing", "simulate", "--out into a folder that does not exist", "", [](Dir& d) { d.write("act.csv", actuation(kRows)); },
   "simulate --robot {ex}/robots/tube_pair_B.yaml --actuation {d}/act.csv --out {d}/none/rec.csv", 2, {"{d}/none/rec.csv", "cannot write"}},
  {"SimulateOutIsInput", "simulate", "--out equal to --actuation (output = input)", "", [](Dir& d) { d.write("act.csv", actuation(kRows)); },
   "simulate --robot {ex}/robots/tube_pair_B.yaml --actuation {d}/act.csv --out {d}/act.csv", 2, {"act.csv", "input"}, "act.csv"},
  {"SimulateFrictionNaN", "simulate", "--distributed-friction nan", "", [](Dir& d) { d.write("act.csv", actuation(kRows)); },
   "simulate --robot {ex}/robots/tube_pair_B.yaml --actuation {d}/act.csv --out {d}/rec.csv --boundary-friction 0.1 --distributed-friction nan", 2, {"--distributed-friction", "nan", "finite"}},
  // ---- diagnose (recordings) ----
  {"DiagnoseRecordingMissing", "diagnose", "recording file does not exist", "diag", none,
   "diagnose --robot {ex}/recordings/friction_masked_B.robot.yaml --recording {d}/rec.csv --json {d}/d.json", 2, {"{d}/rec.csv", "not found"}},
  {"DiagnoseEmptyRecording", "diagnose", "empty recording (header only)", "diag", [](Dir& d) { d.write("rec.csv", firstLines(recordingB(), 1)); },
   "diagnose --robot {ex}/recordings/friction_masked_B.robot.yaml --recording {d}/rec.csv --json {d}/d.json", 2, {"rec.csv:1", "no data rows"}},
  {"DiagnoseOneRow", "diagnose", "recording with one row", "diag", [](Dir& d) { d.write("rec.csv", firstLines(recordingB(), 2)); },
   "diagnose --robot {ex}/recordings/friction_masked_B.robot.yaml --recording {d}/rec.csv --json {d}/d.json", 2, {"rec.csv", "1 data row(s)", "at least 8"}},
  {"DiagnoseNoMeasurement", "diagnose", "recording without measured columns", "diag", [](Dir& d) { d.write("rec.csv", actuation(kRows)); },
   "diagnose --robot {ex}/recordings/friction_masked_B.robot.yaml --recording {d}/rec.csv --json {d}/d.json", 2, {"rec.csv:1", "no measured quantity"}},
  {"DiagnoseUnsortedTime", "diagnose", "unsorted time", "diag", [](Dir& d) {
     d.write("rec.csv", edit(firstLines(latencyA(), 6), ",0.2\n", ",0.05\n")); },
   "diagnose --robot {ex}/robots/tube_pair_A.yaml --recording {d}/rec.csv --json {d}/d.json", 2, {"rec.csv:4", "time", "not after"}},
  {"DiagnoseTangentNotUnit", "diagnose", "tip tangent that is not a unit vector (wrong units)", "diag", [](Dir& d) {
     std::string t = firstLines(recordingB(), 13);
     t = edit(t, ",0.8265067893695675,", ",82.65067893695675,");
     d.write("rec.csv", t); },
   "diagnose --robot {ex}/recordings/friction_masked_B.robot.yaml --recording {d}/rec.csv --json {d}/d.json", 2, {"rec.csv:2", "tip_tx", "unit vector"}},
  {"DiagnoseWrongJoints", "diagnose", "recording of a 2-tube robot with a 3-tube robot", "diag", [](Dir& d) { d.write("rec.csv", firstLines(recordingB(), 13)); },
   "diagnose --robot {ex}/robots/dupont_lab_3tube.yaml --recording {d}/rec.csv --json {d}/d.json", 2, {"rec.csv:1", "alpha_3", "missing column"}},
  {"DiagnoseUnknownFrame", "diagnose", "unknown --frame", "diag", [](Dir& d) { d.write("rec.csv", firstLines(recordingB(), 13)); },
   "diagnose --robot {ex}/recordings/friction_masked_B.robot.yaml --recording {d}/rec.csv --json {d}/d.json --frame world", 2, {"--frame", "world"}},
  {"DiagnoseBadNoise", "diagnose", "--noise with a unit that does not fit the quantity", "diag", [](Dir& d) { d.write("rec.csv", firstLines(recordingB(), 13)); },
   "diagnose --robot {ex}/recordings/friction_masked_B.robot.yaml --recording {d}/rec.csv --json {d}/d.json --noise tip_position=1deg", 2, {"--noise", "tip_position=1deg", "does not fit"}},
  {"DiagnoseNoiseNotPositive", "diagnose", "--noise with a zero standard deviation", "diag", [](Dir& d) { d.write("rec.csv", firstLines(recordingB(), 13)); },
   "diagnose --robot {ex}/recordings/friction_masked_B.robot.yaml --recording {d}/rec.csv --json {d}/d.json --noise twist=0deg", 2, {"--noise", "positive"}},
  {"DiagnoseUnknownBranch", "diagnose", "unknown --branch rule", "diag", [](Dir& d) { d.write("rec.csv", firstLines(recordingB(), 13)); },
   "diagnose --robot {ex}/recordings/friction_masked_B.robot.yaml --recording {d}/rec.csv --json {d}/d.json --branch sideways", 2, {"--branch", "sideways"}},
  {"DiagnoseAutoBranch", "diagnose", "--branch auto (not offered: rows are in the order taken)", "diag", [](Dir& d) { d.write("rec.csv", firstLines(recordingB(), 13)); },
   "diagnose --robot {ex}/recordings/friction_masked_B.robot.yaml --recording {d}/rec.csv --json {d}/d.json --branch auto", 2, {"--branch", "auto", "path", "rest"}},
  {"DiagnoseUnknownCandidate", "diagnose", "unknown effect in --candidates", "diag", [](Dir& d) { d.write("rec.csv", firstLines(recordingB(), 13)); },
   "diagnose --robot {ex}/recordings/friction_masked_B.robot.yaml --recording {d}/rec.csv --json {d}/d.json --candidates boundary_friction,warp_drive", 2, {"--candidates", "warp_drive"}},
  {"DiagnoseJsonIsInput", "diagnose", "--json equal to --recording (output = input)", "diag", [](Dir& d) { d.write("rec.csv", firstLines(recordingB(), 13)); },
   "diagnose --robot {ex}/recordings/friction_masked_B.robot.yaml --recording {d}/rec.csv --json {d}/rec.csv", 2, {"rec.csv", "input"}, "rec.csv"},
  {"DiagnoseJsonDirMissing", "diagnose", "--json into a folder that does not exist", "diag", [](Dir& d) { d.write("rec.csv", firstLines(recordingB(), 13)); },
   "diagnose --robot {ex}/recordings/friction_masked_B.robot.yaml --recording {d}/rec.csv --json {d}/none/d.json", 2, {"{d}/none", "does not exist"}},
  {"DiagnoseSecondRecordingMissing", "diagnose", "the second of several recordings does not exist", "diag", [](Dir& d) { d.write("rec.csv", firstLines(recordingB(), 13)); },
   "diagnose --robot {ex}/recordings/friction_masked_B.robot.yaml --recording {d}/rec.csv --recording {d}/gone.csv --json {d}/d.json", 2, {"gone.csv", "not found"}},
  {"DiagnoseSecondRecordingShort", "diagnose", "the second of several recordings has one row", "diag", [](Dir& d) { d.write("rec.csv", firstLines(recordingB(), 13)); d.write("rec2.csv", firstLines(recordingB(), 2)); },
   "diagnose --robot {ex}/recordings/friction_masked_B.robot.yaml --recording {d}/rec.csv --recording {d}/rec2.csv --json {d}/d.json", 2, {"rec2.csv", "1 data row(s)", "at least 8"}},
  {"DiagnoseSameRecordingTwice", "diagnose", "one recording given twice", "diag", [](Dir& d) { d.write("rec.csv", firstLines(recordingB(), 13)); },
   "diagnose --robot {ex}/recordings/friction_masked_B.robot.yaml --recording {d}/rec.csv --recording {d}/rec.csv --json {d}/d.json", 2, {"rec.csv", "given twice"}},
  {"DiagnoseSeveralWithReport", "diagnose", "--report with several recordings (it takes one)", "diag", [](Dir& d) { d.write("rec.csv", firstLines(recordingB(), 13)); d.write("rec2.csv", firstLines(recordingB(), 13)); },
   "diagnose --robot {ex}/recordings/friction_masked_B.robot.yaml --recording {d}/rec.csv --recording {d}/rec2.csv --json {d}/d.json --report {d}/r.md", 2, {"--report", "one --recording"}},
  // ---- recording import / inject ----
  {"ImportInputMissing", "recording import", "input table does not exist", "diag", none,
   "recording import --format dupont-lab --input {d}/lab.txt --out {d}/rec.csv", 2, {"{d}/lab.txt", "not found"}},
  {"ImportNoMapping", "recording import", "no column mapping", "diag", [](Dir& d) { d.write("lab.txt", "1 2 3\n4 5 6\n"); },
   "recording import --input {d}/lab.txt --out {d}/rec.csv", 2, {"no column mapping"}},
  {"ImportBadMapping", "recording import", "malformed --column", "diag", [](Dir& d) { d.write("lab.txt", "1 2 3\n4 5 6\n"); },
   "recording import --input {d}/lab.txt --column alpha_1=x --out {d}/rec.csv", 2, {"--column", "alpha_1=x"}},
  {"ImportColumnBeyondTable", "recording import", "mapped column beyond the table", "diag", [](Dir& d) { d.write("lab.txt", "0 -0.01 0.1\n0.1 -0.01 0.1\n"); },
   "recording import --input {d}/lab.txt --column alpha_1=1 --column beta_1=2 --column tip_x=9 --column tip_y=3 --column tip_z=3 --out {d}/rec.csv", 2, {"lab.txt:1", "tip_x"}},
  {"ImportGarbage", "recording import", "garbage bytes instead of a table", "diag", [](Dir& d) { d.write("lab.txt", std::string("\x01\x02\xff\xfe garbage\n\x7f\x00\x13\n", 16)); },
   "recording import --input {d}/lab.txt --column alpha_1=1 --column beta_1=2 --column twist_2=3 --tubes 1 --out {d}/rec.csv", 2, {"lab.txt"}},
  {"ImportOutIsInput", "recording import", "--out equal to --input (output = input)", "diag", [](Dir& d) { d.write("lab.txt", "0 -0.01 0.1\n0.1 -0.01 0.1\n"); },
   "recording import --input {d}/lab.txt --column alpha_1=1 --column beta_1=2 --column tip_x=3 --column tip_y=3 --column tip_z=3 --out {d}/lab.txt", 2, {"lab.txt", "input"}, "lab.txt"},
  {"InjectUnknownEffect", "recording inject", "unknown --effect", "diag", none,
   "recording inject --robot {ex}/robots/tube_pair_B.yaml --effect gravity_well:g=3 --out {d}/rec.csv", 2, {"--effect", "gravity_well"}},
  {"InjectActuationNaN", "recording inject", "NaN in the actuation", "diag", [](Dir& d) { d.write("act.csv", actuation({kRows[0], "nan,0.1,-0.018,-0.018"})); },
   "recording inject --robot {ex}/robots/tube_pair_B.yaml --actuation {d}/act.csv --out {d}/rec.csv", 2, {"act.csv:3", "alpha_1", "not a finite number"}},
  {"InjectMeasureNothing", "recording inject", "--measure names nothing recordable", "diag", none,
   "recording inject --robot {ex}/robots/tube_pair_B.yaml --measure pressure --out {d}/rec.csv", 2, {"--measure"}},
  {"InjectNoiseNaN", "recording inject", "--noise-twist nan", "diag", none,
   "recording inject --robot {ex}/robots/tube_pair_B.yaml --noise-twist nan --out {d}/rec.csv", 2, {"--noise-twist", "not a finite number"}},
  // ---- env ----
  {"EnvMissing", "env info", "environment file does not exist", "env", none,
   "env info {d}/env.yaml --json", 2, {"{d}/env.yaml"}},
  {"EnvTargetOutsideMap", "env info", "a target outside the map", "env", [](Dir& d) {
     d.write("pts.xyz", "0 0 0\n0.01 0.01 0.01\n");
     d.write("env.yaml", "obstacles: [{points: pts.xyz}]\ntargets: {far: [1, 1, 1]}\n"); },
   "env info {d}/env.yaml", 2, {"env.yaml", "far", "outside the map"}},
  {"EnvTargetMillimetres", "env info", "wrong units: target in mm given as metres", "env", [](Dir& d) {
     d.write("pts.xyz", "0 0 0\n0.01 0.01 0.01\n");
     d.write("env.yaml", "obstacles: [{points: pts.xyz}]\ntargets: {apex: [5, 5, 5]}\n"); },
   "env info {d}/env.yaml", 2, {"env.yaml", "apex", "outside the map"}},
  {"EnvUnknownKey", "env info", "misspelt key", "env", [](Dir& d) {
     const std::string t = edit(readText(kEx + "/environments/proc_intracardiac.yaml"), "resolution: 0.001", "resolutoin: 0.001");
     d.write("env.yaml", t); d.expect["line"] = std::to_string(lineOf(t, "resolutoin")); },
   "env info {d}/env.yaml", 2, {"env.yaml:{line}", "resolutoin", "unknown key"}},
  {"EnvResolutionZero", "env info", "resolution 0", "env", [](Dir& d) {
     const std::string t = edit(readText(kEx + "/environments/proc_intracardiac.yaml"), "resolution: 0.001", "resolution: 0");
     d.write("env.yaml", t); d.expect["line"] = std::to_string(lineOf(t, "resolution: 0")); },
   "env info {d}/env.yaml", 2, {"env.yaml:{line}", "resolution", "must be in"}},
  {"EnvPointsMissing", "env info", "a source file that does not exist", "env", [](Dir& d) { d.write("env.yaml", "obstacles: [{points: nope.xyz}]\n"); },
   "env info {d}/env.yaml", 2, {"nope.xyz"}},
  {"EnvBuildBadExtension", "env build", "output that is not .bt/.ot", "env", none,
   "env build {ex}/environments/proc_intracardiac.yaml -o {d}/heart.png", 2, {"-o", ".bt or .ot"}},
  {"EnvBuildDirMissing", "env build", "output into a folder that does not exist", "env", none,
   "env build {ex}/environments/proc_intracardiac.yaml --resolution 0.004 -o {d}/none/heart.bt", 2, {"{d}/none/heart.bt", "does not exist"}},
  {"EnvCheckWrongJoints", "env check", "wrong number of joints in --alpha", "env", none,
   "env check {ex}/environments/proc_intracardiac.yaml --resolution 0.004 --robot {ex}/robots/proc_intracardiac.yaml --alpha 0,0", 2, {"--alpha", "2 values", "3 tubes"}},
  {"EnvUnknownStart", "env info", "unknown --start name", "env", none,
   "env info {ex}/environments/proc_intracardiac.yaml --resolution 0.004 --start nowhere", 2, {"--start", "nowhere"}},
  // ---- plan / bench (queries) ----
  {"PlanQueryMissing", "plan", "query file does not exist", "plan", none,
   "plan {d}/q.yaml --json {d}/r.json", 2, {"{d}/q.yaml"}},
  {"PlanTimeLimitZero", "plan", "time_limit: 0 in the query", "plan", [](Dir& d) {
     const std::string t = edit(heartQuery(), "time_limit: 20", "time_limit: 0");
     d.write("q.yaml", t); d.expect["line"] = std::to_string(lineOf(t, "time_limit: 0")); },
   "plan {d}/q.yaml --json {d}/r.json", 2, {"q.yaml:{line}", "time_limit", "> 0"}},
  {"PlanFrictionRangeReversed", "plan", "a friction range with lo > hi", "plan", [](Dir& d) {
     const std::string t = edit(heartQuery(), "friction: {boundary: 0.1}", "friction: {boundary: [0.12, 0.06]}");
     d.write("q.yaml", t); d.expect["line"] = std::to_string(lineOf(t, "[0.12, 0.06]")); },
   "plan {d}/q.yaml --json {d}/r.json", 2, {"q.yaml:{line}", "friction.boundary", "lo <= hi"}},
  {"PlanRangeInExactMode", "plan", "a range of a drive's play in exact mode", "plan", [](Dir& d) {
     const std::string t = heartQuery() + "actuation: [{tube: 2, rotation: {play: [0.05, 0.15]}}]\n";
     d.write("q.yaml", t); d.expect["line"] = std::to_string(lineOf(t, "mode: exact")); },
   "plan {d}/q.yaml --json {d}/r.json", 2, {"q.yaml:{line}", "mode", "robust mode"}},
  {"PlanRobustWithLoads", "plan", "robust mode with a tip load (its guarantee covers the load-free model)", "plan", [](Dir& d) {
     const std::string t = edit(heartQuery(), "mode: exact", "mode: robust") + "loads: {tip_force: [0, 0.1, 0]}\n";
     d.write("q.yaml", t); d.expect["line"] = std::to_string(lineOf(t, "loads:")); },
   "plan {d}/q.yaml --json {d}/r.json", 2, {"q.yaml:{line}", "loads", "exact mode"}},
  {"PlanUnknownTimeClock", "plan", "time_limit_clock neither wall nor cpu", "plan", [](Dir& d) {
     const std::string t = edit(heartQuery(), "time_limit: 20", "time_limit: 20\ntime_limit_clock: sundial");
     d.write("q.yaml", t); d.expect["line"] = std::to_string(lineOf(t, "sundial")); },
   "plan {d}/q.yaml --json {d}/r.json", 2, {"q.yaml:{line}", "time_limit_clock", "wall or cpu"}},
  {"PlanTimeOptionZero", "plan", "--time 0", "plan", [](Dir& d) { d.write("q.yaml", heartQuery()); },
   "plan {d}/q.yaml --time 0 --json {d}/r.json", 2, {"--time", "must be > 0"}},
  {"PlanTimeOptionInfinite", "plan", "--time inf", "plan", [](Dir& d) { d.write("q.yaml", heartQuery()); },
   "plan {d}/q.yaml --time inf --json {d}/r.json", 2, {"--time", "inf", "finite"}},
  {"PlanTimeOptionNegative", "plan", "--time -1", "plan", [](Dir& d) { d.write("q.yaml", heartQuery()); },
   "plan {d}/q.yaml --time -1 --json {d}/r.json", 2, {"--time", "-1", "must be > 0"}},
  {"PlanUnknownPlannerInQuery", "plan", "unknown planner in the query", "plan", [](Dir& d) {
     const std::string t = edit(heartQuery(), "planner: portfolio", "planner: teleport");
     d.write("q.yaml", t); d.expect["line"] = std::to_string(lineOf(t, "teleport")); },
   "plan {d}/q.yaml --json {d}/r.json", 2, {"q.yaml:{line}", "planner", "teleport"}},
  {"PlanGravityWithoutDensity", "plan", "gravity in the query's loads on a robot without linear densities", "plan",
   [](Dir& d) {
     const std::string t = edit(heartQuery(), "time_limit: 20", "time_limit: 20\nloads:\n  gravity: [0, 0, -9.81]");
     d.write("q.yaml", t); d.expect["line"] = std::to_string(lineOf(t, "gravity:")); },
   "plan {d}/q.yaml --json {d}/r.json", 2, {"q.yaml:{line}", "loads.gravity", "linear_density"}},
  {"PlanLoadsFrameUnknown", "plan", "unknown frame of the query's loads", "plan", [](Dir& d) {
     const std::string t =
         edit(heartQuery(), "time_limit: 20", "time_limit: 20\nloads: {tip_force: [0.01, 0, 0], frame: world}");
     d.write("q.yaml", t); d.expect["line"] = std::to_string(lineOf(t, "frame: world")); },
   "plan {d}/q.yaml --json {d}/r.json", 2, {"q.yaml:{line}", "loads.frame", "base or environment"}},
  {"PlanUnknownPlannerOption", "plan", "unknown --planner", "plan", [](Dir& d) { d.write("q.yaml", heartQuery()); },
   "plan {d}/q.yaml --planner teleport --json {d}/r.json --path {d}/p.csv", 2, {"teleport"}},
  {"PlanUnknownMode", "plan", "unknown --mode", "plan", [](Dir& d) { d.write("q.yaml", heartQuery()); },
   "plan {d}/q.yaml --mode psychic --json {d}/r.json", 2, {"psychic"}},
  {"PlanStartInCollision", "plan", "a start configuration in collision", "plan", [](Dir& d) {
     const std::string t = edit(heartQuery(), "beta: [-0.10, -0.16, -0.21]", "beta: [-0.01, -0.07, -0.12]");
     d.write("q.yaml", t); d.expect["line"] = std::to_string(lineOf(t, "start:")); },
   "plan {d}/q.yaml --json {d}/r.json --path {d}/p.csv", 2, {"q.yaml:{line}", "start", "collision"}},
  {"PlanStartInadmissible", "plan", "wrong units: start translations in mm", "plan", [](Dir& d) {
     const std::string t = edit(heartQuery(), "beta: [-0.10, -0.16, -0.21]", "beta: [-100, -160, -210]");
     d.write("q.yaml", t); d.expect["line"] = std::to_string(lineOf(t, "start:")); },
   "plan {d}/q.yaml --json {d}/r.json", 2, {"q.yaml:{line}", "start", "admissible"}},
  {"PlanStartBeyondTolerance", "plan", "start with the middle tube end 1 mm behind (beyond the admissibility tolerance)", "plan", [](Dir& d) {
     const std::string t = edit(heartQuery(), "beta: [-0.10, -0.16, -0.21]", "beta: [-0.10, -0.161, -0.21]");
     d.write("q.yaml", t); d.expect["line"] = std::to_string(lineOf(t, "start:")); },
   "plan {d}/q.yaml --json {d}/r.json", 2, {"q.yaml:{line}", "start", "distal end of tube 2"}},
  {"PlanStartWrongJoints", "plan", "start with 2 values for a 3-tube robot", "plan", [](Dir& d) {
     const std::string t = edit(edit(heartQuery(), "alpha: [0.0, 0.0, 0.0]", "alpha: [0.0, 0.0]"), "beta: [-0.10, -0.16, -0.21]", "beta: [-0.10, -0.16]");
     d.write("q.yaml", t); d.expect["line"] = std::to_string(lineOf(t, "alpha: [0.0, 0.0]")); },
   "plan {d}/q.yaml --json {d}/r.json", 2, {"q.yaml:{line}", "start.alpha"}},
  {"PlanGoalOutsideMap", "plan", "a goal position outside the map", "plan", [](Dir& d) {
     const std::string t = edit(heartQuery(), "target: tricuspid", "position: [3.0, 3.0, 3.0]");
     d.write("q.yaml", t); d.expect["line"] = std::to_string(lineOf(t, "position: [3.0")); },
   "plan {d}/q.yaml --json {d}/r.json", 2, {"q.yaml:{line}", "goal.position", "outside the environment's map"}},
  {"PlanUnknownTarget", "plan", "goal target not in the environment", "plan", [](Dir& d) {
     const std::string t = edit(heartQuery(), "target: tricuspid", "target: mitral");
     d.write("q.yaml", t); d.expect["line"] = std::to_string(lineOf(t, "mitral")); },
   "plan {d}/q.yaml --json {d}/r.json", 2, {"q.yaml:{line}", "goal.target", "mitral"}},
  {"PlanRobotMissing", "plan", "query names a robot file that does not exist", "plan", [](Dir& d) {
     const std::string t = edit(heartQuery(), "robots/proc_intracardiac.yaml", "robots/nope.yaml");
     d.write("q.yaml", t); d.expect["line"] = std::to_string(lineOf(t, "nope.yaml")); },
   "plan {d}/q.yaml --json {d}/r.json", 2, {"q.yaml:{line}", "robot", "nope.yaml"}},
  {"PlanJsonIsQuery", "plan", "--json equal to the query (output = input)", "plan", [](Dir& d) {
     d.write("q.yaml", edit(heartQuery(), "beta: [-0.10, -0.16, -0.21]", "beta: [-0.01, -0.07, -0.12]")); },
   "plan {d}/q.yaml --json {d}/q.yaml", 2, {"q.yaml", "input"}, "q.yaml"},
  {"PlanJsonDirMissing", "plan", "--json into a folder that does not exist", "plan", [](Dir& d) { d.write("q.yaml", heartQuery()); },
   "plan {d}/q.yaml --json {d}/none/r.json --time 0.5", 2, {"{d}/none", "does not exist"}},
  {"BenchUnknownPlanner", "bench", "unknown planner in --planners", "plan", [](Dir& d) { d.write("q.yaml", heartQuery()); },
   "bench {d}/q.yaml --planners rrt,teleport --runs 1 --time 1 --out {d}/bench", 2, {"teleport"}},
  {"BenchUnknownMode", "bench", "unknown --mode", "plan", [](Dir& d) { d.write("q.yaml", heartQuery()); },
   "bench {d}/q.yaml --mode psychic --runs 1 --time 1 --out {d}/bench", 2, {"psychic"}},
  {"BenchRunsZero", "bench", "--runs 0", "plan", [](Dir& d) { d.write("q.yaml", heartQuery()); },
   "bench {d}/q.yaml --runs 0 --out {d}/bench", 2, {"--runs", "must be > 0"}},
  {"BenchTimeZero", "bench", "--time 0", "plan", [](Dir& d) { d.write("q.yaml", heartQuery()); },
   "bench {d}/q.yaml --time 0 --out {d}/bench", 2, {"--time", "must be > 0"}},
  {"BenchOutIsFile", "bench", "--out is an existing file, not a folder", "plan", [](Dir& d) {
     d.write("q.yaml", heartQuery()); d.write("bench", "x"); },
   "bench {d}/q.yaml --runs 1 --time 0.5 --out {d}/bench", 2, {"{d}/bench", "not a folder"}, "bench"},
  {"BenchQueryMissing", "bench", "query file does not exist", "plan", none,
   "bench {d}/q.yaml --out {d}/bench", 2, {"{d}/q.yaml"}},
  // ---- design (queries, a design space, shards) ----
  {"DesignNoQuery", "design", "no query file", "plan", none,
   "design --out {d}/o", 2, {"query files are required"}},
  {"DesignOutIsFile", "design", "--out is an existing file, not a folder", "plan", [](Dir& d) {
     d.write("q.yaml", heartQuery()); d.write("o", "x"); },
   "design {d}/q.yaml --out {d}/o", 2, {"{d}/o", "not a folder"}, "o"},
  {"DesignStrainInPercent", "design", "--strain-limit given in percent (6 for 6 %)", "plan",
   [](Dir& d) { d.write("q.yaml", heartQuery()); },
   "design {d}/q.yaml --out {d}/o --strain-limit 6", 2, {"--strain-limit", "fraction"}},
  {"DesignShardOutOfRange", "design", "--shard 2/2 (shards are 0..N-1)", "plan",
   [](Dir& d) { d.write("q.yaml", heartQuery()); },
   "design {d}/q.yaml --out {d}/o --starts 2 --shard 2/2", 2, {"--shard", "0 <= I < N"}},
  {"DesignHtmlWithShard", "design", "--html on a shard (the report belongs to the merge)", "plan",
   [](Dir& d) { d.write("q.yaml", heartQuery()); },
   "design {d}/q.yaml --out {d}/o --starts 2 --shard 0/2 --html", 2, {"--html", "design merge --html"}},
  {"DesignSpaceMisspeltKey", "design", "misspelt key in the design space", "plan", [](Dir& d) {
     d.write("q.yaml", heartQuery()); d.write("s.yaml", "name: s\nstrain_limt: 0.06\n"); },
   "design {d}/q.yaml --space {d}/s.yaml --out {d}/o", 2, {"s.yaml:2", "strain_limt", "unknown key"}},
  {"DesignGoalOutsideMap", "design", "a goal outside the map (no design can be scored): refused up front", "plan",
   [](Dir& d) {
     const std::string t = edit(heartQuery(), "target: tricuspid", "position: [3.0, 3.0, 3.0]");
     d.write("q.yaml", t); d.expect["line"] = std::to_string(lineOf(t, "position: [3.0")); },
   "design {d}/q.yaml --out {d}/o", 2, {"q.yaml:{line}", "goal.position", "outside the environment's map"}},
  {"DesignMergeNoShards", "design merge", "a folder without design shards", "plan", none,
   "design merge {d} --out {d}/m", 2, {"{d}", "no design shard here"}},
  {"DesignMergeOfAMergedResult", "design merge", "a merged result given as a shard", "plan", [](Dir& d) {
     d.write("result.json", R"({"shard": "merged", "fingerprint": "f", "evaluations": [], "queries": []})"); },
   "design merge {d} --out {d}/m", 2, {"result.json", "shard", "a merged result is not a shard"}},
  // ---- demo and the command line itself ----
  {"DemoNegativeFriction", "demo", "negative --boundary-friction", "", none,
   "demo --paper --boundary-friction -1", 2, {"--boundary-friction", "must not be negative"}},
  {"DemoPathDirMissing", "demo", "--path into a folder that does not exist", "plan", none,
   "demo --path {d}/none/path.csv", 2, {"{d}/none", "does not exist"}},
  {"UnknownSubcommand", "(none)", "unknown subcommand", "", none, "teleport --json", 2, {"unknown subcommand", "teleport"}},
  {"NoSubcommand", "(none)", "no subcommand", "", none, "", 2, {"subcommand"}},
  {"UnknownOption", "fk", "unknown option", "", none,
   "fk --robot {ex}/robots/tube_pair_B.yaml --alpah 0,0", 2, {"--alpah"}},
};
// clang-format on

std::string substitute(std::string s, const Dir& d) {
  auto repl = [&s](const std::string& from, const std::string& to) {
    for (std::size_t at = s.find(from); at != std::string::npos; at = s.find(from, at + to.size()))
      s.replace(at, from.size(), to);
  };
  repl("{d}", d.path.string());
  repl("{ex}", kEx);
  for (const auto& [k, v] : d.expect) repl("{" + k + "}", v);
  return s;
}

bool available(const std::string& needs) {
  if (needs.empty()) return true;
#ifndef CTR_TEST_ENVIRONMENTS
  if (needs == "env" || needs == "plan") return false;
#endif
#ifndef CTR_TEST_DIAGNOSIS
  if (needs == "diag") return false;
#endif
#ifndef CTR_TEST_PLANNER
  if (needs == "plan") return false;
#endif
  return true;
}

// Every file under `root` (recursively, hidden ones included) with its content.
std::map<std::string, std::string> snapshot(const fs::path& root) {
  std::map<std::string, std::string> out;
  for (const auto& e : fs::recursive_directory_iterator(root)) {
    const std::string rel = fs::relative(e.path(), root).string();
    out[rel] = e.is_regular_file() ? readText(e.path()) : std::string("<dir>");
  }
  return out;
}

class BadInput : public ::testing::TestWithParam<Case> {};

TEST_P(BadInput, ExitCodeMessageAndNoOutput) {
  const Case& c = GetParam();
  if (!available(c.needs)) GTEST_SKIP() << "`ctr " << c.command << "` is not part of this build";
  Dir d(c.id);
  c.setup(d);
  const auto before = snapshot(d.path);
  const fs::path logs = fs::temp_directory_path() / ("ctr_bad_logs_" + std::to_string(::getpid()));
  fs::create_directories(logs);
  const std::string out = (logs / (c.id + ".out")).string(), err = (logs / (c.id + ".err")).string();
  const std::string args = substitute(c.args, d);
  const std::string cmd = std::string("cd '") + d.path.string() + "' && '" + CTR_EXE + "' " + args + " > '" + out +
                          "' 2> '" + err + "' < /dev/null";
  const int status = std::system(cmd.c_str());
  ASSERT_TRUE(WIFEXITED(status)) << "crashed (signal) on: ctr " << args;
  const int code = WEXITSTATUS(status);
  const std::string serr = readText(err);
  if (std::getenv("CTR_SHOW_STDERR")) std::cout << c.id << " -> " << code << ": " << serr;
  EXPECT_EQ(code, c.code) << "ctr " << args << "\nstderr:\n" << serr;
  for (const std::string& x : c.expect) {
    const std::string want = substitute(x, d);
    EXPECT_NE(serr.find(want), std::string::npos) << "stderr lacks '" << want << "' for: ctr " << args << "\nstderr:\n"
                                                  << serr;
  }
  // One clear message: no stack of unrelated errors, no empty stderr.
  EXPECT_FALSE(serr.empty());
  EXPECT_LT(serr.size(), 2000u) << serr;
  // Nothing written: the folder holds exactly the inputs, unchanged (no output, no temporary file).
  const auto after = snapshot(d.path);
  for (const auto& [name, text] : after) {
    const auto it = before.find(name);
    EXPECT_TRUE(it != before.end()) << "left behind: " << name << " (ctr " << args << ")";
    if (it != before.end()) {
      EXPECT_TRUE(it->second == text) << "changed: " << name << " (ctr " << args << ")";
    }
  }
  EXPECT_EQ(after.size(), before.size()) << "an input disappeared (ctr " << args << ")";
  if (!c.unchanged.empty()) {
    EXPECT_TRUE(fs::exists(d.path / c.unchanged));
  }
  fs::remove(out);
  fs::remove(err);
  std::error_code ec;
  fs::remove(logs, ec);  // only when empty
}

INSTANTIATE_TEST_SUITE_P(Catalogue, BadInput, ::testing::ValuesIn(kCases),
                         [](const ::testing::TestParamInfo<Case>& info) { return info.param.id; });

// The markdown table of docs/reliability.md, generated from kCases.
std::string catalogueTable() {
  std::ostringstream os;
  os << "| # | command | bad input | exit code | stderr contains |\n|---|---|---|---|---|\n";
  int k = 0;
  for (const Case& c : kCases) {
    os << "| " << ++k << " | `" << c.command << "` | " << c.what << " | " << c.code << " | ";
    for (std::size_t i = 0; i < c.expect.size(); ++i) {
      std::string x = c.expect[i];
      for (const auto& [from, to] : std::vector<std::pair<std::string, std::string>>{{"{d}/", ""}, {"{d}", "DIR"}, {"{line}", "LINE"}, {"|", "\\|"}})
        for (std::size_t at = x.find(from); at != std::string::npos; at = x.find(from, at + to.size())) x.replace(at, from.size(), to);
      os << (i ? ", " : "") << "`" << x << "`";
    }
    os << " |\n";
  }
  return os.str();
}

TEST(BadInputCatalogue, HasAtLeast45CasesOverEveryCommand) {
  EXPECT_GE(kCases.size(), 45u);
  std::map<std::string, int> per;
  for (const Case& c : kCases) per[c.command.substr(0, c.command.find(' '))]++;
  for (const char* cmd : {"fk", "ik", "sweep", "simulate", "env", "plan", "bench", "diagnose", "recording", "demo"})
    EXPECT_GE(per[cmd], 1) << cmd;
  std::map<std::string, int> ids;
  for (const Case& c : kCases) EXPECT_EQ(++ids[c.id], 1) << "duplicate id " << c.id;
}

TEST(BadInputCatalogue, DocsTableIsUpToDate) {
  const fs::path doc = fs::path(CTR_SOURCE_DIR) / "docs" / "reliability.md";
  const std::string begin = "<!-- bad-input-catalogue:begin (generated by tests/cli/test_bad_inputs.cpp) -->\n";
  const std::string end = "<!-- bad-input-catalogue:end -->";
  std::string text = readText(doc);
  const std::size_t b = text.find(begin), e = text.find(end);
  ASSERT_NE(b, std::string::npos) << "docs/reliability.md lacks the catalogue markers";
  ASSERT_NE(e, std::string::npos);
  const std::string current = text.substr(b + begin.size(), e - b - begin.size());
  const std::string table = catalogueTable();
  if (current != table && std::getenv("CTR_UPDATE_CATALOGUE")) {
    text.replace(b + begin.size(), e - b - begin.size(), table);
    std::ofstream(doc, std::ios::binary) << text;
    return;
  }
  EXPECT_EQ(current, table) << "regenerate with CTR_UPDATE_CATALOGUE=1 ./test_bad_inputs "
                               "--gtest_filter=BadInputCatalogue.DocsTableIsUpToDate";
}

}  // namespace
