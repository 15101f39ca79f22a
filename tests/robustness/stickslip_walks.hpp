// Stick-slip friction robustness: random walks of quasi-static steps (friction.hpp `step`) with random step sizes
// in rotation and admissible translation and random reversals. After every step: a status is returned (converged,
// or explicitly not converged / inadmissible); a converged step keeps every lumped friction torque within
// mu'|m|, applies it as an equal and opposite pair (jumps of k_t u_z at the site), keeps the total torque
// sum k_t u_z = 0 along the backbone, and leaves a finite hysteresis state. A sample of converged steps is
// re-solved independently (every contact stuck at the returned relative twist, half the integration step, warm
// start from the previous step instead of this one): torques, tip and twist must agree.
// Shared by the ctr_robustness executable (--walks) and the fast test subset.
#pragma once

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cmath>
#include <map>
#include <random>
#include <sstream>
#include <string>

#include "ctr/model.hpp"
#include "ctr/model/friction.hpp"

namespace ctr::robustness {

struct WalkTally {
  long walks = 0, steps = 0, converged = 0, not_converged = 0, inadmissible = 0, silent_wrong = 0;
  long snapped = 0, enumerated = 0, inconsistent_reported = 0, substeps = 0;
  long active_set_iterations = 0, max_active_set_per_step = 0;
  double max_active_set_per_substep = 0;  // iterations / sub-steps of a step (upper bound of the per-sub-step mean)
  long slipping_contacts = 0, stuck_contacts = 0;
  long resolved = 0, resolve_failed = 0;  // independent re-solves (sample) and their disagreements
  double max_bound_ratio = 0;             // max |T| / (mu'|m|) over converged steps
  double max_pair_error = 0, max_balance_error = 0;  // relative to the torque scale
  double max_resolve_torque = 0, max_resolve_tip = 0;
  double seconds = 0;
  std::map<std::string, long> failure_classes;
  void add(const WalkTally& o) {
    walks += o.walks;
    steps += o.steps;
    converged += o.converged;
    not_converged += o.not_converged;
    inadmissible += o.inadmissible;
    silent_wrong += o.silent_wrong;
    snapped += o.snapped;
    enumerated += o.enumerated;
    inconsistent_reported += o.inconsistent_reported;
    substeps += o.substeps;
    active_set_iterations += o.active_set_iterations;
    max_active_set_per_step = std::max(max_active_set_per_step, o.max_active_set_per_step);
    max_active_set_per_substep = std::max(max_active_set_per_substep, o.max_active_set_per_substep);
    slipping_contacts += o.slipping_contacts;
    stuck_contacts += o.stuck_contacts;
    resolved += o.resolved;
    resolve_failed += o.resolve_failed;
    max_bound_ratio = std::max(max_bound_ratio, o.max_bound_ratio);
    max_pair_error = std::max(max_pair_error, o.max_pair_error);
    max_balance_error = std::max(max_balance_error, o.max_balance_error);
    max_resolve_torque = std::max(max_resolve_torque, o.max_resolve_torque);
    max_resolve_tip = std::max(max_resolve_tip, o.max_resolve_tip);
    seconds += o.seconds;
    for (auto& [k, v] : o.failure_classes) failure_classes[k] += v;
  }
};

struct WalkOptions {
  long walks = 1000;
  int steps = 200;
  unsigned seed = 1;
  double mu = 0.12;
  int resolve_every = 10;  ///< Re-solve every k-th converged step independently (0 = never).
};

inline bool stateFinite(const HysteresisState& s) {
  if (!s.q.alpha.allFinite() || !s.q.beta.allFinite() || !s.base_twist_rate.allFinite() || !s.direction.allFinite() ||
      !s.twist.allFinite() || !s.interface_direction.allFinite())
    return false;
  for (const ContactMemory& m : s.contacts)
    if (!std::isfinite(m.relative_twist) || !std::isfinite(m.torque) || !std::isfinite(m.bound)) return false;
  return true;
}

// Checks a converged step; returns an empty string or what failed. Updates the error maxima.
inline std::string verifyStep(const Robot& r, const StepResult& res, double mu, const KinematicsOptions& kopt,
                              WalkTally& t) {
  const Solution& s = res.solution;
  const int n = r.size();
  const Configuration& q = s.q;
  if (!stateFinite(res.state) || !s.tip_position.allFinite()) return "hysteresis state not finite";
  if (!res.state.valid) return "converged but state invalid";
  if ((res.state.q.alpha - q.alpha).norm() > 0 || (res.state.q.beta - q.beta).norm() > 0)
    return "state not at the commanded configuration";
  // Torque bounds.
  double scale = 1e-9, ktsum = 0;
  for (int i = 0; i < n; ++i) {
    scale = std::max(scale, std::abs(r.tube(i).torsional_stiffness * s.base_twist_rate[i]));
    ktsum += r.tube(i).torsional_stiffness;
  }
  for (const ContactResult& c : s.contacts) {
    const double bound = mu * c.moment;
    scale = std::max(scale, std::abs(c.torque));
    if (!std::isfinite(c.torque) || !std::isfinite(c.moment)) return "contact torque not finite";
    if (bound > 0) t.max_bound_ratio = std::max(t.max_bound_ratio, std::abs(c.torque) / bound);
    if (std::abs(c.torque) > bound * (1.0 + 1e-8) + 1e-14) return "torque bound";
    if (std::abs(c.torque) >= bound * (1.0 - 1e-9) && bound > 0) {
      ++t.slipping_contacts;
    } else {
      ++t.stuck_contacts;
    }
  }
  if (s.backbone.empty()) return "backbone missing";
  const double tol = 1e-8 * scale + 10.0 * kopt.tolerance * ktsum;
  auto endOf = [&](int i) { return q.beta[i] + r.tube(i).length(); };
  // Total torque balance: sum of k_t u_z over tubes present on the node's side of a boundary vanishes.
  for (std::size_t k = 0; k < s.backbone.size(); ++k) {
    const BackbonePoint& p = s.backbone[k];
    const bool after = p.segment_start || k + 1 == s.backbone.size();
    double sum = 0;
    for (int i = 0; i < n; ++i) {
      const double e = endOf(i);
      const bool present = after ? e > p.s + 1e-12 : e > p.s - 1e-12;
      if (present) sum += r.tube(i).torsional_stiffness * p.uz[i];
    }
    t.max_balance_error = std::max(t.max_balance_error, std::abs(sum) / scale);
    if (std::abs(sum) > tol) return "torque balance";
  }
  // Equal and opposite pairs: at each contact arc length, the point torque on each tube (sum over the contacts
  // there of +T on the inner tube, -T on the outer one) equals the jump of k_t u_z (continuing tube) or
  // k_t u_z(s-) (tube ending there).
  std::vector<double> done;
  for (const ContactResult& c0 : s.contacts) {
    const double sc = c0.site.s;
    if (std::any_of(done.begin(), done.end(), [&](double d) { return std::abs(d - sc) <= 1e-12; })) continue;
    done.push_back(sc);
    Eigen::VectorXd P = Eigen::VectorXd::Zero(n);
    for (const ContactResult& c : s.contacts)
      if (std::abs(c.site.s - sc) <= 1e-12) {
        P[c.site.inner] += c.torque;
        P[c.site.outer] -= c.torque;
      }
    const BackbonePoint *before = nullptr, *afterp = nullptr;
    for (std::size_t k = 0; k < s.backbone.size(); ++k) {
      const BackbonePoint& p = s.backbone[k];
      if (std::abs(p.s - sc) > 1e-12) continue;
      if (!p.segment_start && k + 1 < s.backbone.size()) before = &p;
      if (p.segment_start) afterp = &p;
    }
    if (!before) continue;  // a site at the tip: its s- node is overwritten by the final values
    for (int i = 0; i < n; ++i) {
      const double e = endOf(i);
      const double kt = r.tube(i).torsional_stiffness;
      double err = 0;
      if (std::abs(e - sc) <= 1e-12) {
        err = std::abs(kt * before->uz[i] - P[i]);
      } else if (e > sc + 1e-12 && afterp) {
        err = std::abs(kt * (afterp->uz[i] - before->uz[i]) + P[i]);
      } else {
        continue;
      }
      t.max_pair_error = std::max(t.max_pair_error, err / scale);
      if (err > tol) return "equal/opposite torque pair";
    }
  }
  return {};
}

// Independent re-solve: every contact stuck at the returned relative twist, half the step, warm start from `prev`.
inline std::string resolveCheck(const Robot& r, const StepResult& res, const Solution& prev, Workspace& ws,
                                const KinematicsOptions& kopt, double mu, WalkTally& t) {
  const Solution& s = res.solution;
  const std::vector<ContactSite> sites = contactSites(r, s.q);
  if (sites.size() != s.contacts.size()) return "contact sites differ";
  std::vector<ContactCondition> cond(sites.size());
  for (std::size_t c = 0; c < sites.size(); ++c) {
    if (!(sites[c] == s.contacts[c].site)) return "contact sites differ";
    cond[c] = {ContactCondition::Law::Stick, s.contacts[c].relative_twist};
  }
  KinematicsOptions half = kopt;
  half.max_step = 0.5 * kopt.max_step;
  half.record_backbone = false;
  half.homotopy = false;
  ++t.resolved;
  const Solution h = solveWithContacts(r, s.q, cond, ws, half, &prev);
  if (!h.converged()) return "re-solve did not converge";
  const double tip = (h.tip_position - s.tip_position).norm();
  t.max_resolve_tip = std::max(t.max_resolve_tip, tip);
  if (tip > 1e-6) return "re-solve tip disagrees";
  if (r.size() > 1 && (h.twist - s.twist).cwiseAbs().maxCoeff() > 1e-5) return "re-solve twist disagrees";
  for (std::size_t c = 0; c < sites.size(); ++c) {
    const double bound = std::max(mu * s.contacts[c].moment, 1e-12);
    const double d = std::abs(h.contacts[c].torque - s.contacts[c].torque) / bound;
    t.max_resolve_torque = std::max(t.max_resolve_torque, d);
    if (d > 1e-3) return "re-solve torque disagrees";
  }
  return {};
}

/// Runs `o.walks` random walks of `o.steps` steps on robot r with boundary friction mu' = o.mu.
inline WalkTally stickSlipWalks(const Robot& r0, const WalkOptions& o) {
  const Robot r = r0.withFriction({o.mu, 0.0});
  const int n = r.size();
  std::mt19937_64 rng(o.seed);
  std::uniform_real_distribution<double> U(0.0, 1.0);
  const TranslationSampler sampler(r);
  Workspace ws;
  FrictionOptions fo;
  fo.kinematics.record_backbone = true;
  WalkTally t;
  for (long w = 0; w < o.walks; ++w) {
    ++t.walks;
    Configuration q = sampleConfiguration(r, sampler, rng);
    StepResult cur = initialState(r, q, ws, fo);
    if (!cur.summary.converged) {
      t.failure_classes["initial state not converged (reported)"]++;
      continue;
    }
    Eigen::VectorXd rot_dir(n), tr_dir(n);
    for (int i = 0; i < n; ++i) {
      rot_dir[i] = U(rng) < 0.5 ? -1.0 : 1.0;
      tr_dir[i] = U(rng) < 0.5 ? -1.0 : 1.0;
    }
    for (int k = 0; k < o.steps; ++k) {
      // Random reversals, then random step sizes (log-uniform scale, per-tube uniform fraction).
      for (int i = 0; i < n; ++i) {
        if (U(rng) < 0.15) rot_dir[i] = -rot_dir[i];
        if (U(rng) < 0.15) tr_dir[i] = -tr_dir[i];
      }
      const double rot_scale = std::exp(std::log(0.002) + U(rng) * (std::log(0.15) - std::log(0.002)));
      const double tr_scale = U(rng) < 0.5 ? 0.0 : std::exp(std::log(1e-4) + U(rng) * (std::log(3e-3) - std::log(1e-4)));
      Configuration next = cur.state.q;
      for (int i = 0; i < n; ++i) next.alpha[i] += rot_dir[i] * rot_scale * U(rng);
      if (!checkAdmissible(r, next)) {  // a rotation limit: turn back the tubes that would leave their range
        Configuration back = next;
        for (int i = 0; i < n; ++i) {
          back.alpha[i] = cur.state.q.alpha[i] - (next.alpha[i] - cur.state.q.alpha[i]);
          Configuration one = cur.state.q;
          one.alpha[i] = next.alpha[i];
          if (!checkAdmissible(r, one)) rot_dir[i] = -rot_dir[i];
          else back.alpha[i] = next.alpha[i];
        }
        next = checkAdmissible(r, back) ? back : cur.state.q;
      }
      Eigen::VectorXd db(n);
      for (int i = 0; i < n; ++i) db[i] = tr_dir[i] * tr_scale * U(rng);
      Configuration cand = next;
      cand.beta += db;
      if (!checkAdmissible(r, cand)) {
        tr_dir = -tr_dir;
        cand.beta = next.beta - db;
      }
      if (checkAdmissible(r, cand)) next = cand;
      // Now and then an inadmissible command: it must be reported and leave the state unchanged.
      const bool bad = U(rng) < 0.01;
      if (bad) next.beta[0] = 0.01;
      const Solution prev = cur.solution;
      const auto t0 = std::chrono::steady_clock::now();
      StepResult res = step(r, cur.state, next, ws, fo);
      t.seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      ++t.steps;
      t.substeps += res.summary.substeps;
      t.active_set_iterations += res.summary.active_set_iterations;
      t.max_active_set_per_step = std::max<long>(t.max_active_set_per_step, res.summary.active_set_iterations);
      if (res.summary.substeps > 0)
        t.max_active_set_per_substep = std::max(
            t.max_active_set_per_substep, static_cast<double>(res.summary.active_set_iterations) / res.summary.substeps);
      if (res.summary.enumerated) ++t.enumerated;
      if (bad) {
        if (res.solution.summary.status != SolveStatus::Inadmissible || res.summary.converged ||
            !(res.state.q.alpha == cur.state.q.alpha) || !(res.state.q.beta == cur.state.q.beta)) {
          ++t.silent_wrong;
          t.failure_classes["SILENT WRONG: inadmissible command not reported"]++;
        } else {
          ++t.inadmissible;
        }
        continue;  // state unchanged
      }
      if (res.solution.summary.status == SolveStatus::Inadmissible) {
        ++t.silent_wrong;  // the generator only sends admissible commands here
        t.failure_classes["SILENT WRONG: admissible command rejected"]++;
        continue;
      }
      if (!res.summary.converged) {
        ++t.not_converged;
        std::string why = res.summary.message;
        if (why.rfind("sub-step", 0) == 0 && why.find(": ") != std::string::npos) why = why.substr(why.find(": ") + 2);
        why = why.substr(0, why.find(':'));
        why.erase(std::remove_if(why.begin(), why.end(), [](char ch) { return std::isdigit(static_cast<unsigned char>(ch)); }),
                  why.end());
        t.failure_classes["not converged (reported): " + why]++;
        if (res.solution.summary.status == SolveStatus::Converged || !res.state.valid || !stateFinite(res.state)) {
          ++t.silent_wrong;
          t.failure_classes["SILENT WRONG: failure without a status or a usable state"]++;
        }
        if (!res.state.valid) break;
        cur.state = res.state;  // continue from the last good sub-step
        continue;
      }
      if (res.summary.snapped) ++t.snapped;
      const bool inconsistent = res.summary.message.find("no consistent stick/slip") != std::string::npos;
      if (inconsistent) ++t.inconsistent_reported;
      std::string bad_check = verifyStep(r, res, o.mu, fo.kinematics, t);
      if (bad_check.empty() && o.resolve_every > 0 && t.converged % o.resolve_every == 0 && prev.converged()) {
        const std::string rs = resolveCheck(r, res, prev, ws, fo.kinematics, o.mu, t);
        if (!rs.empty()) {
          ++t.resolve_failed;
          bad_check = rs;
        }
      }
      if (!bad_check.empty()) {
        if (inconsistent && bad_check == "torque bound") {
          t.failure_classes["inconsistent mode set (reported): " + bad_check]++;
        } else {
          ++t.silent_wrong;
          t.failure_classes["SILENT WRONG: " + bad_check]++;
        }
      } else {
        ++t.converged;
      }
      cur = std::move(res);
    }
  }
  return t;
}

inline std::string walkReport(const std::string& name, const WalkTally& t) {
  std::ostringstream os;
  os.setf(std::ios::fixed);
  os.precision(3);
  const double N = std::max<long>(1, t.steps);
  const double admissible = std::max<long>(1, t.steps - t.inadmissible);
  os << "| " << name << " | " << t.walks << " | " << t.steps << " | " << 100.0 * t.converged / admissible << " % | "
     << t.not_converged << " | " << t.inadmissible << " | " << t.silent_wrong << " | " << t.inconsistent_reported
     << " | " << t.snapped << " | "
     << t.enumerated << " | " << static_cast<double>(t.substeps) / N << " | "
     << static_cast<double>(t.active_set_iterations) / std::max<long>(1, t.substeps) << " / "
     << t.max_active_set_per_step << " | ";
  os.precision(2);
  os << 100.0 * t.slipping_contacts / std::max<long>(1, t.slipping_contacts + t.stuck_contacts) << " % | ";
  os.unsetf(std::ios::fixed);
  os.precision(3);
  os << t.max_bound_ratio << " | " << t.max_pair_error << " / " << t.max_balance_error << " | " << t.resolved << " ("
     << t.resolve_failed << " failed), max dT/bound " << t.max_resolve_torque << ", tip " << t.max_resolve_tip
     << " m | ";
  os.setf(std::ios::fixed);
  os.precision(0);
  os << 1e6 * t.seconds / N << " |";
  return os.str();
}

inline const char* walkHeader() {
  return "| robot, mu' | walks | steps | converged+verified (of admissible commands) | not converged (reported) | inadmissible (reported) | "
         "silent wrong | no consistent mode set (message only) | snapped (reported) | enumerated | sub-steps per step | active-set iterations per sub-step "
         "mean / max per step | contacts slipping | max abs(T)/mu'abs(m) | max pair / balance error (rel.) | "
         "independent re-solves | time per step (us) |\n"
         "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n";
}

}  // namespace ctr::robustness
