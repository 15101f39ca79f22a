#include "ctr/planner/planner.hpp"

#include "ctr/planner/portfolio.hpp"
#include "ctr/planner/stopwatch.hpp"

#include <ompl/base/ScopedState.h>
#include <ompl/base/goals/GoalState.h>
#include <ompl/base/objectives/MaximizeMinClearanceObjective.h>
#include <ompl/base/objectives/PathLengthOptimizationObjective.h>
#include <ompl/control/SteeredControlSampler.h>
#include <ompl/control/planners/est/EST.h>
#include <ompl/control/planners/kpiece/KPIECE1.h>
#include <ompl/control/planners/pdst/PDST.h>
#include <ompl/control/planners/rrt/RRT.h>
#include <ompl/control/planners/sst/SST.h>
#include <ompl/control/spaces/RealVectorControlSpace.h>
#include <ompl/geometric/planners/est/EST.h>
#include <ompl/geometric/planners/informedtrees/BITstar.h>
#include <ompl/geometric/planners/kpiece/BKPIECE1.h>
#include <ompl/geometric/planners/kpiece/KPIECE1.h>
#include <ompl/geometric/planners/prm/LazyPRM.h>
#include <ompl/geometric/planners/prm/PRM.h>
#include <ompl/geometric/planners/prm/PRMstar.h>
#include <ompl/geometric/planners/rrt/RRT.h>
#include <ompl/geometric/planners/rrt/RRTConnect.h>
#include <ompl/geometric/planners/rrt/RRTstar.h>
#include <ompl/geometric/planners/sbl/SBL.h>
#include <ompl/util/Console.h>
#include <ompl/util/RandomNumbers.h>

#include <chrono>
#include <limits>
#include <mutex>

#include "ctr/environments/environment_yaml.hpp"
#include "ctr/io/input_error.hpp"
#include "ctr/io/robot_yaml.hpp"

namespace ob = ompl::base;
namespace og = ompl::geometric;
namespace oc = ompl::control;

namespace ctr::planner {
namespace {

constexpr double kRotationRate = 1.0;      // rad per unit control time
constexpr double kTranslationRate = 0.02;  // m per unit control time
constexpr double kPropagationStep = 0.05;  // one propagation step: <= 0.05 rad / 1 mm
constexpr int kRangeReplaySamples = 20;    // random points of the ranges a plan is replayed at (after the corners)

void seedOnce(std::uint64_t seed) {
  static std::once_flag flag;
  std::call_once(flag, [&] {
    ompl::msg::setLogLevel(ompl::msg::LOG_WARN);
    ompl::RNG::setSeed(static_cast<std::uint_fast32_t>(seed));
  });
}

}  // namespace

CtrPlanner::CtrPlanner(const Query& query) : query_(query) {
  environments::BuildOptions bo;
  if (query.env_resolution > 0) bo.resolution = query.env_resolution;
  Robot robot = io::loadRobot(query.robot);
  init(std::move(robot), environments::loadEnvironment(query.environment, bo));
}

CtrPlanner::CtrPlanner(const Query& query, Robot robot, environments::Environment environment) : query_(query) {
  init(std::move(robot), std::move(environment));
}

void CtrPlanner::init(Robot robot, environments::Environment e) {
  const Query& query = query_;
  seedOnce(query.seed);
  if (query.friction) {
    try {
      robot = robot.withFriction(*query.friction);
    } catch (const std::invalid_argument& e) {
      throw io::InputError(query.file, query.lineOf("friction"), "friction", e.what());
    }
  }
  // The query's values and ranges of the robot's friction and drives: the robot at the middle of each; robust mode
  // plans for every value of the open ranges.
  RobotRanges open_ranges;
  if (!query.ranges.empty()) {
    const std::string key = !query.robot_uncertainty.empty() ? "robot_uncertainty" : "actuation";
    std::vector<double> middle;
    for (const RangeDimension& d : query.ranges) {
      middle.push_back(0.5 * (d.lo + d.hi));
      if (d.hi > d.lo) open_ranges.push_back(d);
    }
    try {
      checkRanges(robot, query.ranges);
      robot = robotAt(robot, query.ranges, middle);
    } catch (const std::invalid_argument& ex) {
      throw io::InputError(query.file, query.lineOf(key), key, ex.what());
    }
    if (!open_ranges.empty() && query.mode != Mode::Robust)
      throw io::InputError(query.file, query.lineOf("mode"), "mode",
                           "ranges of the robot's values (" + open_ranges[0].name() +
                               ", ...) are planned for in robust mode, not " + toString(query.mode));
  }
  const int n = robot.size();
  if (query.start.size() != n)
    throw io::InputError(query.file, query.lineOf("start.alpha"), "start.alpha",
                         "has " + std::to_string(query.start.size()) + " values, robot '" + robot.name() + "' has " +
                             std::to_string(n) + " tubes");
  // Start and goal configurations are read from the query file (rounded values): violations up to
  // kAdmissibilityTolerance are projected in query_ (docs/formats.md "Admissibility tolerance"), larger ones name
  // the file, line, key and constraint.
  const Admissibility adm = projectAdmissible(robot, query_.start);
  if (!adm) throw io::InputError(query.file, query.lineOf("start"), "start", "not admissible: " + adm.message);
  if (query.goal_configuration) {
    if (query.goal_configuration->size() != n)
      throw io::InputError(query.file, query.lineOf("goal.configuration"), "goal.configuration",
                           "wrong number of tubes");
    const Admissibility ga = projectAdmissible(robot, *query_.goal_configuration);
    if (!ga)
      throw io::InputError(query.file, query.lineOf("goal.configuration"), "goal.configuration",
                           "not admissible: " + ga.message);
  }
  if (!query.base_start.empty()) {
    try {
      e.useStart(query.base_start);
    } catch (const std::invalid_argument& ex) {
      throw io::InputError(query.file, query.lineOf("base_start"), "base_start", ex.what());
    }
  }
  if (!query.target_name.empty()) {
    try {
      query_.tip_goal->position = e.target(query.target_name).position;
    } catch (const std::invalid_argument& ex) {
      throw io::InputError(query.file, query.lineOf("goal.target"), "goal.target", ex.what());
    }
  }
  if (query_.tip_goal && !e.bounds().empty() && !e.bounds().contains(query_.tip_goal->position)) {
    const std::string key = query.target_name.empty() ? "goal.position" : "goal.target";
    throw io::InputError(query.file, query.lineOf(key), key, "the target lies outside the environment's map");
  }
  if (query.loads) {
    // The query's loads replace the robot's; given in the environment's frame they are turned into the base frame of
    // the base pose in use (dead loads: fixed in the base frame while planning).
    Loads l = *query.loads;
    if (query.loads_frame == Query::LoadsFrame::Environment) {
      const Eigen::Matrix3d Rt = e.basePose().linear().transpose();
      l.gravity = Rt * l.gravity;
      l.tip_force = Rt * l.tip_force;
      l.tip_moment = Rt * l.tip_moment;
    }
    if (l.gravity.norm() > 0.0 && !robot.hasWeight())
      throw io::InputError(query.file, query.lineOf("loads.gravity"), "loads.gravity",
                           "gravity has no effect: no tube of robot '" + robot.name() +
                               "' has a linear_density (or density with diameters)");
    try {
      robot = robot.withLoads(l);
    } catch (const std::invalid_argument& ex) {
      throw io::InputError(query.file, query.lineOf("loads"), "loads", ex.what());
    }
  }
  if (query.mode == Mode::Robust && !robot.loads().empty()) {
    const std::string key = query.loads ? "loads" : "mode";  // the query's loads, or the robot's own
    throw io::InputError(query.file, query.lineOf(key), key,
                         "robust mode plans for every history only where one equilibrium per contact torque is "
                         "certified, and the certificate covers the load-free model (docs/planning.md, \"What robust "
                         "mode guarantees\"): plan with loads in exact mode");
  }
  env_ = std::make_shared<const environments::Environment>(std::move(e));

  ContextOptions co;
  co.mode = query.mode;
  co.motion.max_rotation_step = query.resolution_rotation;
  co.motion.max_translation_step = query.resolution_translation;
  co.friction.kinematics.record_backbone = true;
  co.ranges = std::move(open_ranges);
  try {
    ctx_ = std::make_shared<const Context>(robot, env_, co, environments::CollisionOptions::fromEnvironment(*env_));
  } catch (const std::invalid_argument& ex) {
    throw io::InputError(query.file, query.lineOf("robot"), "robot", ex.what());
  }

  auto space = std::make_shared<CtrStateSpace>(ctx_->robot(), ctx_->translationSampler());
  space->registerDefaultProjection(std::make_shared<TipProjection>(space.get(), ctx_));
  space_holder_ = space;
  start_cache_ = startCache(*ctx_, query.start, query.history);

  ob::SpaceInformationPtr si;
  if (query.mode == Mode::Exact) {
    auto cspace = std::make_shared<oc::RealVectorControlSpace>(space, 2 * n);
    ob::RealVectorBounds cb(2 * n);
    for (int i = 0; i < n; ++i) {
      cb.setLow(i, -kRotationRate);
      cb.setHigh(i, kRotationRate);
      cb.setLow(n + i, -kTranslationRate);
      cb.setHigh(n + i, kTranslationRate);
    }
    cspace->setBounds(cb);
    css_ = std::make_shared<oc::SimpleSetup>(cspace);
    const oc::SpaceInformationPtr& csi = css_->getSpaceInformation();
    csi->setPropagationStepSize(kPropagationStep);
    csi->setMinMaxControlDuration(1, 10);
    css_->setStatePropagator(std::make_shared<FrictionPropagator>(csi.get(), ctx_, kRotationRate, kTranslationRate));
    css_->setStateValidityChecker(std::make_shared<ValidityChecker>(csi, ctx_));
    csi->setDirectedControlSamplerAllocator(
        [](const oc::SpaceInformation* s) { return std::make_shared<oc::SteeredControlSampler>(s); });
    si = csi;
  } else {
    gss_ = std::make_shared<og::SimpleSetup>(space);
    si = gss_->getSpaceInformation();
    gss_->setStateValidityChecker(std::make_shared<ValidityChecker>(si, ctx_));
    si->setMotionValidator(std::make_shared<ForwardMotionValidator>(si, ctx_));
  }
  ob::ScopedState<> start(space);
  space->setConfiguration(start.get(), query.start);
  start->as<CtrStateSpace::StateType>()->cache = start_cache_;
  ob::GoalPtr goal;
  if (query.goal_configuration) {
    auto gs = std::make_shared<ob::GoalState>(si);
    ob::ScopedState<> g(space);
    space->setConfiguration(g.get(), *query.goal_configuration);
    gs->setState(g);
    gs->setThreshold(query.goal_configuration_tolerance);
    goal = gs;
  } else {
    goal_ = std::make_shared<TipGoal>(si, ctx_, *query_.tip_goal);
    goal = goal_;
  }
  auto pdef = std::make_shared<ob::ProblemDefinition>(si);
  pdef->addStartState(start);
  pdef->setGoal(goal);
  if (query.objective == "clearance") {
    pdef->setOptimizationObjective(std::make_shared<ob::MaximizeMinClearanceObjective>(si));
  } else {
    pdef->setOptimizationObjective(std::make_shared<ob::PathLengthOptimizationObjective>(si));
  }
  if (gss_) {
    gss_->setStartState(start);
    gss_->setGoal(goal);
    gss_->setOptimizationObjective(pdef->getOptimizationObjective());
  } else {
    css_->setStartState(start);
    css_->setGoal(goal);
    css_->setOptimizationObjective(pdef->getOptimizationObjective());
  }
}

ob::PlannerPtr CtrPlanner::makePlanner(const std::string& name0) const {
  const std::string name = name0 == "default" ? (css_ ? "rrt" : "rrtconnect") : name0;
  if (css_) {
    const oc::SpaceInformationPtr& si = css_->getSpaceInformation();
    if (name == "rrt") {
      auto p = std::make_shared<oc::RRT>(si);
      p->setGoalBias(0.2);  // the goal pool holds valid IK configurations: steer toward them often
      return p;
    }
    if (name == "kpiece") return std::make_shared<oc::KPIECE1>(si);
    if (name == "sst") {
      auto p = std::make_shared<oc::SST>(si);
      p->setGoalBias(0.2);  // as RRT: the goal pool holds valid IK configurations
      return p;
    }
    if (name == "est") return std::make_shared<oc::EST>(si);
    if (name == "pdst") return std::make_shared<oc::PDST>(si);
    if (name == "portfolio")  // RRT and KPIECE solve different queries (docs/planning.md): both, on two threads
      return std::make_shared<Portfolio>(si, std::vector<ob::PlannerPtr>{makePlanner("rrt"), makePlanner("kpiece")});
  } else {
    const ob::SpaceInformationPtr& si = gss_->getSpaceInformation();
    if (name == "rrtconnect") return std::make_shared<og::RRTConnect>(si);
    if (name == "rrt") {
      auto p = std::make_shared<og::RRT>(si);
      p->setGoalBias(0.2);  // as in exact mode: the goal pool holds valid IK configurations
      return p;
    }
    if (name == "rrtstar") return std::make_shared<og::RRTstar>(si);
    if (name == "bitstar") return std::make_shared<og::BITstar>(si);
    if (name == "prm") return std::make_shared<og::PRM>(si);
    if (name == "prmstar") return std::make_shared<og::PRMstar>(si);
    if (name == "lazyprm") return std::make_shared<og::LazyPRM>(si);
    if (name == "kpiece") return std::make_shared<og::KPIECE1>(si);
    if (name == "bkpiece") return std::make_shared<og::BKPIECE1>(si);
    if (name == "est") return std::make_shared<og::EST>(si);
    if (name == "sbl") return std::make_shared<og::SBL>(si);
    if (name == "portfolio")
      return std::make_shared<Portfolio>(si,
                                         std::vector<ob::PlannerPtr>{makePlanner("rrtconnect"), makePlanner("kpiece")});
  }
  std::string known;
  for (const auto& x : plannerNames(query_.mode)) known += (known.empty() ? "" : ", ") + x;
  throw std::invalid_argument("unknown planner '" + name0 + "' for mode " + toString(query_.mode) + " (" + known + ")");
}

void CtrPlanner::checkStart() const {
  ThreadScratch& t = scratch();
  const std::shared_ptr<const StateCache> c = startCache(*ctx_, query_.start, query_.history);
  if (!c->solution.converged())
    throw io::InputError(query_.file, query_.lineOf("start"), "start",
                         "the model does not converge at the start: " + c->message);
  const ShapeCheck sc = checkShape(*ctx_, c->solution, t);
  if (!sc.ok)
    throw io::InputError(query_.file, query_.lineOf("start"), "start", "start configuration is invalid: " + sc.message);
  if (query_.mode == Mode::Robust) {
    const std::string why = robustStartOutsideBand(*ctx_, query_.start, c->solution, t);
    if (!why.empty()) throw io::InputError(query_.file, query_.lineOf("start.history"), "start.history", why);
  }
}

PlanResult CtrPlanner::solve() {
  return solve(query_.planner, query_.time_limit);
}

std::size_t CtrPlanner::prepareGoal(double time_limit) {
  if (!goal_) return 0;
  // Robust goals cost a friction band each: start planning with a few and let the pool grow while planning.
  const std::size_t target = gss_ ? 16 : 8;
  const std::size_t first = query_.mode == Mode::Robust ? 4 : target;
  const Stopwatch watch(query_.cpu_time_limit);
  std::size_t n = goal_->fillPool(first, std::min(0.25 * time_limit, 5.0), query_.seed, query_.cpu_time_limit, target);
  // No goal yet (rare goals, or a slow machine): keep looking up to half of the time limit rather than give up with
  // most of it unused.
  if (n == 0) n = goal_->fillPool(1, 0.5 * time_limit - watch.seconds(), query_.seed, query_.cpu_time_limit, target);
  return n;
}

PlanResult CtrPlanner::solve(const std::string& planner_name, double time_limit) {
  const Stopwatch watch(query_.cpu_time_limit);
  prepareGoal(time_limit);
  const ob::PlannerPtr p = makePlanner(planner_name);
  // Deadline on the query's clock (at least 0.05 s for the planner itself).
  const double deadline = std::max(time_limit, watch.seconds() + 0.05);
  const ob::PlannerTerminationCondition ptc([&watch, deadline] { return watch.seconds() >= deadline; });
  ob::PlannerStatus status;
  if (gss_) {
    gss_->clear();
    gss_->setPlanner(p);
    gss_->setup();
    status = gss_->solve(ptc);
  } else {
    css_->clear();
    css_->setPlanner(p);
    css_->setup();
    status = css_->solve(ptc);
  }
  const double planning_time = watch.seconds();
  const double planning_wall_time = watch.wallSeconds();
  const bool exact = status == ob::PlannerStatus::EXACT_SOLUTION;
  PlanResult r;
  if (exact) {
    r = replaySolution(p->getName(), planning_time, true);
  } else {
    r.mode = query_.mode;
    r.planner = p->getName();
    r.planning_time = planning_time;
    // One line saying why: no goal configuration at all, or the planner's status (the time limit ran out).
    if (goal_ && goal_->maxSampleCount() == 0)
      r.message = goal_->emptyPoolReason();
    else
      r.message = std::string("planner: ") + status.asString() +
                  (status == ob::PlannerStatus::APPROXIMATE_SOLUTION || status == ob::PlannerStatus::TIMEOUT
                       ? " (no path to a goal configuration within the time limit)"
                       : "");
  }
  r.planning_wall_time = planning_wall_time;
  r.goal_pool = goal_ ? goal_->maxSampleCount() : 0;
  return r;
}

PlanResult CtrPlanner::replaySolution(const std::string& planner, double planning_time, bool exact) {
  PlanResult r;
  r.mode = query_.mode;
  r.planner = planner;
  r.planning_time = planning_time;
  r.planner_solved = exact;
  const CtrStateSpace& space = *space_holder_;
  std::vector<const ob::State*> states;
  og::PathGeometric* gpath = nullptr;
  oc::PathControl* cpath = nullptr;
  if (gss_) {
    // OMPL's simplifier checks the states it repairs, not always every motion between them ("Solution path may
    // slightly touch on an invalid region"): a simplified path is kept only if every state and motion is valid in the
    // planning mode (PathGeometric::check), else the planner's own path is replayed.
    const og::PathGeometric found = gss_->getSolutionPath();
    gss_->simplifySolution(std::min(1.0, 0.1 * query_.time_limit));
    gpath = &gss_->getSolutionPath();
    if (!gpath->check()) *gpath = found;
    for (const ob::State* s : gpath->getStates()) states.push_back(s);
  } else {
    cpath = &css_->getSolutionPath();
    for (const ob::State* s : cpath->getStates()) states.push_back(s);
  }
  if (states.empty()) {
    r.message = "empty solution path";
    return r;
  }
  // Unwrapped waypoints from the query's start. Exact mode: every propagation step of every control is a waypoint,
  // computed as the propagator did (q += u * step per step, from the memory's command), so that the replay slices the
  // path into exactly the sub-steps the planner checked; since a step depends only on its state and command, the
  // replay then recomputes the checked states bit for bit.
  r.path.push_back(query_.start);
  const int n = query_.start.size();
  for (std::size_t k = 1; k < states.size(); ++k) {
    const auto* st = states[k]->as<CtrStateSpace::StateType>();
    if (cpath && k - 1 < cpath->getControlCount()) {
      const double* u = cpath->getControl(k - 1)->as<oc::RealVectorControlSpace::ControlType>()->values;
      const double dt = css_->getSpaceInformation()->getPropagationStepSize();
      const long steps = std::lround(cpath->getControlDuration(k - 1) / dt);
      for (long j = 1; j < steps; ++j) {
        Configuration q = r.path.back();
        for (int i = 0; i < n; ++i) {
          q.alpha[i] += u[i] * dt;
          q.beta[i] += u[n + i] * dt;
        }
        r.path.push_back(q);
      }
    }
    if (st->cache && st->cache->hysteresis.valid) {
      r.path.push_back(st->cache->hysteresis.lastCommand());
    } else {
      const Configuration d = space.difference(states[k - 1], states[k]);
      r.path.push_back(Configuration(r.path.back().alpha + d.alpha, r.path.back().beta + d.beta));
    }
    r.path_length += space.distance(states[k - 1], states[k]);
  }
  // Robust mode: a path that ends at an approach goal's start ends with its final approach, checked with the goal.
  if (goal_) {
    if (const std::optional<Configuration> move = goal_->approachMove(states.back())) {
      const Configuration& last = r.path.back();
      r.path.push_back(Configuration(last.alpha + move->alpha, last.beta + move->beta));
      const Configuration from = space.configuration(states.back());
      ob::State* end = space.allocState();
      space.setConfiguration(end, Configuration(from.alpha + move->alpha, from.beta + move->beta));
      r.path_length += space.distance(states.back(), end);
      space.freeState(end);
      r.final_approach = *move;
    }
  }
  const auto t0 = std::chrono::steady_clock::now();
  GoalTest test;
  if (goal_) {
    test = [this](const Solution& s, const Configuration&) {
      const auto [e, a] = goal_->errors(s);
      const bool ok = e <= goal_->spec().tolerance && (!goal_->spec().direction || a <= goal_->spec().cone_angle);
      return std::make_tuple(e, a, ok);
    };
  } else {
    const Configuration g = *query_.goal_configuration;
    const double tol = query_.goal_configuration_tolerance;
    test = [g, tol](const Solution&, const Configuration& q) {  // the commands (the query's coordinates)
      Eigen::VectorXd da = q.alpha - g.alpha;
      for (int i = 0; i < da.size(); ++i) da[i] = std::remainder(da[i], 2 * M_PI);
      const double d = std::sqrt(da.squaredNorm() + 2500.0 * (q.beta - g.beta).squaredNorm());
      return std::make_tuple(d, 0.0, d <= tol);
    };
  }
  r.replay =
      replayPath(*ctx_, r.path, query_.history, test, query_.replay_rotation_step, query_.replay_translation_step);
  const RobotRanges& ranges = ctx_->options().ranges;
  if (!ranges.empty() && r.replay.ok()) {
    // The path replayed with the robot at every corner of the ranges and at random samples inside them.
    RangeReplay rr;
    for (const RangeDimension& d : ranges) rr.names.push_back(d.name());
    const std::vector<std::vector<double>> points = rangeReplayPoints(ranges, kRangeReplaySamples, query_.seed);
    rr.corners = static_cast<int>(points.size()) - kRangeReplaySamples;
    rr.samples = kRangeReplaySamples;
    rr.worst_clearance = std::numeric_limits<double>::infinity();
    for (std::size_t k = 0; k < points.size(); ++k) {
      const ReplayReport rep = replayPath(*ctx_, robotAt(ctx_->robot(), ranges, points[k]), r.path, query_.history,
                                          test, query_.replay_rotation_step, query_.replay_translation_step);
      RangeReplay::Point p{
          points[k],  static_cast<int>(k) < rr.corners, rep.ok(), rep.min_clearance, rep.tip_error, rep.failure,
          rep.message};
      rr.clean += p.ok;
      if (rep.completed && rep.min_clearance < rr.worst_clearance) {
        rr.worst_clearance = rep.min_clearance;
        rr.worst = k;
      }
      rr.points.push_back(std::move(p));
    }
    r.range_replay = std::move(rr);
  }
  r.replay_time = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  r.solved = exact && r.replay.ok() && (!r.range_replay || r.range_replay->ok());
  if (!r.solved) r.message = "replay: " + (r.replay.message.empty() ? "failed" : r.replay.message);
  if (!r.solved && r.replay.ok() && r.range_replay)
    for (const RangeReplay::Point& p : r.range_replay->points)
      if (!p.ok) {
        r.message = "replay at " + r.range_replay->describe(p) + ": " + (p.message.empty() ? "failed" : p.message);
        break;
      }
  return r;
}

PlanResult plan(const Query& query) {
  CtrPlanner p(query);
  return p.solve();
}

}  // namespace ctr::planner
