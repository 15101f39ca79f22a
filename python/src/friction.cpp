// Bindings of the friction layer of ctr::model: options, the hysteresis state as a Python object, initial_state /
// step, the friction band, simulate (replay of a command sequence) and the CLI's one-tube sweep.
#include <cmath>

#include "common.hpp"
#include "ctr/model/friction.hpp"
#include "ctr/model/replay.hpp"
#include "ctr/model/uniqueness.hpp"

namespace ctr::py {

namespace {

using pyb::arg;

ContactMode parseContactMode(const std::string& s) {
  for (ContactMode m : {ContactMode::Stick, ContactMode::SlipPositive, ContactMode::SlipNegative})
    if (s == toString(m)) return m;
  throw pyb::value_error("contact mode '" + s + "': expected stick, slip_positive or slip_negative");
}

FrictionMode parseFrictionMode(const pyb::handle& h) {
  if (pyb::isinstance<FrictionMode>(h)) return h.cast<FrictionMode>();
  const std::string s = pyb::str(h).cast<std::string>();
  if (s == "stick_slip") return FrictionMode::StickSlip;  // the Python enum's spelling
  for (FrictionMode m : {FrictionMode::StickSlip, FrictionMode::Paper})
    if (s == toString(m)) return m;
  throw pyb::value_error("friction mode '" + s + "': expected 'stick-slip' or 'paper'");
}

MomentKind parseKind(const std::string& s) {
  for (MomentKind k : {MomentKind::TubeEnd, MomentKind::CurvatureDiscontinuity})
    if (s == toString(k)) return k;
  throw pyb::value_error("contact kind '" + s + "': expected tube_end or curvature_discontinuity");
}

pyb::list contactMemoryList(const HysteresisState& h) {
  pyb::list out;
  for (const ContactMemory& c : h.contacts) {
    pyb::dict d = siteDict(c.site);
    d["mode"] = toString(c.mode);
    d["relative_twist"] = c.relative_twist;
    d["torque"] = c.torque;
    d["bound"] = c.bound;
    out.append(d);
  }
  return out;
}

// Pickling: the state as plain Python values (every field; round-trips exactly).
// Format 2 adds the solver's warm-start memory (previous_*), format 3 the command and the drives' plays; formats 1
// and 2 still load (without drives: their command is their configuration).
pyb::tuple stateGetState(const HysteresisState& h) {
  return pyb::make_tuple(3, h.q.alpha, h.q.beta, h.base_twist_rate, contactMemoryList(h), h.direction, h.twist,
                         h.interface_direction, h.valid, h.base_moment, h.previous_q.alpha, h.previous_q.beta,
                         h.previous_base_twist_rate, h.previous_base_moment, h.previous_torques, h.command.alpha,
                         h.command.beta, h.drives.rotation, h.drives.translation);
}

HysteresisState stateSetState(const pyb::tuple& t) {
  const int format = t.size() > 0 ? t[0].cast<int>() : 0;
  if (!((format == 1 && t.size() == 10) || (format == 2 && t.size() == 15) || (format == 3 && t.size() == 19)))
    throw pyb::value_error("HysteresisState: unknown pickled format");
  HysteresisState h;
  h.q = Configuration(t[1].cast<Eigen::VectorXd>(), t[2].cast<Eigen::VectorXd>());
  h.base_twist_rate = t[3].cast<Eigen::VectorXd>();
  for (const pyb::handle item : t[4].cast<pyb::list>()) {
    const pyb::dict d = pyb::reinterpret_borrow<pyb::dict>(item);
    ContactMemory c;
    c.site.kind = parseKind(d["kind"].cast<std::string>());
    c.site.tube = d["tube"].cast<int>() - 1;
    c.site.outer = d["outer"].cast<int>() - 1;
    c.site.inner = d["inner"].cast<int>() - 1;
    c.site.s = d["s"].cast<double>();
    c.mode = parseContactMode(d["mode"].cast<std::string>());
    c.relative_twist = d["relative_twist"].cast<double>();
    c.torque = d["torque"].cast<double>();
    c.bound = d["bound"].cast<double>();
    h.contacts.push_back(c);
  }
  h.direction = t[5].cast<Eigen::VectorXd>();
  h.twist = t[6].cast<Eigen::VectorXd>();
  h.interface_direction = t[7].cast<Eigen::VectorXd>();
  h.valid = t[8].cast<bool>();
  h.base_moment = t[9].cast<Eigen::Vector3d>();
  if (format >= 2) {
    h.previous_q = Configuration(t[10].cast<Eigen::VectorXd>(), t[11].cast<Eigen::VectorXd>());
    h.previous_base_twist_rate = t[12].cast<Eigen::VectorXd>();
    h.previous_base_moment = t[13].cast<Eigen::Vector3d>();
    h.previous_torques = t[14].cast<Eigen::VectorXd>();
  }
  if (format >= 3) {
    h.command = Configuration(t[15].cast<Eigen::VectorXd>(), t[16].cast<Eigen::VectorXd>());
    h.drives.rotation = t[17].cast<Eigen::VectorXd>();
    h.drives.translation = t[18].cast<Eigen::VectorXd>();
  }
  return h;
}

/// Default friction options of the Python calls that return arrays only: no backbone (as the CLI's sweep).
FrictionOptions arrayOptions(const std::optional<FrictionOptions>& o) {
  if (o) return *o;
  FrictionOptions f;
  f.kinematics.record_backbone = false;
  return f;
}

}  // namespace

void registerFriction(pyb::module_& m) {
  pyb::enum_<FrictionMode>(m, "FrictionMode", "How the friction torque at a contact is determined.")
      .value("stick_slip", FrictionMode::StickSlip, "Coulomb friction with memory (default).")
      .value("paper", FrictionMode::Paper, "Always slipping, sign from the commanded direction (paper eq. 34-35).");

  pyb::class_<FrictionOptions> fo(m, "FrictionOptions",
                                  "Options of the friction stepping (ctr::FrictionOptions). mode accepts "
                                  "ctr.FrictionMode or the CLI's names 'stick-slip' / 'paper'.");
  fo.def_property(
        "mode", [](const FrictionOptions& o) { return o.mode; },
        [](FrictionOptions& o, const pyb::object& v) { o.mode = parseFrictionMode(v); })
      .def_readwrite("follow", &FrictionOptions::follow)
      .def_readwrite("max_active_set_iterations", &FrictionOptions::max_active_set_iterations)
      .def_readwrite("kinematics", &FrictionOptions::kinematics);
  addOptionsProtocol<FrictionOptions>(fo, {"mode", "follow", "max_active_set_iterations", "kinematics"});

  pyb::class_<HysteresisState>(m, "HysteresisState",
                               "Everything the friction model remembers of the path so far (a plain value: "
                               "copy.copy() it to branch a path; picklable).")
      .def(pyb::init<>(), "An uninitialised state (valid False); use ctr.initial_state.")
      .def_property_readonly(
          "alpha", [](const HysteresisState& h) { return h.q.alpha; },
          "The tubes' rotations at the last step (the command's joints through the robot's drives; the command "
          "itself without an actuation block).")
      .def_property_readonly(
          "beta", [](const HysteresisState& h) { return h.q.beta; }, "The tubes' translations at the last step.")
      .def_property_readonly(
          "command", [](const HysteresisState& h) { return configurationTuple(h.lastCommand()); },
          "The last command (alpha, beta).")
      .def_property_readonly(
          "plays", [](const HysteresisState& h) { return pyb::make_tuple(h.drives.rotation, h.drives.translation); },
          "The drives' play positions (rotation, translation) per tube; NaN where a drive has no play or no history; "
          "empty arrays for a robot without actuation.")
      .def_property_readonly(
          "base_twist_rate", [](const HysteresisState& h) { return h.base_twist_rate; },
          "u_iz(0) at the last step: the equilibrium branch.")
      .def_property_readonly("contacts", &contactMemoryList,
                             "Memory of each contact site (dicts: kind, tube, outer, inner, s, mode "
                             "'stick'/'slip_positive'/'slip_negative', relative_twist, torque, bound).")
      .def_property_readonly(
          "direction", [](const HysteresisState& h) { return h.direction; },
          "Last commanded rotation direction per tube (-1, 0, +1).")
      .def_property_readonly("twist", [](const HysteresisState& h) { return h.twist; })
      .def_property_readonly("interface_direction", [](const HysteresisState& h) { return h.interface_direction; })
      .def_property_readonly(
          "base_moment", [](const HysteresisState& h) { return array3(h.base_moment); },
          "With external loads: m(0) at the last step (warm start).")
      .def_property_readonly("valid", [](const HysteresisState& h) { return h.valid; })
      .def("__copy__", [](const HysteresisState& h) { return HysteresisState(h); })
      .def("__deepcopy__", [](const HysteresisState& h, const pyb::dict&) { return HysteresisState(h); })
      .def(pyb::pickle(&stateGetState, &stateSetState))
      .def("__repr__", [](const HysteresisState& h) {
        if (!h.valid) return std::string("<ctr.HysteresisState (not initialised)>");
        std::string modes;
        for (const auto& c : h.contacts) modes += std::string(modes.empty() ? "" : ", ") + toString(c.mode);
        return "<ctr.HysteresisState alpha=" + pyb::repr(pyb::cast(h.q.alpha)).cast<std::string>() + ", contacts [" +
               modes + "]>";
      });

  pyb::class_<StepSummary>(m, "StepSummary", "How a quasi-static step went.")
      .def_readonly("converged", &StepSummary::converged)
      .def_readonly("substeps", &StepSummary::substeps)
      .def_readonly("active_set_iterations", &StepSummary::active_set_iterations)
      .def_readonly("snapped", &StepSummary::snapped)
      .def_readonly("enumerated", &StepSummary::enumerated)
      .def_readonly("message", &StepSummary::message)
      .def("__repr__", [](const StepSummary& s) {
        return std::string("<ctr.StepSummary ") + (s.converged ? "converged" : "not converged") + ", " +
               std::to_string(s.substeps) + " sub-steps" + (s.snapped ? ", snapped" : "") +
               (s.message.empty() ? "" : ": " + s.message) + ">";
      });

  pyb::class_<StepResult>(m, "StepResult", "The equilibrium at the command, the new memory, and how it went.")
      .def_readonly("solution", &StepResult::solution)
      .def_readonly("state", &StepResult::state)
      .def_readonly("summary", &StepResult::summary)
      .def_property_readonly("converged", [](const StepResult& r) { return r.summary.converged; })
      .def("__repr__", [](const StepResult& r) {
        return "<ctr.StepResult " + pyb::repr(pyb::cast(r.solution)).cast<std::string>() + ", " +
               pyb::repr(pyb::cast(r.summary)).cast<std::string>() + ">";
      });

  m.def(
      "initial_state",
      [](const Robot& r, const pyb::object& alpha, const pyb::object& beta, std::optional<FrictionOptions> options) {
        const Configuration q = toConfiguration(r, alpha, beta);
        pyb::gil_scoped_release release;
        return initialState(r, q, workspace(), options.value_or(FrictionOptions{}));
      },
      arg("robot"), arg("alpha") = pyb::none(), arg("beta") = pyb::none(), arg("options") = pyb::none(),
      "Robot at rest at (alpha, beta) without friction torques; carry .state along a path with ctr.step. Uses the "
      "robot's friction coefficients (robot.with_friction(...) to change them).");
  m.def(
      "step",
      [](const Robot& r, const HysteresisState& from, const pyb::object& alpha, const pyb::object& beta,
         std::optional<FrictionOptions> options) {
        if (!from.valid) throw pyb::value_error("state: not initialised (use ctr.initial_state first)");
        const pyb::object a = alpha.is_none() ? pyb::cast(from.lastCommand().alpha) : alpha;
        const pyb::object b = beta.is_none() ? pyb::cast(from.lastCommand().beta) : beta;
        const Configuration q = toConfiguration(r, a, b);
        pyb::gil_scoped_release release;
        return step(r, from, q, workspace(), options.value_or(FrictionOptions{}));
      },
      arg("robot"), arg("state"), arg("alpha") = pyb::none(), arg("beta") = pyb::none(), arg("options") = pyb::none(),
      "Quasi-static move from `state` to the command (alpha, beta); None keeps the state's last command for that "
      "part. Sub-stepped, so the result does not depend on how a path is sliced (docs/friction.md).");

  m.def(
      "simulate",
      [](const Robot& r, const pyb::object& alpha, const pyb::object& beta, std::optional<FrictionOptions> options,
         bool keep_states, const std::string& branch) {
        const int n = r.size();
        const Eigen::MatrixXd A = toMatrix(alpha, "alpha", n), B = toMatrix(beta, "beta", n);
        if (A.rows() != B.rows())
          throw pyb::value_error("alpha has " + std::to_string(A.rows()) + " rows, beta " + std::to_string(B.rows()));
        std::vector<Configuration> qs;
        for (Eigen::Index k = 0; k < A.rows(); ++k) {
          Configuration q(A.row(k).transpose(), B.row(k).transpose());
          const Admissibility adm = projectAdmissible(r, q);
          if (!adm) throw pyb::value_error("row " + std::to_string(k + 1) + " is not admissible: " + adm.message);
          qs.push_back(std::move(q));
        }
        ReplayOptions ro;
        ro.friction = arrayOptions(options);
        try {
          ro.branch = parseBranchRule(branch);
        } catch (const std::invalid_argument& e) {
          throw pyb::value_error(std::string("branch: ") + e.what());
        }
        std::vector<ReplayRow> res;
        {
          pyb::gil_scoped_release release;
          res = replay(r, qs, workspace(), ro);
        }
        std::vector<const Solution*> sols;
        pyb::array_t<bool> snapped(static_cast<pyb::ssize_t>(res.size()));
        pyb::list messages, failures, states, reached;
        for (std::size_t k = 0; k < res.size(); ++k) {
          sols.push_back(&res[k].result.solution);
          snapped.mutable_at(static_cast<pyb::ssize_t>(k)) = res[k].result.summary.snapped;
          messages.append(res[k].ok ? res[k].result.summary.message : res[k].message);
          failures.append(toString(res[k].failure));
          reached.append(toString(res[k].reached));
          if (keep_states) states.append(pyb::cast(res[k].result.state));
        }
        pyb::dict d = solutionRows(sols, n);
        const pyb::tuple ab = configurationArrays(qs, n);
        d["alpha"] = ab[0];
        d["beta"] = ab[1];
        d["snapped"] = snapped;
        d["message"] = messages;
        d["failure"] = failures;
        d["reached"] = reached;
        if (keep_states) d["states"] = states;
        return d;
      },
      arg("robot"), arg("alpha"), arg("beta"), arg("options") = pyb::none(), arg("keep_states") = false,
      arg("branch") = toString(BranchRule::Path),
      "Replays K commands (alpha, beta: (K, n)) through the stateful friction model as `ctr simulate` (branch: "
      "'path' or 'rest', docs/friction.md \"Replaying a sequence\"). Dict of arrays: alpha, beta, twist, "
      "tip_position, tip_tangent (NaN where not converged), stability, converged, stable, snapped, status, message, "
      "failure (why a row failed: 'none', 'not_converged', 'snapped', ...) and reached ('path', 'rest' or 'restart' "
      "per row) (+ states: the HysteresisState after each row, with "
      "keep_states). Runs without the GIL.");

  m.def(
      "sweep",
      [](const Robot& r, int tube, double start, double stop, double step_size, bool both, const pyb::object& alpha,
         const pyb::object& beta, std::optional<FrictionOptions> options) {
        const int n = r.size();
        if (tube < 1 || tube > n)
          throw pyb::value_error("tube: " + std::to_string(tube) + " is not a tube of robot '" + r.name() + "' (1.." +
                                 std::to_string(n) + ")");
        const double st = std::abs(step_size);
        if (!(st > 0.0) || !std::isfinite(st)) throw pyb::value_error("step: must be non-zero and finite");
        if (!std::isfinite(start) || !std::isfinite(stop)) throw pyb::value_error("start, stop: must be finite");
        // The angles of `ctr sweep --from start --to stop --step step [--both-directions]`.
        const int count = static_cast<int>(std::floor(std::abs(stop - start) / st + 1e-9));
        if (count > 1000000) throw pyb::value_error("step: too many steps (" + std::to_string(count) + ")");
        const double sgn = stop >= start ? 1.0 : -1.0;
        std::vector<double> angles;
        for (int k = 0; k <= count; ++k) angles.push_back(start + sgn * st * k);
        if (std::abs(angles.back() - stop) > 1e-12) angles.push_back(stop);
        std::vector<int> dirs(angles.size(), static_cast<int>(sgn));
        if (both) {
          for (int k = static_cast<int>(angles.size()) - 2; k >= 0; --k) {
            angles.push_back(angles[static_cast<std::size_t>(k)]);
            dirs.push_back(-static_cast<int>(sgn));
          }
        }
        const int K = tube - 1;
        Configuration q = toConfiguration(r, alpha, beta, K, angles[0]);
        const FrictionOptions fo = arrayOptions(options);
        std::vector<StepResult> res(angles.size());
        std::vector<Configuration> qs(angles.size());
        {
          pyb::gil_scoped_release release;
          StepResult cur = initialState(r, q, workspace(), fo);
          for (std::size_t k = 0; k < angles.size(); ++k) {
            if (k > 0) {
              q.alpha[K] = angles[k];
              cur = cur.state.valid ? step(r, cur.state, q, workspace(), fo) : initialState(r, q, workspace(), fo);
            }
            qs[k] = q;
            res[k] = cur;
          }
        }
        std::vector<const Solution*> sols;
        const auto rows = static_cast<pyb::ssize_t>(angles.size());
        pyb::array_t<bool> snapped(rows);
        pyb::array_t<int> direction(rows);
        for (pyb::ssize_t k = 0; k < rows; ++k) {
          sols.push_back(&res[static_cast<std::size_t>(k)].solution);
          snapped.mutable_at(k) = res[static_cast<std::size_t>(k)].summary.snapped;
          direction.mutable_at(k) = dirs[static_cast<std::size_t>(k)];
        }
        pyb::dict d = solutionRows(sols, n);
        const pyb::tuple ab = configurationArrays(qs, n);
        d["angle"] = pyb::array_t<double>(rows, angles.data());
        d["direction"] = direction;
        d["alpha"] = ab[0];
        d["beta"] = ab[1];
        d["snapped"] = snapped;
        return d;
      },
      arg("robot"), arg("tube"), arg("start"), arg("stop"), arg("step"), arg("both_directions") = false,
      arg("alpha") = pyb::none(), arg("beta") = pyb::none(), arg("options") = pyb::none(),
      "`ctr sweep`: rotates tube `tube` (1 = outermost) from start to stop (rad) in steps of `step` (and back with "
      "both_directions), carrying the branch and the hysteresis state. The other tubes at (alpha, beta) (None: the "
      "CLI's default). Dict of arrays with the CSV's rows: angle, direction, alpha, beta, twist, tip_position, "
      "tip_tangent (NaN where not converged), stability, converged, stable, snapped, status. Runs without the GIL.");

  pyb::class_<FrictionBand>(m, "FrictionBand",
                            "All equilibria at one configuration reachable under some history (vertex and interior "
                            "shapes of the contact torque box).")
      .def_readonly("converged", &FrictionBand::converged)
      .def_readonly("shapes", &FrictionBand::shapes, "Solutions; [0] is the frictionless shape.")
      .def_property_readonly(
          "torque_fractions",
          [](const FrictionBand& b) {
            const std::size_t k = b.torque_fractions.empty() ? 0 : b.torque_fractions.front().size();
            Eigen::MatrixXd t(b.torque_fractions.size(), k);
            for (std::size_t r = 0; r < b.torque_fractions.size(); ++r)
              for (std::size_t c = 0; c < k && c < b.torque_fractions[r].size(); ++c)
                t(static_cast<Eigen::Index>(r), static_cast<Eigen::Index>(c)) = b.torque_fractions[r][c];
            return t;
          },
          "(shapes, contacts): torque / bound of each contact in each shape.")
      .def_readonly("twist_min", &FrictionBand::twist_min, "Smallest twist of each tube 2..n over the shapes (rad).")
      .def_readonly("twist_max", &FrictionBand::twist_max)
      .def_readonly("tip_spread", &FrictionBand::tip_spread, "Largest tip distance from the frictionless tip (m).")
      .def_readonly("message", &FrictionBand::message)
      .def_property_readonly(
          "sites", [](const FrictionBand& b) { return siteList(b.sites); },
          "The contact sites at q (dicts as contact_sites returns), in the order of torque_fractions' columns.")
      .def_property_readonly(
          "tip_positions",
          [](const FrictionBand& b) {
            Eigen::MatrixXd p(b.shapes.size(), 3);
            for (std::size_t k = 0; k < b.shapes.size(); ++k)
              p.row(static_cast<Eigen::Index>(k)) = b.shapes[k].tip_position.transpose();
            return p;
          },
          "(shapes, 3) tip positions (m).")
      .def("__repr__", [](const FrictionBand& b) {
        return "<ctr.FrictionBand " + std::to_string(b.shapes.size()) + " shapes, twist " +
               pyb::repr(pyb::cast(b.twist_min)).cast<std::string>() + " .. " +
               pyb::repr(pyb::cast(b.twist_max)).cast<std::string>() + ">";
      });

  m.def(
      "friction_band",
      [](const Robot& r, const pyb::object& alpha, const pyb::object& beta, int interior_samples,
         std::optional<KinematicsOptions> kinematics, const FrictionBand* follow) {
        const Configuration q = toConfiguration(r, alpha, beta);
        if (interior_samples < 0) throw pyb::value_error("interior_samples: must not be negative");
        FrictionBandOptions o;
        o.interior_samples = interior_samples;
        if (kinematics) o.kinematics = *kinematics;
        o.follow = follow;
        pyb::gil_scoped_release release;
        return frictionBand(r, q, workspace(), o);
      },
      arg("robot"), arg("alpha") = pyb::none(), arg("beta") = pyb::none(), arg("interior_samples") = 1,
      arg("kinematics") = pyb::none(), arg("follow") = pyb::none(),
      "The friction band at (alpha, beta) with the robot's mu' (every contact torque within its bound). For one "
      "contact, twist_min / twist_max are the two branches of a sweep's envelope. `follow`: the band of a "
      "configuration just before this one on a path; each shape is then continued from the shape with the same "
      "torque fractions at the same sites (the branch a robot moving along the path stays on) instead of solved cold.");

  m.def(
      "uniqueness_certificate",
      [](const Robot& r, const pyb::object& alpha, const pyb::object& beta, const FrictionBand* band) {
        UniquenessOptions o;
        o.measure = true;
        const UniquenessCertificate c =
            band ? uniquenessCertificate(r, *band, o) : uniquenessCertificate(r, toConfiguration(r, alpha, beta), o);
        pyb::dict d;
        d["status"] = toString(c.status);
        d["certified"] = c.certified();
        d["interaction"] = c.interaction;
        return d;
      },
      arg("robot"), arg("alpha") = pyb::none(), arg("beta") = pyb::none(), arg("band") = pyb::none(),
      "Whether each contact torque vector has exactly one equilibrium (docs/friction.md, \"One equilibrium per "
      "torque\"): at (alpha, beta) for every rotation, or around `band` (a friction_band with the tubes' angles "
      "recorded, the default). Dict: status ('certified', 'interacting', 'loaded', 'inadmissible'), certified, "
      "interaction (the largest ratio of the coupling over the torsional energy; < 0.98 is certified). ValueError for "
      "a "
      "band without the tubes' angles.");
}

}  // namespace ctr::py
