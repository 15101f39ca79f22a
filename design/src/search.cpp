#include "ctr/design/search.hpp"

#include <pagmo/algorithm.hpp>
#include <pagmo/algorithms/gaco.hpp>
#include <pagmo/batch_evaluators/member_bfe.hpp>
#include <pagmo/bfe.hpp>
#include <pagmo/population.hpp>
#include <pagmo/problem.hpp>
#include <pagmo/rng.hpp>
#include <pagmo/types.hpp>
#include <pagmo/utils/generic.hpp>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <iomanip>
#include <mutex>
#include <sstream>
#include <thread>

#include "ctr/environments/environment_yaml.hpp"
#include "ctr/io/input_error.hpp"
#include "ctr/io/robot_yaml.hpp"
#include "ctr/model/sampling.hpp"
#include "ctr/planner/result_json.hpp"
#include "ctr/planner/validity.hpp"

namespace ctr::design {
namespace {

using Clock = std::chrono::steady_clock;

double since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

std::string mm(double v) {
  std::ostringstream o;
  o << std::fixed << std::setprecision(2) << v * 1e3 << " mm";
  return o.str();
}

// SplitMix64: independent seeds for (run seed, start, candidate).
std::uint64_t mix(std::uint64_t a, std::uint64_t b) {
  std::uint64_t z = a * 0x9E3779B97F4A7C15ULL + b + 0x632BE59BD9B4E019ULL;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  return z ^ (z >> 31);
}

// The fitness of a candidate that was not evaluated (the time limit, or past the budget in the last batch).
constexpr double kUnevaluated = 1e15;

// Runs fn(i) for every i in [0, n) on `threads` threads (the calling one included), each taking the next i as it
// frees up; the first exception is rethrown once every thread has finished.
void parallelFor(std::size_t n, int threads, const std::function<void(std::size_t)>& fn) {
  std::atomic<std::size_t> next{0};
  std::exception_ptr error;
  std::mutex error_mutex;
  auto worker = [&] {
    for (std::size_t i = next++; i < n; i = next++) {
      try {
        fn(i);
      } catch (...) {
        std::lock_guard<std::mutex> lock(error_mutex);
        if (!error) error = std::current_exception();
      }
    }
  };
  std::vector<std::thread> pool;
  const int nt = static_cast<int>(std::min<std::size_t>(static_cast<std::size_t>(std::max(1, threads)), n));
  for (int k = 1; k < nt; ++k) pool.emplace_back(worker);
  worker();
  for (auto& th : pool) th.join();
  if (error) std::rethrow_exception(error);
}

int threadCount(const DesignOptions& o) {
  return o.threads > 0 ? o.threads : std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
}

double longestTube(const Candidate& c) {
  double l = 0.0;
  for (const auto& t : c.tubes) l = std::max(l, t.straight_length + t.curved_length);
  return l;
}

}  // namespace

const char* toString(QueryOutcome::Stage s) {
  switch (s) {
    case QueryOutcome::Stage::StartInvalid:
      return "start_invalid";
    case QueryOutcome::Stage::Unreachable:
      return "unreachable";
    case QueryOutcome::Stage::NoValidGoal:
      return "no_valid_goal";
    case QueryOutcome::Stage::NoPath:
      return "no_path";
    case QueryOutcome::Stage::Solved:
      return "solved";
  }
  return "?";
}

int QueryOutcome::confirmationSolved() const {
  return static_cast<int>(
      std::count_if(confirmation.begin(), confirmation.end(), [](const ConfirmationPlan& p) { return p.solved; }));
}

double Score::fitness() const {
  if (!(badness < std::numeric_limits<double>::infinity())) return kUnevaluated;  // never evaluated (or NaN)
  const double l = length >= 0.0 ? length / (1.0 + length) : 0.0;                 // in [0, 1): shorter is smaller
  const double b = std::round(badness * 1e6);                                     // feasibility in steps of 1e-6
  if (b > 0.0) return 2e6 + std::min(b, 1e14) + l;
  // Solved: clearance in 0.1 mm bins (a shorter robot wins over a few micrometres of clearance), larger first.
  const double bin = std::clamp(std::floor(clearance * 1e4), -1e6, 1e6);
  if (!confirmed()) return -bin + l;
  // A finalist: its success rate (steps of 0.001) before the clearance; each step spans more than the whole range of
  // -bin + l, and every step lies below the unconfirmed designs.
  const double rate = std::round(std::clamp(success_rate, 0.0, 1.0) * 1000.0);
  return -2.2e6 * (1.0 + rate) - bin + l;
}

Score scoreOf(const std::vector<QueryOutcome>& queries, const Candidate& c) {
  Score s;
  s.badness = 0.0;
  s.clearance = std::numeric_limits<double>::infinity();
  for (const QueryOutcome& q : queries) {
    using St = QueryOutcome::Stage;
    // Stage penalty (4 for an invalid start ... 0 solved) plus a progress in [0, 1) within the stage.
    double f = 0.0;
    switch (q.stage) {
      case St::StartInvalid:
        f = 4.0;
        break;
      case St::Unreachable:
        f = 3.0 + std::min(q.closest / 0.1, 0.999);
        break;
      case St::NoValidGoal:
        // The least robot length in collision among the goal shapes (0.1 m saturates), else none was stable.
        f = 2.0 + (std::isfinite(q.goal_collision_length) ? std::min(q.goal_collision_length / 0.1, 0.998) : 0.999);
        break;
      case St::NoPath:
        f = 1.0 + (q.ik_on_target > 0 ? 1.0 - static_cast<double>(q.valid_goals) / q.ik_on_target : 1.0) * 0.5 +
            (q.plans > 0 ? 0.5 * (1.0 - static_cast<double>(q.plans_solved) / q.plans) : 0.5) * 0.999;
        f = std::min(f, 1.999);
        break;
      case St::Solved:
        f = 0.0;
        break;
    }
    s.badness += f;
    s.clearance =
        std::min(s.clearance, q.stage == St::Solved ? q.min_clearance : -std::numeric_limits<double>::infinity());
  }
  if (!(s.badness == 0.0)) s.clearance = -std::numeric_limits<double>::infinity();
  s.length = longestTube(c);
  // A finalist's success rate: the least over the queries of its independent plans solved / made.
  for (const QueryOutcome& q : queries)
    if (!q.confirmation.empty()) {
      const double rate = static_cast<double>(q.confirmationSolved()) / static_cast<double>(q.confirmation.size());
      s.success_rate = s.confirmed() ? std::min(s.success_rate, rate) : rate;
    }
  return s;
}

std::optional<Evaluation> bestOf(const std::vector<Evaluation>& evaluations) {
  std::optional<Evaluation> best;
  for (const Evaluation& e : evaluations)
    if (!best || e.score.better(best->score)) best = e;
  return best;
}

std::vector<std::size_t> finalistsOf(const std::vector<Evaluation>& evaluations, int count) {
  std::vector<std::size_t> order;
  for (std::size_t i = 0; i < evaluations.size(); ++i)
    if (evaluations[i].score.solved()) order.push_back(i);
  // Best first; the earliest of equals first.
  std::stable_sort(order.begin(), order.end(),
                   [&](std::size_t a, std::size_t b) { return evaluations[a].score.better(evaluations[b].score); });
  std::vector<std::size_t> out;
  for (std::size_t i : order) {
    if (static_cast<int>(out.size()) >= count) break;
    const bool same = std::any_of(
        out.begin(), out.end(), [&](std::size_t j) { return evaluations[j].robot_yaml == evaluations[i].robot_yaml; });
    if (!same) out.push_back(i);
  }
  return out;
}

std::vector<std::uint64_t> confirmationSeeds(std::uint64_t seed, int count) {
  std::vector<std::uint64_t> seeds;
  for (std::uint64_t j = 0; static_cast<int>(seeds.size()) < count; ++j) {
    const std::uint64_t s = mix(seed, 0xc0f1c0f1ULL + j) >> 33;
    if (std::find(seeds.begin(), seeds.end(), s) == seeds.end()) seeds.push_back(s);
  }
  return seeds;
}

// ---------------------------------------------------------------------------------------------------------------
// Decoder: the decision vector of the search

Decoder::Decoder(const DesignSpace& space)
    : space_(space),
      combos_(space.size_combinations()),
      continuous_(static_cast<std::size_t>(continuousDimension(space))) {
  if (combos_.empty()) throw std::invalid_argument("design space: no size combination nests");
}

std::pair<std::vector<double>, std::vector<double>> Decoder::bounds() const {
  std::vector<double> lo(dimension(), 0.0), hi(dimension(), 1.0);
  if (integerDimension() > 0) hi.back() = static_cast<double>(combos_.size() - 1);
  return {lo, hi};
}

Candidate Decoder::decode(const std::vector<double>& x) const {
  if (x.size() != dimension()) throw std::invalid_argument("design: decision vector of the wrong length");
  std::vector<double> u(x.begin(), x.begin() + static_cast<std::ptrdiff_t>(continuous_));
  for (double& v : u) v = std::clamp(v, 0.0, 1.0);
  const std::size_t n = combos_.size();
  const std::size_t c0 =
      integerDimension() > 0
          ? static_cast<std::size_t>(std::clamp<double>(std::round(x.back()), 0.0, static_cast<double>(n - 1)))
          : 0;
  // The combination drawn first, then the others by distance of their index.
  std::vector<std::size_t> order{c0};
  for (std::size_t d = 1; d < n; ++d) {
    if (c0 >= d) order.push_back(c0 - d);
    if (c0 + d < n) order.push_back(c0 + d);
  }
  // The point itself, then pulled toward the centre of the lengths and the least precurvature (which the space's
  // parser guarantees some combination repairs).
  for (double t : {1.0, 0.75, 0.5, 0.25, 0.0}) {
    std::vector<double> p(u);
    for (std::size_t j = 0; j < p.size(); ++j) p[j] = t * u[j] + (1.0 - t) * (j % 3 == 2 ? 0.0 : 0.5);
    for (std::size_t c : order)
      if (auto cand = candidateAt(space_, p, c)) return std::move(*cand);
  }
  throw std::runtime_error("design space: no candidate within the constraints near this point");
}

std::vector<double> Decoder::encode(const Candidate& c) const {
  std::vector<double> x = unitPoint(space_, c);
  if (integerDimension() > 0) {
    std::vector<int> sizes;
    for (const auto& t : c.tubes) sizes.push_back(t.size);
    const auto it = std::find(combos_.begin(), combos_.end(), sizes);
    x.push_back(it == combos_.end() ? 0.0 : static_cast<double>(it - combos_.begin()));
  }
  return x;
}

// ---------------------------------------------------------------------------------------------------------------
// The search: pagmo's gaco over a user-defined problem whose batch fitness evaluates a generation in parallel.

namespace {

// Clears the paths of every evaluation but the best and the finalists (finalistsOf(evals, finalists)).
void keepPathsOf(std::vector<Evaluation>& evals, int finalists) {
  std::vector<std::size_t> keep = finalistsOf(evals, finalists);
  std::size_t best = 0;
  for (std::size_t i = 1; i < evals.size(); ++i)
    if (evals[i].score.better(evals[best].score)) best = i;
  keep.push_back(best);
  for (std::size_t i = 0; i < evals.size(); ++i)
    if (std::find(keep.begin(), keep.end(), i) == keep.end())
      for (auto& q : evals[i].queries) q.path_csv.clear();
}

// What the problem's copies share (pagmo copies the problem into the population and the algorithm).
struct SearchState {
  Decoder decoder;
  const EvaluateFn* evaluate = nullptr;
  const std::function<bool()>* stop = nullptr;
  int threads = 1;
  int finalists = 0;       // the best this many that solve every query keep their paths
  std::size_t budget = 0;  // candidates of the start
  int start = 0, generation = 0;
  std::vector<Evaluation> evals;  // in the order of evaluation
  explicit SearchState(const DesignSpace& s) : decoder(s) {}
};

// The pagmo user-defined problem: minimise Score::fitness() over the Decoder's box (the last variable, the size
// combination, is an integer). batch_fitness() is what pagmo::member_bfe calls for a whole generation.
class DesignProblem {
 public:
  DesignProblem() = default;
  explicit DesignProblem(std::shared_ptr<SearchState> s) : s_(std::move(s)) {}
  pagmo::vector_double fitness(const pagmo::vector_double& x) const { return batch_fitness(x); }
  std::pair<pagmo::vector_double, pagmo::vector_double> get_bounds() const { return s_->decoder.bounds(); }
  pagmo::vector_double::size_type get_nix() const { return s_->decoder.integerDimension(); }
  std::string get_name() const { return "ctr::design candidate (Score::fitness)"; }

  // Evaluates the batch in parallel threads, each candidate seeded by its index in the start (so the outcome does
  // not depend on which thread ran it); records the evaluations in the batch's order. Candidates past the start's
  // budget, or not started when stop() turned true, are not evaluated (fitness kUnevaluated).
  pagmo::vector_double batch_fitness(const pagmo::vector_double& xs) const {
    SearchState& s = *s_;
    const std::size_t dim = s.decoder.dimension(), n = xs.size() / dim, base = s.evals.size();
    const std::size_t m = std::min(n, s.budget > base ? s.budget - base : 0);
    std::vector<Candidate> cands(m);
    for (std::size_t i = 0; i < m; ++i)
      cands[i] = s.decoder.decode(std::vector<double>(xs.begin() + static_cast<std::ptrdiff_t>(i * dim),
                                                      xs.begin() + static_cast<std::ptrdiff_t>((i + 1) * dim)));
    std::vector<std::optional<Evaluation>> results(m);
    parallelFor(m, s.threads, [&](std::size_t i) {
      if (!(*s.stop)()) results[i] = (*s.evaluate)(cands[i], base + i);
    });
    pagmo::vector_double f(n, kUnevaluated);
    for (std::size_t i = 0; i < m; ++i) {
      if (!results[i]) continue;
      Evaluation& ev = *results[i];
      ev.candidate = cands[i];
      ev.index = base + i;
      ev.start = s.start;
      ev.generation = s.generation;
      f[i] = ev.score.fitness();
      s.evals.push_back(std::move(ev));
    }
    // Only the best so far and the finalists to be keep their paths (the rest would only fill memory).
    keepPathsOf(s.evals, s.finalists);
    return f;
  }

 private:
  std::shared_ptr<SearchState> s_;
};

}  // namespace

std::vector<Evaluation> searchStart(const DesignSpace& space, int start, const DesignOptions& o,
                                    const std::optional<Candidate>& first, const EvaluateFn& evaluate,
                                    const std::function<bool()>& stop) {
  if (o.evaluations < 1) throw std::invalid_argument("design: evaluations must be >= 1");
  if (o.population < 2) throw std::invalid_argument("design: population must be >= 2 (gaco's solution archive)");
  auto state = std::make_shared<SearchState>(space);
  state->evaluate = &evaluate;
  state->stop = &stop;
  state->threads = threadCount(o);
  state->finalists = o.finalist_plans > 0 ? o.finalists : 0;
  state->budget = static_cast<std::size_t>(o.evaluations);
  state->start = start;
  const pagmo::problem prob{DesignProblem(state)};
  const pagmo::bfe batch{pagmo::member_bfe{}};
  const std::uint64_t key = mix(o.seed, 0x5eed0000ULL + static_cast<std::uint64_t>(start));

  // First generation: the given candidate, then uniform samples of the box (integer index uniform).
  const std::size_t pop_size = static_cast<std::size_t>(o.population);
  const std::size_t n0 = std::min(pop_size, state->budget);
  pagmo::detail::random_engine_type rng(static_cast<unsigned>(key));
  pagmo::vector_double xs;
  for (std::size_t i = 0; i < n0; ++i) {
    const pagmo::vector_double x = i == 0 && first && violation(space, *first).empty()
                                       ? state->decoder.encode(*first)
                                       : pagmo::random_decision_vector(prob, rng);
    xs.insert(xs.end(), x.begin(), x.end());
  }
  const pagmo::vector_double f0 = batch(prob, xs);
  if (n0 < pop_size || state->evals.size() >= state->budget || stop()) return std::move(state->evals);
  pagmo::population pop{prob, 0u, static_cast<unsigned>(key >> 32)};
  const std::size_t dim = state->decoder.dimension();
  for (std::size_t i = 0; i < n0; ++i)
    pop.push_back(pagmo::vector_double(xs.begin() + static_cast<std::ptrdiff_t>(i * dim),
                                       xs.begin() + static_cast<std::ptrdiff_t>((i + 1) * dim)),
                  pagmo::vector_double{f0[i]});

  // Then one gaco generation per evolve() (memory on: the solution archive and the generator carry over), so that
  // the budget and the time limit are checked between generations. Kernel (solution archive) = the population;
  // convergence speed q = 1 (ants start from any archived solution almost alike) for the first half of the
  // generations, then 0.01 (from the best); accuracy 0 (every archived fitness counts); other parameters gaco's.
  const unsigned generations = static_cast<unsigned>((state->budget - n0 + pop_size - 1) / pop_size);
  pagmo::gaco uda(1u, static_cast<unsigned>(pop_size), 1.0, 0.0, 0.0, generations / 2 + 1, 7u, 100000u, 100000u, 0.0,
                  true, static_cast<unsigned>(mix(key, 1)));
  uda.set_bfe(batch);
  pagmo::algorithm algo{uda};
  while (state->evals.size() < state->budget && !stop()) {
    ++state->generation;
    pop = algo.evolve(pop);
  }
  return std::move(state->evals);
}

// ---------------------------------------------------------------------------------------------------------------
// Designer

Designer::Designer(std::vector<planner::Query> queries, std::optional<DesignSpace> space)
    : queries_(std::move(queries)) {
  if (queries_.empty()) throw std::invalid_argument("design: no query");
  for (const planner::Query& q : queries_) {
    if (!q.tip_goal)
      throw io::InputError(q.file, q.lineOf("goal"), "goal",
                           "a design needs a tip goal (target or position), not a goal configuration");
    bases_.push_back(io::loadRobot(q.robot));
    environments::BuildOptions bo;
    if (q.env_resolution > 0) bo.resolution = q.env_resolution;
    environments::Environment e = environments::loadEnvironment(q.environment, bo);
    if (!q.base_start.empty()) {
      try {
        e.useStart(q.base_start);
      } catch (const std::invalid_argument& ex) {
        throw io::InputError(q.file, q.lineOf("base_start"), "base_start", ex.what());
      }
    }
    envs_.push_back(std::make_shared<const environments::Environment>(std::move(e)));
  }
  if (space) {
    space_ = std::move(*space);
  } else {
    try {
      space_ = defaultSpace(bases_.front());
    } catch (const std::invalid_argument& e) {
      throw io::InputError(queries_.front().robot, 0, "", e.what());
    }
  }
  for (std::size_t k = 0; k < queries_.size(); ++k)
    if (bases_[k].size() != static_cast<int>(space_.tubes.size()))
      throw io::InputError(queries_[k].file, queries_[k].lineOf("robot"), "robot",
                           "robot '" + bases_[k].name() + "' has " + std::to_string(bases_[k].size()) +
                               " tubes, the design space " + std::to_string(space_.tubes.size()));
  keep_.resize(queries_.size());
  // The problem itself (friction, loads, target, collision checker and its distance field) set up once with the
  // query's own robot, as `ctr plan` does: a query that cannot be planned for a reason no design changes is refused
  // here (bad input) instead of failing every candidate. The context it builds is kept, so the first candidate shares
  // its distance field.
  for (std::size_t k = 0; k < queries_.size(); ++k) {
    planner::Query q = queries_[k];
    q.base_start.clear();  // the environment is already at its base pose
    try {
      keep_[k] = planner::CtrPlanner(q, bases_[k], *envs_[k]).context();
    } catch (const io::InputError&) {
      throw;
    } catch (const std::exception& e) {
      throw io::InputError(q.file, 0, "",
                           std::string("the problem cannot be set up with the query's own robot (as `ctr plan` would "
                                       "refuse it), so no design can be scored: ") +
                               e.what());
    }
  }
}

std::optional<Candidate> Designer::baseCandidate() const {
  return candidateOf(space_, bases_.front());
}

Robot Designer::robotOf(const Candidate& c) const {
  return makeRobot(space_, c, bases_.front(), bases_.front().name() + "_design");
}

planner::Query Designer::queryFor(std::size_t k, const Configuration& start, std::uint64_t seed,
                                  const DesignOptions* search) const {
  planner::Query q = queries_[k];
  q.base_start.clear();  // the environment is already at its base pose
  q.start = start;
  q.seed = seed;
  if (search && search->plan_time > 0) q.time_limit = search->plan_time;
  if (search && !search->planner.empty()) q.planner = search->planner;
  return q;
}

ConfirmationPlan Designer::planAgain(const planner::Query& q, const Robot& robot, std::size_t k) const {
  ConfirmationPlan c;
  c.seed = q.seed;
  try {
    planner::CtrPlanner p(q, robot, *envs_.at(k));
    const planner::PlanResult r = p.solve();
    c.path_found = r.planner_solved;
    c.solved = r.solved;
    c.planning_time = r.planning_time;
    if (!r.replay.points.empty()) c.min_clearance = r.replay.min_clearance;
    if (!r.solved) c.message = r.message;
  } catch (const std::exception& ex) {
    const auto* ie = dynamic_cast<const io::InputError*>(&ex);
    c.message = ie ? ie->message() : ex.what();
  }
  return c;
}

ConfirmationPlan Designer::confirmPlan(const Evaluation& e, std::size_t k, std::uint64_t seed) const {
  try {
    // The robot as written (robot.yaml) and the query's own settings: what `ctr plan` of the written query plans.
    const Robot robot = e.robot_yaml.empty() ? robotOf(e.candidate) : io::parseRobot(e.robot_yaml, "robot.yaml");
    return planAgain(queryFor(k, e.queries.at(k).start, seed, nullptr), robot, k);
  } catch (const std::exception& ex) {
    ConfirmationPlan c;
    c.seed = seed;
    c.message = ex.what();
    return c;
  }
}

Evaluation Designer::evaluate(const Candidate& c, std::uint64_t seed, const DesignOptions& o) const {
  const auto t0 = Clock::now();
  Evaluation ev;
  ev.candidate = c;
  const Robot robot = robotOf(c);
  ev.robot_yaml = io::robotToYaml(robot);
  using St = QueryOutcome::Stage;
  std::vector<std::unique_ptr<planner::CtrPlanner>> planners(queries_.size());
  std::vector<planner::Query> qs(queries_.size());
  ev.queries.resize(queries_.size());
  bool all_goals = true;
  for (std::size_t k = 0; k < queries_.size(); ++k) {
    const auto tq = Clock::now();
    QueryOutcome& out = ev.queries[k];
    Configuration start;
    if (!adaptStart(bases_[k], queries_[k].start, robot, start)) {
      out.stage = St::StartInvalid;
      out.message = "the query's start (distal ends kept) is not admissible for this design";
      all_goals = false;
      continue;
    }
    const planner::Query q = queryFor(k, start, mix(seed, k), &o);
    out.start = start;
    try {
      planners[k] = std::make_unique<planner::CtrPlanner>(q, robot, *envs_[k]);
      {
        std::lock_guard<std::mutex> lock(keep_mutex_);
        keep_[k] = planners[k]->context();
      }
      planners[k]->checkStart();
    } catch (const std::exception& e) {
      out.stage = St::StartInvalid;
      const auto* ie = dynamic_cast<const io::InputError*>(&e);
      out.message = ie ? ie->message() : e.what();
      planners[k].reset();
      all_goals = false;
      continue;
    }
    qs[k] = planners[k]->query();
    // Goal probe: inverse kinematics from random configurations, as the planner's goal pool does, keeping what the
    // score needs (closest tip distance, best clearance on the target).
    const planner::Context& ctx = *planners[k]->context();
    const planner::TipGoalSpec& goal = *qs[k].tip_goal;
    std::mt19937_64 gen(mix(seed, 1000 + k));
    planner::ThreadScratch& t = planner::scratch();
    const auto tp = Clock::now();
    while (out.ik_tried < o.probe_candidates && out.valid_goals < o.probe_goals && since(tp) < o.probe_time) {
      Configuration cq = sampleConfiguration(ctx.robot(), ctx.translationSampler(), gen);
      const double err = planner::inverseKinematics(ctx, goal.position, cq);
      ++out.ik_tried;
      if (std::isfinite(err)) out.closest = std::min(out.closest, err);
      if (!(err < 0.5 * goal.tolerance)) continue;
      const planner::ConfigurationCheck chk = planner::checkFrictionless(ctx, cq, t);
      if (!chk.shape.converged()) continue;
      const Eigen::Vector3d tip = ctx.basePose() * chk.shape.tip_position;
      bool on = (tip - goal.position).norm() <= goal.tolerance;
      if (goal.direction) {
        const Eigen::Vector3d tg = ctx.basePose().linear() * chk.shape.tipTangent();
        on = on && std::acos(std::clamp(tg.dot(goal.direction->normalized()), -1.0, 1.0)) <= goal.cone_angle;
      }
      if (!on) continue;
      ++out.ik_on_target;
      bool ok = chk.ok;
      if (ok && qs[k].mode == planner::Mode::Robust) ok = planner::checkRobust(ctx, cq, t).ok;
      if (ok) ++out.valid_goals;
      if (chk.shape.summary.stable && ctx.checker().distanceField()) {
        const environments::ClearanceResult cr = ctx.checker().clearance(chk.shape, t.query);
        const double cl = chk.ok ? std::max(cr.clearance, 0.0) : std::min(cr.clearance, 0.0);
        out.goal_clearance = std::max(out.goal_clearance, cl);
      }
      if (chk.shape.summary.stable) {
        // How much of the shape collides: the progress measure of a design whose goal shapes all collide (the
        // distance field's clearance saturates at contact).
        double len = 0.0;
        std::vector<int> tubes;
        if (!chk.ok) {
          ctx.checker().check(chk.shape, t.query);
          const std::vector<environments::Capsule> caps = t.query.capsules();
          for (const environments::Capsule& cap : caps)
            if (ctx.checker().capsuleCollidesFcl(cap, t.query)) {
              len += (cap.b - cap.a).norm();
              if (std::find(tubes.begin(), tubes.end(), cap.tube + 1) == tubes.end()) tubes.push_back(cap.tube + 1);
            }
        }
        if (len < out.goal_collision_length) {
          out.goal_collision_length = len;
          out.goal_collision_tubes = tubes;
        }
      }
    }
    if (out.ik_on_target == 0) {
      out.stage = St::Unreachable;
      out.message = "no inverse-kinematics solution puts the tip on the target (closest " + mm(out.closest) + ", " +
                    std::to_string(out.ik_tried) + " tried)";
      all_goals = false;
    } else if (out.valid_goals == 0) {
      out.stage = St::NoValidGoal;
      std::string tubes;
      for (int tb : out.goal_collision_tubes) tubes += (tubes.empty() ? "" : ", ") + std::to_string(tb);
      out.message = std::to_string(out.ik_on_target) +
                    " inverse-kinematics solutions put the tip on the target, none is valid (" +
                    (std::isfinite(out.goal_collision_length)
                         ? "least length in collision " + mm(out.goal_collision_length) + ", tube(s) " + tubes
                         : std::string("none stable")) +
                    ")";
      all_goals = false;
    } else {
      out.stage = St::NoPath;
      out.message = "not planned (another query has no valid goal)";
    }
    out.seconds = since(tq);
  }
  // Plans only when every query has a goal (the cheap filter first).
  if (all_goals) {
    bool all_solved = true;
    for (std::size_t k = 0; k < queries_.size(); ++k) {
      const auto tq = Clock::now();
      QueryOutcome& out = ev.queries[k];
      const planner::PlanResult r = planners[k]->solve();
      ++out.plans;
      out.plan_json = planner::resultJson(qs[k], r);
      if (!r.replay.points.empty()) out.path_csv = planner::replayCsv(planners[k]->context()->robot(), r.replay);
      if (r.solved) {
        ++out.plans_solved;
        out.min_clearance = r.replay.min_clearance;
        out.stage = St::Solved;
        out.message.clear();
      } else {
        out.message = r.message;
        all_solved = false;
      }
      out.seconds += since(tq);
    }
    // Confirmation plans with other seeds (fresh goal pools): a design counts as solved only if they replay clean.
    for (int s = 1; all_solved && s <= o.confirm_seeds; ++s) {
      for (std::size_t k = 0; k < queries_.size() && all_solved; ++k) {
        const auto tq = Clock::now();
        QueryOutcome& out = ev.queries[k];
        planner::Query q = qs[k];
        q.seed = mix(seed, 7919 * static_cast<std::uint64_t>(s) + k);
        const ConfirmationPlan r = planAgain(q, robot, k);
        ++out.plans;
        if (r.solved) {
          ++out.plans_solved;
          out.min_clearance = std::min(out.min_clearance, r.min_clearance);
        } else {
          out.stage = St::NoPath;
          out.message = "confirmation plan " + std::to_string(s) + " (seed " + std::to_string(q.seed) +
                        ") not solved: " + r.message;
          all_solved = false;
        }
        out.seconds += since(tq);
      }
    }
  }
  ev.score = scoreOf(ev.queries, c);
  ev.seconds = since(t0);
  return ev;
}

DesignResult Designer::run(const DesignOptions& o) const {
  if (o.evaluations < 1) throw std::invalid_argument("design: evaluations must be >= 1");
  if (o.population < 2) throw std::invalid_argument("design: population must be >= 2 (gaco's solution archive)");
  if (o.starts < 1) throw std::invalid_argument("design: starts must be >= 1");
  const auto t0 = Clock::now();
  DesignResult res;
  std::vector<int> starts = o.start_indices;
  if (starts.empty())
    for (int s = 0; s < o.starts; ++s) starts.push_back(s);
  const std::size_t total = starts.size() * static_cast<std::size_t>(o.evaluations);
  std::mutex mutex;
  std::size_t done = 0;
  auto out_of_time = [&] { return o.time_limit > 0 && since(t0) >= o.time_limit; };
  std::optional<Score> best_score;
  const std::function<bool()> stop = out_of_time;
  for (int s : starts) {
    const EvaluateFn score_one = [&](const Candidate& c, std::size_t index) {
      Evaluation ev;
      try {
        ev = this->evaluate(c, mix(mix(o.seed, static_cast<std::uint64_t>(s)), index), o);
      } catch (const std::exception& e) {
        // A failure inside the model or the planner for this candidate: recorded as its outcome (never thrown out
        // of a worker thread).
        ev.candidate = c;
        ev.queries.resize(queries_.size());
        for (QueryOutcome& q : ev.queries) q.message = std::string("evaluation failed: ") + e.what();
        ev.score = scoreOf(ev.queries, c);
      }
      std::lock_guard<std::mutex> lock(mutex);
      ++done;
      if (!best_score || ev.score.better(*best_score)) best_score = ev.score;
      if (o.progress) {
        std::ostringstream d;
        d << "start " << s << ": ";
        if (best_score->solved())
          d << "best solves every query, clearance " << mm(best_score->clearance) << ", longest tube "
            << mm(best_score->length);
        else
          d << "best badness " << std::setprecision(3) << best_score->badness;
        o.progress(done, total, d.str());
      }
      return ev;
    };
    // The query's own robot (when in the space) is the first candidate of the first start run here.
    std::vector<Evaluation> evals =
        searchStart(space_, s, o, s == starts.front() ? baseCandidate() : std::nullopt, score_one, stop);
    for (auto& e : evals) res.evaluations.push_back(std::move(e));
  }
  res.budget_exhausted = out_of_time();
  std::vector<std::string> names;
  for (const auto& q : queries_) names.push_back(q.name);
  // The finalists: planned again with independent seeds as `ctr plan` plans the written query, every (finalist, query,
  // seed) on the threads; their success rate is counted in their score, so the best of them is the design kept.
  if (o.finalist_plans > 0 && o.finalists > 0) {
    res.finalists = finalistsOf(res.evaluations, o.finalists);
    res.confirmation_seeds = confirmationSeeds(o.seed, o.finalist_plans);
    keepPathsOf(res.evaluations, o.finalists);
    struct Job {
      std::size_t f, k, j;  // finalist, query, seed
    };
    std::vector<Job> jobs;
    for (std::size_t f = 0; f < res.finalists.size(); ++f)
      for (std::size_t k = 0; k < queries_.size(); ++k)
        for (std::size_t j = 0; j < res.confirmation_seeds.size(); ++j) jobs.push_back({f, k, j});
    std::vector<ConfirmationPlan> plans(jobs.size());
    std::size_t confirmed = 0;
    parallelFor(jobs.size(), threadCount(o), [&](std::size_t i) {
      const Job& jb = jobs[i];
      plans[i] = confirmPlan(res.evaluations[res.finalists[jb.f]], jb.k, res.confirmation_seeds[jb.j]);
      std::lock_guard<std::mutex> lock(mutex);
      ++confirmed;
      if (o.progress)
        o.progress(done + confirmed, done + jobs.size(),
                   "independent plans of " + std::to_string(res.finalists.size()) + " finalist(s)");
    });
    for (std::size_t i = 0; i < jobs.size(); ++i)
      res.evaluations[res.finalists[jobs[i].f]].queries[jobs[i].k].confirmation.push_back(std::move(plans[i]));
    for (std::size_t f : res.finalists) {
      Evaluation& e = res.evaluations[f];
      e.score = scoreOf(e.queries, e.candidate);
    }
    std::stable_sort(res.finalists.begin(), res.finalists.end(), [&](std::size_t a, std::size_t b) {
      return res.evaluations[a].score.better(res.evaluations[b].score);
    });
  }
  res.best = bestOf(res.evaluations);
  // Keep only the best's path among every start's.
  for (auto& e : res.evaluations)
    if (!res.best || e.start != res.best->start || e.index != res.best->index)
      for (auto& q : e.queries) q.path_csv.clear();
  res.solved = res.best && res.best->score.solved() &&
               (!res.best->score.confirmed() || res.best->score.success_rate >= o.finalist_rate);
  res.message = verdict(res.evaluations, res.best, names, o.finalist_rate);
  res.wall_time = since(t0);
  return res;
}

DesignResult designRobot(std::vector<planner::Query> queries, std::optional<DesignSpace> space,
                         const DesignOptions& options) {
  const Designer d(std::move(queries), std::move(space));
  return d.run(options);
}

std::string verdict(const std::vector<Evaluation>& evals, const std::optional<Evaluation>& best,
                    const std::vector<std::string>& names, double required_rate) {
  if (!best) return "no candidate evaluated (time limit)";
  auto name = [&](std::size_t k) { return "'" + (k < names.size() ? names[k] : std::to_string(k)) + "'"; };
  if (best->score.solved()) {
    const std::string clear = "smallest clearance along the paths " + mm(best->score.clearance);
    if (!best->score.confirmed()) return "every query solved with a clean replay; " + clear;
    std::string per;
    for (std::size_t k = 0; k < best->queries.size(); ++k)
      per += (per.empty() ? "" : ", ") + name(k) + " " + std::to_string(best->queries[k].confirmationSolved()) + "/" +
             std::to_string(best->queries[k].confirmation.size());
    std::ostringstream rate;
    rate << "success rate " << std::lround(best->score.success_rate * 100) << " %";
    if (best->score.success_rate >= required_rate)
      return "every query solved with a clean replay; independent plans (the written queries' settings) solved " + per +
             " (" + rate.str() + "); " + clear;
    std::ostringstream req;
    req << std::lround(required_rate * 100);
    return "no design plans reliably: the best finalist's independent plans (the written queries' settings) solved " +
           per + " with a clean replay (" + rate.str() + ", required " + req.str() + " %); " + clear + " in the search";
  }
  using St = QueryOutcome::Stage;
  std::string msg;
  for (std::size_t k = 0; k < best->queries.size(); ++k) {
    const QueryOutcome& q = best->queries[k];
    if (q.stage == St::Solved) continue;
    std::string m;
    const std::string n = name(k);
    if (q.stage == St::Unreachable) {
      double closest = std::numeric_limits<double>::infinity();
      for (const Evaluation& e : evals)
        if (k < e.queries.size()) closest = std::min(closest, e.queries[k].closest);
      m = "no design of the " + std::to_string(evals.size()) + " evaluated puts the tip on the target of " + n +
          " (closest tip distance reached " + mm(closest) + ")";
    } else if (q.stage == St::NoValidGoal) {
      m = "no design of the " + std::to_string(evals.size()) + " evaluated has a valid goal configuration for " + n +
          " (best: " + q.message + ")";
    } else if (q.stage == St::StartInvalid) {
      m = n + ": the start is invalid for the best design (" + q.message + ")";
    } else {
      m = q.plans == 0 ? n + ": valid goals found, not planned (another query has none)"
                       : n + ": goal configurations exist but no plan replayed clean (" + q.message + ")";
    }
    msg += (msg.empty() ? "" : "; ") + m;
  }
  return msg;
}

}  // namespace ctr::design
