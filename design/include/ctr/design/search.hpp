/// @file search.hpp
/// @brief Patient-specific robot design (docs/design.md): a seeded search (pagmo's gaco) over a DesignSpace in which
/// every candidate is scored by what the planner does with it on one or several queries: a goal probe (can a valid,
/// collision-free configuration put the tip on the target?) as a cheap first filter, then a friction-aware plan in
/// each query's mode whose replay must be clean. The best few candidates (the finalists) are then planned again with
/// several independent seeds, as `ctr plan` plans the written query, and their success rate ranks them.
/// @code
///   std::vector<ctr::planner::Query> qs{ctr::planner::loadQuery("examples/queries/medmpd_lung_patient1.yaml")};
///   ctr::design::DesignResult r = ctr::design::designRobot(qs, std::nullopt, {});  // default space of the robot
///   // r.solved, r.message, r.best->robot_yaml, r.best->queries[k].plan_json
/// @endcode
#pragma once

#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "ctr/design/space.hpp"
#include "ctr/planner/planner.hpp"

namespace ctr::design {

/// @brief Options of a design run.
struct DesignOptions {
  std::uint64_t seed = 1;
  /// Independent searches (restarts) of the run: start k is seeded by (seed, k). A shard runs some of them.
  int starts = 1;
  std::vector<int> start_indices;  ///< The starts this process runs (empty: all).
  int evaluations = 40;            ///< Candidates per start.
  int population = 8;              ///< Ants per generation (>= 2), evaluated as one batch in parallel.
  double time_limit = 0.0;         ///< Wall seconds of the whole run (0: no limit); running candidates finish.
  int threads = 0;                 ///< Candidates evaluated at once (0: the machine's cores).
  double probe_time = 2.0;         ///< Wall seconds of the goal probe per query and candidate.
  int probe_candidates = 400;      ///< Inverse-kinematics attempts of the probe at most.
  int probe_goals = 3;             ///< The probe stops once it has found this many valid goal configurations.
  double plan_time = 0.0;          ///< Planning time limit per query (0: the query's).
  std::string planner;             ///< Overrides the queries' planner ("": theirs).
  /// A candidate that solves every query is planned again with this many further seeds; it counts as solved only if
  /// every plan replays clean (a design whose goals are rare would otherwise fail an independent `ctr plan`).
  int confirm_seeds = 1;
  /// After the search, the best this many candidates that solve every query (the finalists) are planned
  /// `finalist_plans` times per query with independent seeds and the written query's settings (confirmPlan()); their
  /// success rate ranks them before clearance and length (Score), and the kept design is the best finalist.
  /// 0: no finalists (the best candidate of the search is kept unconfirmed).
  int finalists = 3;
  int finalist_plans = 8;  ///< Independent plans per finalist and query (0: no finalists).
  /// The kept design counts as solved only when its success rate (the smallest over the queries) reaches this.
  double finalist_rate = 0.8;
  /// Called after every evaluation (from the thread that ran it; calls are serialised).
  std::function<void(std::size_t done, std::size_t total, const std::string& detail)> progress;
};

/// @brief One independent plan of a finalist (Designer::confirmPlan()): `ctr plan` of the written query with `seed`.
struct ConfirmationPlan {
  std::uint64_t seed = 0;
  bool path_found = false;  ///< The planner found a path (`planner_solved`).
  bool solved = false;      ///< ... and its replay was clean (`solved` of `ctr plan`).
  double min_clearance = -std::numeric_limits<double>::infinity();  ///< Smallest replay clearance (m).
  double planning_time = 0.0;                                       ///< Seconds in the planner.
  std::string message;                                              ///< Why not solved ("" if solved).
};

/// @brief What one query made of one candidate.
struct QueryOutcome {
  /// How far the candidate got, worst first.
  enum class Stage { StartInvalid, Unreachable, NoValidGoal, NoPath, Solved };
  Stage stage = Stage::StartInvalid;
  double closest = std::numeric_limits<double>::infinity();  ///< Closest tip distance to the target reached (m).
  /// Largest clearance (m; <= 0 in contact) of a frictionless shape with the tip on the target.
  double goal_clearance = -std::numeric_limits<double>::infinity();
  /// Smallest length of robot in collision (m; sum of the colliding capsules' lengths) of a stable frictionless shape
  /// with the tip on the target, and the tubes (1-based, the outermost of each colliding section) it collides with.
  double goal_collision_length = std::numeric_limits<double>::infinity();
  std::vector<int> goal_collision_tubes;
  int ik_tried = 0, ik_on_target = 0, valid_goals = 0;  ///< Of the goal probe.
  int plans = 0, plans_solved = 0;                      ///< Plans made (first + confirmations), clean replays.
  double min_clearance = -std::numeric_limits<double>::infinity();  ///< Smallest replay clearance of the plans (m).
  std::string message;                                              ///< Why not solved, in one line.
  std::string plan_json;  ///< The first plan's result as `ctr plan --json` writes it ("" if not planned).
  std::string path_csv;   ///< Its replayed path (`ctr plan --path`; "" if not planned).
  Configuration start;    ///< The query's start for the designed robot (distal ends kept).
  double seconds = 0.0;
  /// A finalist's independent plans (empty for a candidate that is not one); not counted in `plans`.
  std::vector<ConfirmationPlan> confirmation;
  /// @brief Independent plans solved with a clean replay.
  int confirmationSolved() const;
};

const char* toString(QueryOutcome::Stage s);

/// @brief The objective, compared lexicographically (docs/design.md "Objective"): feasibility first (the sum over
/// queries of the stage reached plus a continuous progress within it, in steps of 1e-6), then for a finalist the
/// success rate of its independent plans (a confirmed finalist ranks above every unconfirmed candidate), then the
/// largest minimum clearance along the replayed paths (0.1 mm bins), then the shortest robot.
struct Score {
  double badness = std::numeric_limits<double>::infinity();     ///< 0: every query solved.
  double clearance = -std::numeric_limits<double>::infinity();  ///< Min over queries of the replay clearance (m).
  double length = std::numeric_limits<double>::infinity();      ///< Length of the longest tube (m).
  /// A finalist's success rate in [0, 1]: the smallest over the queries of its independent plans solved with a clean
  /// replay / made; -1 for a candidate that was not confirmed.
  double success_rate = -1.0;
  bool solved() const { return badness == 0.0; }
  /// @brief Has a success rate (a finalist whose independent plans were made).
  bool confirmed() const { return success_rate >= 0.0; }
  /// @brief The lexicographic order as one number to minimise (the search's fitness): confirmed solved designs
  /// -2.2e6 x (1 + round(1000 x success_rate)) - bin(clearance) + l / (1 + l), other solved designs
  /// -bin(clearance) + l / (1 + l) (bins of 0.1 mm, clamped to +-1e6), others 2e6 + round(badness x 1e6) +
  /// l / (1 + l), with l the length in m; 1e15 for a score never evaluated.
  double fitness() const;
  /// Strictly better than `o`: fitness() < o.fitness().
  bool better(const Score& o) const { return fitness() < o.fitness(); }
};

/// @brief One evaluated candidate.
struct Evaluation {
  std::size_t index = 0;  ///< In the order of evaluation within its start.
  int start = 0, generation = 0;
  Candidate candidate;
  std::string robot_yaml;  ///< Its robot description.
  std::vector<QueryOutcome> queries;
  Score score;
  double seconds = 0.0;
};

/// @brief Result of a design run.
struct DesignResult {
  /// The best candidate solves every query with clean replays (and, when confirmed, its success rate reaches
  /// DesignOptions::finalist_rate).
  bool solved = false;
  std::string message;  ///< Why not (one line), e.g. the closest distance reached when no design reaches a target.
  std::optional<Evaluation> best;  ///< The best finalist (when there are finalists), else the best evaluation.
  std::vector<Evaluation> evaluations;
  /// Indices into `evaluations` of the finalists (those with independent plans), best first by their final score.
  std::vector<std::size_t> finalists;
  std::vector<std::uint64_t> confirmation_seeds;  ///< The seeds of the finalists' independent plans.
  double wall_time = 0.0;
  bool budget_exhausted = false;  ///< Stopped by the time limit.
};

/// @brief The search's decision vector (docs/design.md "Search"): the unit-cube coordinates of candidateAt() (3 per
/// tube, continuous) followed, when the space has more than one size combination, by the index of the combination
/// (an integer variable). decode() repairs every point of the box into a candidate within the space's constraints.
class Decoder {
 public:
  explicit Decoder(const DesignSpace& space);
  /// @brief Length of the decision vector.
  std::size_t dimension() const { return continuous_ + (combos_.size() > 1 ? 1 : 0); }
  /// @brief Integer variables at the end of the vector (0 or 1).
  std::size_t integerDimension() const { return combos_.size() > 1 ? 1 : 0; }
  /// @brief The box: [0, 1] for the continuous coordinates, [0, combinations - 1] for the size index.
  std::pair<std::vector<double>, std::vector<double>> bounds() const;
  /// @brief The candidate of a decision vector: candidateAt() of its coordinates and size combination; when that
  /// repair fails, the other combinations (nearest index first), then the point pulled toward the cube's centre with
  /// the least precurvature, until one repairs. Throws std::runtime_error when no candidate satisfies the space.
  Candidate decode(const std::vector<double>& x) const;
  /// @brief The decision vector of a candidate within the space (decode(encode(c)) == c up to rounding).
  std::vector<double> encode(const Candidate& c) const;

 private:
  DesignSpace space_;
  std::vector<std::vector<int>> combos_;
  std::size_t continuous_ = 0;
};

/// @brief Scores one candidate; `index` is its place in the start's order of evaluation. Called from several
/// threads at once.
using EvaluateFn = std::function<Evaluation(const Candidate& candidate, std::size_t index)>;

/// @brief One start of the search (docs/design.md "Search"): pagmo's extended ant colony optimisation (pagmo::gaco)
/// over the Decoder's decision vectors, minimising Score::fitness(). The first generation is `first` (when given)
/// and uniform samples of the box, seeded by (o.seed, start); each further generation of o.population ants is
/// evaluated as one batch, o.threads candidates at once. Stops after o.evaluations candidates or when `stop()`
/// returns true (checked before each candidate starts). Returns the evaluations in their order (index), with
/// `start` and `generation` set; only the best keeps its paths.
std::vector<Evaluation> searchStart(const DesignSpace& space, int start, const DesignOptions& o,
                                    const std::optional<Candidate>& first, const EvaluateFn& evaluate,
                                    const std::function<bool()>& stop);

/// @brief The queries' problems, loaded once (robot, environment and its map), and the evaluation of candidates.
class Designer {
 public:
  /// @brief `space`: nullopt for the default space of the first query's robot. Throws ctr::io::InputError for a
  /// query without a tip goal, queries whose robots have another number of tubes than the space.
  Designer(std::vector<planner::Query> queries, std::optional<DesignSpace> space);
  const DesignSpace& space() const { return space_; }
  const std::vector<planner::Query>& queries() const { return queries_; }
  /// @brief The first query's robot (friction, loads and the default space come from it).
  const Robot& baseRobot() const { return bases_.front(); }
  /// @brief The query's robot as a candidate, when it lies in the space.
  std::optional<Candidate> baseCandidate() const;
  /// @brief Scores one candidate on every query (thread-safe). `seed` seeds the probe and the plans.
  Evaluation evaluate(const Candidate& c, std::uint64_t seed, const DesignOptions& o) const;
  /// @brief One independent plan of query `k` for an evaluated design (thread-safe): its robot from its start, with
  /// the query's own settings (mode, planner, time limit; not the search's `plan_time` and `planner`) and `seed`, as
  /// `ctr plan DIR/queries/NAME.yaml --seed SEED` plans the written query.
  ConfirmationPlan confirmPlan(const Evaluation& e, std::size_t k, std::uint64_t seed) const;
  /// @brief Runs the search.
  DesignResult run(const DesignOptions& o) const;
  /// @brief The robot of a candidate (named after the first query's robot, "_design" appended).
  Robot robotOf(const Candidate& c) const;

 private:
  // Query k as planned for a design from `start` with `seed`: the query's settings, with the search's `plan_time` and
  // `planner` when `search` is given.
  planner::Query queryFor(std::size_t k, const Configuration& start, std::uint64_t seed,
                          const DesignOptions* search) const;
  // One further plan of query k (`q`, a fresh planner and goal pool) for `robot`: the search's confirmations and the
  // finalists' independent plans.
  ConfirmationPlan planAgain(const planner::Query& q, const Robot& robot, std::size_t k) const;

  std::vector<planner::Query> queries_;
  std::vector<Robot> bases_;
  std::vector<std::shared_ptr<const environments::Environment>> envs_;
  DesignSpace space_;
  // The last planning context of each query: keeps its distance field alive, so that the next candidate's collision
  // checker shares it instead of building it again (ctr::environments::CollisionChecker shares equal fields).
  mutable std::mutex keep_mutex_;
  mutable std::vector<std::shared_ptr<const planner::Context>> keep_;
};

/// @brief Loads the queries' problems and runs the search: Designer(queries, space).run(options). Throws
/// ctr::io::InputError for bad input; an unsolved design is a result (`solved` false, `message` why), not an error.
DesignResult designRobot(std::vector<planner::Query> queries, std::optional<DesignSpace> space,
                         const DesignOptions& options);

/// @brief The score of the queries' outcomes for a candidate.
Score scoreOf(const std::vector<QueryOutcome>& queries, const Candidate& c);

/// @brief Picks the best evaluation (the earliest of equals); nullopt for none.
std::optional<Evaluation> bestOf(const std::vector<Evaluation>& evaluations);

/// @brief The finalists of a run: the indices into `evaluations` of the best `count` that solve every query (distinct
/// robots), best first.
std::vector<std::size_t> finalistsOf(const std::vector<Evaluation>& evaluations, int count);

/// @brief The seeds of a run's independent plans: `count` seeds derived from the run's `seed` (each < 2^31, so that
/// `ctr plan --seed` takes it), the same for every finalist.
std::vector<std::uint64_t> confirmationSeeds(std::uint64_t seed, int count);

/// @brief The one-line verdict of a run from its best evaluation: per unsolved query the stage it reached (the
/// closest tip distance over every evaluation when no design reaches a target), and a confirmed design's
/// independent plans per query (below `required_rate`: not reliable). `names`: the queries' names.
std::string verdict(const std::vector<Evaluation>& evaluations, const std::optional<Evaluation>& best,
                    const std::vector<std::string>& names, double required_rate = 0.0);

}  // namespace ctr::design
