// Bindings of ctr::environments: load an environment YAML, its map, collision and clearance of a solved shape.
#include <octomap/OcTree.h>

#include <chrono>
#include <iostream>

#include "common.hpp"
#include "ctr/environments/collision.hpp"
#include "ctr/environments/environment_json.hpp"
#include "ctr/environments/environment_yaml.hpp"

namespace ctr::py {

namespace {

using pyb::arg;
using EnvPtr = std::shared_ptr<environments::Environment>;

pyb::list vec(const Eigen::Vector3d& v) {
  pyb::list l;
  for (int k = 0; k < 3; ++k) l.append(jsonNumber(v[k]));
  return l;
}

/// The `ctr env info --json` object (environments::infoJson, as the CLI writes it).
pyb::object infoDict(const environments::Environment& e) {
  return pyb::module_::import("json").attr("loads")(environments::infoJson(e));
}

/// A collision checker with the environment it checks against (kept alive by the Python object).
struct Checker {
  std::shared_ptr<const environments::Environment> env;
  std::shared_ptr<const environments::CollisionChecker> checker;
  double build_seconds = 0.0;
};

Checker makeChecker(const EnvPtr& e, const Robot& robot, std::optional<double> margin,
                    const std::optional<std::string>& unknown, double max_distance) {
  if (!e) throw pyb::value_error("environment: None");
  environments::CollisionOptions co = environments::CollisionOptions::fromEnvironment(*e);
  if (margin) {
    if (!(*margin >= 0.0)) throw pyb::value_error("margin: must be a finite number >= 0");
    co.geometry.safety_margin = *margin;
  }
  if (unknown) co.unknown_space = environments::parseUnknownSpace(*unknown);
  if (!(max_distance > 0.0)) throw pyb::value_error("max_distance: must be > 0");
  co.max_distance = max_distance;
  Checker c;
  c.env = e;
  pyb::gil_scoped_release release;
  const auto t0 = std::chrono::steady_clock::now();
  c.checker = std::make_shared<const environments::CollisionChecker>(c.env, robot, co);
  c.build_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return c;
}

void requireShape(const Solution& sol) {
  if (!sol.converged()) throw pyb::value_error("solution: not converged (" + sol.summary.message + ")");
  if (sol.backbone.empty()) throw pyb::value_error("solution: no backbone (solved with record_backbone off)");
}

pyb::dict collisionDict(const environments::CollisionResult& col, const Robot& robot) {
  pyb::dict d;
  d["collision"] = col.collision;
  if (col.collision) {
    pyb::dict f;
    f["section"] = col.section;
    f["tube"] = col.tube + 1;
    f["tube_name"] = col.tube >= 0 ? robot.tube(col.tube).name : std::string();
    pyb::list range;
    range.append(jsonNumber(col.s0));
    range.append(jsonNumber(col.s1));
    f["s"] = range;
    f["outside_map"] = col.outside_map;
    d["first_colliding_section"] = f;
  } else {
    d["first_colliding_section"] = pyb::none();
  }
  d["capsules"] = col.capsules;
  d["narrowphase_calls"] = col.narrowphase_calls;
  return d;
}

pyb::dict clearanceDict(const environments::ClearanceResult& cl) {
  pyb::dict d;
  d["clearance"] = jsonNumber(cl.clearance);
  d["clearance_saturated"] = cl.saturated;
  d["clearance_complete"] = cl.complete;
  pyb::dict c;
  c["section"] = cl.section;
  c["tube"] = cl.tube + 1;
  c["s"] = jsonNumber(cl.s);
  c["robot_point"] = vec(cl.robot_point);
  c["obstacle_point"] = vec(cl.obstacle_point);
  d["closest"] = c;
  return d;
}

}  // namespace

void registerEnvironments(pyb::module_& m) {
  pyb::class_<environments::Environment, EnvPtr>(
      m, "Environment",
      "An anatomy environment: occupancy octree (world frame, m), base pose, named "
      "starts and targets. Load with ctr.load_environment(path).")
      .def_property_readonly("name", &environments::Environment::name)
      .def_property_readonly("resolution", &environments::Environment::resolution, "Octree leaf size (m).")
      .def_property_readonly(
          "bounds",
          [](const environments::Environment& e) {
            return pyb::make_tuple(array3(e.bounds().min), array3(e.bounds().max));
          },
          "(min, max) corners of the mapped region (m).")
      .def_property_readonly(
          "base_pose", [](const environments::Environment& e) { return Eigen::Matrix4d(e.basePose().matrix()); },
          "world_T_base (4, 4): the robot base frame in the world.")
      .def_property_readonly("base_pose_source", &environments::Environment::basePoseSource)
      .def_property_readonly(
          "starts",
          [](const environments::Environment& e) {
            pyb::dict d;
            for (const auto& s : e.starts()) d[pyb::str(s.name)] = Eigen::Matrix4d(s.pose.matrix());
            return d;
          },
          "Named start poses {name: (4, 4)}.")
      .def_property_readonly(
          "targets",
          [](const environments::Environment& e) {
            pyb::dict d;
            for (const auto& t : e.targets()) d[pyb::str(t.name)] = array3(t.position);
            return d;
          },
          "Named targets {name: (3,)} (world, m).")
      .def_property_readonly("sources", &environments::Environment::sources)
      .def_property_readonly("build_seconds", &environments::Environment::buildSeconds)
      .def(
          "with_start",
          [](const environments::Environment& e, const std::string& name) {
            auto copy = std::make_shared<environments::Environment>(e);
            copy->useStart(name);
            return copy;
          },
          arg("name"), "A copy whose base pose is the named start pose (the CLI's --start).")
      .def(
          "occupancy",
          [](const environments::Environment& e, const pyb::object& p) {
            const Eigen::VectorXd v = toVector(p, "point");
            if (v.size() != 3) throw pyb::value_error("point: expected 3 coordinates");
            return std::string(environments::toString(e.occupancy(v)));
          },
          arg("point"), "'free', 'occupied' or 'unknown' at a world point (m).")
      .def(
          "is_obstacle",
          [](const environments::Environment& e, const pyb::object& points, const std::string& unknown) {
            const Eigen::MatrixXd P = toMatrix(points, "points", 3);
            const environments::UnknownSpace u = environments::parseUnknownSpace(unknown);
            pyb::array_t<bool> out(P.rows());
            for (Eigen::Index k = 0; k < P.rows(); ++k) out.mutable_at(k) = e.isObstacle(P.row(k).transpose(), u);
            return out;
          },
          arg("points"), arg("unknown") = "free", "Whether each world point (K, 3) is an obstacle.")
      .def(
          "occupied_voxels",
          [](const environments::Environment& e, const pyb::object& lo, const pyb::object& hi) {
            environments::Aabb box(Eigen::Vector3d::Constant(-1e300), Eigen::Vector3d::Constant(1e300));
            if (!lo.is_none()) box.min = toVector(lo, "lo");
            if (!hi.is_none()) box.max = toVector(hi, "hi");
            std::vector<double> centres, sizes;
            {
              pyb::gil_scoped_release release;
              const octomap::OcTree& tree = e.tree();
              for (auto it = tree.begin_leafs(), end = tree.end_leafs(); it != end; ++it) {
                if (!tree.isNodeOccupied(*it)) continue;
                const Eigen::Vector3d c(it.getX(), it.getY(), it.getZ());
                if (!box.contains(c)) continue;
                centres.insert(centres.end(), {c.x(), c.y(), c.z()});
                sizes.push_back(it.getSize());
              }
            }
            const auto N = static_cast<pyb::ssize_t>(sizes.size());
            pyb::array_t<double> C({N, pyb::ssize_t(3)});
            std::copy(centres.begin(), centres.end(), C.mutable_data());
            return pyb::make_tuple(C, pyb::array_t<double>(N, sizes.data()));
          },
          arg("lo") = pyb::none(), arg("hi") = pyb::none(),
          "(centres (N, 3), edge lengths (N,)) of the occupied octree leaves inside the box [lo, hi] (world, m).")
      .def("stats",
           [](const environments::Environment& e) {
             const environments::OccupancyStats st = e.stats();
             pyb::dict d;
             d["nodes"] = st.nodes;
             d["occupied_leaves"] = st.occupied_leaves;
             d["free_leaves"] = st.free_leaves;
             d["occupied_volume"] = st.occupied_volume;
             d["free_volume"] = st.free_volume;
             d["memory_bytes"] = st.memory_bytes;
             return d;
           })
      .def("info", &infoDict, "The `ctr env info --json` object.")
      .def(
          "write",
          [](const environments::Environment& e, const std::filesystem::path& path) { e.write(path.string()); },
          arg("path"), "Writes the octree (.bt or .ot) atomically.")
      .def("__repr__", [](const environments::Environment& e) {
        return "<ctr.Environment '" + e.name() + "', resolution " +
               pyb::repr(pyb::float_(e.resolution())).cast<std::string>() + " m>";
      });

  m.def(
      "load_environment",
      [](const std::filesystem::path& path, std::optional<double> resolution, const std::optional<std::string>& start,
         bool verbose) {
        environments::BuildOptions bo;
        if (resolution) {
          if (!(*resolution > 0.0)) throw pyb::value_error("resolution: must be > 0");
          bo.resolution = *resolution;
        }
        if (verbose) bo.log = [](const std::string& msg) { std::cerr << "  " << msg << "\n"; };
        pyb::gil_scoped_release release;
        auto e = std::make_shared<environments::Environment>(environments::loadEnvironment(path.string(), bo));
        if (start) e->useStart(*start);
        return e;
      },
      arg("path"), arg("resolution") = pyb::none(), arg("start") = pyb::none(), arg("verbose") = false,
      "Loads an environment description (YAML) and builds its map (the CLI's `ctr env` ENV [--resolution] "
      "[--start]). Raises ctr.InputError naming the file, line and key. Runs without the GIL.");

  pyb::class_<Checker>(m, "CollisionChecker",
                       "Collision and clearance of one robot in one environment (FCL + distance field). Build once, "
                       "then check many solved shapes.")
      .def(pyb::init(&makeChecker), arg("environment"), arg("robot"), arg("margin") = pyb::none(),
           arg("unknown") = pyb::none(), arg("max_distance") = 0.005,
           "margin: safety margin added to every tube radius (m; default the environment's); unknown: 'free' or "
           "'occupied'; max_distance: clearance saturates there (m). Builds without the GIL.")
      .def_property_readonly("reach", [](const Checker& c) { return c.checker->reach(); })
      .def_property_readonly("build_seconds", [](const Checker& c) { return c.build_seconds; })
      .def(
          "check",
          [](const Checker& c, const Solution& sol) {
            requireShape(sol);
            environments::CollisionResult col;
            {
              pyb::gil_scoped_release release;
              auto q = c.checker->query();
              col = c.checker->check(sol, q);
            }
            return collisionDict(col, c.checker->robot());
          },
          arg("solution"), "Collision of a solved shape: dict collision, first_colliding_section, capsules, ...")
      .def(
          "clearance",
          [](const Checker& c, const Solution& sol) {
            requireShape(sol);
            environments::ClearanceResult cl;
            {
              pyb::gil_scoped_release release;
              auto q = c.checker->query();
              cl = c.checker->clearance(sol, q);
            }
            return clearanceDict(cl);
          },
          arg("solution"), "Clearance of a solved shape (m; <= 0 in contact): dict clearance, closest, ...");

  m.def(
      "check_shape",
      [](const EnvPtr& e, const Robot& robot, const pyb::object& alpha, const pyb::object& beta,
         std::optional<double> margin, const std::optional<std::string>& unknown, double max_distance) {
        const Configuration q = toConfiguration(robot, alpha, beta);
        Solution sol;
        {
          pyb::gil_scoped_release release;
          KinematicsOptions ko;
          ko.record_backbone = true;
          sol = solve(robot, q, workspace(), ko);
        }
        if (!sol.converged()) throw std::runtime_error("the model did not converge: " + sol.summary.message);
        const Checker c = makeChecker(e, robot, margin, unknown, max_distance);
        environments::CollisionResult col;
        environments::ClearanceResult cl;
        double us_col = 0.0, us_cl = 0.0;
        {
          pyb::gil_scoped_release release;
          auto query = c.checker->query();
          const auto t1 = std::chrono::steady_clock::now();
          col = c.checker->check(sol, query);
          const auto t2 = std::chrono::steady_clock::now();
          cl = c.checker->clearance(sol, query);
          const auto t3 = std::chrono::steady_clock::now();
          us_col = std::chrono::duration<double, std::micro>(t2 - t1).count();
          us_cl = std::chrono::duration<double, std::micro>(t3 - t2).count();
        }
        const Eigen::Vector3d tip = e->basePose() * sol.tip_position;
        pyb::dict j;
        j["environment"] = e->name();
        j["robot"] = robot.name();
        pyb::dict cd = collisionDict(col, robot);
        for (const auto& item : cd) j[item.first] = item.second;
        pyb::dict cld = clearanceDict(cl);
        for (const auto& item : cld) j[item.first] = item.second;
        j["tip_position"] = vec(tip);
        pyb::dict tg;
        for (const auto& t : e->targets()) tg[pyb::str(t.name)] = (t.position - tip).norm();
        j["tip_to_targets"] = tg;
        pyb::dict timing;
        timing["collision"] = us_col;
        timing["clearance"] = us_cl;
        timing["checker_build"] = c.build_seconds * 1e6;
        j["timing_us"] = timing;
        return j;
      },
      arg("environment"), arg("robot"), arg("alpha") = pyb::none(), arg("beta") = pyb::none(),
      arg("margin") = pyb::none(), arg("unknown") = pyb::none(), arg("max_distance") = 0.005,
      "`ctr env check --json`: solves the shape at (alpha, beta) and returns its collision and clearance in the "
      "environment as the CLI's dict (tip_position in the world frame).");
}

}  // namespace ctr::py
