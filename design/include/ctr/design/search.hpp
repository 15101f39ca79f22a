/// @file search.hpp
/// @brief Patient-specific robot design (docs/design.md): a seeded search over a DesignSpace in which every candidate
/// is scored by what the planner does with it on one or several queries: a goal probe (can a valid, collision-free
/// configuration put the tip on the target?) as a cheap first filter, then a friction-aware plan in each query's mode
/// whose replay must be clean.
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
#include <random>
#include <string>
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
  int population = 8;              ///< Candidates per generation (evaluated in parallel).
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
  /// Called after every evaluation (from the thread that ran it; calls are serialised).
  std::function<void(std::size_t done, std::size_t total, const std::string& detail)> progress;
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
};

const char* toString(QueryOutcome::Stage s);

/// @brief The objective, compared lexicographically (docs/design.md "Objective"): feasibility first (the sum over
/// queries of the stage reached plus a continuous progress within it), then the largest minimum clearance along the
/// replayed paths (0.1 mm bins), then the shortest robot.
struct Score {
  double badness = std::numeric_limits<double>::infinity();     ///< 0: every query solved.
  double clearance = -std::numeric_limits<double>::infinity();  ///< Min over queries of the replay clearance (m).
  double length = std::numeric_limits<double>::infinity();      ///< Length of the longest tube (m).
  bool solved() const { return badness == 0.0; }
  /// Strictly better than `o`.
  bool better(const Score& o) const;
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
  bool solved = false;  ///< The best candidate solves every query with clean replays.
  std::string message;  ///< Why not (one line), e.g. the closest distance reached when no design reaches a target.
  std::optional<Evaluation> best;
  std::vector<Evaluation> evaluations;
  double wall_time = 0.0;
  bool budget_exhausted = false;  ///< Stopped by the time limit.
};

/// @brief The search's sampler (docs/design.md "Search"): a seeded cross-entropy / CMA-like distribution over the
/// unit cube of the continuous coordinates (a Gaussian with a diagonal covariance, reflected at the faces) and a
/// categorical distribution over the size combinations; each generation is re-fitted to the best candidates so far.
/// Every candidate it returns satisfies the space's constraints (strain limit, nesting, admissible translations).
class Sampler {
 public:
  Sampler(const DesignSpace& space, std::uint64_t seed);
  /// @brief `n` new candidates (the first generation: `seed_candidate`, when given, then uniform samples).
  std::vector<Candidate> generation(int n, const std::optional<Candidate>& seed_candidate = std::nullopt);
  /// @brief Re-fits the distribution to the candidates ranked best first.
  void update(const std::vector<Candidate>& ranked);
  const std::vector<double>& mean() const { return mean_; }
  const std::vector<double>& sigma() const { return sigma_; }

 private:
  std::optional<Candidate> draw(bool uniform);
  const DesignSpace& space_;
  std::vector<std::vector<int>> combos_;
  std::mt19937_64 rng_;
  std::vector<double> mean_, sigma_, combo_p_;
  bool fitted_ = false;
};

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
  /// @brief Runs the search.
  DesignResult run(const DesignOptions& o) const;
  /// @brief The robot of a candidate (named after the first query's robot, "_design" appended).
  Robot robotOf(const Candidate& c) const;

 private:
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

/// @brief The one-line verdict of a run from its best evaluation: per unsolved query the stage it reached (the
/// closest tip distance over every evaluation when no design reaches a target). `names`: the queries' names.
std::string verdict(const std::vector<Evaluation>& evaluations, const std::optional<Evaluation>& best,
                    const std::vector<std::string>& names);

}  // namespace ctr::design
