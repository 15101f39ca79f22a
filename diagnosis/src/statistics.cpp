// Tail probabilities (incomplete gamma / beta, Numerical-Recipes style) and correlation tests.
#include "ctr/diagnosis/statistics.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <Eigen/QR>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <random>
#include <stdexcept>
#include <vector>

namespace ctr::diagnosis::stats {

double normalSf(double z) {
  return 0.5 * std::erfc(z / std::sqrt(2.0));
}

namespace {

// Upper regularised incomplete gamma Q(a, x) by its continued fraction (Lentz), valid for x >= a + 1.
double gammaQContinuedFraction(double a, double x, double gln) {
  double b = x + 1.0 - a, c = 1.0 / 1e-300, d = 1.0 / b, h = d;
  for (int i = 1; i < 1000; ++i) {
    const double an = -i * (i - a);
    b += 2.0;
    d = an * d + b;
    if (std::abs(d) < 1e-300) d = 1e-300;
    c = b + an / c;
    if (std::abs(c) < 1e-300) c = 1e-300;
    d = 1.0 / d;
    const double del = d * c;
    h *= del;
    if (std::abs(del - 1.0) < 1e-15) break;
  }
  return std::exp(-x + a * std::log(x) - gln) * h;
}

}  // namespace

double gammaP(double a, double x) {
  if (!(x > 0)) return 0.0;
  if (!(a > 0)) return 1.0;
  const double gln = std::lgamma(a);
  if (x < a + 1.0) {
    double ap = a, sum = 1.0 / a, del = sum;
    for (int n = 0; n < 1000; ++n) {
      ap += 1.0;
      del *= x / ap;
      sum += del;
      if (std::abs(del) < std::abs(sum) * 1e-15) break;
    }
    return std::min(1.0, sum * std::exp(-x + a * std::log(x) - gln));
  }
  return std::max(0.0, 1.0 - gammaQContinuedFraction(a, x, gln));
}

double chiSquareSf(double x, double k) {
  if (!(x > 0)) return 1.0;
  if (!(k > 0)) return 0.0;
  // Q = 1 - P computed directly where P ~ 1 to keep tiny p-values.
  const double a = 0.5 * k, xx = 0.5 * x;
  if (xx < a + 1.0) return std::max(0.0, 1.0 - gammaP(a, xx));
  return gammaQContinuedFraction(a, xx, std::lgamma(a));
}

double chiSquareQuantile(double p, double k) {
  if (!(p > 0)) return 0.0;
  if (!(p < 1)) return std::numeric_limits<double>::infinity();
  // Bisection on the CDF (monotone): bracket, then 200 halvings (relative precision far below what is used).
  double lo = 0.0, hi = std::max(1.0, k);
  while (1.0 - chiSquareSf(hi, k) < p) hi *= 2.0;
  for (int i = 0; i < 200 && hi - lo > 1e-14 * hi; ++i) {
    const double mid = 0.5 * (lo + hi);
    (1.0 - chiSquareSf(mid, k) < p ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

double chiSquarePdf(double x, double k) {
  if (!(x > 0) || !(k > 0)) return 0.0;
  return std::exp((0.5 * k - 1.0) * std::log(x) - 0.5 * x - 0.5 * k * std::log(2.0) - std::lgamma(0.5 * k));
}

double fSf(double x, double d1, double d2) {
  if (!(x > 0)) return 1.0;
  if (!(d1 > 0)) return 0.0;
  if (!std::isfinite(d2) || d2 > 1e7) return chiSquareSf(x * d1, d1);
  if (!(d2 > 0)) return 1.0;
  return betaI(0.5 * d2, 0.5 * d1, d2 / (d2 + d1 * x));
}

namespace {
double betacf(double a, double b, double x) {
  const double qab = a + b, qap = a + 1.0, qam = a - 1.0;
  double c = 1.0, d = 1.0 - qab * x / qap;
  if (std::abs(d) < 1e-300) d = 1e-300;
  d = 1.0 / d;
  double h = d;
  for (int m = 1; m <= 1000; ++m) {
    const int m2 = 2 * m;
    double aa = m * (b - m) * x / ((qam + m2) * (a + m2));
    d = 1.0 + aa * d;
    if (std::abs(d) < 1e-300) d = 1e-300;
    c = 1.0 + aa / c;
    if (std::abs(c) < 1e-300) c = 1e-300;
    d = 1.0 / d;
    h *= d * c;
    aa = -(a + m) * (qab + m) * x / ((a + m2) * (qap + m2));
    d = 1.0 + aa * d;
    if (std::abs(d) < 1e-300) d = 1e-300;
    c = 1.0 + aa / c;
    if (std::abs(c) < 1e-300) c = 1e-300;
    d = 1.0 / d;
    const double del = d * c;
    h *= del;
    if (std::abs(del - 1.0) < 1e-15) break;
  }
  return h;
}
}  // namespace

double betaI(double a, double b, double x) {
  if (x <= 0) return 0.0;
  if (x >= 1) return 1.0;
  const double bt =
      std::exp(std::lgamma(a + b) - std::lgamma(a) - std::lgamma(b) + a * std::log(x) + b * std::log(1 - x));
  if (x < (a + 1.0) / (a + b + 2.0)) return bt * betacf(a, b, x) / a;
  return 1.0 - bt * betacf(b, a, 1.0 - x) / b;
}

double studentSf(double t, double nu) {
  if (!(nu > 0)) return 0.5;
  const double x = nu / (nu + t * t);
  const double tail = 0.5 * betaI(0.5 * nu, 0.5, x);
  return t > 0 ? tail : 1.0 - tail;
}

Correlation pearson(const Eigen::VectorXd& x, const Eigen::VectorXd& y) {
  Correlation c;
  std::vector<double> a, b;
  for (Eigen::Index k = 0; k < x.size() && k < y.size(); ++k)
    if (std::isfinite(x[k]) && std::isfinite(y[k])) {
      a.push_back(x[k]);
      b.push_back(y[k]);
    }
  c.n = static_cast<int>(a.size());
  if (c.n < 4) return c;
  const double ma = std::accumulate(a.begin(), a.end(), 0.0) / c.n, mb = std::accumulate(b.begin(), b.end(), 0.0) / c.n;
  double sab = 0, saa = 0, sbb = 0;
  for (int k = 0; k < c.n; ++k) {
    sab += (a[k] - ma) * (b[k] - mb);
    saa += (a[k] - ma) * (a[k] - ma);
    sbb += (b[k] - mb) * (b[k] - mb);
  }
  if (saa <= 0 || sbb <= 0) return c;
  c.r = std::clamp(sab / std::sqrt(saa * sbb), -1.0, 1.0);
  const double dof = c.n - 2;
  const double t = c.r * std::sqrt(dof / std::max(1e-300, 1 - c.r * c.r));
  c.p_value = std::min(1.0, 2.0 * studentSf(std::abs(t), dof));
  return c;
}

namespace {
Eigen::VectorXd ranks(const Eigen::VectorXd& v) {
  std::vector<Eigen::Index> idx;
  for (Eigen::Index k = 0; k < v.size(); ++k)
    if (std::isfinite(v[k])) idx.push_back(k);
  std::sort(idx.begin(), idx.end(), [&](Eigen::Index a, Eigen::Index b) { return v[a] < v[b]; });
  Eigen::VectorXd r = Eigen::VectorXd::Constant(v.size(), std::nan(""));
  std::size_t i = 0;
  while (i < idx.size()) {
    std::size_t j = i;
    while (j + 1 < idx.size() && v[idx[j + 1]] == v[idx[i]]) ++j;
    const double rank = 0.5 * static_cast<double>(i + j);
    for (std::size_t k = i; k <= j; ++k) r[idx[k]] = rank;
    i = j + 1;
  }
  return r;
}
}  // namespace

Correlation spearman(const Eigen::VectorXd& x, const Eigen::VectorXd& y) {
  Eigen::VectorXd xx = x, yy = y;
  for (Eigen::Index k = 0; k < xx.size() && k < yy.size(); ++k)
    if (!std::isfinite(xx[k]) || !std::isfinite(yy[k])) xx[k] = yy[k] = std::nan("");
  return pearson(ranks(xx), ranks(yy));
}

double chunkedMeanTest(const Eigen::VectorXd& d, int chunks) {
  std::vector<double> v;
  for (Eigen::Index k = 0; k < d.size(); ++k)
    if (std::isfinite(d[k])) v.push_back(d[k]);
  const int n = static_cast<int>(v.size());
  chunks = std::min(chunks, n);
  if (chunks < 3) return 1.0;
  std::vector<double> m(static_cast<std::size_t>(chunks), 0.0);
  for (int c = 0; c < chunks; ++c) {
    const int a = c * n / chunks, b = (c + 1) * n / chunks;
    double s = 0;
    for (int k = a; k < b; ++k) s += v[static_cast<std::size_t>(k)];
    m[static_cast<std::size_t>(c)] = s / std::max(1, b - a);
  }
  const double mean = std::accumulate(m.begin(), m.end(), 0.0) / chunks;
  double var = 0;
  for (double x : m) var += (x - mean) * (x - mean);
  var /= (chunks - 1);
  if (var <= 0) return mean > 0 ? 0.0 : 1.0;
  const double t = mean / std::sqrt(var / chunks);
  return studentSf(t, chunks - 1);
}

double chunkedLogRatioTest(const Eigen::VectorXd& before, const Eigen::VectorXd& after, int chunks) {
  const Eigen::Index n = std::min(before.size(), after.size());
  chunks = static_cast<int>(std::min<Eigen::Index>(chunks, n));
  if (chunks < 3) return 1.0;
  const double eps = 1e-9 * (before.head(n).cwiseAbs().mean() + 1e-300);
  Eigen::VectorXd l(chunks);
  for (int c = 0; c < chunks; ++c) {
    const Eigen::Index a = c * n / chunks, b = (c + 1) * n / chunks;
    double sb = 0, sa = 0;
    for (Eigen::Index k = a; k < b; ++k) {
      if (std::isfinite(before[k]) && std::isfinite(after[k])) {
        sb += before[k];
        sa += after[k];
      }
    }
    l[c] = std::log((sb + eps) / (sa + eps));
  }
  return chunkedMeanTest(l, chunks);
}

double chunkedBootstrapTest(const Eigen::VectorXd& before, const Eigen::VectorXd& after, int chunks, int resamples,
                            unsigned seed) {
  const Eigen::Index n = std::min(before.size(), after.size());
  chunks = static_cast<int>(std::min<Eigen::Index>(chunks, n));
  if (chunks < 3) return 1.0;
  std::vector<double> sb(static_cast<std::size_t>(chunks), 0.0), sa(static_cast<std::size_t>(chunks), 0.0);
  for (int c = 0; c < chunks; ++c) {
    const Eigen::Index a = c * n / chunks, b = (c + 1) * n / chunks;
    for (Eigen::Index k = a; k < b; ++k)
      if (std::isfinite(before[k]) && std::isfinite(after[k])) {
        sb[static_cast<std::size_t>(c)] += before[k];
        sa[static_cast<std::size_t>(c)] += after[k];
      }
  }
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> pick(0, chunks - 1);
  int worse = 0;
  for (int r = 0; r < resamples; ++r) {
    double tb = 0, ta = 0;
    for (int c = 0; c < chunks; ++c) {
      const int j = pick(rng);
      tb += sb[static_cast<std::size_t>(j)];
      ta += sa[static_cast<std::size_t>(j)];
    }
    if (!(ta < tb)) ++worse;
  }
  return (1.0 + worse) / (1.0 + resamples);
}

namespace {

// Bartlett-kernel long-run covariance of the columns of V (k x T) with Andrews' AR(1) bandwidth (lags < 0).
Eigen::MatrixXd bartlett(const Eigen::MatrixXd& V, int& lags, double& rho) {
  const Eigen::Index k = V.rows(), T = V.cols();
  if (lags < 0) {
    double num = 0.0, den = 0.0;
    for (Eigen::Index j = 0; j < k; ++j) {
      const double ss = V.row(j).squaredNorm();
      if (!(ss > 0)) continue;
      den += 1.0;
      double c = 0.0;
      for (Eigen::Index t = 1; t < T; ++t) c += V(j, t) * V(j, t - 1);
      num += c / ss;
    }
    rho = den > 0 ? std::clamp(num / den, 0.0, 0.97) : 0.0;
    const double a = 4.0 * rho * rho / std::pow(1.0 - rho, 4);
    lags = static_cast<int>(std::ceil(1.1447 * std::cbrt(a * static_cast<double>(T))));
    lags = std::clamp(lags, 1, static_cast<int>(std::max<Eigen::Index>(1, T / 2)));
  }
  Eigen::MatrixXd Omega = V * V.transpose();
  for (int l = 1; l <= lags && l < T; ++l) {
    const double w = 1.0 - static_cast<double>(l) / (lags + 1);
    const Eigen::MatrixXd S = V.rightCols(T - l) * V.leftCols(T - l).transpose();
    Omega += w * (S + S.transpose());
  }
  return Omega;
}

}  // namespace

HacCovariance hacCovariance(const Eigen::MatrixXd& J, const Eigen::VectorXd& r, int per_row, int lags) {
  if (per_row < 1 || J.rows() != r.size() || J.rows() % per_row != 0)
    throw std::invalid_argument("hacCovariance: J and r must have rows x per_row entries");
  const Eigen::Index k = J.cols(), T = J.rows() / per_row;
  HacCovariance out;
  Eigen::MatrixXd G(k, T);  // scores per row
  for (Eigen::Index t = 0; t < T; ++t)
    G.col(t) = J.middleRows(t * per_row, per_row).transpose() * r.segment(t * per_row, per_row);
  Eigen::MatrixXd Omega;
  if (lags < 0 && T > 4 * (k + 1)) {
    // Andrews-Monahan pre-whitening: g_t = A g_{t-1} + v_t (least squares, spectral radius capped at 0.97), a
    // Bartlett estimate for v, recoloured: Omega = (I - A)^-1 Omega_v (I - A)^-T. Far less small-sample bias than
    // the plain Bartlett estimate when the scores are strongly autocorrelated.
    const Eigen::MatrixXd X = G.leftCols(T - 1), Y = G.rightCols(T - 1);
    Eigen::MatrixXd A = (Y * X.transpose()) * (X * X.transpose()).completeOrthogonalDecomposition().pseudoInverse();
    const double radius = A.eigenvalues().cwiseAbs().maxCoeff();
    if (radius > 0.97) A *= 0.97 / radius;
    const Eigen::MatrixXd V = Y - A * X;
    const Eigen::MatrixXd Ov = bartlett(V, lags, out.rho);
    const Eigen::MatrixXd B = (Eigen::MatrixXd::Identity(k, k) - A).inverse();
    Omega = B * Ov * B.transpose() * (static_cast<double>(T) / static_cast<double>(T - 1));
    // Report the AR(1) coefficient of the scores (mean diagonal of A) as the serial correlation found.
    out.rho = k > 0 ? std::clamp(A.diagonal().mean(), -1.0, 1.0) : 0.0;
  } else {
    Omega = bartlett(G, lags, out.rho);
  }
  out.lags = lags;
  const Eigen::MatrixXd Hinv = (J.transpose() * J).completeOrthogonalDecomposition().pseudoInverse();
  const double dof = T > k ? static_cast<double>(T) / static_cast<double>(T - k) : 1.0;
  out.covariance = dof * Hinv * Omega * Hinv;
  return out;
}

}  // namespace ctr::diagnosis::stats
