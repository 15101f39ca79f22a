// Bindings of ctr::model and the robot YAML of ctr::io: Robot, KinematicsOptions, Solution, solve and sweeps.
#include <random>

#include "common.hpp"
#include "ctr/io/solution_json.hpp"
#include "ctr/io/robot_yaml.hpp"
#include "ctr/model/backbone.hpp"
#include "ctr/model/jacobian.hpp"
#include "ctr/model/kinematics.hpp"
#include "ctr/model/sampling.hpp"

namespace ctr::py {

namespace {

using pyb::arg;

/// A tube as a dict with the keys of the robot YAML (the rule of robotToYaml for poisson_ratio vs
/// torsional_stiffness, so that the dict round-trips through Robot(dict)).
pyb::dict tubeDict(const Tube& t) {
  pyb::dict d;
  d["name"] = t.name;
  d["straight_length"] = t.straight_length;
  d["curved_length"] = t.curved_length;
  d["curvature"] = t.curvature;
  d["bending_stiffness"] = t.bending_stiffness;
  if (t.poisson_ratio) d["poisson_ratio"] = *t.poisson_ratio;
  if (!t.poisson_ratio || t.bending_stiffness / (1.0 + *t.poisson_ratio) != t.torsional_stiffness)
    d["torsional_stiffness"] = t.torsional_stiffness;
  if (t.outer_diameter > 0.0) d["outer_diameter"] = t.outer_diameter;
  if (t.inner_diameter > 0.0) d["inner_diameter"] = t.inner_diameter;
  if (t.rotation_limits) d["rotation_limits"] = pyb::make_tuple((*t.rotation_limits)[0], (*t.rotation_limits)[1]);
  if (t.translation_limits)
    d["translation_limits"] = pyb::make_tuple((*t.translation_limits)[0], (*t.translation_limits)[1]);
  if (t.linear_density > 0.0) d["linear_density"] = t.linear_density;
  // The drives, with the keys of the robot YAML's actuation block (the ones that are not zero / default).
  pyb::dict actuation;
  for (const bool rotation : {true, false}) {
    const Drive& v = rotation ? t.rotation_drive : t.translation_drive;
    if (v.ideal()) continue;
    pyb::dict a;
    if (v.offset != 0.0) a["offset"] = v.offset;
    if (v.play != 0.0) a["play"] = v.play;
    if (v.ratio_error != 0.0) {
      a["ratio_error"] = v.ratio_error;
      a["ratio_reference"] = v.ratio_reference;
    }
    if (v.periodic != std::array<double, 4>{}) a["periodic"] = pyb::cast(v.periodic);
    if (v.stage != std::array<double, 3>{}) {
      a["stage_error"] = pyb::cast(v.stage);
      a["stage_reference"] = v.stage_reference;
      a["stage_scale"] = v.stage_scale;
    }
    actuation[rotation ? "rotation" : "translation"] = a;
  }
  if (pyb::len(actuation) > 0) d["actuation"] = actuation;
  return d;
}

pyb::list list3(const Eigen::Vector3d& v) {
  pyb::list l;
  for (int k = 0; k < 3; ++k) l.append(v[k]);
  return l;
}

pyb::dict loadsDict(const Loads& l) {
  pyb::dict d;
  d["gravity"] = list3(l.gravity);
  d["tip_force"] = list3(l.tip_force);
  d["tip_moment"] = list3(l.tip_moment);
  return d;
}

pyb::dict frictionDict(const FrictionCoefficients& f) {
  pyb::dict d;
  d["boundary"] = f.boundary;
  d["distributed"] = f.distributed;
  return d;
}

pyb::dict robotDict(const Robot& r) {
  pyb::dict d;
  d["name"] = r.name();
  pyb::list tubes;
  for (const Tube& t : r.tubes()) tubes.append(tubeDict(t));
  d["tubes"] = tubes;
  d["friction"] = frictionDict(r.friction());
  if (!r.loads().empty()) d["loads"] = loadsDict(r.loads());
  return d;
}

/// Robot from a dict with the keys of the robot YAML: the dict is written as JSON (a subset of YAML) and parsed by
/// the library's robot parser, so validation and messages are the YAML file's; errors name "<robot dict>" and the key.
Robot robotFromDict(const pyb::dict& d) {
  const pyb::object json = pyb::module_::import("json");
  const pyb::cpp_function plain([](const pyb::object& o) -> pyb::object {
    if (pyb::hasattr(o, "tolist")) return o.attr("tolist")();  // numpy arrays and scalars
    throw pyb::type_error("robot dict: value " + pyb::repr(o).cast<std::string>() + " is not a number, string or list");
  });
  const std::string text =
      json.attr("dumps")(d, pyb::arg("indent") = 2, pyb::arg("default") = plain).cast<std::string>();
  try {
    return io::parseRobot(text, "<robot dict>");
  } catch (const io::InputError& e) {
    throw io::InputError("<robot dict>", 0, e.key(), e.message());  // lines of the generated text mean nothing
  }
}

pyb::dict backboneDict(const std::vector<BackbonePoint>& pts, int n) {
  const auto N = static_cast<pyb::ssize_t>(pts.size());
  const bool states = !pts.empty() && pts.front().theta.size() == n;
  pyb::array_t<double> s(N), pos({N, pyb::ssize_t(3)}), frame({N, pyb::ssize_t(3), pyb::ssize_t(3)}),
      u0({N, pyb::ssize_t(2)}), force({N, pyb::ssize_t(3)}), moment({N, pyb::ssize_t(3)}),
      theta({states ? N : 0, pyb::ssize_t(n)}), uz({states ? N : 0, pyb::ssize_t(n)});
  pyb::array_t<int> outermost(N);
  pyb::array_t<bool> segment_start(N);
  auto sv = s.mutable_unchecked<1>();
  auto pv = pos.mutable_unchecked<2>();
  auto fv = frame.mutable_unchecked<3>();
  auto uv = u0.mutable_unchecked<2>();
  auto nv = force.mutable_unchecked<2>();
  auto mv = moment.mutable_unchecked<2>();
  auto tv = theta.mutable_unchecked<2>();
  auto zv = uz.mutable_unchecked<2>();
  auto ov = outermost.mutable_unchecked<1>();
  auto gv = segment_start.mutable_unchecked<1>();
  for (pyb::ssize_t k = 0; k < N; ++k) {
    const BackbonePoint& p = pts[static_cast<std::size_t>(k)];
    sv(k) = p.s;
    for (int d = 0; d < 3; ++d) {
      pv(k, d) = p.position[d];
      for (int c = 0; c < 3; ++c) fv(k, d, c) = p.frame(d, c);
      nv(k, d) = p.force[d];
      mv(k, d) = p.moment[d];
    }
    uv(k, 0) = p.u0.x();
    uv(k, 1) = p.u0.y();
    if (states)
      for (int i = 0; i < n; ++i) {
        tv(k, i) = i < p.theta.size() ? p.theta[i] : NAN;
        zv(k, i) = i < p.uz.size() ? p.uz[i] : NAN;
      }
    ov(k) = p.outermost + 1;
    gv(k) = p.segment_start;
  }
  pyb::dict d;
  d["s"] = s;
  d["position"] = pos;
  d["frame"] = frame;
  d["u0"] = u0;
  d["force"] = force;
  d["moment"] = moment;
  d["theta"] = theta;
  d["uz"] = uz;
  d["outermost"] = outermost;
  d["segment_start"] = segment_start;
  return d;
}

pyb::list momentsList(const Solution& sol) {
  pyb::list out;
  for (const auto& m : sol.moments) {
    pyb::dict d;
    d["kind"] = toString(m.kind);
    d["tube"] = m.tube + 1;
    d["s"] = m.s;
    d["magnitude"] = m.magnitude;
    out.append(d);
  }
  return out;
}

/// The `ctr fk --json` object of a solution (io::solutionJson, as the CLI writes it): same keys and values.
pyb::object solutionDict(const Solution& sol) {
  return pyb::module_::import("json").attr("loads")(io::solutionJson(sol));
}

/// Rows of a configuration sweep: (K, n) arrays, a 1-D input (or a single row) is repeated over the other's rows.
std::vector<Configuration> configurationRows(const Robot& robot, const pyb::handle& alpha, const pyb::handle& beta) {
  const int n = robot.size();
  const Configuration def = defaultConfiguration(robot);
  Eigen::MatrixXd A = alpha.is_none() ? Eigen::MatrixXd(def.alpha.transpose()) : toMatrix(alpha, "alpha", n);
  Eigen::MatrixXd B = beta.is_none() ? Eigen::MatrixXd(def.beta.transpose()) : toMatrix(beta, "beta", n);
  const Eigen::Index rows = std::max(A.rows(), B.rows());
  if ((A.rows() != rows && A.rows() != 1) || (B.rows() != rows && B.rows() != 1))
    throw pyb::value_error("alpha has " + std::to_string(A.rows()) + " rows, beta " + std::to_string(B.rows()) +
                           " (give equal counts, or one row for either)");
  std::vector<Configuration> qs;
  qs.reserve(static_cast<std::size_t>(rows));
  for (Eigen::Index r = 0; r < rows; ++r) {
    Configuration q(A.row(A.rows() == 1 ? 0 : r).transpose(), B.row(B.rows() == 1 ? 0 : r).transpose());
    projectAdmissible(robot, q);  // within the tolerance; a larger violation is reported by the solve per row
    qs.push_back(std::move(q));
  }
  return qs;
}

}  // namespace

pyb::dict solutionRows(const std::vector<const Solution*>& sols, int n) {
  const auto K = static_cast<pyb::ssize_t>(sols.size());
  pyb::array_t<double> twist({K, pyb::ssize_t(std::max(n - 1, 0))}), tip({K, pyb::ssize_t(3)}),
      tangent({K, pyb::ssize_t(3)}), stability(K);
  pyb::array_t<bool> converged(K), stable(K);
  pyb::list status;
  auto wv = twist.mutable_unchecked<2>();
  auto pv = tip.mutable_unchecked<2>();
  auto tv = tangent.mutable_unchecked<2>();
  auto sv = stability.mutable_unchecked<1>();
  auto cv = converged.mutable_unchecked<1>();
  auto bv = stable.mutable_unchecked<1>();
  for (pyb::ssize_t k = 0; k < K; ++k) {
    const Solution& s = *sols[static_cast<std::size_t>(k)];
    const bool ok = s.converged();
    for (int i = 0; i + 1 < n; ++i) wv(k, i) = ok && i < s.twist.size() ? s.twist[i] : NAN;
    const Eigen::Vector3d t = s.tipTangent();
    for (int d = 0; d < 3; ++d) {
      pv(k, d) = ok ? s.tip_position[d] : NAN;
      tv(k, d) = ok ? t[d] : NAN;
    }
    sv(k) = s.summary.stability;
    cv(k) = ok;
    bv(k) = s.summary.stable;
    status.append(toString(s.summary.status));
  }
  pyb::dict d;
  d["twist"] = twist;
  d["tip_position"] = tip;
  d["tip_tangent"] = tangent;
  d["stability"] = stability;
  d["converged"] = converged;
  d["stable"] = stable;
  d["status"] = status;
  return d;
}

pyb::dict siteDict(const ContactSite& c) {
  pyb::dict d;
  d["kind"] = toString(c.kind);
  d["tube"] = c.tube + 1;
  d["outer"] = c.outer + 1;
  d["inner"] = c.inner + 1;
  d["s"] = c.s;
  return d;
}

pyb::list siteList(const std::vector<ContactSite>& sites) {
  pyb::list out;
  for (const auto& c : sites) out.append(siteDict(c));
  return out;
}

void registerModel(pyb::module_& m) {
  // ---- Robot ----
  pyb::class_<Robot>(m, "Robot",
                     "An immutable, validated robot description (tubes numbered from the outermost; SI units). "
                     "Robot(dict) takes the keys of the robot YAML (docs/formats.md); load_robot(path) reads a file.")
      .def(pyb::init(&robotFromDict), arg("description"))
      .def_property_readonly("name", &Robot::name)
      .def_property_readonly("size", &Robot::size, "Number of tubes n.")
      .def("__len__", &Robot::size)
      .def_property_readonly(
          "tubes",
          [](const Robot& r) {
            pyb::list l;
            for (const Tube& t : r.tubes()) l.append(tubeDict(t));
            return l;
          },
          "The tubes as dicts (YAML keys), outermost first.")
      .def_property_readonly(
          "torsional_stiffness",
          [](const Robot& r) {
            Eigen::VectorXd v(r.size());
            for (int i = 0; i < r.size(); ++i) v[i] = r.tube(i).torsional_stiffness;
            return v;
          },
          "G*J of each tube (N m^2).")
      .def_property_readonly(
          "lengths",
          [](const Robot& r) {
            Eigen::VectorXd v(r.size());
            for (int i = 0; i < r.size(); ++i) v[i] = r.tube(i).length();
            return v;
          },
          "Total length of each tube (m).")
      .def_property_readonly(
          "friction", [](const Robot& r) { return frictionDict(r.friction()); },
          "Friction coefficients {'boundary': mu', 'distributed': mu}.")
      .def_property_readonly(
          "loads", [](const Robot& r) { return loadsDict(r.loads()); },
          "External loads in the base frame {'gravity' (m/s^2), 'tip_force' (N), 'tip_moment' "
          "(N m)} as lists; all zero: the load-free model.")
      .def(
          "with_loads",
          [](const Robot& r, const pyb::object& gravity, const pyb::object& tip_force, const pyb::object& tip_moment) {
            Loads l = r.loads();
            auto take = [](const pyb::object& o, const char* name, Eigen::Vector3d& dst) {
              if (o.is_none()) return;
              const Eigen::VectorXd v = toVector(o, name);
              if (v.size() != 3) throw pyb::value_error(std::string(name) + ": expected 3 values (base frame)");
              dst = v;
            };
            take(gravity, "gravity", l.gravity);
            take(tip_force, "tip_force", l.tip_force);
            take(tip_moment, "tip_moment", l.tip_moment);
            return r.withLoads(l);
          },
          arg("gravity") = pyb::none(), arg("tip_force") = pyb::none(), arg("tip_moment") = pyb::none(),
          "A copy with other external loads (base frame; None keeps the robot's).")
      .def("to_dict", &robotDict, "The description as a dict; Robot(robot.to_dict()) is the same robot.")
      .def("to_yaml", &io::robotToYaml, "The robot YAML text.")
      .def(
          "save", [](const Robot& r, const std::filesystem::path& path) { io::saveRobot(r, path.string()); },
          arg("path"), "Writes the robot YAML atomically.")
      .def(
          "with_friction",
          [](const Robot& r, std::optional<double> boundary, std::optional<double> distributed) {
            FrictionCoefficients f = r.friction();
            if (boundary) f.boundary = *boundary;
            if (distributed) f.distributed = *distributed;
            return r.withFriction(f);
          },
          arg("boundary") = pyb::none(), arg("distributed") = pyb::none(),
          "A copy with other friction coefficients (None keeps the robot's).")
      .def(pyb::pickle([](const Robot& r) { return io::robotToYaml(r); },
                       [](const std::string& yaml) { return io::parseRobot(yaml, "<pickled robot>"); }))
      .def("__copy__", [](const Robot& r) { return Robot(r); })
      .def("__deepcopy__", [](const Robot& r, const pyb::dict&) { return Robot(r); })
      .def("__repr__", [](const Robot& r) {
        return "<ctr.Robot '" + r.name() + "', " + std::to_string(r.size()) +
               " tubes, mu' = " + pyb::repr(pyb::float_(r.friction().boundary)).cast<std::string>() + ">";
      });

  m.def(
      "load_robot", [](const std::filesystem::path& path) { return io::loadRobot(path.string()); }, arg("path"),
      "Loads and validates a robot YAML file. Raises ctr.InputError naming the file, line, tube and key.");
  m.def("parse_robot", &io::parseRobot, arg("text"), arg("source") = "<string>",
        "Parses robot YAML text; `source` names it in error messages.");
  m.def("robot_from_dict", &robotFromDict, arg("description"), "Same as ctr.Robot(description).");

  // ---- Configurations ----
  m.def(
      "default_configuration", [](const Robot& r) { return configurationTuple(defaultConfiguration(r)); }, arg("robot"),
      "(alpha, beta) used when a call is given none (as the CLI): rotations zero, straight parts retracted.");
  m.def(
      "check_admissible",
      [](const Robot& r, const pyb::object& alpha, const pyb::object& beta) {
        Configuration q(toVector(alpha, "alpha"), toVector(beta, "beta"));
        const Admissibility a = checkAdmissible(r, q);
        return pyb::make_tuple(a.ok, a.message);
      },
      arg("robot"), arg("alpha"), arg("beta"), "(ok, message): nesting, ordering and limits of a configuration.");
  m.def(
      "contact_sites",
      [](const Robot& r, const pyb::object& alpha, const pyb::object& beta) {
        return siteList(contactSites(r, toConfiguration(r, alpha, beta)));
      },
      arg("robot"), arg("alpha") = pyb::none(), arg("beta") = pyb::none(),
      "Places of concentrated bending moments between neighbouring tubes (where lumped friction acts).");
  m.def(
      "sample_configurations",
      [](const Robot& r, int count, std::uint64_t seed, double min_protrusion) {
        if (count < 0) throw pyb::value_error("count: must not be negative");
        std::vector<Configuration> qs;
        {
          pyb::gil_scoped_release release;
          const TranslationSampler sampler(r, min_protrusion);
          if (!sampler.feasible()) throw std::invalid_argument("no admissible translations for this robot");
          std::mt19937_64 rng(seed);
          for (int k = 0; k < count; ++k) qs.push_back(sampleConfiguration(r, sampler, rng));
        }
        return configurationArrays(qs, r.size());
      },
      arg("robot"), arg("count"), arg("seed") = 1, arg("min_protrusion") = 1e-3,
      "(alpha (count, n), beta (count, n)): uniform admissible configurations (ctr::sampleConfiguration).");

  // ---- FollowOptions ----
  pyb::class_<FollowOptions> flo(m, "FollowOptions",
                                 "How an equilibrium is followed along a move (ctr::FollowOptions): sub-step sizes "
                                 "and the snap rule; the `follow` of KinematicsOptions and FrictionOptions.");
  flo.def_readwrite("max_rotation_step", &FollowOptions::max_rotation_step)
      .def_readwrite("max_translation_step", &FollowOptions::max_translation_step)
      .def_readwrite("snap_threshold", &FollowOptions::snap_threshold)
      .def_readwrite("judge_stability", &FollowOptions::judge_stability);
  addOptionsProtocol<FollowOptions>(flo,
                                    {"max_rotation_step", "max_translation_step", "snap_threshold", "judge_stability"});

  // ---- KinematicsOptions ----
  pyb::class_<KinematicsOptions> ko(m, "KinematicsOptions",
                                    "Options of the kinematics solver (ctr::KinematicsOptions).");
  ko.def_readwrite("max_step", &KinematicsOptions::max_step)
      .def_readwrite("max_bending_per_step", &KinematicsOptions::max_bending_per_step)
      .def_readwrite("bending_limit_per_segment", &KinematicsOptions::bending_limit_per_segment)
      .def_readwrite("max_iterations", &KinematicsOptions::max_iterations)
      .def_readwrite("line_search_steps", &KinematicsOptions::line_search_steps)
      .def_readwrite("tolerance", &KinematicsOptions::tolerance)
      .def_readwrite("record_backbone", &KinematicsOptions::record_backbone)
      .def_readwrite("record_tube_states", &KinematicsOptions::record_tube_states)
      .def_readwrite("homotopy", &KinematicsOptions::homotopy)
      .def_readwrite("homotopy_steps", &KinematicsOptions::homotopy_steps)
      .def_readwrite("follow", &KinematicsOptions::follow)
      .def_readwrite("refine_below_stability", &KinematicsOptions::refine_below_stability)
      .def_readwrite("loaded_model", &KinematicsOptions::loaded_model)
      .def_readwrite("extrapolate_warm_start", &KinematicsOptions::extrapolate_warm_start);
  addOptionsProtocol<KinematicsOptions>(
      ko, {"max_step", "max_bending_per_step", "bending_limit_per_segment", "max_iterations", "line_search_steps",
           "tolerance", "record_backbone", "record_tube_states", "homotopy", "homotopy_steps", "follow",
           "refine_below_stability", "loaded_model", "extrapolate_warm_start"});

  // ---- Solution ----
  pyb::class_<Solution>(m, "Solution",
                        "A solved (or failed) equilibrium: tip pose, twist, backbone (numpy arrays, base frame, SI).")
      .def_property_readonly("converged", &Solution::converged)
      .def_property_readonly("stable", [](const Solution& s) { return s.summary.stable; })
      .def_property_readonly(
          "status", [](const Solution& s) { return std::string(toString(s.summary.status)); },
          "'converged', 'not_converged' or 'inadmissible'.")
      .def_property_readonly("stability", [](const Solution& s) { return s.summary.stability; })
      .def_property_readonly("iterations", [](const Solution& s) { return s.summary.iterations; })
      .def_property_readonly("residual_norm", [](const Solution& s) { return s.summary.residual_norm; })
      .def_property_readonly("snapped", [](const Solution& s) { return s.summary.snapped; })
      .def_property_readonly("continuation_steps", [](const Solution& s) { return s.summary.continuation_steps; })
      .def_property_readonly("message", [](const Solution& s) { return s.summary.message; })
      .def_property_readonly("alpha", [](const Solution& s) { return s.q.alpha; })
      .def_property_readonly("beta", [](const Solution& s) { return s.q.beta; })
      .def_property_readonly(
          "tip_position", [](const Solution& s) { return array3(s.tip_position); },
          "Tip position (3,), base frame (m).")
      .def_property_readonly("tip_tangent", [](const Solution& s) { return array3(s.tipTangent()); })
      .def_property_readonly(
          "tip_frame", [](const Solution& s) { return Eigen::Matrix3d(s.tip_frame); },
          "Tip frame (3, 3); column 2 is the tangent.")
      .def_property_readonly(
          "tip_pose",
          [](const Solution& s) {
            Eigen::Matrix4d T = Eigen::Matrix4d::Identity();
            T.topLeftCorner<3, 3>() = s.tip_frame;
            T.topRightCorner<3, 1>() = s.tip_position;
            return T;
          },
          "Homogeneous tip pose (4, 4) in the base frame.")
      .def_property_readonly(
          "twist", [](const Solution& s) { return s.twist; },
          "twist_k = theta_k - theta_1 at the distal end of tube 1, k = 2..n (rad).")
      .def_property_readonly("base_twist_rate", [](const Solution& s) { return s.base_twist_rate; })
      .def_property_readonly("theta0", [](const Solution& s) { return s.theta0; })
      .def_property_readonly("tip_arc_length", &Solution::tipArcLength)
      .def_property_readonly(
          "loaded", [](const Solution& s) { return s.loaded; },
          "Solved by the loaded (Cosserat-rod) solver (external loads, or loaded_model).")
      .def_property_readonly(
          "base_force", [](const Solution& s) { return array3(s.base_force); },
          "Internal force at s = 0 (base frame, N); zero without loads.")
      .def_property_readonly(
          "base_moment", [](const Solution& s) { return array3(s.base_moment); },
          "Internal moment at s = 0 (base frame, N m); zero without loads.")
      .def_property_readonly(
          "backbone", [](const Solution& s) { return backboneDict(s.backbone, s.q.size()); },
          "Integration nodes as arrays: s (N,), position (N, 3), frame (N, 3, 3), u0 (N, 2), theta and uz (N, n; "
          "empty without tube states), force and moment (N, 3: internal force and moment of the cross-section, "
          "base frame; zero without loads), outermost (1-based), segment_start. Empty when solved without "
          "record_backbone.")
      .def(
          "resample",
          [](const Solution& s, double ds) {
            if (!(ds > 0)) throw pyb::value_error("ds: must be > 0");
            if (s.backbone.empty()) throw pyb::value_error("the solution has no backbone (record_backbone was off)");
            return backboneDict(resampleBackbone(s, ds), s.q.size());
          },
          arg("ds") = 1e-3, "The backbone every ds metres from s = 0 to the tip (same arrays as `backbone`).")
      .def_property_readonly("moments", &momentsList, "Concentrated moments (dicts: kind, tube, s, magnitude).")
      .def_property_readonly(
          "contacts",
          [](const Solution& s) {
            pyb::list out;
            for (const auto& c : s.contacts) {
              pyb::dict d = siteDict(c.site);
              d["law"] = toString(c.condition.law);
              d["value"] = c.condition.value;
              d["relative_twist"] = c.relative_twist;
              d["torque"] = c.torque;
              d["moment"] = c.moment;
              out.append(d);
            }
            return out;
          },
          "Contact sites with friction unknowns (dicts).")
      .def("to_dict", &solutionDict, "The `ctr fk --json` object of this solution.")
      .def("__copy__", [](const Solution& s) { return Solution(s); })
      .def("__deepcopy__", [](const Solution& s, const pyb::dict&) { return Solution(s); })
      .def("__repr__", [](const Solution& s) {
        std::string out = "<ctr.Solution " + std::string(toString(s.summary.status));
        if (s.converged())
          out +=
              ", tip " + pyb::repr(array3(s.tip_position)).cast<std::string>() + (s.summary.stable ? "" : ", unstable");
        return out + ">";
      });

  m.def(
      "solve",
      [](const Robot& r, const pyb::object& alpha, const pyb::object& beta, std::optional<KinematicsOptions> options,
         const Solution* warm) {
        const Configuration q = toConfiguration(r, alpha, beta);
        pyb::gil_scoped_release release;
        return solve(r, q, workspace(), options.value_or(KinematicsOptions{}), warm);
      },
      arg("robot"), arg("alpha") = pyb::none(), arg("beta") = pyb::none(), arg("options") = pyb::none(),
      arg("warm") = pyb::none(),
      "Frictionless equilibrium at (alpha, beta) (None: the CLI's default). `warm`: a nearby Solution to start "
      "Newton from. Raises ValueError for an inadmissible configuration; a non-converged solve is returned with "
      "converged False and the reason in .message.");
  m.def(
      "continue_to",
      [](const Robot& r, const Solution& from, const pyb::object& alpha, const pyb::object& beta,
         std::optional<KinematicsOptions> options) {
        const Configuration q = toConfiguration(r, alpha, beta);
        pyb::gil_scoped_release release;
        return continueTo(r, from, q, workspace(), options.value_or(KinematicsOptions{}));
      },
      arg("robot"), arg("from_solution"), arg("alpha") = pyb::none(), arg("beta") = pyb::none(),
      arg("options") = pyb::none(),
      "Frictionless quasi-static continuation from a solution to (alpha, beta) following the branch (.snapped).");
  m.def(
      "solve_sweep",
      [](const Robot& r, const pyb::object& alpha, const pyb::object& beta, std::optional<KinematicsOptions> options,
         bool warm_start, bool keep_solutions) {
        const std::vector<Configuration> qs = configurationRows(r, alpha, beta);
        KinematicsOptions ko = options.value_or(KinematicsOptions{});
        if (!options && !keep_solutions) ko.record_backbone = false;
        std::vector<Solution> sols(qs.size());
        {
          pyb::gil_scoped_release release;
          for (std::size_t k = 0; k < qs.size(); ++k) {
            const Solution* warm = warm_start && k > 0 && sols[k - 1].converged() ? &sols[k - 1] : nullptr;
            sols[k] = solve(r, qs[k], workspace(), ko, warm);
          }
        }
        std::vector<const Solution*> ptrs;
        for (const auto& s : sols) ptrs.push_back(&s);
        pyb::dict d = solutionRows(ptrs, r.size());
        const pyb::tuple ab = configurationArrays(qs, r.size());
        d["alpha"] = ab[0];
        d["beta"] = ab[1];
        if (keep_solutions) d["solutions"] = pyb::cast(std::move(sols));
        return d;
      },
      arg("robot"), arg("alpha") = pyb::none(), arg("beta") = pyb::none(), arg("options") = pyb::none(),
      arg("warm_start") = true, arg("keep_solutions") = false,
      "Frictionless solves of K configurations (alpha, beta: (K, n) arrays, or one row repeated), each warm-started "
      "from the previous one. Returns a dict of arrays: alpha, beta, twist (K, n-1), tip_position, tip_tangent "
      "(K, 3; NaN where not converged), stability, converged, stable, status (+ solutions with keep_solutions). "
      "Runs without the GIL.");

  // ---- Tip Jacobian and compliance ----
  pyb::class_<TipJacobian>(m, "TipJacobian",
                           "Derivatives of the tip pose at an equilibrium; rows (p_x, p_y, p_z, w_x, w_y, w_z): tip "
                           "position and a small rotation as a spatial angle in the base frame (ctr::TipJacobian).")
      .def_readonly("actuation", &TipJacobian::actuation,
                    "(6, 2n): columns alpha_1..alpha_n (per rad), then beta_1..beta_n (per m); material frame of the "
                    "innermost tube at the tip.")
      .def_readonly("compliance", &TipJacobian::compliance,
                    "(6, 6): columns tip force (per N) then tip moment (per N m), dead loads in the base frame.")
      .def_readonly("bishop_actuation", &TipJacobian::bishop_actuation, "As actuation, for Solution.tip_frame.")
      .def_readonly("bishop_compliance", &TipJacobian::bishop_compliance)
      .def_readonly("residual_norm", &TipJacobian::residual_norm)
      .def_readonly("message", &TipJacobian::message)
      .def_readonly("ok", &TipJacobian::ok)
      .def("__repr__", [](const TipJacobian& j) {
        return std::string("<ctr.TipJacobian ") + (j.ok ? "ok" : "failed: " + j.message) + ">";
      });
  m.def(
      "tip_jacobian",
      [](const Robot& r, const Solution& sol, std::optional<KinematicsOptions> options) {
        pyb::gil_scoped_release release;
        return tipJacobian(r, sol, workspace(), options.value_or(KinematicsOptions{}));
      },
      arg("robot"), arg("solution"), arg("options") = pyb::none(),
      "Exact tip Jacobian (actuators) and compliance (tip wrench) at a converged solution of `robot` (with or "
      "without loads; contact laws held). `options`: the KinematicsOptions the solution was solved with. Raises "
      "ValueError for a solution that did not converge or does not match the robot.");
}

}  // namespace ctr::py
