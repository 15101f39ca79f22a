// Solver robustness sweep: random admissible configurations, cold and warm starts, every converged result verified
// (distal boundary conditions, proximal transmission condition, torque-balance invariant, re-integration at half the
// step size). Shared by the ctr_robustness executable and the fast test subset.
#pragma once

#include <chrono>
#include <cmath>
#include <map>
#include <random>
#include <sstream>
#include <string>

#include "ctr/model.hpp"

namespace ctr::robustness {

struct Tally {
  long samples = 0, converged = 0, stable = 0, unstable = 0, not_converged = 0, silent_wrong = 0;
  long iterations = 0, max_iterations = 0, homotopy_used = 0;
  double seconds = 0;
  std::map<std::string, long> failure_classes;  // reason -> count (not converged or verification failure)
  void add(const Tally& o) {
    samples += o.samples;
    converged += o.converged;
    stable += o.stable;
    unstable += o.unstable;
    not_converged += o.not_converged;
    silent_wrong += o.silent_wrong;
    iterations += o.iterations;
    max_iterations = std::max(max_iterations, o.max_iterations);
    homotopy_used += o.homotopy_used;
    seconds += o.seconds;
    for (auto& [k, v] : o.failure_classes) failure_classes[k] += v;
  }
};

// Verifies a converged solution; returns an empty string or what failed.
inline std::string verify(const Robot& r, const Solution& s, Workspace& ws, const KinematicsOptions& opt) {
  const int n = r.size();
  const Configuration& q = s.q;
  double scale = 1e-6, ktsum = 0;
  for (int i = 0; i < n; ++i) {
    scale = std::max(scale, std::abs(r.tube(i).torsional_stiffness * s.base_twist_rate[i]));
    ktsum += r.tube(i).torsional_stiffness;
  }
  // At a tube's end node u_z equals the Newton residual (<= tolerance), which enters the sum there.
  const double torque_tol = 1e-8 * scale + 10.0 * opt.tolerance * ktsum;
  // Proximal transmission condition theta_i(0) = alpha_i - beta_i u_iz(0).
  const BackbonePoint& p0 = s.backbone.front();
  for (int i = 0; i < n; ++i) {
    if (std::abs(p0.theta[i] - (q.alpha[i] - q.beta[i] * p0.uz[i])) > 1e-9) return "proximal condition";
  }
  // Distal conditions: u_iz = 0 at every tube end (node recorded just before the end's events).
  for (int i = 0; i < n; ++i) {
    const double e = q.beta[i] + r.tube(i).length();
    if (e <= 0) continue;
    bool found = false;
    for (const BackbonePoint& p : s.backbone)
      if (std::abs(p.s - e) < 1e-12) {
        found = true;
        if (std::abs(p.uz[i]) > 1e-8 * std::max(1.0, s.base_twist_rate.cwiseAbs().maxCoeff()))
          return "distal condition";
        break;
      }
    if (!found) return "distal node missing";
  }
  // Torque balance: sum of k_t u_z over present tubes vanishes along s.
  for (const BackbonePoint& p : s.backbone) {
    double sum = 0;
    for (int i = 0; i < n; ++i)
      if (q.beta[i] + r.tube(i).length() > p.s + 1e-12) sum += r.tube(i).torsional_stiffness * p.uz[i];
    if (std::abs(sum) > torque_tol) return "torque balance";
  }
  // Independent re-integration at half the step size, warm-started from the solution.
  KinematicsOptions half = opt;
  half.max_step = 0.5 * opt.max_step;
  half.record_backbone = false;
  half.homotopy = false;
  const Solution h = solve(r, q, ws, half, &s);
  if (!h.converged()) return "half-step re-solve failed";
  if ((h.tip_position - s.tip_position).norm() > 1e-6) return "half-step tip disagrees";
  if (n > 1 && (h.twist - s.twist).cwiseAbs().maxCoeff() > 1e-5) return "half-step twist disagrees";
  return {};
}

inline void classify(const Robot& r, const Solution& s, Workspace& ws, const KinematicsOptions& opt, Tally& t) {
  ++t.samples;
  t.iterations += s.summary.iterations;
  t.max_iterations = std::max<long>(t.max_iterations, s.summary.iterations);
  if (s.summary.continuation_steps > 0) ++t.homotopy_used;
  if (!s.converged()) {
    ++t.not_converged;
    std::string why = s.summary.message.substr(0, s.summary.message.find(" ("));
    t.failure_classes["not converged: " + why]++;
    return;
  }
  const std::string bad = verify(r, s, ws, opt);
  if (!bad.empty()) {
    ++t.silent_wrong;
    t.failure_classes["SILENT WRONG: " + bad]++;
    return;
  }
  ++t.converged;
  if (s.summary.stable) {
    ++t.stable;
  } else {
    ++t.unstable;
  }
}

/// Cold solves of `count` uniform admissible configurations and warm solves of each from a random neighbour.
inline void sweep(const Robot& r, long count, unsigned seed, Tally& cold, Tally& warm) {
  std::mt19937_64 rng(seed);
  const TranslationSampler sampler(r);
  Workspace ws;
  KinematicsOptions opt;
  std::normal_distribution<double> da(0.0, 0.15), db(0.0, 0.003);
  for (long k = 0; k < count; ++k) {
    const Configuration q = sampleConfiguration(r, sampler, rng);
    auto t0 = std::chrono::steady_clock::now();
    const Solution c = solve(r, q, ws, opt);
    cold.seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    classify(r, c, ws, opt, cold);
    // Warm start from a random admissible neighbour's solution.
    Configuration nb = q;
    for (int i = 0; i < r.size(); ++i) {
      nb.alpha[i] += da(rng);
      nb.beta[i] += db(rng);
    }
    if (!checkAdmissible(r, nb)) nb = q;
    const Solution from = solve(r, nb, ws, opt);
    if (!from.converged()) continue;
    t0 = std::chrono::steady_clock::now();
    const Solution w = solve(r, q, ws, opt, &from);
    warm.seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    classify(r, w, ws, opt, warm);
  }
}

inline std::string report(const std::string& name, const Tally& t) {
  std::ostringstream os;
  os.setf(std::ios::fixed);
  os.precision(3);
  const double N = std::max<long>(1, t.samples);
  os << "| " << name << " | " << t.samples << " | " << 100.0 * t.converged / N << " % | " << 100.0 * t.stable / N
     << " % | " << t.unstable << " | " << t.not_converged << " | " << t.silent_wrong << " | "
     << static_cast<double>(t.iterations) / N << " / " << t.max_iterations << " | " << t.homotopy_used << " | "
     << 1e6 * t.seconds / N << " |";
  return os.str();
}

}  // namespace ctr::robustness
