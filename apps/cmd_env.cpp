// `ctr env`: anatomy environments -- info, build (write an OctoMap), check (collision and clearance of a shape).
#include <nlohmann/json.hpp>

#include <chrono>
#include <cmath>
#include <iomanip>
#include <iostream>
#include <sstream>

#include <octomap/OcTree.h>

#include "commands.hpp"
#include "ctr/environments/collision.hpp"
#include "ctr/environments/environment_json.hpp"
#include "ctr/environments/environment_yaml.hpp"
#include "ctr/io/robot_yaml.hpp"
#include "ctr/model/kinematics.hpp"
#include "progress.hpp"

namespace ctr::cli {

namespace {

using Json = nlohmann::json;

Json vec(const Eigen::Vector3d& v) {
  return Json::array({v.x(), v.y(), v.z()});
}

std::string fmtMm(const Eigen::Vector3d& v) {
  std::ostringstream os;
  os << std::fixed << std::setprecision(2) << "(" << v.x() * 1e3 << ", " << v.y() * 1e3 << ", " << v.z() * 1e3
     << ") mm";
  return os.str();
}

struct EnvOptions {
  std::string file;
  double resolution = 0.0;  // 0: the description's
  std::string start;        // named start pose to use as the base pose
  std::string json;         // --json [FILE|-]
  bool verbose = false;
  bool quiet = false;  // env build: no progress line
};

void addEnvOptions(CLI::App* sub, EnvOptions& o) {
  sub->add_option("ENV", o.file, "Environment description (YAML)")->required();
  sub->add_option("--resolution", o.resolution, "Override the map resolution (m)")->check(finitePositive());
  sub->add_option("--start", o.start, "Use this named start pose as the robot base pose");
  sub->add_flag("--verbose", o.verbose, "Print build progress on stderr");
}

// With `progress`: its total is set to the build's steps (load each source, rasterise, + one step left to the
// caller, e.g. writing the octree), and each step is counted as it starts.
environments::Environment buildFrom(const EnvOptions& o, Progress* progress = nullptr) {
  environments::BuildOptions bo;
  if (o.resolution > 0.0) bo.resolution = o.resolution;
  const environments::EnvironmentDescription desc = environments::loadEnvironmentDescription(o.file);
  std::size_t step = 0;
  if (progress) progress->setTotal(desc.obstacles.size() + (desc.stay_inside ? 1 : 0) + 2);
  if (o.verbose || progress)
    bo.log = [&o, progress, &step](const std::string& m) {
      if (progress) {
        progress->set(step++);
        progress->setDetail(m);
        if (o.verbose) progress->note("  " + m);
      } else {
        std::cerr << "  " << m << "\n";
      }
    };
  environments::Environment e = environments::buildEnvironment(desc, bo);
  if (!o.start.empty()) {
    try {
      e.useStart(o.start);
    } catch (const std::invalid_argument& ex) {
      throw UsageError(std::string("--start: ") + ex.what());
    }
  }
  return e;
}

void printInfo(std::ostream& os, const environments::Environment& e) {
  const environments::OccupancyStats st = e.stats();
  const Eigen::Vector3d sz = e.bounds().size();
  os << "environment  " << e.name() << "\n";
  os << "resolution   " << e.resolution() * 1e3 << " mm\n";
  os << "bounds       " << fmtMm(e.bounds().min) << " .. " << fmtMm(e.bounds().max) << "  (" << std::fixed
     << std::setprecision(1) << sz.x() * 1e3 << " x " << sz.y() * 1e3 << " x " << sz.z() * 1e3 << " mm)\n";
  os << std::defaultfloat;
  os << "octree       " << st.nodes << " nodes, " << st.occupied_leaves << " occupied / " << st.free_leaves
     << " free leaves, " << std::setprecision(3) << st.memory_bytes / 1048576.0 << " MiB\n";
  os << "occupied     " << st.occupied_volume * 1e6 << " cm^3 (free " << st.free_volume * 1e6 << " cm^3)\n";
  os << "build time   " << e.buildSeconds() << " s\n";
  for (const auto& s : e.sources()) os << "source       " << s << "\n";
  os << "base pose    " << e.basePoseSource() << ": position " << fmtMm(e.basePose().translation()) << ", direction "
     << e.basePose().linear().col(2).transpose() << " ("
     << environments::toString(e.occupancy(e.basePose().translation())) << ")\n";
  for (const auto& s : e.starts())
    os << "start        " << s.name << ": position " << fmtMm(s.pose.translation()) << ", direction "
       << s.pose.linear().col(2).transpose() << "\n";
  for (const auto& t : e.targets())
    os << "target       " << t.name << ": " << fmtMm(t.position) << " ("
       << environments::toString(e.occupancy(t.position)) << ", " << std::setprecision(4)
       << (t.position - e.basePose().translation()).norm() * 1e3 << " mm from the base)\n";
  os << "collision    safety margin " << e.collisionDefaults().safety_margin * 1e3 << " mm, unknown space "
     << environments::toString(e.collisionDefaults().unknown_space);
  if (e.collisionDefaults().exclude_proximal > 0)
    os << ", first " << e.collisionDefaults().exclude_proximal * 1e3 << " mm excluded";
  os << "\n";
}

}  // namespace

void registerEnv(CLI::App& app, Action& action) {
  CLI::App* env = app.add_subcommand("env", "Anatomy environments: info, build, check (see docs/environments.md)");
  env->require_subcommand(1);

  // ctr env info
  {
    auto o = std::make_shared<EnvOptions>();
    CLI::App* sub = env->add_subcommand("info",
                                        "Build an environment and print bounds, resolution, occupied volume, "
                                        "base pose, starts, targets and build time");
    addEnvOptions(sub, *o);
    addJsonOption(sub, o->json, "the information (one object)");
    sub->callback([o, &action]() {
      action = [o]() {
        checkOutputTarget("--json", o->json, {{"ENV", o->file}});
        const environments::Environment e = buildFrom(*o);
        writeOutput(o->json, environments::infoJson(e, 2) + "\n");
        if (o->json != kStandardOutput) printInfo(std::cout, e);
        return static_cast<int>(kOk);
      };
    });
  }

  // ctr env build
  {
    auto o = std::make_shared<EnvOptions>();
    auto out = std::make_shared<std::string>();
    CLI::App* sub = env->add_subcommand("build", "Build an environment and write its octree (.bt for octovis, or .ot)");
    addEnvOptions(sub, *o);
    sub->add_option("-o,--output", *out, "Output octree file (.bt or .ot)")->required();
    sub->add_flag("--quiet", o->quiet, "No progress on stderr");
    sub->callback([o, out, &action]() {
      action = [o, out]() {
        const std::string& path = *out;
        const bool ok_ext = (path.size() > 3 && (path.compare(path.size() - 3, 3, ".bt") == 0 ||
                                                 path.compare(path.size() - 3, 3, ".ot") == 0));
        if (!ok_ext) throw UsageError("-o: the output must end in .bt or .ot");
        checkOutputPath("-o", path, {{"ENV", o->file}});
        Progress progress("env build", 0, "steps", o->quiet);
        const environments::Environment e = buildFrom(*o, &progress);
        const std::size_t steps = progress.total();
        progress.set(steps - 1);  // loaded and rasterised; the last step writes the octree
        progress.setDetail("writing " + path);
        e.write(path);  // atomic: OUT.tmp + rename
        progress.setDetail("");
        progress.set(steps);
        progress.finish();
        const environments::OccupancyStats st = e.stats();
        std::cout << "wrote " << path << ": " << st.nodes << " nodes, resolution " << e.resolution() * 1e3
                  << " mm, occupied " << st.occupied_volume * 1e6 << " cm^3, built in " << e.buildSeconds() << " s\n";
        return static_cast<int>(kOk);
      };
    });
  }

  // ctr env check
  {
    struct CheckOpts {
      EnvOptions env;
      std::string robot;
      ConfigOptions config;
      double margin = -1.0;
      std::string unknown;
      double max_distance = 0.005;
    };
    auto o = std::make_shared<CheckOpts>();
    CLI::App* sub = env->add_subcommand(
        "check", "Collision (yes/no, first colliding section) and clearance of the robot's shape at a configuration");
    addEnvOptions(sub, o->env);
    sub->add_option("--robot", o->robot, "Robot description YAML")->required();
    o->config.add(sub);
    sub->add_option("--margin", o->margin, "Safety margin added to every tube radius (m); default: the environment's")
        ->check(finiteNonNegative());
    sub->add_option("--unknown", o->unknown, "Unknown space: free or occupied; default: the environment's")
        ->check(CLI::IsMember({"free", "occupied"}));
    sub->add_option("--max-distance", o->max_distance, "Clearance saturates at this distance (m)")
        ->check(finitePositive());
    addJsonOption(sub, o->env.json, "the result (one object)");
    sub->callback([o, &action]() {
      action = [o]() {
        checkOutputTarget("--json", o->env.json, {{"ENV", o->env.file}, {"--robot", o->robot}});
        const Robot robot = io::loadRobot(o->robot);
        const Configuration q = o->config.resolve(robot);
        auto e = std::make_shared<const environments::Environment>(buildFrom(o->env));
        Workspace ws;
        KinematicsOptions ko;
        ko.record_backbone = true;
        const Solution sol = solve(robot, q, ws, ko);
        if (sol.summary.status == SolveStatus::Inadmissible)
          throw UsageError("configuration is not admissible: " + sol.summary.message);
        if (!sol.converged()) {
          std::cerr << "error: the model did not converge: " << sol.summary.message << "\n";
          return static_cast<int>(kRuntimeFailure);
        }
        environments::CollisionOptions co = environments::CollisionOptions::fromEnvironment(*e);
        if (o->margin >= 0.0) co.geometry.safety_margin = o->margin;
        if (!o->unknown.empty()) co.unknown_space = environments::parseUnknownSpace(o->unknown);
        co.max_distance = o->max_distance;
        const auto t0 = std::chrono::steady_clock::now();
        environments::CollisionChecker checker(e, robot, co);
        const double t_checker = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        auto query = checker.query();
        const auto t1 = std::chrono::steady_clock::now();
        const environments::CollisionResult col = checker.check(sol, query);
        const auto t2 = std::chrono::steady_clock::now();
        const environments::ClearanceResult cl = checker.clearance(sol, query);
        const auto t3 = std::chrono::steady_clock::now();
        const double us_col = std::chrono::duration<double, std::micro>(t2 - t1).count();
        const double us_cl = std::chrono::duration<double, std::micro>(t3 - t2).count();
        const Eigen::Vector3d tip = e->basePose() * sol.tip_position;
        auto tubeName = [&](int t) { return t >= 0 ? robot.tube(t).name : std::string(); };
        if (!o->env.json.empty()) {
          Json j;
          j["environment"] = e->name();
          j["robot"] = robot.name();
          j["collision"] = col.collision;
          if (col.collision)
            j["first_colliding_section"] = {{"section", col.section},
                                            {"tube", col.tube + 1},
                                            {"tube_name", tubeName(col.tube)},
                                            {"s", Json::array({col.s0, col.s1})},
                                            {"outside_map", col.outside_map}};
          else
            j["first_colliding_section"] = nullptr;
          j["clearance"] = cl.clearance;
          j["clearance_saturated"] = cl.saturated;
          j["clearance_complete"] = cl.complete;
          j["closest"] = {{"section", cl.section},
                          {"tube", cl.tube + 1},
                          {"s", cl.s},
                          {"robot_point", vec(cl.robot_point)},
                          {"obstacle_point", vec(cl.obstacle_point)}};
          j["tip_position"] = vec(tip);
          Json tg = Json::object();
          for (const auto& t : e->targets()) tg[t.name] = (t.position - tip).norm();
          j["tip_to_targets"] = tg;
          j["capsules"] = col.capsules;
          j["narrowphase_calls"] = col.narrowphase_calls;
          j["timing_us"] = {{"collision", us_col}, {"clearance", us_cl}, {"checker_build", t_checker * 1e6}};
          writeOutput(o->env.json, j.dump(2) + "\n");
        }
        if (o->env.json != kStandardOutput) {
          std::cout << "environment  " << e->name() << " (base: " << e->basePoseSource() << ")\n";
          std::cout << "robot        " << robot.name() << ", tip at " << fmtMm(tip) << "\n";
          if (col.collision) {
            std::cout << "collision    yes: first colliding section " << col.section << " (tube " << col.tube + 1
                      << " '" << tubeName(col.tube) << "' outermost, s = " << col.s0 * 1e3 << " .. " << col.s1 * 1e3
                      << " mm)" << (col.outside_map ? " -- leaves the map (unknown space is occupied)" : "") << "\n";
          } else {
            std::cout << "collision    no\n";
          }
          std::cout << "clearance    " << cl.clearance * 1e3 << " mm" << (cl.saturated ? " (saturated)" : "")
                    << (cl.complete ? "" : " (part of the shape is outside the distance field)");
          if (cl.section >= 0)
            std::cout << " at s = " << cl.s * 1e3 << " mm (tube " << cl.tube + 1 << "), obstacle near "
                      << fmtMm(cl.obstacle_point);
          std::cout << "\n";
          for (const auto& t : e->targets())
            std::cout << "target       " << t.name << ": tip distance " << (t.position - tip).norm() * 1e3 << " mm\n";
          std::cout << "timing       collision " << us_col << " us (" << col.narrowphase_calls << " FCL calls, "
                    << col.capsules << " capsules), clearance " << us_cl << " us, checker build " << t_checker
                    << " s\n";
        }
        return static_cast<int>(kOk);
      };
    });
  }
}

}  // namespace ctr::cli
