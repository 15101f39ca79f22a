// The measurement noise: given, from repeated poses, or from neighbouring rows, with its uncertainty.
#include "ctr/diagnosis/noise.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <set>
#include <sstream>
#include <stdexcept>

#include "ctr/diagnosis/statistics.hpp"

namespace ctr::diagnosis {

std::optional<double> GivenNoise::of(Quantity q) const {
  return q == Quantity::Twist ? twist : q == Quantity::TipPosition ? tip_position : tip_tangent;
}

GivenNoise parseGivenNoise(const std::string& text) {
  GivenNoise g;
  std::stringstream ss(text);
  std::string item;
  while (std::getline(ss, item, ',')) {
    const auto eq = item.find('=');
    if (eq == std::string::npos)
      throw std::invalid_argument("'" + item + "': expected QUANTITY=SIGMA (e.g. tip_position=0.5mm)");
    const std::string key = item.substr(0, eq), val = item.substr(eq + 1);
    const bool position = key == "tip_position";
    if (!position && key != "tip_tangent" && key != "twist")
      throw std::invalid_argument("'" + key + "': unknown quantity (known: twist, tip_position, tip_tangent)");
    // Unit suffix: positions m, mm, um; angles rad, deg.
    struct Unit {
      const char* suffix;
      double scale;
      bool length;
    };
    static const Unit units[] = {
        {"mm", 1e-3, true}, {"um", 1e-6, true}, {"m", 1.0, true}, {"deg", M_PI / 180, false}, {"rad", 1.0, false}};
    double scale = 1.0;
    std::string number = val;
    for (const Unit& u : units) {
      const std::string sfx = u.suffix;
      if (val.size() > sfx.size() && val.compare(val.size() - sfx.size(), sfx.size(), sfx) == 0) {
        if (u.length != position)
          throw std::invalid_argument("'" + item + "': unit '" + sfx + "' does not fit " + key +
                                      (position ? " (m, mm, um)" : " (rad, deg)"));
        scale = u.scale;
        number = val.substr(0, val.size() - sfx.size());
        break;
      }
    }
    std::size_t used = 0;
    double v = std::numeric_limits<double>::quiet_NaN();
    try {
      v = std::stod(number, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (number.empty() || used != number.size() || !std::isfinite(v) || !(v > 0))
      throw std::invalid_argument("'" + item + "': the standard deviation must be a positive number with a unit");
    std::optional<double>& slot = key == "twist" ? g.twist : position ? g.tip_position : g.tip_tangent;
    if (slot) throw std::invalid_argument("'" + key + "' given twice");
    slot = v * scale;
  }
  if (g.empty()) throw std::invalid_argument("no QUANTITY=SIGMA given");
  return g;
}

Eigen::VectorXd noisePart(Quantity q, Eigen::VectorXd e, const Eigen::VectorXd& t) {
  if (q == Quantity::Twist)
    for (Eigen::Index c = 0; c < e.size(); ++c) e[c] = std::remainder(e[c], 2 * M_PI);
  if (q != Quantity::TipTangent || t.size() != 3 || !t.allFinite() || !(t.norm() > 0)) return e;
  const Eigen::Vector3d u = t.normalized();
  return e - u * u.dot(e);
}

bool Visits::anyRepeated() const {
  for (int f : frames)
    if (f > 1) return true;
  return false;
}

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

bool sameCommand(const Configuration& a, const Configuration& b) {
  return a.size() == b.size() && ((a.alpha - b.alpha).cwiseAbs().maxCoeff() <= 1e-12) &&
         ((a.beta - b.beta).cwiseAbs().maxCoeff() <= 1e-12);
}

/// A difference of residuals (noise only, up to model error) with the configuration distance it spans.
struct Difference {
  double squared = 0.0;  // |e|^2 of the normalised pseudo-residual (variance sigma^2 per noisy component)
  double distance = 0.0;
};

struct VarianceEstimate {
  double variance = kNaN, dof = 0.0;
  int count = 0;
};

/// Estimate from `d` (sorted by distance: the first `use` of them), `per` noisy components each: a median-based start,
/// then the mean of the values below the 99.9 % point of the scaled chi-square (gross outliers -- a snap, a branch
/// change, a tracker glitch -- left out), corrected for that truncation: E[X | X < c] = d F_{d+2}(c) / F_d(c) for
/// X ~ chi2_d. Unbiased for Gaussian noise, with the degrees of freedom of the mean of squares (`efficiency_scale`
/// for correlated differences).
VarianceEstimate robustEstimate(const std::vector<Difference>& d, std::size_t use, double per,
                                double efficiency_scale) {
  VarianceEstimate v;
  use = std::min(use, d.size());
  if (use < 3) return v;
  std::vector<double> x(use);
  for (std::size_t i = 0; i < use; ++i) x[i] = d[i].squared;
  std::vector<double> sorted = x;
  std::nth_element(sorted.begin(), sorted.begin() + static_cast<long>(use / 2), sorted.end());
  const double start = sorted[use / 2] / stats::chiSquareQuantile(0.5, per);
  if (!(start > 0)) {
    v.variance = 0.0;
    v.dof = static_cast<double>(use) * per * efficiency_scale;
    v.count = static_cast<int>(use);
    return v;
  }
  const double c = stats::chiSquareQuantile(0.999, per);
  double sum = 0.0;
  int kept = 0;
  for (double xi : x)
    if (xi < c * start) {
      sum += xi;
      ++kept;
    }
  const double truncated_mean = per * (1.0 - stats::chiSquareSf(c, per + 2)) / 0.999;
  v.variance = kept > 0 ? sum / kept / truncated_mean : start;
  v.dof = static_cast<double>(kept) * per * efficiency_scale;
  v.count = kept;
  return v;
}

/// Differences of residuals along the path at lags 1 and 2 around row k: |r_k - r_{k-1}|^2 / 2 and
/// |r_{k+1} - r_{k-1}|^2 / 2 (noisy parts), each sigma^2 per component for independent noise.
struct LagDifferences {
  double lag1 = 0.0, lag2 = 0.0;
};

/// Tests whether the differences the estimate uses are those of independent noise: for independent noise the
/// difference of residuals two rows apart is as large as that of neighbouring rows; a filtered or oversampled stream
/// (noise shared by neighbouring rows) or model error that changes from row to row makes it larger (a 10-sample
/// moving average at 50 Hz, every second sample kept: twice as large). One-sided t test of the chunk means (10-30
/// chunks) of lag2 - lag1 at 0.1 %, and a ratio of their sums above 1.5; gross outliers (as robustEstimate screens
/// them) left out. Fewer than 100 rows: not tested.
void testSerialCorrelation(const std::vector<LagDifferences>& d, double variance, double per, NoiseEstimate& est) {
  if (!(variance > 0)) return;
  const double c = 2.0 * stats::chiSquareQuantile(0.999, per) * variance;
  std::vector<double> x;
  double s1 = 0.0, s2 = 0.0;
  for (const LagDifferences& l : d) {
    if (l.lag1 > c || l.lag2 > c) continue;
    x.push_back((l.lag2 - l.lag1) / (variance * per));
    s1 += l.lag1;
    s2 += l.lag2;
  }
  if (x.size() < 100 || !(s1 > 0)) return;
  const int n = static_cast<int>(x.size());
  est.serial_ratio = s2 / s1;
  est.serial_p = stats::chunkedMeanTest(Eigen::Map<const Eigen::VectorXd>(x.data(), n), std::clamp(n / 10, 10, 30));
  est.white = !(est.serial_p < 0.001 && est.serial_ratio > 1.5);
  if (!est.white) {
    est.supported = false;
    char b[300];
    std::snprintf(b, sizeof b,
                  "; residuals two rows apart differ %.2f x as much (in variance) as neighbouring ones (1 for "
                  "independent noise; p = %.2g): a filtered or oversampled stream, or model error from row to row -- "
                  "the noise cannot be told from these data",
                  est.serial_ratio, est.serial_p);
    est.note += b;
  }
}

/// The configuration metric of the neighbours: relative angles as (cos, sin), translations over 1 cm (1 ~ 1 rad ~
/// 1 cm).
Eigen::MatrixXd configFeatures(const io::Recording& rec) {
  const int n = rec.tubes, rows = rec.rows();
  Eigen::MatrixXd F(rows, 3 * n);
  for (int k = 0; k < rows; ++k) {
    const Configuration& q = rec.commands[static_cast<std::size_t>(k)];
    for (int i = 0; i < n; ++i) {
      const double a = q.alpha[i] - (i > 0 ? q.alpha[0] : 0.0);
      F(k, 3 * i) = std::cos(a);
      F(k, 3 * i + 1) = std::sin(a);
      F(k, 3 * i + 2) = q.beta[i] / 0.01;
    }
  }
  return F;
}

std::string fmtSigma(Quantity q, double s) {
  char b[64];
  if (q == Quantity::TipPosition)
    std::snprintf(b, sizeof b, "%.3g mm", s * 1e3);
  else
    std::snprintf(b, sizeof b, "%.3g deg", s * 180 / M_PI);
  return b;
}

}  // namespace

Visits collapseFrames(const io::Recording& rec) {
  Visits v;
  io::Recording& out = v.recording;
  out.tubes = rec.tubes;
  const int rows = rec.rows();
  std::vector<std::pair<int, int>> runs;  // [first, end)
  for (int k = 0; k < rows;) {
    int e = k + 1;
    while (e < rows &&
           sameCommand(rec.commands[static_cast<std::size_t>(e)], rec.commands[static_cast<std::size_t>(k)]))
      ++e;
    runs.push_back({k, e});
    k = e;
  }
  const int nv = static_cast<int>(runs.size());
  auto alloc = [&](const Eigen::MatrixXd& M) { return Eigen::MatrixXd(M.cols() ? nv : 0, M.cols()); };
  out.twist = alloc(rec.twist);
  out.tip_position = alloc(rec.tip_position);
  out.tip_tangent = alloc(rec.tip_tangent);
  if (rec.hasTime()) out.time.resize(nv);
  // Jitter: squared deviations of the frames from their visit's mean, per noisy component.
  std::map<Quantity, std::array<double, 2>> ss;  // {sum of squares, degrees of freedom}
  for (int j = 0; j < nv; ++j) {
    const auto [a, e] = runs[static_cast<std::size_t>(j)];
    out.commands.push_back(rec.commands[static_cast<std::size_t>(a)]);
    v.first_row.push_back(a);
    v.frames.push_back(e - a);
    if (rec.hasTime()) out.time[j] = rec.time[a];
    for (Quantity q : presentQuantities(rec)) {
      const Eigen::MatrixXd& M = q == Quantity::Twist         ? rec.twist
                                 : q == Quantity::TipPosition ? rec.tip_position
                                                              : rec.tip_tangent;
      Eigen::MatrixXd& O = q == Quantity::Twist         ? out.twist
                           : q == Quantity::TipPosition ? out.tip_position
                                                        : out.tip_tangent;
      for (Eigen::Index c = 0; c < M.cols(); ++c) {
        // Twist: circular mean (angles near +-pi); others: plain mean of the finite values.
        double sx = 0, sy = 0, s = 0;
        int m = 0;
        for (int r = a; r < e; ++r)
          if (std::isfinite(M(r, c))) {
            sx += std::cos(M(r, c));
            sy += std::sin(M(r, c));
            s += M(r, c);
            ++m;
          }
        if (m == 0) {
          O(j, c) = kNaN;
          continue;
        }
        if (q == Quantity::Twist) {
          const double mean = std::atan2(sy, sx);
          // Keep the frames' own branch of the angle (recordings carry continuous angles).
          O(j, c) = mean + 2 * M_PI * std::round((s / m - mean) / (2 * M_PI));
        } else {
          O(j, c) = s / m;
        }
      }
      if (q == Quantity::TipTangent && O.row(j).allFinite() && O.row(j).norm() > 0) O.row(j).normalize();
      // Jitter of this visit.
      int m = 0;
      double sq = 0;
      for (int r = a; r < e; ++r) {
        if (!M.row(r).allFinite() || !O.row(j).allFinite()) continue;
        const Eigen::VectorXd d = noisePart(q, (M.row(r) - O.row(j)).transpose(), O.row(j).transpose());
        sq += d.squaredNorm();
        ++m;
      }
      if (m >= 2) {
        ss[q][0] += sq;
        ss[q][1] += static_cast<double>(rowDof(q, M.cols())) * (m - 1);
      }
    }
  }
  for (const auto& [q, x] : ss)
    if (x[1] > 0) v.jitter[q] = {std::sqrt(x[0] / x[1]), x[1]};
  return v;
}

NoiseLevels NoiseReport::levels() const {
  NoiseLevels l;
  for (const auto& [q, e] : by_quantity) {
    (q == Quantity::Twist ? l.twist : q == Quantity::TipPosition ? l.tip_position : l.tip_tangent) = e.sigma;
    (q == Quantity::Twist ? l.twist_dof : q == Quantity::TipPosition ? l.tip_position_dof : l.tip_tangent_dof) = e.dof;
  }
  return l;
}

bool NoiseReport::supported() const {
  for (const auto& [q, e] : by_quantity)
    if (!e.supported) return false;
  return true;
}

bool NoiseReport::white() const {
  for (const auto& [q, e] : by_quantity)
    if (!e.white) return false;
  return true;
}

NoiseReport estimateNoise(const io::Recording& rec, const Residuals& r, const Prediction& p,
                          const std::vector<char>& use, const GivenNoise& given, const Visits* visits) {
  NoiseReport out;
  const int rows = rec.rows();
  auto usable = [&](int k) { return k >= 0 && k < rows && (use.empty() || use[static_cast<std::size_t>(k)]); };
  // A row whose path from the previous one is not a short continuation: second differences across it would hold
  // the model's error over a long move (a coarsely sampled motion, a pose set) or a change of branch.
  const ReplayOptions steps;
  auto notAlongPath = [&](int k) {
    if (k <= 0 || k >= rows) return true;
    if (k < static_cast<int>(p.reached.size()) && p.reached[static_cast<std::size_t>(k)] != Reached::Path) return true;
    return isLongMove(rec.commands[static_cast<std::size_t>(k - 1)], rec.commands[static_cast<std::size_t>(k)], steps);
  };
  // The model predicts the same at two rows (the same branch and memory): within 1 um and 1e-5 rad, far below any
  // tracker's noise.
  auto samePrediction = [&](int a, int b) {
    auto close = [&](const Eigen::MatrixXd& M, double tol) {
      return M.rows() <= std::max(a, b) || (M.row(a) - M.row(b)).cwiseAbs().maxCoeff() <= tol;
    };
    return close(p.tip_position, 1e-6) && close(p.tip_tangent, 1e-5) && close(p.twist, 1e-5);
  };
  const Eigen::MatrixXd F = configFeatures(rec);
  int typical_frames = 1;
  if (visits && !visits->frames.empty()) {
    std::vector<int> f = visits->frames;
    std::nth_element(f.begin(), f.begin() + static_cast<long>(f.size() / 2), f.end());
    typical_frames = f[f.size() / 2];
  }
  for (Quantity q : presentQuantities(rec)) {
    const Eigen::MatrixXd& R = r.of(q);
    const Eigen::MatrixXd& M = q == Quantity::Twist         ? rec.twist
                               : q == Quantity::TipPosition ? rec.tip_position
                                                            : rec.tip_tangent;
    const double per = rowDof(q, R.cols());
    NoiseEstimate est;
    est.frames = typical_frames;
    if (visits) {
      const auto j = visits->jitter.find(q);
      if (j != visits->jitter.end()) est.jitter = j->second[0];
    }
    auto finiteRow = [&](int k) { return usable(k) && R.row(k).allFinite(); };
    auto diff = [&](const Eigen::VectorXd& e, int k) {
      return noisePart(q, e, q == Quantity::TipTangent ? Eigen::VectorXd(M.row(k).transpose()) : Eigen::VectorXd());
    };
    if (const auto g = given.of(q)) {
      est.sigma = *g;
      est.dof = std::numeric_limits<double>::infinity();
      est.interval95 = {*g, *g};
      est.source = "given";
      est.note = "given: " + fmtSigma(q, *g);
      out.by_quantity[q] = est;
      continue;
    }
    // 1. Repeated poses: returns to a pose after a long move (a pose set), where the model predicts the same. Rows
    //    along a short path (a sweep up and back) are left out: a robot with hysteresis is not in the same state when
    //    it passes a command in the other direction, and that difference is not noise.
    std::vector<Difference> rep;
    {
      std::vector<int> order;
      for (int k = 0; k < rows; ++k)
        if (finiteRow(k) && notAlongPath(k)) order.push_back(k);
      std::vector<char> done(order.size(), 0);
      for (std::size_t i = 0; i < order.size(); ++i) {
        if (done[i]) continue;
        int prev = order[i];
        for (std::size_t j = i + 1; j < order.size(); ++j) {
          if (done[j] ||
              !sameCommand(rec.commands[static_cast<std::size_t>(order[j])],
                           rec.commands[static_cast<std::size_t>(prev)]) ||
              !samePrediction(order[j], prev))
            continue;
          done[j] = 1;
          const Eigen::VectorXd e = diff((R.row(order[j]) - R.row(prev)).transpose(), prev) / std::sqrt(2.0);
          rep.push_back({e.squaredNorm(), 0.0});
          prev = order[j];
        }
      }
    }
    VarianceEstimate v;
    if (rep.size() >= 5) {
      v = robustEstimate(rep, rep.size(), per, 1.0);
      est.source = "repeated";
      est.supported = true;
      est.note = "from " + std::to_string(v.count) + " returns to the same pose";
    } else {
      // 2. Neighbours: second differences along path moves, else nearest neighbours in configuration space.
      std::vector<Difference> d;
      std::vector<LagDifferences> lags;  // for the test of serial correlation
      for (int k = 1; k + 1 < rows; ++k) {
        if (!(finiteRow(k - 1) && finiteRow(k) && finiteRow(k + 1)) || notAlongPath(k) || notAlongPath(k + 1)) continue;
        const double da = (F.row(k) - F.row(k - 1)).norm(), db = (F.row(k + 1) - F.row(k)).norm();
        const double wa = da + db > 0 ? db / (da + db) : 0.5, wb = 1.0 - wa;
        const Eigen::VectorXd e = diff((R.row(k) - wa * R.row(k - 1) - wb * R.row(k + 1)).transpose(), k) /
                                  std::sqrt(1.0 + wa * wa + wb * wb);
        d.push_back({e.squaredNorm(), std::max(da, db)});
        lags.push_back({0.5 * diff((R.row(k) - R.row(k - 1)).transpose(), k).squaredNorm(),
                        0.5 * diff((R.row(k + 1) - R.row(k - 1)).transpose(), k).squaredNorm()});
      }
      // Second differences of independent noise are correlated at lags 1 and 2 (-2/3 and 1/6 for equal weights):
      // the median's degrees of freedom shrink by 1 + 2 (4/9 + 1/36).
      double efficiency = 1.0 / 1.944;
      est.note = "from second differences of consecutive rows along the path";
      // Too few path moves (a pose set, or a log of large moves): nearest neighbours in configuration space instead.
      if (static_cast<int>(d.size()) < std::max(8, rows / 3)) {
        d.clear();
        efficiency = 1.0;
        est.note = "from differences between nearest neighbours in configuration space";
        std::set<std::pair<int, int>> pairs;  // each unordered pair once
        for (int k = 0; k < rows; ++k) {
          if (!finiteRow(k)) continue;
          int best = -1;
          double bd = std::numeric_limits<double>::infinity();
          for (int j = 0; j < rows; ++j) {
            if (j == k || !finiteRow(j)) continue;
            const double dist = (F.row(k) - F.row(j)).norm();
            if (dist < bd) {
              bd = dist;
              best = j;
            }
          }
          if (best < 0 || !pairs.insert({std::min(k, best), std::max(k, best)}).second) continue;
          const Eigen::VectorXd e = diff((R.row(k) - R.row(best)).transpose(), k) / std::sqrt(2.0);
          d.push_back({e.squaredNorm(), bd});
        }
      }
      std::sort(d.begin(), d.end(), [](const Difference& a, const Difference& b) { return a.distance < b.distance; });
      // The closer half; the closer quarter against it tells whether the differences still grow with distance.
      const std::size_t half = std::max<std::size_t>(std::min<std::size_t>(8, d.size()), d.size() / 2);
      v = robustEstimate(d, half, per, efficiency);
      est.source = "neighbours";
      est.supported = true;
      if (efficiency < 1.0) testSerialCorrelation(lags, v.variance, per, est);
      if (d.size() >= 32) {
        const VarianceEstimate nearest = robustEstimate(d, d.size() / 4, per, efficiency);
        std::vector<Difference> far(d.end() - static_cast<long>(d.size() / 4), d.end());
        const VarianceEstimate farthest = robustEstimate(far, far.size(), per, efficiency);
        // Differences that grow with the neighbours' distance hold model error: the farthest quarter's variance
        // at least 1.5 x the nearest quarter's (model error as large as half the noise variance) and significantly
        // so (one-sided F test at 0.1 %).
        const double ratio = farthest.variance / nearest.variance;
        if (std::isfinite(nearest.variance) && std::isfinite(farthest.variance) && nearest.variance > 0 &&
            ratio > 1.5 && stats::fSf(ratio, farthest.dof, nearest.dof) < 0.001) {
          est.supported = false;
          est.note += "; they grow with the neighbours' distance, so they hold model error: the noise is at most this";
        }
      } else {
        est.supported = false;
        est.note += "; too few close neighbours to separate the noise from model error: the noise is at most this";
      }
    }
    const double floor = q == Quantity::TipPosition ? 1e-7 : 1e-5;
    est.sigma = std::isfinite(v.variance) ? std::sqrt(v.variance) : floor;
    est.dof = std::max(1.0, v.dof);
    est.pairs = v.count;
    // The noise of a visit's mean is at least its frames' jitter over sqrt(frames).
    if (est.jitter > 0 && est.sigma < est.jitter / std::sqrt(static_cast<double>(typical_frames))) {
      est.sigma = est.jitter / std::sqrt(static_cast<double>(typical_frames));
      est.note += "; raised to the jitter of the repeated frames";
    }
    if (est.sigma < floor) est.sigma = floor;
    const double lo2 = est.sigma * est.sigma * est.dof / stats::chiSquareQuantile(0.975, est.dof);
    const double hi2 = est.sigma * est.sigma * est.dof / stats::chiSquareQuantile(0.025, est.dof);
    est.interval95 = {std::sqrt(lo2), std::sqrt(hi2)};
    out.by_quantity[q] = est;
  }
  return out;
}

}  // namespace ctr::diagnosis
