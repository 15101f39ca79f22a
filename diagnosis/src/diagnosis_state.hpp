// What the stages of a diagnosis share (internal): the working rows, fit options, the current model of the
// selection, the findings so far, and the progress sink. Each stage is a free function in a file of its name.
#pragma once

#include <chrono>
#include <cstdio>
#include <functional>
#include <map>
#include <mutex>
#include <set>
#include <string>
#include <tuple>
#include <vector>

#include "ctr/diagnosis/diagnose.hpp"

namespace ctr::diagnosis::detail {

/// printf-style formatting of up to four numbers.
std::string fmt(const char* f, double a, double b = 0, double c = 0, double d = 0);
/// A reported parameter in words: "mu=0.118" / "force=(0.05, 0, -0.1)" / "tube=2" (report.cpp).
std::string paramText(const NamedParameter& p);
/// Its 95 % interval: "[lo, hi]", one per component of a vector parameter (report.cpp).
std::string intervalText(const NamedParameter& p);

/// The command log behind every stride-th row of the visits `vrec` (PredictOptions::history; empty for stride 1).
CommandHistory historyOfVisits(const io::Recording& vrec, int stride);

/// The accepted finding that names `e`'s slot in the verdict (nullptr: none).
const Finding* namingFinding(const DiagnosisReport& r, const Effect& e);
/// Effects of the recording (its timing and its tracker), not of the robot: sensor latency, tracker drift.
bool ofTheRecording(EffectKind k);
/// An effect of the final model that --robot-out applies: named by the verdict, of the robot (not of the recording,
/// not a generic description).
bool robotEffectOf(const DiagnosisReport& r, const Effect& e);

/// "nominal+effect+..." of a list of effects.
std::string modelName(const std::vector<Effect>& e);

/// A model of the selection: effects, full-data fit, cross-validation, BIC.
struct Candidate {
  Effect slot;
  FitResult fit;
  CrossValidation cv;
  bool cv_done = false;
  double bic = 0.0;
  double delta_bic = 0.0;
  double heldout_p = 1.0;
  double gain = 0.0;
  bool pass = false;
  bool failed = false;
  bool probed_only = false;  ///< Not fitted: distributed friction probed at a large coefficient, or a load whose
                             ///< first-order screen predicts no BIC gain (screenFirstOrder).
  std::string reason;
};

/// The detection limit of a candidate not in the final model, with its sentence for the finding.
struct DetectionNote {
  double value = 0.0;  ///< In the parameter's units (infinity: no size can be told from none).
  std::string text;    ///< For the finding's explanation.
};

/// The shared state of one diagnosis.
struct State {
  State(const Robot& nominal, const io::Recording& rec, const DiagnoseOptions& o, DiagnosisReport& rep);

  const Robot& nominal;
  const io::Recording& rec;  ///< The rows diagnosed (visits, decimated when long).
  const DiagnoseOptions& o;
  DiagnosisReport& rep;
  std::vector<int> origin;       ///< 1-based row of the recording as given where each diagnosed row starts.
  CommandHistory history;        ///< The full-rate commands behind decimated rows.
  FitOptions fo;                 ///< Fits that run beside others (one thread each).
  FitOptions fo_alone;           ///< Fits that run alone (every thread).
  std::vector<char> all;         ///< Every row.
  std::vector<char> evaluable;   ///< Rows used by every residual, fit and score.
  std::vector<char> last_block;  ///< The latest held-out block.
  Workspace ws;
  FitResult base;  ///< The nominal model.
  CrossValidation baseline_cv;
  Candidate cur;              ///< The current model of the selection.
  int chunks = 3;             ///< Contiguous chunks of the block bootstrap.
  std::vector<Effect> slots;  ///< Candidates of the library.

  std::map<std::string, Finding> last;                  ///< Latest finding per slot label.
  std::vector<std::string> order;                       ///< Slot labels in the order first tried.
  std::map<std::string, std::vector<Rival>> rivals_of;  ///< Accepted label -> look-alikes it cannot be told from.
  std::map<std::string, std::string> removed;           ///< Accepted, then dropped: why.
  std::map<std::string, std::string> removed_partial;   ///< Accepted, kept in the fit, not named: why.
  std::set<std::string> confounded;                     ///< Labels of removed_partial.
  std::set<std::string> calibrated;                     ///< Labels accepted with the calibration of the description.
  std::map<std::string, std::vector<std::string>> replaced_by;  ///< Generic label -> library candidates it beat.
  std::vector<FitResult> without;  ///< Refits of `cur` without each of its effects (elimination, confounding).
  MismatchReport final_mismatch;   ///< Locate tests on the final model's residuals.
  std::map<std::string, DetectionNote> detection;  ///< Slot label -> detection limit (candidates not in the model).
  double base_ratio = 1.0;                         ///< Baseline held-out mean square over the noise variance.

  /// BIC of model b minus model a, on the rows both evaluated.
  double deltaBic(const Residuals& a, int ka, const Residuals& b, int kb) const;
  /// Held-out mean square over the noise variance (per independent component) and its p-value against the noise.
  double heldoutRatio(const CrossValidation& cv, double& p) const;
  /// Reports progress (thread-safe).
  void say(DiagnoseProgress::Stage stage, const std::string& message);
  /// One more candidate of the round screened (thread-safe).
  void progressScreened();
  /// Adds replays to the report's count (thread-safe).
  void count(int replays);
  /// Effects of the current model selected one by one (not by the calibration of the description).
  int selected() const;
  /// The current model has an effect in this slot (kind, tube).
  bool inModel(const Effect& slot) const;
  /// The progress counters (round, candidates) are updated by the stages.
  DiagnoseProgress progress;

 private:
  std::chrono::steady_clock::time_point t0_;
  std::mutex mutex_;
};

/// Held-out scores of two models on the same rows (same noise): the block bootstrap p that `after` predicts them
/// better than `before`, and the fraction by which its mean score is lower.
struct HeldOutComparison {
  double p = 1.0;
  double gain = 0.0;
};
HeldOutComparison compareHeldOut(const Eigen::VectorXd& before, const Eigen::VectorXd& after, int chunks);

/// Held-out test of a candidate's model against the current one, on the rows both evaluated: cross-validation
/// (one-step from its linearisation when asked and available), bootstrap p and gain. Returns the replays used.
int heldOut(State& s, Candidate& c, Workspace& ws, int threads, bool one_step);
/// Runs fn(c, ws); a model that cannot be evaluated marks the candidate failed with the reason.
void guarded(State& s, Candidate& c, Workspace& ws, const std::function<void(Candidate&, Workspace&)>& fn);
/// A finalist: the linearisation of its screened model (intervals; the one-step held-out test from it) and the
/// held-out test (pass / reason).
void refineCandidate(State& s, Candidate& c, Workspace& ws);

/// The outcome of the look-alike tests of a round's winner.
struct LookAlikes {
  int best = -1;                          ///< The winner (a rival that explains more replaces it).
  std::vector<int> partners;              ///< Look-alikes accepted together with it (each adds on top of the other).
  Candidate pair;                         ///< The joint model of the winner and its partners.
  std::vector<Rival> ties;                ///< Look-alikes this recording cannot tell from the winner.
  std::map<int, std::string> rival_note;  ///< Candidate index -> why it lost to (or ties with) the winner.
  bool look_alikes = true;                ///< The partners are look-alikes of the winner (else a joint pair).
};

/// Encompassing tests of cands[best] against the best screened candidates of its look-alike group (`ranked`: the
/// round's candidates by screening BIC).
LookAlikes resolveLookAlikes(State& s, std::vector<Candidate>& cands, int best, const std::vector<int>& ranked);

/// When no candidate of a round passes on its own: the two strongest refined candidates of different kinds, each
/// with a held-out gain that is not significant alone, fitted jointly. The pair is accepted (best + one partner) when
/// each adds on top of the other and together they predict the held-out rows significantly better than the current
/// model; otherwise best stays -1.
LookAlikes jointPair(State& s, std::vector<Candidate>& cands, const std::vector<int>& ranked);

/// Runs selection round `round` on top of s.cur (screening, finalists, held-out preference, look-alikes, joint
/// refinement); records the findings. Returns false when no candidate was accepted.
bool selectionRound(State& s, int round);

/// The current model's effects without those at the indices `drop`.
std::vector<Effect> withoutEffects(const State& s, const std::vector<std::size_t>& drop);
/// Fills s.without: the current model refitted without each of its effects (warm, in parallel).
void refitEachWithout(State& s);
/// A noise estimated from neighbouring rows, estimated again on the current model's residuals (less model error than
/// the nominal model's): the later rounds, the remainder and the report use it; the current and baseline held-out
/// scores are recomputed against it.
void updateNoise(State& s, const Visits& visits);
/// Removes accepted effects that later ones made redundant (BIC), refitting the model. `why` (a format with the BIC
/// change, %+.1f) is the reason recorded for each removed effect.
void backwardElimination(State& s, const char* why =
                                       "removed again after the later rounds: without it BIC changes by "
                                       "only %+.1f, so the other accepted effects explain what it "
                                       "explained");

/// The replays' integration steps (s.fo.predict) against the library's default steps on the nominal model, in units of
/// the noise (s.rep.discretisation); when the error exceeds DiagnoseOptions::max_discretisation_error the default steps
/// replace them in s.fo and true is returned (the baseline must be replayed again).
bool checkDiscretisation(State& s);

/// When the selection leaves a remainder, the description's parameters fitted together on top of the current model
/// (calibration.cpp): accepted as a block when they pass the selection's BIC and held-out tests, then pruned by
/// backward elimination. Returns true when the current model was replaced.
bool calibrateDescription(State& s, int round);

/// What the selection has found so far (the parts of State the stages change), to return to.
struct Snapshot {
  FitOptions fo, fo_alone;
  Candidate cur;
  std::map<std::string, Finding> last;
  std::vector<std::string> order;
  std::map<std::string, std::vector<Rival>> rivals_of;
  std::map<std::string, std::string> removed, removed_partial;
  std::set<std::string> confounded, calibrated;
  std::map<std::string, std::vector<std::string>> replaced_by;
  MismatchReport final_mismatch;
  DiagnosisReport rep;
  auto fields() {
    return std::tie(fo, fo_alone, cur, last, order, rivals_of, removed, removed_partial, confounded, calibrated,
                    replaced_by, final_mismatch, rep);
  }
};
/// The same parts of the state, in Snapshot's order (snapshot: copy from; restore: copy into).
inline auto snapshotFields(State& s) {
  return std::tie(s.fo, s.fo_alone, s.cur, s.last, s.order, s.rivals_of, s.removed, s.removed_partial, s.confounded,
                  s.calibrated, s.replaced_by, s.final_mismatch, s.rep);
}

/// After a calibration and the selection on top of it: the result is kept only when its final model predicts the
/// held-out rows significantly better than the model `before` the calibration (the proxy tests on the calibrated
/// model may have dropped effects the model before it named); otherwise the state returns to `before`, with the
/// reason in a warning and in the findings of the calibrated parameters.
void keepCalibrationIfBetter(State& s, Snapshot& before);

/// Locate tests on the final model's residuals and its held-out error against the noise (docs/formats.md
/// `unexplained`), into s.rep.unexplained.
void assessRemainder(State& s);

/// Proxies: accepted effects whose fitted value is not constant over the recording are dropped (constancy), and
/// those a generic correction of the remainder can replace are kept in the fit but not named (confounding).
void checkProxies(State& s);

/// The generic slots of a recording (generic.cpp): a drive error per rotating tube, a stage error per translating
/// tube, a tracker drift with time and tip positions.
std::vector<Effect> genericSlots(const io::Recording& rec);

/// When the selection accepted generic models of physics outside the library (drive transmission errors, stage
/// errors, tracker drift): the remainder of the library model (s.rep.unexplained, present) and each generic model's
/// description with its held-out gain (s.rep.unexplained.described).
void describeRemainder(State& s);

/// The detection limit of every one-parameter library candidate not in the final model (s.detection).
void assessDetectionLimits(State& s);

/// The verdict, the findings with their final values, failed-row reliability and the summary paragraph.
void writeVerdict(State& s);

/// Rows whose residual `r` (under the final model, on the rows flagged in `use`) looks like a tracker glitch: beyond
/// the noise times the residuals' own robust scale (their median over the chi-square median) at a family-wise rate
/// `alpha` over rows and quantities, alone (neither neighbouring row beyond the limit: a stretch of such rows is model
/// error), and -- along a densely sampled path, where model error is smooth -- beyond it against the mean of the two
/// neighbouring rows as well. None when more than `max_fraction` of the rows would be.
/// Each with its row index in `rec` and the row of the recording as given (`origin`).
std::vector<std::pair<int, OutlierRow>> screenOutliers(const io::Recording& rec, const Residuals& r,
                                                       const NoiseLevels& noise, const std::vector<char>& use,
                                                       const std::vector<int>& origin, double alpha,
                                                       double max_fraction);

/// Plain words for the significant locate tests of a residual (for `unexplained.where`).
std::string remainderWords(const MismatchReport& m, double ratio, const NoiseReport& noise);

}  // namespace ctr::diagnosis::detail
