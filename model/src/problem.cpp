// Problem set-up: segments between discontinuities, breakpoints with their events, active contacts.
#include "problem.hpp"

#include "solvers.hpp"

#include <algorithm>
#include <cmath>

namespace ctr {

using detail::kSameS;

namespace {

double disconStart(const Robot& r, const Configuration& q, int i) {
  return q.beta[i] + r.tube(i).straight_length;
}

bool hasDiscontinuity(const Robot& r, const Configuration& q, int i) {
  const Tube& t = r.tube(i);
  const double sd = disconStart(r, q, i);
  return t.curvature != 0.0 && t.curved_length > 0.0 && t.straight_length > 0.0 && sd > kSameS &&
         sd < distalEnd(r, q, i) - kSameS;
}

}  // namespace

std::vector<ContactSite> contactSites(const Robot& robot, const Configuration& q) {
  std::vector<ContactSite> sites;
  const int n = robot.size();
  if (n < 2) return sites;
  sites.reserve(static_cast<std::size_t>(2 * n));
  for (int i = 0; i + 1 < n; ++i) {
    const double e = distalEnd(robot, q, i);
    if (e > kSameS) sites.push_back({MomentKind::TubeEnd, i, i, i + 1, e});
  }
  for (int j = 0; j < n; ++j) {
    if (!hasDiscontinuity(robot, q, j)) continue;
    const double sd = disconStart(robot, q, j);
    int outer = -1, inner = -1;
    if (j > 0 && distalEnd(robot, q, j - 1) > sd + kSameS) {
      outer = j - 1;
      inner = j;
    } else if (j + 1 < n) {
      outer = j;
      inner = j + 1;
    }
    if (outer >= 0) sites.push_back({MomentKind::CurvatureDiscontinuity, j, outer, inner, sd});
  }
  // Stable insertion sort by s (a handful of sites; std::stable_sort would allocate a buffer per call).
  for (std::size_t k = 1; k < sites.size(); ++k)
    for (std::size_t j = k; j > 0 && sites[j].s < sites[j - 1].s; --j) std::swap(sites[j], sites[j - 1]);
  return sites;
}

namespace detail {

void Problem::setup(const Robot& robot, const Configuration& q, const std::vector<ContactCondition>* conditions,
                    const KinematicsOptions& opt, double kappa_scale, double step_factor) {
  const double max_step = step_factor * opt.max_step;
  const double max_bending_per_step = step_factor * opt.max_bending_per_step;
  const bool per_segment = opt.bending_limit_per_segment;
  n = robot.size();
  mu_boundary = robot.friction().boundary;
  kb.resize(n);
  kt.resize(n);
  kappa.resize(n);
  alpha = q.alpha;
  beta = q.beta;
  end.resize(n);
  disc.resize(n);
  for (int i = 0; i < n; ++i) {
    const Tube& t = robot.tube(i);
    kb[i] = t.bending_stiffness;
    kt[i] = t.torsional_stiffness;
    kappa[i] = t.curvature * kappa_scale;
    end[i] = distalEnd(robot, q, i);
    disc[i] = disconStart(robot, q, i);
  }
  s_tip = end.maxCoeff();
  s_twist = end[0];
  const double kmax = kappa.cwiseAbs().maxCoeff();  // the whole robot's (bending limit not per segment)

  // Active contacts (those with an unknown torque).
  contacts.clear();
  if (conditions) {
    const std::vector<ContactSite> sites = contactSites(robot, q);
    for (std::size_t c = 0; c < sites.size() && c < conditions->size(); ++c) {
      // Every site gets an unknown (Free ones a trivial one, tau = 0) so that all report their relative twist.
      ContactCondition cc = (*conditions)[c];
      if (cc.law == ContactCondition::Law::Torque && (cc.value == 0.0 || mu_boundary == 0.0))
        cc = ContactCondition{ContactCondition::Law::Free, 0.0};
      ActiveContact ac;
      ac.site = sites[c];
      ac.condition = cc;
      ac.site_index = static_cast<int>(c);
      contacts.push_back(ac);
    }
  }
  m = n + static_cast<int>(contacts.size());

  // Breakpoints.
  std::vector<double> pts;
  pts.reserve(static_cast<std::size_t>(2 * n + 1));
  pts.push_back(0.0);
  for (int i = 0; i < n; ++i) {
    if (end[i] > kSameS) pts.push_back(end[i]);
    if (hasDiscontinuity(robot, q, i)) pts.push_back(disc[i]);
  }
  std::sort(pts.begin(), pts.end());
  std::size_t kept = 0;  // merge breakpoints closer than kSameS (in place)
  for (double p : pts)
    if (kept == 0 || p > pts[kept - 1] + kSameS) pts[kept++] = p;
  pts.resize(kept);
  const std::vector<double>& uniq = pts;

  // Segments and breakpoints are rebuilt in place: their vectors keep their storage from the previous solve.
  const std::size_t count = uniq.size() > 1 ? uniq.size() - 1 : 0;
  segments.resize(count);
  breakpoints.resize(count);
  for (std::size_t b = 0; b < count; ++b) {
    Segment& sg = segments[b];
    sg.s0 = uniq[b];
    sg.s1 = uniq[b + 1];
    const double mid = 0.5 * (sg.s0 + sg.s1);
    // Step: at most max_step, and at most max_bending_per_step over the largest precurvature of the tubes curved on
    // this segment (the backbone curvature is a weighted mean of theirs; where no tube is curved nothing bends), or
    // of the whole robot when not per segment.
    double kseg = per_segment ? 0.0 : kmax;
    if (per_segment)
      for (int i = 0; i < n; ++i)
        if (end[i] > mid && mid > disc[i]) kseg = std::max(kseg, std::abs(kappa[i]));
    const double h_max =
        kseg > 0.0 && max_bending_per_step > 0.0 ? std::min(max_step, max_bending_per_step / kseg) : max_step;
    sg.steps = std::max(1, static_cast<int>(std::ceil((sg.s1 - sg.s0) / h_max - 1e-9)));
    sg.h = (sg.s1 - sg.s0) / sg.steps;
    sg.present.assign(static_cast<std::size_t>(n), 0);
    sg.a.setZero(n);
    sg.w.setZero(n);
    sg.K = 0.0;
    sg.outermost = n - 1;
    for (int i = n - 1; i >= 0; --i) {
      if (end[i] > mid) {
        sg.present[static_cast<std::size_t>(i)] = 1;
        sg.K += kb[i];
        sg.outermost = i;
      }
    }
    for (int i = 0; i < n; ++i) {
      if (!sg.present[static_cast<std::size_t>(i)]) continue;
      const bool curved = mid > disc[i] && kappa[i] != 0.0;
      if (curved) {
        sg.w[i] = kb[i] * kappa[i];
        sg.a[i] = kb[i] / kt[i] * kappa[i] / sg.K;
      }
    }
    Breakpoint& bp = breakpoints[b];
    bp.s = sg.s1;
    bp.ending.clear();
    bp.discontinuities.clear();
    bp.contacts.clear();
    for (int i = 0; i < n; ++i)
      if (std::abs(end[i] - sg.s1) <= kSameS) bp.ending.push_back(i);
    for (int i = 0; i < n; ++i)
      if (hasDiscontinuity(robot, q, i) && std::abs(disc[i] - sg.s1) <= kSameS) bp.discontinuities.push_back(i);
    for (std::size_t c = 0; c < contacts.size(); ++c)
      if (std::abs(contacts[c].site.s - sg.s1) <= kSameS) bp.contacts.push_back(static_cast<int>(c));
    bp.twist_point = std::abs(sg.s1 - s_twist) <= kSameS;
  }
}

Solution inadmissibleSolution(const Configuration& q, const std::string& why, int n, bool loaded) {
  Solution s;
  s.q = q;
  s.loaded = loaded;
  s.summary.status = SolveStatus::Inadmissible;
  s.summary.message = why;
  s.base_twist_rate = Eigen::VectorXd::Zero(n);
  s.theta0 = Eigen::VectorXd::Zero(n);
  s.twist = Eigen::VectorXd::Zero(std::max(0, n - 1));
  return s;
}

}  // namespace detail
}  // namespace ctr
