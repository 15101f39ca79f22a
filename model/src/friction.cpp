// Lumped Coulomb friction at concentrated moments (Lock & Dupont 2011 §II.D) with stick-slip memory.
//
// Each contact site c (kinematics.hpp) carries a torque T_c on its inner tube (-T_c on the outer tube) with
// |T_c| <= mu' |m_c|. A quasi-static sub-step is solved by return mapping (active set): every contact is first
// assumed stuck (relative twist at the site unchanged); contacts whose required torque exceeds the bound slip
// with the torque at the bound opposing the relative motion; slipping contacts whose motion would reverse stick
// again. The modes are iterated to a consistent set; if they cycle, all 3^k mode combinations are enumerated.
#include "ctr/model/friction.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <set>
#include <sstream>
#include <stdexcept>

#include "workspace_impl.hpp"

namespace ctr {
namespace {

constexpr double kBoundSlack = 1e-9;   // relative slack on |T| <= bound
constexpr double kTwistSlack = 1e-10;  // rad: a slip "reversal" smaller than this is noise

ContactCondition conditionFor(ContactMode mode, double stick_twist) {
  switch (mode) {
    case ContactMode::Stick:
      return {ContactCondition::Law::Stick, stick_twist};
    case ContactMode::SlipPositive:
      return {ContactCondition::Law::Torque, -1.0};  // inner moves +, torque -
    case ContactMode::SlipNegative:
      return {ContactCondition::Law::Torque, +1.0};
  }
  return {};
}

// A warm start carrying the previous branch and contact torques.
Solution warmFrom(const HysteresisState& s) {
  Solution w;
  w.base_twist_rate = s.base_twist_rate;
  w.base_moment = s.base_moment;
  w.loaded = !s.base_moment.isZero(0.0);
  w.summary.status = SolveStatus::Converged;
  for (const ContactMemory& m : s.contacts) {
    ContactResult cr;
    cr.site = m.site;
    cr.torque = m.torque;
    w.contacts.push_back(cr);
  }
  return w;
}

// The warm start of a step from `s` to q: the state's own solution, or, following a path (extrapolate_warm_start),
// the secant through the state and the one a sub-step before it when q continues their line (within 2.6 deg of its
// direction, at most twice its length ahead; actuation measured as alpha and 50 x beta, as the frictionless chain).
// A function of the state and q only.
Solution warmFor(const HysteresisState& s, const Configuration& q, const KinematicsOptions& opt) {
  Solution w = warmFrom(s);
  const int n = s.q.size();
  if (!opt.extrapolate_warm_start || s.previous_q.size() != n || q.size() != n ||
      s.previous_base_twist_rate.size() != n || s.previous_torques.size() != static_cast<int>(s.contacts.size()))
    return w;
  Eigen::VectorXd back(2 * n), ahead(2 * n);
  back << s.q.alpha - s.previous_q.alpha, detail::kHistoryBetaScale * (s.q.beta - s.previous_q.beta);
  ahead << q.alpha - s.q.alpha, detail::kHistoryBetaScale * (q.beta - s.q.beta);
  const double len = back.norm(), dist = ahead.norm();
  if (!(len > 0.0) || !(dist > 0.0) || dist > 2.0 * len || ahead.dot(back) < 0.999 * dist * len) return w;
  const double f = dist / len;
  w.base_twist_rate = s.base_twist_rate + f * (s.base_twist_rate - s.previous_base_twist_rate);
  w.base_moment = s.base_moment + f * (s.base_moment - s.previous_base_moment);
  for (std::size_t c = 0; c < w.contacts.size(); ++c)
    w.contacts[c].torque += f * (s.contacts[c].torque - s.previous_torques[static_cast<int>(c)]);
  return w;
}

// Keeps `prev` as the warm-start memory of `next` when their contacts are the same sites in the same modes.
void rememberPrevious(const HysteresisState& prev, HysteresisState& next) {
  if (prev.contacts.size() != next.contacts.size()) return;
  for (std::size_t c = 0; c < prev.contacts.size(); ++c)
    if (!(prev.contacts[c].site == next.contacts[c].site) || prev.contacts[c].mode != next.contacts[c].mode) return;
  next.previous_q = prev.q;
  next.previous_base_twist_rate = prev.base_twist_rate;
  next.previous_base_moment = prev.base_moment;
  next.previous_torques.resize(static_cast<int>(prev.contacts.size()));
  for (std::size_t c = 0; c < prev.contacts.size(); ++c)
    next.previous_torques[static_cast<int>(c)] = prev.contacts[c].torque;
}

const ContactMemory* findMemory(const HysteresisState& s, const ContactSite& site) {
  for (const ContactMemory& m : s.contacts)
    if (m.site == site) return &m;
  return nullptr;
}

HysteresisState stateFrom(const Solution& sol, const std::vector<ContactMode>& modes, const Configuration& q,
                          const Eigen::VectorXd& direction) {
  HysteresisState st;
  st.q = q;
  st.base_twist_rate = sol.base_twist_rate;
  st.base_moment = sol.base_moment;
  st.direction = direction;
  st.twist = sol.twist;
  st.valid = sol.converged();
  for (std::size_t c = 0; c < sol.contacts.size(); ++c) {
    ContactMemory m;
    m.site = sol.contacts[c].site;
    m.mode = c < modes.size() ? modes[c] : ContactMode::Stick;
    m.relative_twist = sol.contacts[c].relative_twist;
    m.torque = sol.contacts[c].torque;
    m.bound = 0.0;
    st.contacts.push_back(m);
  }
  return st;
}

struct SubstepOutcome {
  Solution solution;
  Eigen::VectorXd interface_direction;
  std::vector<ContactMode> modes;
  int iterations = 0;
  bool enumerated = false;
  bool ok = false;
  std::string message;
};

// Consistency of a solved mode set: stuck torques within bounds, slipping contacts moving the right way.
// Returns the proposed modes (equal to `modes` when consistent) and a violation measure.
double checkModes(const Solution& sol, const std::vector<ContactMode>& modes, const std::vector<double>& ref_twist,
                  double mu, std::vector<ContactMode>& proposal) {
  proposal = modes;
  double violation = 0.0;
  for (std::size_t c = 0; c < modes.size(); ++c) {
    const ContactResult& cr = sol.contacts[c];
    const double bound = mu * cr.moment;
    if (modes[c] == ContactMode::Stick) {
      const double excess = std::abs(cr.torque) - bound * (1.0 + kBoundSlack) - 1e-15;
      if (excess > 0.0) {
        violation += excess / std::max(bound, 1e-12);
        // A positive torque is needed to hold the inner tube: it tends to move negatively.
        proposal[c] = cr.torque > 0.0 ? ContactMode::SlipNegative : ContactMode::SlipPositive;
      }
    } else {
      const double dphi = cr.relative_twist - ref_twist[c];
      const bool wrong = (modes[c] == ContactMode::SlipPositive && dphi < -kTwistSlack) ||
                         (modes[c] == ContactMode::SlipNegative && dphi > kTwistSlack);
      if (wrong) {
        violation += std::abs(dphi);
        proposal[c] = ContactMode::Stick;
      }
    }
  }
  return violation;
}

SubstepOutcome solveSubstep(const Robot& robot, const HysteresisState& prev, const Configuration& q, Workspace& ws,
                            const FrictionOptions& opt) {
  SubstepOutcome out;
  const double mu = robot.friction().boundary;
  const std::vector<ContactSite> sites = contactSites(robot, q);
  const std::size_t k = sites.size();
  std::vector<ContactMode> modes(k, ContactMode::Stick);
  std::vector<double> ref(k, 0.0);
  std::vector<bool> known(k, false);
  for (std::size_t c = 0; c < k; ++c) {
    if (const ContactMemory* m = findMemory(prev, sites[c])) {
      ref[c] = m->relative_twist;
      known[c] = true;
      modes[c] = m->mode;  // first trial: the contact keeps doing what it did (one solve while slipping on)
    }
  }
  const Solution warm = warmFor(prev, q, opt.kinematics);
  KinematicsOptions kopt = opt.kinematics;
  const bool distributed = robot.friction().distributed > 0.0;
  DistributedFrictionOptions dopt;
  if (distributed) {
    // Distributed-contact friction (§II.B): sign per interface from the commanded relative rotation.
    const int n = robot.size();
    dopt.mu = robot.friction().distributed;
    dopt.kinematics = kopt;
    dopt.direction.assign(static_cast<std::size_t>(std::max(0, n - 1)), 1);
    out.interface_direction = Eigen::VectorXd::Ones(std::max(0, n - 1));
    for (int j = 0; j + 1 < n; ++j) {
      const double cmd = (q.alpha[j + 1] - q.alpha[j]) - (prev.q.alpha[j + 1] - prev.q.alpha[j]);
      double d = cmd > 0 ? 1.0 : (cmd < 0 ? -1.0 : 0.0);
      if (d == 0.0 && prev.interface_direction.size() == n - 1) d = prev.interface_direction[j];
      if (d == 0.0) d = 1.0;
      dopt.direction[static_cast<std::size_t>(j)] = static_cast<int>(d);
      out.interface_direction[j] = d;
    }
    if (mu == 0.0) {
      DistributedFrictionSolution ds = solveDistributedFriction(robot, q, ws, dopt, &warm);
      out.solution = std::move(ds.solution);
      out.ok = out.solution.converged();
      out.iterations = 1;
      if (!out.ok) out.message = out.solution.summary.message;
      return out;
    }
  }
  // Equilibrium under given contact laws, with the distributed friction when the robot has it.
  auto solveLaws = [&](const std::vector<ContactCondition>& cond) {
    if (!distributed) return solveWithContacts(robot, q, cond, ws, kopt, &warm);
    dopt.contacts = cond;
    return std::move(solveDistributedFriction(robot, q, ws, dopt, &warm).solution);
  };
  if (mu == 0.0) {
    // Frictionless: exactly the frictionless model (no contact unknowns), following the branch.
    out.solution = solve(robot, q, ws, kopt, &warm);
    out.ok = out.solution.converged();
    out.iterations = 1;
    if (!out.ok) out.message = out.solution.summary.message;
    return out;
  }

  auto conditionsFor = [&](const std::vector<ContactMode>& md) {
    std::vector<ContactCondition> cond(k);
    for (std::size_t c = 0; c < k; ++c)
      cond[c] = known[c] ? conditionFor(md[c], ref[c]) : ContactCondition{ContactCondition::Law::Free, 0.0};
    return cond;
  };

  if (opt.mode == FrictionMode::Paper) {
    // Always slipping; sign from the commanded relative rotation direction (kept when there is none).
    for (std::size_t c = 0; c < k; ++c) {
      const int a = sites[c].outer, b = sites[c].inner;
      const double cmd = (q.alpha[b] - q.alpha[a]) - (prev.q.alpha[b] - prev.q.alpha[a]);
      double dir = cmd > 0 ? 1.0 : (cmd < 0 ? -1.0 : 0.0);
      if (dir == 0.0) {
        const ContactMemory* m = findMemory(prev, sites[c]);
        if (m && m->mode != ContactMode::Stick) dir = m->mode == ContactMode::SlipPositive ? 1.0 : -1.0;
      }
      modes[c] = dir > 0 ? ContactMode::SlipPositive : (dir < 0 ? ContactMode::SlipNegative : ContactMode::Stick);
      known[c] = true;
      if (modes[c] == ContactMode::Stick) {
        // No direction ever commanded: no friction torque.
        known[c] = false;
      }
    }
    out.solution = solveLaws(conditionsFor(modes));
    out.modes = modes;
    out.ok = out.solution.converged();
    out.iterations = 1;
    if (!out.ok) out.message = out.solution.summary.message;
    return out;
  }

  // Stick-slip: return mapping over contact modes.
  std::set<std::vector<ContactMode>> visited;
  for (int it = 0; it < opt.max_active_set_iterations; ++it) {
    ++out.iterations;
    visited.insert(modes);
    Solution sol = solveLaws(conditionsFor(modes));
    if (!sol.converged()) {
      out.message = "equilibrium with contact modes did not converge: " + sol.summary.message;
      out.solution = std::move(sol);
      break;
    }
    std::vector<ContactMode> proposal;
    const double v = checkModes(sol, modes, ref, mu, proposal);
    if (v == 0.0) {
      out.solution = std::move(sol);
      out.modes = modes;
      out.ok = true;
      return out;
    }
    modes = proposal;
    if (visited.count(modes)) break;  // cycling: enumerate below
  }

  // Enumerate all 3^k mode combinations; keep the consistent one (or the least inconsistent).
  out.enumerated = true;
  std::size_t combos = 1;
  for (std::size_t c = 0; c < k; ++c) combos *= 3;
  double best_v = std::numeric_limits<double>::infinity();
  for (std::size_t code = 0; code < combos; ++code) {
    std::vector<ContactMode> md(k);
    std::size_t x = code;
    for (std::size_t c = 0; c < k; ++c, x /= 3) md[c] = static_cast<ContactMode>(x % 3);
    Solution sol = solveLaws(conditionsFor(md));
    ++out.iterations;
    if (!sol.converged()) continue;
    std::vector<ContactMode> proposal;
    const double v = checkModes(sol, md, ref, mu, proposal);
    if (v < best_v) {
      best_v = v;
      out.solution = std::move(sol);
      out.modes = md;
      out.ok = true;
      if (v == 0.0) break;
    }
  }
  if (out.ok && best_v > 0.0) {
    // No quasi-static equilibrium respects the friction bounds here (typically where the branch folds): the robot
    // would move dynamically. The least-violating shape exceeds a bound, so it is not returned as an answer.
    std::ostringstream os;
    os << "no consistent stick/slip mode set (least bound violation " << best_v
       << "): no quasi-static equilibrium with friction here (dynamic slip)";
    out.message = os.str();
    out.ok = false;
  } else if (!out.ok && out.message.empty()) {
    out.message = "no contact mode set converged";
  }
  return out;
}

}  // namespace

const char* toString(FrictionMode mode) {
  switch (mode) {
    case FrictionMode::StickSlip:
      return "stick-slip";
    case FrictionMode::Paper:
      return "paper";
  }
  return "?";
}

const char* toString(ContactMode mode) {
  switch (mode) {
    case ContactMode::Stick:
      return "stick";
    case ContactMode::SlipPositive:
      return "slip_positive";
    case ContactMode::SlipNegative:
      return "slip_negative";
  }
  return "?";
}

StepResult initialState(const Robot& robot, const Configuration& q, Workspace& ws, const FrictionOptions& opt,
                        const Solution* branch) {
  if (hasActuation(robot)) {
    if (q.size() != robot.size() || q.beta.size() != robot.size() || !checkAdmissible(robot, q))
      return initialState(robot.withoutActuation(), q, ws, opt, branch);  // reports the command as it is
    DriveState drives;
    const Configuration joints = jointsOf(robot, q, drives);
    StepResult r = initialState(robot.withoutActuation(), joints, ws, opt, branch);
    r.state.command = q;
    r.state.drives = std::move(drives);
    return r;
  }
  StepResult r;
  const std::vector<ContactSite> sites = contactSites(robot, q);
  std::vector<ContactCondition> free(sites.size(), ContactCondition{ContactCondition::Law::Free, 0.0});
  r.solution = robot.friction().boundary == 0.0 ? solve(robot, q, ws, opt.kinematics, branch)
                                                : solveWithContacts(robot, q, free, ws, opt.kinematics, branch);
  std::vector<ContactMode> modes(sites.size(), ContactMode::Stick);
  r.state = stateFrom(r.solution, modes, q, Eigen::VectorXd::Zero(robot.size()));
  r.summary.converged = r.solution.converged();
  r.summary.message = r.solution.summary.message;
  r.summary.substeps = 0;
  return r;
}

HysteresisState stuckStateAt(const Robot& robot, const Solution& shape) {
  if (hasActuation(robot))
    throw std::invalid_argument("stuckStateAt: the robot has drives (pass its tubes: Robot::withoutActuation)");
  if (!shape.converged() || shape.q.size() != robot.size())
    throw std::invalid_argument("stuckStateAt: the shape is not a converged equilibrium of this robot");
  const std::vector<ContactSite> sites = contactSites(robot, shape.q);
  if (sites.size() != shape.contacts.size())
    throw std::invalid_argument("stuckStateAt: the shape's contact sites are not the robot's at its configuration");
  HysteresisState st = stateFrom(shape, std::vector<ContactMode>(sites.size(), ContactMode::Stick), shape.q,
                                 Eigen::VectorXd::Zero(robot.size()));
  for (std::size_t c = 0; c < st.contacts.size(); ++c) {
    if (!(st.contacts[c].site == sites[c]))
      throw std::invalid_argument("stuckStateAt: the shape's contact sites are not the robot's at its configuration");
    st.contacts[c].bound = robot.friction().boundary * shape.contacts[c].moment;
  }
  return st;
}

StepResult step(const Robot& robot, const HysteresisState& from, const Configuration& q, Workspace& ws,
                const FrictionOptions& opt) {
  if (!from.valid) throw std::invalid_argument("step: the hysteresis state is not initialised (use initialState)");
  if (from.q.size() != robot.size()) throw std::invalid_argument("step: state and robot have different tube counts");
  if (hasActuation(robot) && checkAdmissible(robot, q)) {
    DriveState drives = from.drives;
    const Configuration joints = jointsOf(robot, q, drives);
    StepResult r = step(robot.withoutActuation(), from, joints, ws, opt);
    r.state.command = q;  // the drives moved even when the tubes could not follow (a failed step)
    r.state.drives = std::move(drives);
    return r;
  }
  StepResult res;
  const Admissibility adm = checkAdmissible(robot, q);
  if (!adm) {
    res.solution.q = q;
    res.solution.summary.status = SolveStatus::Inadmissible;
    res.solution.summary.message = adm.message;
    res.state = from;
    res.summary.message = adm.message;
    res.summary.failure = Failure::Inadmissible;
    return res;
  }
  HysteresisState cur = from;
  SubstepOutcome sub;
  const Configuration* qk = nullptr;  // the sub-step's command (followMove's, valid until the sub-step is committed)
  FrictionOptions o = opt;
  const FollowSummary f = followMove(
      from.q, q, from.twist, false, opt.follow, OnSnap::Continue,  // (stability not judged under contact laws)
      [&](const Configuration& at, int k, int steps) {
        qk = &at;
        o.kinematics.record_backbone = (k == steps) && opt.kinematics.record_backbone;
        sub = solveSubstep(robot, cur, at, ws, o);
        res.summary.active_set_iterations += sub.iterations;
        res.summary.enumerated = res.summary.enumerated || sub.enumerated;
        res.summary.substeps = k;
        if (sub.ok) return SubStep{&sub.solution, Failure::None, {}};
        return SubStep{nullptr, sub.solution.converged() ? Failure::NoContactSet : Failure::NotConverged,
                       "sub-step " + std::to_string(k) + "/" + std::to_string(steps) + ": " + sub.message};
      },
      noRecovery,
      [&](int, int, SubStep&, bool snapped) {
        // The last sub-step ends exactly at q (the state then remembers the command itself, not a rounding of it).
        if (!sub.message.empty()) res.summary.message = sub.message;
        Eigen::VectorXd dir = cur.direction.size() == q.size() ? cur.direction : Eigen::VectorXd::Zero(q.size());
        for (int i = 0; i < q.size(); ++i) {
          const double d = qk->alpha[i] - cur.q.alpha[i];
          if (d != 0.0) dir[i] = d > 0 ? 1.0 : -1.0;
        }
        res.summary.snapped = res.summary.snapped || snapped;
        HysteresisState next = stateFrom(sub.solution, sub.modes, *qk, dir);
        if (!res.summary.snapped) rememberPrevious(cur, next);
        next.interface_direction = sub.interface_direction.size() ? sub.interface_direction : cur.interface_direction;
        for (std::size_t c = 0; c < next.contacts.size(); ++c)
          next.contacts[c].bound = robot.friction().boundary * sub.solution.contacts[c].moment;
        cur = std::move(next);
        res.solution = std::move(sub.solution);
        return SubStep{};
      });
  if (f.failure != Failure::None) {
    res.solution = std::move(sub.solution);
    res.solution.summary.status = SolveStatus::NotConverged;
    res.summary.converged = false;
    res.summary.failure = f.failure;
    res.summary.message = f.message;
    res.state = cur;  // the last good state
    return res;
  }
  res.summary.converged = true;
  res.solution.summary.snapped = res.summary.snapped;
  res.state = std::move(cur);
  return res;
}

long bandShapeWith(const FrictionBand& band, const std::vector<ContactSite>& sites,
                   const std::vector<double>& fractions) {
  if (band.sites.size() != sites.size() || fractions.size() != sites.size()) return -1;
  std::vector<std::size_t> at(sites.size());  // index in band.sites of each site
  for (std::size_t c = 0; c < sites.size(); ++c) {
    const auto it = std::find(band.sites.begin(), band.sites.end(), sites[c]);
    if (it == band.sites.end()) return -1;
    at[c] = static_cast<std::size_t>(it - band.sites.begin());
  }
  for (std::size_t i = 0; i < band.shapes.size() && i < band.torque_fractions.size(); ++i) {
    bool same = true;
    for (std::size_t c = 0; c < sites.size() && same; ++c) same = band.torque_fractions[i][at[c]] == fractions[c];
    if (same) return static_cast<long>(i);
  }
  return -1;
}

FrictionBand frictionBand(const Robot& robot, const Configuration& q, Workspace& ws, const FrictionBandOptions& opt) {
  FrictionBand band;
  band.sites = contactSites(robot, q);
  const std::size_t k = band.sites.size();
  // The shape of the followed band with the same fractions, if any.
  auto followed = [&](const std::vector<double>& frac) -> const Solution* {
    if (!opt.follow) return nullptr;
    const long i = bandShapeWith(*opt.follow, band.sites, frac);
    return i >= 0 ? &opt.follow->shapes[static_cast<std::size_t>(i)] : nullptr;
  };
  std::vector<ContactCondition> free(k, ContactCondition{ContactCondition::Law::Free, 0.0});
  const std::vector<double> zero(k, 0.0);
  const Solution* base_warm = opt.follow && !opt.follow->shapes.empty() ? &opt.follow->shapes[0] : nullptr;
  Solution base = solveWithContacts(robot, q, free, ws, opt.kinematics, base_warm);
  if (!base.converged()) {
    band.message = "frictionless equilibrium did not converge: " + base.summary.message;
    return band;
  }
  band.shapes.push_back(std::move(base));
  band.torque_fractions.push_back(zero);
  band.converged = true;
  // The extremes over the shapes found; the band so far when a check ends it.
  auto finish = [&band]() -> FrictionBand& {
    const Solution& b = band.shapes[0];
    band.twist_min = band.twist_max = b.twist;
    for (const Solution& s : band.shapes) {
      band.twist_min = band.twist_min.cwiseMin(s.twist);
      band.twist_max = band.twist_max.cwiseMax(s.twist);
      band.tip_spread = std::max(band.tip_spread, (s.tip_position - b.tip_position).norm());
    }
    return band;
  };
  // The caller's check of the newest shape: false ends the band.
  auto accepted = [&]() {
    if (!opt.check) return true;
    const std::string why = opt.check(band);
    if (why.empty()) return true;
    band.converged = false;
    band.message = why;
    return false;
  };
  if (!accepted()) return finish();
  const double mu = robot.friction().boundary;
  if (mu > 0.0 && k > 0) {
    // Levels per contact: -1, +1, interior samples (0 is the frictionless shape already).
    std::vector<double> levels{-1.0, 1.0};
    for (int i = 1; i <= opt.interior_samples; ++i) {
      const double f = static_cast<double>(i) / (opt.interior_samples + 1);
      levels.push_back(-1.0 + 2.0 * f);
    }
    std::size_t combos = 1;
    for (std::size_t c = 0; c < k; ++c) combos *= levels.size();
    const std::size_t cap = 4096;
    if (combos > cap) {
      levels = {-1.0, 1.0};
      combos = std::size_t(1) << k;
    }
    for (std::size_t code = 0; code < combos; ++code) {
      std::vector<ContactCondition> cond(k);
      std::vector<double> frac(k);
      std::size_t x = code;
      bool all_zero = true;
      for (std::size_t c = 0; c < k; ++c, x /= levels.size()) {
        frac[c] = levels[x % levels.size()];
        cond[c] = {ContactCondition::Law::Torque, frac[c]};
        all_zero = all_zero && std::abs(frac[c]) < 1e-12;
      }
      if (all_zero) continue;
      const Solution* warm = followed(frac);
      Solution s = solveWithContacts(robot, q, cond, ws, opt.kinematics, warm ? warm : &band.shapes[0]);
      if (!s.converged()) {
        band.converged = false;
        band.message = "a band vertex did not converge: " + s.summary.message;
        if (opt.check) return finish();
        continue;
      }
      band.shapes.push_back(std::move(s));
      band.torque_fractions.push_back(frac);
      if (!accepted()) return finish();
    }
  }
  return finish();
}

}  // namespace ctr
