// The diagnosis driver: the rows diagnosed (visits, decimation), the baseline (replay, other branches, noise,
// mismatch), then the stages -- selection rounds, backward elimination, the remainder, proxies, generic descriptions
// and the verdict -- each in a file of its own name.
#include "ctr/diagnosis/diagnose.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "diagnosis_state.hpp"

namespace ctr::diagnosis {

const char* toString(DiagnoseProgress::Stage stage) {
  switch (stage) {
    case DiagnoseProgress::Stage::Baseline:
      return "baseline";
    case DiagnoseProgress::Stage::Screening:
      return "screening";
    case DiagnoseProgress::Stage::Finalists:
      return "finalists";
    case DiagnoseProgress::Stage::LookAlikes:
      return "look-alikes";
    case DiagnoseProgress::Stage::Accepted:
      return "accepted";
    case DiagnoseProgress::Stage::Elimination:
      return "elimination";
    case DiagnoseProgress::Stage::Calibration:
      return "calibration";
    case DiagnoseProgress::Stage::Remainder:
      return "remainder";
    case DiagnoseProgress::Stage::Done:
      return "done";
    case DiagnoseProgress::Stage::Recordings:
      return "recordings";
  }
  return "?";
}

namespace detail {

std::string fmt(const char* f, double a, double b, double c, double d) {
  char buf[512];
  std::snprintf(buf, sizeof buf, f, a, b, c, d);
  return buf;
}

std::string modelName(const std::vector<Effect>& e) {
  std::string s = "nominal";
  for (const Effect& x : e) s += "+" + x.label();
  return s;
}

State::State(const Robot& n, const io::Recording& r, const DiagnoseOptions& opt, DiagnosisReport& report)
    : nominal(n), rec(r), o(opt), rep(report), t0_(std::chrono::steady_clock::now()) {
  progress.max_rounds = opt.max_effects;
}

double State::deltaBic(const Residuals& a, int ka, const Residuals& b, int kb) const {
  const std::vector<char> m = commonRows(a, b, evaluable);
  return bic(rec, b, m, kb) - bic(rec, a, m, ka);
}

void State::say(DiagnoseProgress::Stage stage, const std::string& message) {
  std::lock_guard<std::mutex> lock(mutex_);
  progress.stage = stage;
  progress.message = message;
  progress.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0_).count();
  if (o.progress) o.progress(progress);
}

void State::progressScreened() {
  std::lock_guard<std::mutex> lock(mutex_);
  ++progress.screened;
}

int State::selected() const {
  int n = 0;
  for (const Effect& e : cur.fit.effects) n += calibrated.count(e.label()) == 0;
  return n;
}

bool State::inModel(const Effect& slot) const {
  return std::any_of(cur.fit.effects.begin(), cur.fit.effects.end(), [&](const Effect& e) { return e.sameSlot(slot); });
}

void State::count(int replays) {
  std::lock_guard<std::mutex> lock(mutex_);
  rep.evaluations += replays;
}

void updateNoise(State& s, const Visits& visits) {
  if (s.cur.fit.effects.empty()) return;
  const NoiseReport fin =
      estimateNoise(s.rec, s.cur.fit.residuals, s.cur.fit.prediction, s.evaluable, s.o.noise, &visits);
  bool changed = false;
  for (auto& [q, e] : s.rep.noise.by_quantity) {
    const auto f = fin.by_quantity.find(q);
    if (e.source != "neighbours" || f == fin.by_quantity.end() || f->second.source != "neighbours") continue;
    e = f->second;
    e.note += " (on the residuals of " + modelName(s.cur.fit.effects) + ")";
    changed = true;
  }
  if (!changed) return;
  s.fo.noise = s.rep.noise.levels();
  s.fo_alone.noise = s.fo.noise;
  // The held-out scores of the current model and of the baseline against the new noise.
  for (CrossValidation* cv : {&s.cur.cv, &s.baseline_cv}) {
    cv->row_score = rowScores(s.rec, cv->heldout, s.fo.noise);
    cv->score = finiteMean(cv->row_score);
  }
  double p = 1.0;
  s.base_ratio = s.heldoutRatio(s.baseline_cv, p);
}

/// The command log behind every stride-th visit (empty for stride 1).
CommandHistory historyOfVisits(const io::Recording& vrec, int stride) {
  CommandHistory h;
  if (stride <= 1) return h;
  h.commands = vrec.commands;
  if (vrec.hasTime()) h.time = vrec.time;
  for (int r = 0; r < vrec.rows(); r += stride) h.rows.push_back(r);
  return h;
}

namespace {

/// The noise-normalised squared error of a row whose model outputs are those of `sol` (base frame), measured as the
/// recording measures them (registration applied).
double rowScoreOf(const io::Recording& rec, int k, const Solution& sol, const Registration& reg,
                  const NoiseLevels& noise) {
  double e = 0.0;
  for (Quantity q : presentQuantities(rec)) {
    const double sd = noise.of(q);
    if (!(sd > 0)) continue;
    Eigen::VectorXd pred;
    if (q == Quantity::Twist) {
      pred = sol.twist;
    } else {
      const Eigen::Vector3d t = sol.tipTangent();
      pred = q == Quantity::TipPosition ? reg.mapPosition(sol.tip_position, t) : reg.mapTangent(t);
    }
    const Eigen::MatrixXd& M = measured(rec, q);
    for (Eigen::Index c = 0; c < M.cols() && c < pred.size(); ++c) {
      if (!std::isfinite(M(k, c))) continue;
      double r = M(k, c) - pred[c];
      if (q == Quantity::Twist) r = std::remainder(r, 2 * M_PI);
      e += r * r / (sd * sd);
    }
  }
  return e;
}

}  // namespace

}  // namespace detail

namespace {

/// What a pass leaves for the glitch screen: the final model's residuals, the noise and the rows it used.
struct PassResult {
  Residuals residuals;
  NoiseLevels noise;
  std::vector<char> evaluable;
  std::vector<int> origin;
};

/// One diagnosis of the rows `rec` (visits of `given`, every stride-th), with the rows in `outliers` left out of
/// every fit, test and score after the baseline replay.
DiagnosisReport diagnosePass(const Robot& nominal, const io::Recording& given, const Visits& visits,
                             const io::Recording& rec, int stride, const DiagnoseOptions& o,
                             const std::vector<std::pair<int, OutlierRow>>& outliers, PassResult& out) {
  using detail::fmt;
  using Stage = DiagnoseProgress::Stage;
  const io::Recording& vrec = visits.recording;
  const int rows = rec.rows();
  DiagnosisReport rep;
  rep.frame = o.frame;
  rep.rows = rows;
  rep.stride = stride;
  rep.recording_rows = given.rows();
  rep.visits = vrec.rows();
  rep.branch = toString(o.predict.replay.branch);
  detail::State s(nominal, rec, o, rep);
  for (int k = 0; k < rows; ++k) s.origin.push_back(visits.first_row[static_cast<std::size_t>(k * stride)] + 1);
  if (visits.anyRepeated())
    rep.warnings.push_back(std::to_string(given.rows()) +
                           " rows repeat poses: consecutive rows with the same command "
                           "were averaged into " +
                           std::to_string(vrec.rows()) +
                           " visits (their spread is the "
                           "tracker's jitter, reported with the noise)");
  if (stride > 1)
    rep.warnings.push_back("the recording has " + std::to_string(vrec.rows()) + " distinct rows; one in " +
                           std::to_string(stride) + " was used (" + std::to_string(rows) +
                           " rows) to bound the run time (max_rows = " + std::to_string(o.max_rows) +
                           ", --max-rows 0 uses every row)");
  s.all.assign(static_cast<std::size_t>(rows), 1);
  s.last_block.assign(static_cast<std::size_t>(rows), 0);
  {
    const std::vector<int> fold = foldOfRows(rows, o.folds);
    for (int k = 0; k < rows; ++k)
      s.last_block[static_cast<std::size_t>(k)] = fold[static_cast<std::size_t>(k)] == fold.back();
  }
  s.fo.frame = o.frame;
  s.fo.predict = o.predict;
  if (stride > 1) {
    s.history = detail::historyOfVisits(vrec, stride);
    s.fo.predict.history = &s.history;
  }
  s.fo.max_iterations = o.max_iterations;

  // 2. Baseline: replay with the other stable equilibria of rows reached by an unknown path; rows the nominal model
  //    cannot evaluate; the noise (twice in an unknown frame: the registration's weights depend on it); rows whose
  //    measurement lies nearer another equilibrium; the noise again without them.
  s.say(Stage::Baseline, "baseline: replaying " + std::to_string(rows) +
                             " rows through the nominal model (branch rule " + rep.branch + ")");
  FitOptions bo = s.fo;
  bo.predict.replay.find_alternatives = true;
  s.base = evaluateModel(nominal, rec, {}, s.all, bo, s.ws);
  const std::vector<std::vector<Alternative>> alternatives = s.base.prediction.alternatives;
  s.evaluable.assign(static_cast<std::size_t>(rows), 0);
  int nfailed = 0;
  for (int k = 0; k < rows; ++k) {
    s.evaluable[static_cast<std::size_t>(k)] = s.base.prediction.ok[static_cast<std::size_t>(k)];
    if (s.evaluable[static_cast<std::size_t>(k)]) continue;
    ++nfailed;
    rep.failed_rows.push_back({s.origin[static_cast<std::size_t>(k)],
                               s.base.prediction.failure[static_cast<std::size_t>(k)],
                               s.base.prediction.message[static_cast<std::size_t>(k)], "nominal"});
  }
  for (const auto& [k, row] : outliers) {
    s.evaluable[static_cast<std::size_t>(k)] = 0;
    rep.outlier_rows.push_back(row);
  }
  if (!outliers.empty()) {
    rep.warnings.push_back(std::to_string(outliers.size()) +
                           " row(s) look like tracker glitches (their residuals under the final model are far beyond "
                           "the noise and their neighbours') and are excluded from every fit, test and score "
                           "(outlier_rows)");
    s.say(Stage::Baseline, rep.warnings.back());
  }
  if (nfailed == rows)
    throw std::runtime_error(
        "the nominal model could not evaluate any row of the recording (row 1: " + s.base.prediction.message[0] + ")");
  if (nfailed > 0) {
    rep.warnings.push_back(std::to_string(nfailed) + " of " + std::to_string(rows) +
                           " rows could not be evaluated by the nominal model and are excluded from every residual, "
                           "fit, noise estimate and score (failed_rows)");
    s.say(Stage::Baseline, rep.warnings.back());
  }
  auto estimate = [&]() {
    s.fo.rows = s.evaluable;  // (the registration already skipped failed rows: their predictions are NaN)
    excludeRows(s.base.residuals, s.evaluable);
    rep.noise = estimateNoise(rec, s.base.residuals, s.base.prediction, s.evaluable, o.noise, &visits);
    s.fo.noise = rep.noise.levels();
    if (o.frame == FrameMode::Unknown) {
      s.base = evaluateModel(nominal, rec, {}, s.all, s.fo, s.ws);
      rep.noise = estimateNoise(rec, s.base.residuals, s.base.prediction, s.evaluable, o.noise, &visits);
      s.fo.noise = rep.noise.levels();
      s.base = evaluateModel(nominal, rec, {}, s.all, s.fo, s.ws);
    }
  };
  estimate();
  if (detail::checkDiscretisation(s)) {
    s.base = evaluateModel(nominal, rec, {}, s.all, s.fo, s.ws);
    estimate();
  }
  int off_branch = 0;
  for (int k = 0; k < rows; ++k) {
    const std::vector<Alternative>& alt = alternatives[static_cast<std::size_t>(k)];
    if (alt.empty() || !s.evaluable[static_cast<std::size_t>(k)]) continue;
    BranchAmbiguousRow b;
    b.row = s.origin[static_cast<std::size_t>(k)];
    const double own = finiteMean(rowScores(rec, s.base.residuals, s.fo.noise).segment(k, 1));
    for (const Alternative& a : alt) {
      b.alternatives_mm.push_back(a.tip_distance * 1e3);
      b.excluded = b.excluded || detail::rowScoreOf(rec, k, a.solution, s.base.registration, s.fo.noise) < own;
    }
    if (b.excluded) {
      s.evaluable[static_cast<std::size_t>(k)] = 0;
      ++off_branch;
    }
    rep.branch_ambiguous_rows.push_back(b);
  }
  if (!rep.branch_ambiguous_rows.empty())
    s.say(Stage::Baseline, std::to_string(rep.branch_ambiguous_rows.size()) +
                               " row(s) have other stable equilibria the robot may have reached by an unknown path; " +
                               std::to_string(off_branch) + " lie nearer one of them and are excluded");
  if (off_branch > 0) {
    rep.warnings.push_back(std::to_string(off_branch) +
                           " row(s) lie nearer another stable equilibrium of the nominal model than the one reached by "
                           "the branch rule and are excluded from every fit and score (branch_ambiguous_rows)");
    estimate();
  }
  rep.mismatch = locateMismatch(rec, s.base.prediction, s.base.residuals, s.fo.noise, o.mismatch);
  for (const auto& f : rep.mismatch.findings)
    s.say(Stage::Baseline, "mismatch: " + f.signature + " " + f.variable + ": " + f.where);
  s.fo_alone = s.fo;
  s.fo_alone.threads = o.threads;
  s.cur.fit = s.base;
  s.cur.cv = crossValidate(nominal, rec, {}, o.folds, s.fo, s.ws, 6, o.threads);
  s.cur.bic = bic(rec, s.base.residuals, s.evaluable, 0);
  rep.folds = std::min(o.folds, rows);
  s.count(s.base.evaluations + s.cur.cv.evaluations + 2);
  rep.baseline.model = "nominal";
  rep.baseline.heldout_rmse = s.cur.cv.rmse;
  rep.baseline.last_block_rmse = rmse(rec, s.cur.cv.heldout, s.last_block);
  rep.baseline.fit_rmse = rmse(rec, s.base.residuals, s.evaluable);
  rep.baseline.heldout_score = s.cur.cv.score;
  rep.baseline.bic = s.cur.bic;
  s.baseline_cv = s.cur.cv;
  double base_p = 1.0;
  s.base_ratio = s.heldoutRatio(s.baseline_cv, base_p);
  s.slots = candidateSlots(nominal, rec, o);
  if (o.generic_models)
    for (const Effect& g : detail::genericSlots(rec)) s.slots.push_back(g);
  const bool gravity_asked = o.candidates.empty() || std::find(o.candidates.begin(), o.candidates.end(),
                                                               EffectKind::Gravity) != o.candidates.end();
  if (gravity_asked && !gravityUnavailable(nominal).empty())
    rep.warnings.push_back("gravity was not tried: " + gravityUnavailable(nominal));
  s.chunks = std::max(3, std::min(24, rows / 3));

  // 3. Forward selection, backward elimination, the remainder and proxies; with a remainder, the description
  //    calibrated as a block and the selection again on top; generic descriptions, detection limits, the verdict.
  auto selectAndCheck = [&](int first_round) {
    bool grew = false;
    for (int round = first_round; s.selected() < o.max_effects; ++round) {
      if (!detail::selectionRound(s, round)) break;
      grew = true;
      detail::updateNoise(s, visits);
    }
    if (grew) {  // else the model is as the previous elimination (or the calibration's pruning) left it
      detail::backwardElimination(s);
      detail::updateNoise(s, visits);
    }
    detail::assessRemainder(s);
    s.confounded.clear();  // the proxy tests judge the model as it is now
    s.removed_partial.clear();
    detail::checkProxies(s);
  };
  selectAndCheck(1);
  if (o.calibrate_description) {
    detail::Snapshot before;
    before.fields() = detail::snapshotFields(s);
    if (detail::calibrateDescription(s, rep.rounds + 1)) {
      rep.rounds += 1;
      detail::updateNoise(s, visits);
      selectAndCheck(rep.rounds + 1);
      detail::keepCalibrationIfBetter(s, before);
    }
  }
  detail::describeRemainder(s);
  detail::assessDetectionLimits(s);
  detail::writeVerdict(s);
  rep.seconds = s.progress.seconds;
  s.say(Stage::Done, fmt("done in %.1f s: %.0f round(s), %.0f replays", rep.seconds, rep.rounds, rep.evaluations));
  rep.seconds = s.progress.seconds;
  out.residuals = s.cur.fit.residuals;
  out.noise = s.fo.noise;
  out.evaluable = s.evaluable;
  rep.used_rows = s.evaluable;
  out.origin = s.origin;
  return rep;
}

}  // namespace

CommandHistory diagnosedHistory(const io::Recording& rec, int stride) {
  return detail::historyOfVisits(collapseFrames(rec).recording, stride);
}

FitOptions diagnosedFitOptions(const DiagnosisReport& report, const DiagnoseOptions& options,
                               const CommandHistory& history) {
  FitOptions fo;
  fo.frame = report.frame;
  fo.predict = options.predict;
  fo.predict.replay.friction.kinematics.max_step = report.discretisation.max_step;
  fo.predict.replay.friction.kinematics.max_bending_per_step = report.discretisation.max_bending_per_step;
  if (report.stride > 1) fo.predict.history = &history;
  fo.max_iterations = options.max_iterations;
  fo.rows = report.used_rows;
  fo.noise = report.noise.levels();
  fo.threads = options.threads;
  return fo;
}

DiagnosisReport diagnose(const Robot& nominal, const io::Recording& given, const DiagnoseOptions& o) {
  if (given.tubes != nominal.size())
    throw std::invalid_argument("recording has " + std::to_string(given.tubes) + " tubes, robot '" + nominal.name() +
                                "' has " + std::to_string(nominal.size()));
  // 1. The rows diagnosed: repeated frames (consecutive rows with one command) averaged into visits, then every
  //    stride-th visit of a long recording (the replay passes through the path between them).
  const Visits visits = collapseFrames(given);
  const io::Recording& vrec = visits.recording;
  const int stride = (o.max_rows > 0 && vrec.rows() > o.max_rows) ? (vrec.rows() + o.max_rows - 1) / o.max_rows : 1;
  const io::Recording decimated = stride > 1 ? decimateRecording(vrec, stride) : io::Recording{};
  const io::Recording& rec = stride > 1 ? decimated : vrec;  // = diagnosedRows(given, stride)
  const int rows = rec.rows();
  if (rows < 8)
    throw std::invalid_argument("recording has " + std::to_string(rows) + " distinct rows" +
                                (visits.anyRepeated() ? " (after averaging repeated frames)" : "") +
                                "; at least 8 are needed");
  // 2-3. The diagnosis; then rows that look like tracker glitches under its final model are left out and the diagnosis
  //      runs again (up to twice), so that neither the fitted values nor the noise rest on them.
  std::vector<std::pair<int, OutlierRow>> outliers;
  PassResult pass;
  DiagnosisReport rep = diagnosePass(nominal, given, visits, rec, stride, o, outliers, pass);
  double seconds = rep.seconds;
  int replays = rep.evaluations;
  for (int again = 0; again < 2; ++again) {
    const auto found = detail::screenOutliers(rec, pass.residuals, pass.noise, pass.evaluable, pass.origin,
                                              o.outlier_alpha, o.max_outlier_fraction);
    if (found.empty() ||
        static_cast<double>(outliers.size() + found.size()) > o.max_outlier_fraction * static_cast<double>(rows))
      break;
    outliers.insert(outliers.end(), found.begin(), found.end());
    std::sort(outliers.begin(), outliers.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
    if (o.progress) {
      DiagnoseProgress p;
      p.stage = DiagnoseProgress::Stage::Baseline;
      p.seconds = seconds;
      p.message = std::to_string(found.size()) + " row(s) look like tracker glitches under the final model; " +
                  "diagnosing again without them";
      o.progress(p);
    }
    rep = diagnosePass(nominal, given, visits, rec, stride, o, outliers, pass);
    seconds += rep.seconds;
    replays += rep.evaluations;
  }
  rep.seconds = seconds;
  rep.evaluations = replays;
  return rep;
}

}  // namespace ctr::diagnosis
