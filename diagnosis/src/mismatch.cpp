// Statistical localisation of model-recording mismatch.
#include "ctr/diagnosis/mismatch.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include "ctr/diagnosis/statistics.hpp"

namespace ctr::diagnosis {

namespace {
const double kNaN = std::numeric_limits<double>::quiet_NaN();

std::string fmt(const char* f, double a, double b = 0, double c = 0, double d = 0) {
  char buf[256];
  std::snprintf(buf, sizeof buf, f, a, b, c, d);
  return buf;
}

void directionAndSpeed(const io::Recording& rec, const Eigen::VectorXd& cont, ConfigVariable& v) {
  const int rows = rec.rows();
  v.direction = Eigen::VectorXd::Zero(rows);
  v.speed = Eigen::VectorXd::Constant(rows, kNaN);
  double dir = 0;
  const double eps = 1e-9;
  for (int k = 1; k < rows; ++k) {
    const double d = cont[k] - cont[k - 1];
    if (d > eps)
      dir = 1;
    else if (d < -eps)
      dir = -1;
    v.direction[k] = dir;
    if (rec.hasTime() && rec.time[k] > rec.time[k - 1]) v.speed[k] = std::abs(d) / (rec.time[k] - rec.time[k - 1]);
  }
  if (rows > 1) v.speed[0] = v.speed[1];
}
}  // namespace

std::vector<ConfigVariable> configVariables(const io::Recording& rec) {
  std::vector<ConfigVariable> out;
  const int n = rec.tubes, rows = rec.rows();
  if (rows == 0) return out;
  bool tube1_turns = false;
  for (const Configuration& q : rec.commands) tube1_turns = tube1_turns || q.alpha[0] != 0.0;
  for (int i = 0; i < n; ++i) {
    Eigen::VectorXd a(rows);
    for (int k = 0; k < rows; ++k) {
      const Configuration& q = rec.commands[static_cast<std::size_t>(k)];
      a[k] = q.alpha[i] - (i > 0 ? q.alpha[0] : 0.0);
    }
    if (a.maxCoeff() - a.minCoeff() > 1e-6) {
      ConfigVariable v;
      v.name = "alpha_" + std::to_string(i + 1) + (i > 0 && tube1_turns ? "-alpha_1" : "");
      v.angle = true;
      v.value = a.unaryExpr([](double x) { return x - 2 * M_PI * std::floor((x + M_PI) / (2 * M_PI)); });
      directionAndSpeed(rec, a, v);
      out.push_back(std::move(v));
    }
  }
  for (int i = 0; i < n; ++i) {
    Eigen::VectorXd b(rows);
    for (int k = 0; k < rows; ++k) b[k] = rec.commands[static_cast<std::size_t>(k)].beta[i];
    if (b.maxCoeff() - b.minCoeff() > 1e-7) {
      ConfigVariable v;
      v.name = "beta_" + std::to_string(i + 1);
      v.value = b;
      directionAndSpeed(rec, b, v);
      out.push_back(std::move(v));
    }
  }
  return out;
}

NoiseTest testAgainstNoise(const io::Recording& rec, const Residuals& r, const NoiseLevels& noise,
                           const std::vector<char>& use) {
  NoiseTest t;
  const std::vector<Quantity> qs = presentQuantities(rec);
  for (Quantity q : qs) {
    const Eigen::MatrixXd& R = r.of(q);
    const double sd = noise.of(q);
    double cq = 0;
    int dq = 0;
    for (Eigen::Index k = 0; k < R.rows(); ++k)
      if ((use.empty() || (k < static_cast<Eigen::Index>(use.size()) && use[static_cast<std::size_t>(k)])) &&
          R.row(k).allFinite() && sd > 0) {
        cq += R.row(k).squaredNorm() / (sd * sd);
        dq += rowDof(q, R.cols());
      }
    t.chi += cq;
    t.dof += dq;
    if (dq > 0) t.p_value = std::min(t.p_value, stats::fSf(cq / dq, dq, noise.dof(q)) * static_cast<double>(qs.size()));
  }
  t.p_value = std::min(1.0, t.p_value);
  if (t.dof > 0) t.ratio = t.chi / t.dof;
  return t;
}

MismatchReport locateMismatch(const io::Recording& rec, const Prediction& p, const Residuals& r,
                              const NoiseLevels& noise, const MismatchOptions& o) {
  MismatchReport rep;
  const int rows = rec.rows();
  const std::vector<Quantity> qs = presentQuantities(rec);
  const std::vector<ConfigVariable> vars = configVariables(rec);
  // The global test (testAgainstNoise). The family-wise false-alarm rate alpha is shared equally by the four
  // families of tests (global, bins, direction, scaling).
  const NoiseTest global = testAgainstNoise(rec, r, noise);
  const double ratio_all = global.dof ? global.ratio : 0.0;
  rep.global_p_value = global.p_value;
  rep.exceeds_noise = rep.global_p_value < o.alpha / 4 && global.chi > 1.3 * global.dof;
  {
    MismatchFinding g{"exceeds_noise", "all",
                      "all",           rep.global_p_value,
                      ratio_all,       fmt("all rows: residuals are %.2f x the noise variance", ratio_all)};
    rep.tests.push_back(g);
  }
  const int B = std::max(2, o.bins);
  const double alpha_bins = o.alpha / 4 / std::max<std::size_t>(1, B * vars.size() * qs.size());
  const double alpha_vars = o.alpha / 4 / std::max<std::size_t>(1, vars.size() * qs.size());
  // Per-row signed hysteresis values collected for the scaling tests.
  Eigen::VectorXd hyst = Eigen::VectorXd::Constant(rows, kNaN);
  double best_dir_p = 1.0;
  for (const ConfigVariable& v : vars) {
    double lo = v.angle ? -M_PI : v.value.minCoeff(), hi = v.angle ? M_PI : v.value.maxCoeff();
    if (!(hi > lo)) continue;
    auto binOf = [&](double x) { return std::clamp(static_cast<int>((x - lo) / (hi - lo) * B), 0, B - 1); };
    const double unit = v.angle ? 180.0 / M_PI : 1e3;
    const char* uname = v.angle ? "deg" : "mm";
    for (Quantity q : qs) {
      const Eigen::MatrixXd& R = r.of(q);
      const double s = noise.of(q);
      const int C = static_cast<int>(R.cols());
      std::vector<double> bchi(static_cast<std::size_t>(B), 0.0);
      std::vector<int> bcnt(static_cast<std::size_t>(B), 0), brows(static_cast<std::size_t>(B), 0);
      std::vector<std::vector<int>> members(static_cast<std::size_t>(B));
      for (int k = 0; k < rows; ++k) {
        if (!R.row(k).allFinite()) continue;
        const int b = binOf(v.value[k]);
        members[static_cast<std::size_t>(b)].push_back(k);
        bchi[static_cast<std::size_t>(b)] += R.row(k).squaredNorm() / (s * s);
        bcnt[static_cast<std::size_t>(b)] += rowDof(q, C);
        brows[static_cast<std::size_t>(b)] += 1;
      }
      // Bins beyond the noise.
      std::vector<std::pair<double, int>> sig;
      for (int b = 0; b < B; ++b) {
        if (bcnt[static_cast<std::size_t>(b)] == 0) continue;
        const double ratio = bchi[static_cast<std::size_t>(b)] / bcnt[static_cast<std::size_t>(b)];
        const double pb = stats::fSf(ratio, bcnt[static_cast<std::size_t>(b)], noise.dof(q));
        if (pb < alpha_bins && ratio > 1.5) sig.push_back({pb, b});
      }
      std::sort(sig.begin(), sig.end());
      for (std::size_t j = 0; j < sig.size() && static_cast<int>(j) < o.max_bin_reports; ++j) {
        const int b = sig[j].second;
        const double a0 = lo + (hi - lo) * b / B, a1 = lo + (hi - lo) * (b + 1) / B;
        const double ratio = std::sqrt(bchi[static_cast<std::size_t>(b)] / bcnt[static_cast<std::size_t>(b)]);
        MismatchFinding f{"exceeds_noise",
                          v.name,
                          toString(q),
                          sig[j].first,
                          ratio,
                          v.name + fmt(" in [%.1f, %.1f] ", a0 * unit, a1 * unit) + uname + ": " + toString(q) +
                              fmt(" residual RMS %.1f x noise (%.0f rows)", ratio, brows[static_cast<std::size_t>(b)])};
        rep.findings.push_back(f);
      }
      // Binned tables for plots (split by direction).
      for (int b = 0; b < B; ++b)
        for (int d : {1, -1}) {
          BinSummary bs;
          bs.variable = v.name;
          bs.quantity = toString(q);
          bs.lo = lo + (hi - lo) * b / B;
          bs.hi = lo + (hi - lo) * (b + 1) / B;
          bs.direction = d;
          double sum = 0, ss = 0;
          for (int k : members[static_cast<std::size_t>(b)]) {
            if (v.direction[k] != d) continue;
            ++bs.count;
            const double val = q == Quantity::Twist ? R(k, 0) : R.row(k).norm();
            sum += val;
            ss += q == Quantity::Twist ? R.row(k).squaredNorm() / C : R.row(k).squaredNorm();
          }
          if (bs.count == 0) continue;
          bs.mean = sum / bs.count;
          bs.rms = std::sqrt(ss / bs.count);
          rep.bins.push_back(bs);
        }
      // Direction dependence: per bin, r = a + b (x - xbar) + c dir; chi-square of the c's (pooled variance).
      struct BinFit {
        Eigen::MatrixXd coef;  // 3 x C
        double var_c = 0;      // (X^T X)^-1 (2, 2)
        std::vector<int> rows;
        double xbar = 0;
      };
      std::vector<BinFit> fits;
      double pooled_ss = 0;
      int pooled_dof = 0;
      for (int b = 0; b < B; ++b) {
        std::vector<int> m;
        int np = 0, nm = 0;
        for (int k : members[static_cast<std::size_t>(b)]) {
          if (v.direction[k] == 0) continue;
          m.push_back(k);
          (v.direction[k] > 0 ? np : nm)++;
        }
        if (np < 2 || nm < 2 || m.size() < 5) continue;
        BinFit bf;
        for (int k : m) bf.xbar += v.value[k];
        bf.xbar /= static_cast<double>(m.size());
        Eigen::MatrixXd X(static_cast<Eigen::Index>(m.size()), 3), Y(static_cast<Eigen::Index>(m.size()), C);
        for (std::size_t i = 0; i < m.size(); ++i) {
          const int k = m[i];
          X.row(static_cast<Eigen::Index>(i)) << 1.0, (v.value[k] - bf.xbar) / (hi - lo), v.direction[k];
          Y.row(static_cast<Eigen::Index>(i)) = R.row(k);
        }
        const Eigen::Matrix3d XtX = X.transpose() * X;
        if (std::abs(XtX.determinant()) < 1e-12) continue;
        const Eigen::Matrix3d inv = XtX.inverse();
        bf.coef = inv * X.transpose() * Y;
        bf.var_c = inv(2, 2);
        pooled_ss += (Y - X * bf.coef).squaredNorm();
        pooled_dof += (static_cast<int>(m.size()) - 3) * C;
        bf.rows = m;
        fits.push_back(bf);
      }
      if (fits.size() >= 1 && pooled_dof >= 3) {
        // The pooled variance is at least the noise variance per component (residual model error inflates it, never
        // deflates; a tangent's noise variance s^2 is spread over its 3 components as 2 s^2 / 3).
        const double s2 = std::max(pooled_ss / pooled_dof, s * s * rowDof(q, C) / C);
        double chid = 0;
        int dofd = 0;
        double width = 0;
        for (const BinFit& bf : fits) {
          chid += bf.coef.row(2).squaredNorm() / (s2 * bf.var_c);
          dofd += C;
          width = std::max(width, 2 * bf.coef.row(2).norm());
        }
        const double pd = stats::chiSquareSf(chid, dofd);
        MismatchFinding f{"direction_dependent", v.name, toString(q), pd, chid / std::max(1, dofd), ""};
        f.where = toString(q) + std::string(" differs between approaching ") + v.name +
                  " from below and from above at the same configuration" +
                  fmt(": largest gap %.3g ", width * (q == Quantity::Twist         ? 180 / M_PI
                                                      : q == Quantity::TipPosition ? 1e3
                                                                                   : 1.0)) +
                  (q == Quantity::Twist         ? "deg"
                   : q == Quantity::TipPosition ? "mm"
                                                : "(unit vector)") +
                  fmt(", %.0f bins compared", static_cast<double>(fits.size()));
        rep.tests.push_back(f);
        if (pd < alpha_vars) {
          rep.findings.push_back(f);
          best_dir_p = std::min(best_dir_p, pd);
          for (const BinFit& bf : fits) {
            const Eigen::VectorXd c = bf.coef.row(2).transpose();
            if (c.norm() <= 0) continue;
            const Eigen::VectorXd u = c / c.norm();
            for (int k : bf.rows) {
              const Eigen::VectorXd base =
                  bf.coef.row(0).transpose() + bf.coef.row(1).transpose() * (v.value[k] - bf.xbar) / (hi - lo);
              const double h = v.direction[k] * u.dot(R.row(k).transpose() - base);
              if (!std::isfinite(hyst[k]) || std::abs(h) > std::abs(hyst[k])) hyst[k] = h;
            }
          }
        }
      }
    }
  }
  // Scaling of the size of the residuals (and of the direction-dependent part) with moment, speed, time.
  const Eigen::VectorXd e = rowScores(rec, r, noise).cwiseSqrt();
  Eigen::VectorXd speed = Eigen::VectorXd::Constant(rows, kNaN);
  if (rec.hasTime())
    for (const ConfigVariable& v : vars) {
      const double typical = v.speed.array().isFinite().select(v.speed, 0.0).maxCoeff();
      if (!(typical > 0)) continue;
      for (int k = 0; k < rows; ++k)
        if (std::isfinite(v.speed[k]))
          speed[k] = std::max(std::isfinite(speed[k]) ? speed[k] : 0.0, v.speed[k] / typical);
    }
  Eigen::VectorXd t(rows);
  for (int k = 0; k < rows; ++k) t[k] = rec.hasTime() ? rec.time[k] : k;
  const double a3 = o.alpha / 4 / 6;  // the scaling family: at most 6 correlation tests
  auto scaling = [&](const Eigen::VectorXd& y, const char* what, bool directional) {
    bool any = false;
    struct Cov {
      const char* sig;
      const char* var;
      const Eigen::VectorXd* x;
    };
    std::vector<Cov> covs{{"scales_with_moment", "moment", &p.moment}};
    if (rec.hasTime()) covs.push_back({"scales_with_speed", "speed", &speed});
    if (!directional) covs.push_back({"drift", "time", &t});
    for (const Cov& c : covs) {
      const stats::Correlation cr = stats::spearman(*c.x, y);
      if (cr.n < 8) continue;
      MismatchFinding f{c.sig,
                        c.var,
                        what,
                        cr.p_value,
                        cr.r,
                        std::string(directional ? "the direction-dependent part" : "the size") + " of the residuals " +
                            (cr.r > 0 ? "grows" : "shrinks") + " with " +
                            (std::string(c.var) == "moment"  ? "the concentrated bending moment"
                             : std::string(c.var) == "speed" ? "the actuator speed"
                                                             : "time (drift)") +
                            fmt(" (Spearman r = %.2f, n = %.0f)", cr.r, cr.n)};
      rep.tests.push_back(f);
      if (cr.p_value < a3 && cr.r > 0) {
        rep.findings.push_back(f);
        any = true;
      }
    }
    return any;
  };
  bool scaled = false;
  if (best_dir_p < o.alpha) scaled = scaling(hyst, "hysteresis", true) || scaled;
  if (rep.exceeds_noise) scaled = scaling(e, "all", false) || scaled;
  if (rep.exceeds_noise && !scaled && best_dir_p >= alpha_vars)
    rep.findings.push_back({"constant", "all", "all", rep.global_p_value, 0.0,
                            "residuals exceed the noise but depend neither on direction, moment, speed nor time"});
  std::stable_sort(rep.findings.begin(), rep.findings.end(),
                   [](const MismatchFinding& a, const MismatchFinding& b) { return a.p_value < b.p_value; });
  if (rep.exceeds_noise) rep.findings.insert(rep.findings.begin(), rep.tests.front());
  return rep;
}

}  // namespace ctr::diagnosis
