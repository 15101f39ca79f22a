/// @file diagnose.hpp
/// @brief Automatic diagnosis of a recording against a nominal robot: baseline replay, statistical localisation of
/// the mismatch, a library of candidate left-out physics fitted on training blocks and scored on held-out blocks,
/// forward selection (held-out error + BIC), and a plain-language explanation.
#pragma once

#include <functional>
#include <limits>
#include <map>
#include <string>
#include <vector>

#include "ctr/diagnosis/effect.hpp"
#include "ctr/diagnosis/fit.hpp"
#include "ctr/diagnosis/mismatch.hpp"
#include "ctr/diagnosis/noise.hpp"
#include "ctr/diagnosis/residuals.hpp"
#include "ctr/io/recording.hpp"

namespace ctr::diagnosis {

/// @brief Progress of a running diagnosis (as Ceres' IterationSummary): what stage it is in and what it has done.
struct DiagnoseProgress {
  /// @brief Stages in the order they run.
  enum class Stage {
    Baseline,     ///< Replaying the nominal model, estimating the noise, locating the mismatch.
    Screening,    ///< A round's candidates are fitted one by one on top of the current model.
    Finalists,    ///< The best of the round are linearised and cross-validated.
    LookAlikes,   ///< Encompassing fits of the winner against its look-alikes.
    Accepted,     ///< The round ended (an effect accepted, or none).
    Elimination,  ///< Backward elimination.
    Calibration,  ///< The description's parameters fitted together (calibrateDescription).
    Remainder,    ///< What the final model leaves; proxies (constancy, confounding); generic descriptions.
    Done,
    Recordings,  ///< Several recordings (diagnoseRecordings): their effects refitted in each and compared.
  };
  Stage stage = Stage::Baseline;
  int round = 0;         ///< Current selection round (1-based; 0 before the first).
  int rounds = 0;        ///< Rounds completed.
  int max_rounds = 0;    ///< At most this many rounds (DiagnoseOptions::max_effects).
  int candidates = 0;    ///< Candidates of the current round.
  int screened = 0;      ///< Of them, screened so far.
  int accepted = 0;      ///< Effects in the current model.
  double seconds = 0.0;  ///< Since the start.
  std::string message;   ///< One line for people (what happened).
};

/// @brief Name of a stage ("baseline", "screening", ...).
const char* toString(DiagnoseProgress::Stage stage);

/// @brief Options of diagnose().
struct DiagnoseOptions {
  FrameMode frame = FrameMode::Base;  ///< Unknown: registration estimated in every model (baseline included).
  int folds = 4;                      ///< Contiguous held-out blocks.
  int max_effects = 6;                ///< Largest combination of effects selected one by one (the parameters
                                      ///< of a calibrated description do not count).
  /// When the selected effects leave a remainder: fit what a robot calibration fits (precurvatures, bending stiffness
  /// ratios, torsional stiffness, drive zeros) together on top of them and, if the block passes the selection's
  /// tests, keep the parameters that earn their place and select the other effects again on top (docs/diagnosis.md).
  bool calibrate_description = false;
  int calibration_iterations = 20;     ///< Ceres iterations of the calibration's joint fit.
  double bic_threshold = 10.0;         ///< Accept only if BIC drops by more than this ("very strong" evidence).
  double heldout_p = 0.05;             ///< Held-out improvement must be significant at this level.
  double min_heldout_gain = 0.02;      ///< ... and reduce the held-out normalised error by at least this fraction.
  int threads = 2;                     ///< Candidates (and each one's cross-validation folds) fitted in parallel.
  std::vector<EffectKind> candidates;  ///< Kinds to try; empty = all (sensor_latency only with time).
  int max_iterations = 6;              ///< Ceres iterations of a full (joint) fit, started from the screening optimum.
  int screen_iterations = 8;           ///< Ceres iterations when screening a candidate (new parameter only).
  int cv_iterations = 3;               ///< Ceres iterations of a fold refit when no linearisation is available
                                       ///< (otherwise one Gauss-Newton step from the full-data fit, fit.hpp).
  bool one_step_cv = true;             ///< Fold refits by one Gauss-Newton step (see crossValidate).
  int finalists = 4;                   ///< Candidates per round linearised and cross-validated: the best by
                                       ///< screening BIC (plus all within twice bic_threshold of the best); the
                                       ///< round's winner alone is then refitted jointly.
  double unreliable_fraction = 0.05;   ///< More failed rows than this fraction make the verdict unreliable.
  /// Tracker glitches: after the selection, rows whose residual under the final model is beyond what the noise (times
  /// the residuals' own robust scale) allows at this family-wise rate are listed as outliers and the diagnosis runs
  /// again without them (docs/diagnosis.md "Tracker glitches"); 0 = no screen.
  double outlier_alpha = 0.01;
  /// ... but only while they are at most this fraction of the rows (more is model error or noise, not glitches).
  double max_outlier_fraction = 0.1;
  int max_rows = 600;  ///< Longer recordings are decimated uniformly (every k-th row, history kept
                       ///< by the quasi-static sub-stepping) to bound the run time; 0 = never.
  /// Noise given by the user (a tracker's specification); the quantities not given are estimated (noise.hpp).
  GivenNoise noise;
  /// Generic models of physics outside the library tried on the remainder (describeRemainder); false: none.
  bool generic_models = true;
  MismatchOptions mismatch;
  PredictOptions predict;  ///< Replay options, the branch rule among them (replay.hpp).
  /// The replays' integration steps (PredictOptions) are kept when the nominal replay with them differs from the one at
  /// the library's default steps by less than this fraction of the noise on every row and measured component;
  /// otherwise every replay uses the default steps (DiagnosisReport::discretisation).
  double max_discretisation_error = 0.05;
  std::function<void(const DiagnoseProgress&)> progress;  ///< Called at every step (any thread); may be empty.
};

/// @brief Scores of one model.
struct ModelScore {
  std::string model;  ///< "nominal" or "nominal+effect+...".
  std::vector<Effect> effects;
  std::map<std::string, double> heldout_rmse;     ///< Per quantity (SI).
  std::map<std::string, double> fit_rmse;         ///< In-sample RMSE per quantity (all rows).
  std::map<std::string, double> last_block_rmse;  ///< Held-out RMSE on the last (latest in time) block only.
  double heldout_score = 0.0;                     ///< Mean noise-normalised squared error per held-out row.
  double bic = 0.0;
};

/// @brief A rival look-alike effect that fits the recording as well as an accepted one (docs/formats.md
/// `ambiguous_with`): neither adds significantly on top of the other.
struct Rival {
  Effect effect;                               ///< Fitted value alone on top of the model of its round.
  double delta_bic = 0.0;                      ///< BIC(model with it) - BIC(model of its round).
  std::map<std::string, double> heldout_rmse;  ///< Held-out RMSE with it instead of the accepted effect.
  double heldout_p = 1.0;                      ///< One-sided p that the accepted effect predicts held-out rows better.
  std::string why;                             ///< The evidence (encompassing fits).
};

/// @brief One candidate tried (accepted or not), with the evidence.
struct Finding {
  Effect effect;              ///< Fitted value (alone on top of the model of its round).
  std::vector<Effect> model;  ///< The full model it was fitted in.
  bool accepted = false;
  int round = 0;  ///< Selection round (1-based).
  /// The reported parameters with their 95 % intervals (namedParameters): e.g. `mu` (+ `tube`); `force` (3-vector)
  /// for tip_load; `scale` and `direction` for gravity.
  std::vector<NamedParameter> parameters;
  std::map<std::string, double> heldout_rmse;
  double heldout_score = 0.0;
  double heldout_p = 1.0;             ///< One-sided p of the held-out improvement.
  double delta_bic = 0.0;             ///< BIC(model with it) - BIC(model of its round).
  std::vector<Rival> ambiguous_with;  ///< Look-alikes this recording cannot tell from it (accepted only).
  bool partial = false;               ///< Accepted, but a structured remainder is left (see `unexplained`).
  bool named = true;                  ///< Accepted and named in the verdict (false: a partial explanation kept in
                                      ///< the final fit, its value not constant over the recording or confounded
                                      ///< with the unexplained remainder; the explanation says which).
  /// Accepted with a fitted coordinate at a limit of its search range (fit.hpp parameterRange) that its nominal value
  /// is not at: the recording asks for more, so the value is a bound, not an estimate.
  bool at_range_limit = false;
  /// Not accepted, one parameter: the smallest size this recording can tell from none on top of the final model
  /// (the larger of the 95 % interval half-width, serial correlation counted, and the size that would pass the BIC
  /// threshold; first order), in the parameter's units; infinity when the recording does not depend on it; NaN when
  /// not computed (accepted, or several parameters).
  double detection_limit = std::numeric_limits<double>::quiet_NaN();
  std::string explanation;
};

/// @brief A row the model could not evaluate, excluded from every residual, fit, noise estimate and score.
struct FailedRow {
  int row = 0;                      ///< 1-based data row of the recording as given (before any decimation).
  Failure failure = Failure::None;  ///< Why (NotConverged, Inadmissible, NoContactSet, Snapped, Unstable).
  std::string message;              ///< The same in words: "did not converge", "inadmissible command: ...".
  std::string model;   ///< "nominal" or the final model that failed on it.
};

/// @brief A row where the model has other stable equilibria the robot may have reached by an unknown path
/// (docs/formats.md `branch_ambiguous_rows`).
struct BranchAmbiguousRow {
  int row = 0;                          ///< 1-based row of the recording as given.
  std::vector<double> alternatives_mm;  ///< Tip distance of each alternative from the replayed equilibrium (mm).
  bool excluded = false;                ///< The measurement lies nearer an alternative: left out of every fit.
};

/// @brief The verdict's names, one per kind: each entry is a named effect's kind followed by the kinds of the
/// look-alikes the recording cannot tell it from. An entry reads "X or Y" with the kind of fewer parameters first
/// (ties: the effect's own kind, then by name); an entry with a kind that another entry names on its own is left out
/// (that kind is named once; its look-alikes stay in the finding's ambiguous_with); identical entries once.
std::vector<std::string> verdictNames(const std::vector<std::vector<EffectKind>>& entries);

/// @brief A row whose measurement looks like a tracker glitch (docs/formats.md `outlier_rows`): its residual under
/// the final model is far beyond the noise and its neighbours' residuals; it is left out of every fit, test and score.
struct OutlierRow {
  int row = 0;                          ///< 1-based row of the recording as given.
  std::vector<std::string> quantities;  ///< The measured quantities that are off (JSON names).
  double residual_over_noise = 0.0;     ///< Largest residual norm of those quantities over its noise sigma.
};

/// @brief A generic model of physics outside the library (not a library effect) that describes the remainder.
struct GenericDescription {
  Effect model;                                ///< Fitted generic correction (EffectKind generic kinds).
  std::string description;                     ///< Its structure in words ("periodic in alpha_2, ...").
  double delta_bic = 0.0;                      ///< On top of the library model.
  std::map<std::string, double> heldout_rmse;  ///< Held-out RMSE with it.
  double heldout_ratio = 1.0;                  ///< Held-out mean square over the noise variance with it.
  double heldout_gain = 0.0;                   ///< Fraction of the held-out error it removes.
  double heldout_p = 1.0;                      ///< One-sided p of that improvement.
  std::vector<std::string> replaces;           ///< Library effects it makes partial explanations.
};

/// @brief What the final model leaves unexplained (docs/formats.md `unexplained`).
struct Unexplained {
  bool present = false;                        ///< Held-out error above the noise, or a structured residual.
  double fraction_explained = 0.0;             ///< Of the baseline's excess held-out error over the noise.
  std::map<std::string, double> heldout_rmse;  ///< Final model's held-out RMSE.
  double heldout_ratio = 1.0;                  ///< Final held-out squared error / noise variance (per component).
  double heldout_p = 1.0;                      ///< Chi-square p of the held-out residuals against the noise.
  std::vector<MismatchFinding> mismatch;       ///< Locate tests on the final model's residuals (significant ones).
  std::string where;                           ///< Plain words: where the remainder is and how it behaves.
  std::vector<GenericDescription> described;   ///< Generic models that describe the remainder (not library physics).
};

/// @brief Per-row curves for plots (measured vs nominal vs fitted).
struct PlotSeries {
  Prediction nominal, fitted;  ///< In the sensor frame.
  Residuals nominal_residuals, fitted_residuals;
  std::vector<ConfigVariable> variables;
  MismatchReport final_mismatch;  ///< Binned residuals of the final model (for before/after plots).
};

/// @brief The integration steps of a diagnosis's replays, checked against the library's default steps.
struct ReplayDiscretisation {
  double max_step = 0.0;              ///< Longest step (m).
  double max_bending_per_step = 0.0;  ///< Largest bending per step (rad).
  /// Largest difference of the nominal replay from the one at the library's default steps, over the rows and measured
  /// components, as a fraction of the noise level (0 when the steps are the default ones or finer).
  double error_over_noise = 0.0;
  /// The error was above DiagnoseOptions::max_discretisation_error: the default steps were used (the fields above).
  bool refined = false;
};

/// @brief The diagnosis.
struct DiagnosisReport {
  std::vector<std::string> verdict;    ///< Effects judged present (JSON names; "X or Y" when the recording cannot
                                       ///< tell look-alikes apart); empty with `unexplained.present` = a mismatch
                                       ///< no candidate explains; empty without it = nominal explains the data.
  Unexplained unexplained;             ///< Remainder after the final model.
  std::vector<FailedRow> failed_rows;  ///< Rows excluded because a model could not evaluate them.
  std::vector<BranchAmbiguousRow> branch_ambiguous_rows;  ///< Rows with other stable equilibria (replay.hpp).
  std::vector<OutlierRow> outlier_rows;                   ///< Rows that look like tracker glitches, left out.
  bool reliable = true;               ///< False when more than unreliable_fraction of the rows failed.
  std::vector<Effect> final_effects;  ///< With fitted values.
  std::map<std::string, EffectUncertainty> final_uncertainty;  ///< Intervals and covariance, by Effect::label().
  ModelScore baseline, final;
  MismatchReport mismatch;        ///< Of the baseline.
  std::vector<Finding> findings;  ///< Every candidate tried.
  NoiseReport noise;              ///< The noise used per quantity, its source and uncertainty.
  Registration registration;      ///< Final model's registration (FrameMode::Unknown).
  FrameMode frame = FrameMode::Base;
  int rows = 0, folds = 0;              ///< Rows diagnosed (visits, decimated), held-out blocks.
  int recording_rows = 0;               ///< Rows of the recording as given.
  int visits = 0;                       ///< Rows after collapsing repeated frames (consecutive rows, same command).
  int stride = 1;                       ///< Visits used: every stride-th (see max_rows).
  int rounds = 0;                       ///< Selection rounds run.
  /// Per diagnosed row (diagnosedRows(recording, stride)): used by the final model's fit and scores (0: failed,
  /// off-branch or a tracker glitch). Not in the JSON (failed_rows, branch_ambiguous_rows and outlier_rows say why).
  std::vector<char> used_rows;
  std::string branch;                   ///< Branch rule of the replay ("path", "rest").
  ReplayDiscretisation discretisation;  ///< The replays' integration steps and their error against the noise.
  double seconds = 0.0;
  int evaluations = 0;  ///< Sequence replays.
  std::vector<std::string> warnings;
  std::string summary;  ///< Plain-language paragraph.
  PlotSeries plot;
};

/// @brief Every k-th row of a recording (k >= 1).
io::Recording decimateRecording(const io::Recording& rec, int k);

/// @brief The rows a diagnosis works on: repeated frames averaged into visits (collapseFrames), then every
/// `stride`-th visit (DiagnosisReport::stride).
io::Recording diagnosedRows(const io::Recording& rec, int stride);

/// @brief The full-rate command log behind the rows diagnosedRows(rec, stride) (PredictOptions::history; empty
/// when stride is 1: the rows are the whole log).
CommandHistory diagnosedHistory(const io::Recording& rec, int stride);

/// @brief The options of the fits of a finished diagnosis of `rec` (its frame, noise levels, replay integration
/// steps and used rows), with which its final model was fitted: to fit other models to the same rows.
/// `history` must be diagnosedHistory(rec, report.stride) and outlive the options.
FitOptions diagnosedFitOptions(const DiagnosisReport& report, const DiagnoseOptions& options,
                               const CommandHistory& history);

/// @brief The candidate slots (kind, tube) tried for a robot and recording.
std::vector<Effect> candidateSlots(const Robot& nominal, const io::Recording& rec, const DiagnoseOptions& options);

/// @brief Runs the whole diagnosis. Throws std::invalid_argument when the recording does not fit the robot.
DiagnosisReport diagnose(const Robot& nominal, const io::Recording& rec, const DiagnoseOptions& options = {});

/// @brief The robot the diagnosis found (`ctr diagnose --robot-out`): the nominal description with every effect of the
/// final model that the verdict names applied (robotWithEffects: friction, stiffness, precurvature, loads, and the
/// drive effects in the tubes' `actuation:` blocks), at its final fitted value. Not applied: the recording's own
/// effects (sensor latency, tracker drift, the tracker frame), effects kept in the final fit without being named
/// (partial explanations), and everything when the verdict names nothing (e.g. a noise these data cannot establish).
Robot diagnosedRobot(const Robot& nominal, const DiagnosisReport& report);

/// @brief diagnosedRobot as a robot description (docs/formats.md), headed by comments: each applied value with its
/// 95 % interval and the finding it came from (round, held-out improvement, look-alikes the recording cannot tell it
/// from), then what was not applied and why. `recording` names the recording in the header.
std::string diagnosedRobotYaml(const Robot& nominal, const DiagnosisReport& report, const std::string& recording);

/// @brief The diagnosis JSON (docs/formats.md "Diagnosis": verdict, baseline, final, mismatch, findings, noise, ...).
std::string reportToJson(const DiagnosisReport& report);

// ---- Several recordings of one robot (docs/diagnosis.md "Several recordings of one robot") ----

/// @brief How an effect stands across several recordings of one robot (diagnoseRecordings).
enum class Agreement {
  Shared,          ///< A robot effect whose values in the recordings agree, supported by two or more of them: one
                   ///< value, physics of the robot (applied by diagnosedRobot).
  Differs,         ///< A robot effect whose values in the recordings disagree beyond their intervals: not shared.
  OneRecording,    ///< A robot effect that one recording supports and the others cannot tell from none: not shared.
  OfTheRecording,  ///< An effect of a recording's timing (sensor latency): fitted per recording, never shared
                   ///< (tracker frames are per recording too).
};

/// @brief "shared", "differs", "one_recording", "of_the_recording".
const char* toString(Agreement agreement);

/// @brief Options of diagnoseRecordings().
struct MultiDiagnoseOptions {
  DiagnoseOptions diagnose;  ///< Each recording's diagnosis, and the fits across recordings (frame, noise, ...).
  /// Family-wise false-alarm rate of the consistency tests (chi-square of the recordings' values about their common
  /// value), Bonferroni over the robot effects tested.
  double alpha = 0.01;
  int max_iterations = 20;  ///< Ceres iterations of each recording's refit.
};

/// @brief One recording's value of an effect (diagnoseRecordings).
struct RecordingValue {
  int recording = 0;                       ///< 0-based index of the recording.
  Effect effect;                           ///< Fitted value in that recording.
  std::vector<NamedParameter> parameters;  ///< With their 95 % intervals (namedParameters).
  bool named = false;                      ///< That recording's own diagnosis named it.
  bool supports = false;  ///< Its 95 % interval excludes the nominal value (the recording tells it from none).
  /// The recording's other effects take up its prediction change to within 1 % (e.g. a drive's play and the sensor
  /// latency in a sweep at constant speed): the recording cannot tell its value, which is left out of the
  /// consistency test and of the common value.
  bool confounded = false;
};

/// @brief An effect across the recordings: its agreement, its shared value or the recordings' values, and the test.
struct JointEffect {
  Effect effect;  ///< The slot (kind, tube); with the shared value when Agreement::Shared.
  Agreement agreement = Agreement::OfTheRecording;
  /// Shared: the common value with its 95 % interval (the joint estimate); empty otherwise.
  std::vector<NamedParameter> parameters;
  /// Each recording's value, fitted with every effect of MultiDiagnosisReport::effects and its own effects free (the
  /// consistency test's inputs); the values with the shared effects held are in MultiDiagnosisReport::fits.
  std::vector<RecordingValue> per_recording;
  double chi2 = 0.0;  ///< Consistency test: sum of the squared deviations of the recordings' values from the common
                      ///< value over the recordings' covariances.
  int dof = 0;              ///< Its degrees of freedom ((recordings - 1) x coordinates); 0 when not tested.
  double p = 1.0;           ///< Its p-value.
  std::string explanation;  ///< Why it has this agreement, in words.
};

/// @brief One recording's part of the joint fit: the shared effects held, its own effects refitted.
struct RecordingFit {
  std::vector<Effect> effects;                 ///< Shared effects (held) then the recording's own (fitted).
  Registration registration;                   ///< Its tracker frame (FrameMode::Unknown).
  std::map<std::string, double> fit_rmse;      ///< In-sample RMSE per quantity with the shared values.
  std::map<std::string, double> own_fit_rmse;  ///< The same for the recording's own final model (its diagnosis).
};

/// @brief The diagnosis of several recordings of one robot.
struct MultiDiagnosisReport {
  std::vector<std::string> names;           ///< The recordings' names (files), as given.
  std::vector<DiagnosisReport> recordings;  ///< Each recording's own diagnosis.
  std::vector<RecordingFit> fits;           ///< Each recording's part of the joint fit.
  std::vector<std::string> verdict;  ///< The shared effects' kinds, each once (verdictNames): physics of the robot.
  std::vector<JointEffect> effects;  ///< Robot effects named by any recording, then sensor latency when a
                                     ///< recording's final model has it.
  FrameMode frame = FrameMode::Base;
  double alpha = 0.01;  ///< MultiDiagnoseOptions::alpha.
  double seconds = 0.0;
  std::vector<std::string> warnings;
  std::string summary;  ///< Plain-language paragraph.
};

/// @brief Diagnoses several recordings of one robot together: each recording alone (diagnose()); the union of the
/// robot effects any of them names refitted in every recording, with its own recording effects (latency, tracker
/// frame and drift) and partial explanations free; a consistency test of each robot effect's values across the
/// recordings; the effects that agree and that two or more recordings support estimated once (the recordings'
/// values weighted by their covariances: the first-order joint estimate) and held in a refit of each recording's own
/// effects. Throws std::invalid_argument (naming the recording) when a recording does not fit the robot, and when
/// fewer than two recordings are given.
MultiDiagnosisReport diagnoseRecordings(const Robot& nominal, const std::vector<io::Recording>& recordings,
                                        const std::vector<std::string>& names,
                                        const MultiDiagnoseOptions& options = {});

/// @brief The robot several recordings found: the nominal description with the shared effects applied at their common
/// values (never an effect that is not shared, nor a recording's effects).
Robot diagnosedRobot(const Robot& nominal, const MultiDiagnosisReport& report);

/// @brief diagnosedRobot as a robot description headed by comments: each applied value with its 95 % interval and the
/// recordings that named it, then what was not applied and why (differs, one recording, of the recording).
std::string diagnosedRobotYaml(const Robot& nominal, const MultiDiagnosisReport& report);

/// @brief The JSON of several recordings (docs/formats.md "Diagnosis of several recordings"): each recording's own
/// diagnosis (the single-recording document), the shared verdict, the effects with their agreement and values.
std::string reportToJson(const MultiDiagnosisReport& report);
/// @brief Plain-language Markdown report.
std::string reportToMarkdown(const DiagnosisReport& report, const io::Recording& rec);
/// @brief Plot data JSON: per-row measured / nominal / fitted values, configuration variables with direction, and
/// binned residuals vs configuration split by direction (before and after).
std::string plotDataJson(const DiagnosisReport& report, const io::Recording& rec);

}  // namespace ctr::diagnosis
