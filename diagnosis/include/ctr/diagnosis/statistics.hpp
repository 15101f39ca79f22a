/// @file statistics.hpp
/// @brief Small statistics toolbox for the diagnosis: tail probabilities and correlation tests.
#pragma once

#include <Eigen/Core>

namespace ctr::diagnosis::stats {

/// @brief P(Z > z) for a standard normal.
double normalSf(double z);
/// @brief P(X > x) for chi-square with k degrees of freedom.
double chiSquareSf(double x, double k);
/// @brief x with P(X <= x) = p for chi-square with k degrees of freedom (0 < p < 1).
double chiSquareQuantile(double p, double k);
/// @brief Density of chi-square with k degrees of freedom at x.
double chiSquarePdf(double x, double k);
/// @brief P(F > x) for Fisher's F with (d1, d2) degrees of freedom; d2 = infinity gives the chi-square limit
/// P(chi2_d1 / d1 > x). The test of a mean square against a noise variance estimated with d2 degrees of freedom.
double fSf(double x, double d1, double d2);
/// @brief P(T > t) for Student t with nu degrees of freedom.
double studentSf(double t, double nu);
/// @brief Regularised lower incomplete gamma P(a, x).
double gammaP(double a, double x);
/// @brief Regularised incomplete beta I_x(a, b).
double betaI(double a, double b, double x);

/// @brief A correlation with its two-sided p-value.
struct Correlation {
  double r = 0.0;
  double p_value = 1.0;
  int n = 0;
};
/// @brief Pearson correlation of the finite pairs, t-test p-value.
Correlation pearson(const Eigen::VectorXd& x, const Eigen::VectorXd& y);
/// @brief Spearman rank correlation of the finite pairs (Pearson on ranks).
Correlation spearman(const Eigen::VectorXd& x, const Eigen::VectorXd& y);

/// @brief One-sided p-value that the mean of d is > 0, from the t statistic of contiguous chunk means
/// (chunks absorb serial correlation). Returns 1 when too few values.
double chunkedMeanTest(const Eigen::VectorXd& d, int chunks);

/// @brief One-sided p-value that `after` has smaller errors than `before` (per-row squared errors): t-test of the
/// log ratios of contiguous chunk sums (scale-free, so a few large improvements do not swamp the variance).
double chunkedLogRatioTest(const Eigen::VectorXd& before, const Eigen::VectorXd& after, int chunks);

/// @brief One-sided p-value that the total error of `after` is below that of `before` (per-row squared errors):
/// block bootstrap over contiguous chunks of the ratio sum(after) / sum(before); p = share of resamples with
/// ratio >= 1. Robust to improvements concentrated in a few chunks and to serial correlation within chunks.
double chunkedBootstrapTest(const Eigen::VectorXd& before, const Eigen::VectorXd& after, int chunks,
                            int resamples = 2000, unsigned seed = 12345);

/// @brief Result of hacCovariance.
struct HacCovariance {
  Eigen::MatrixXd covariance;  ///< Of the parameters (k x k).
  int lags = 0;                ///< Bartlett bandwidth used (rows).
  double rho = 0.0;  ///< Serial correlation of the row scores found (AR(1) coefficient, lag-1 autocorrelation).
};

/// @brief Heteroskedasticity- and autocorrelation-consistent (Newey-West, Bartlett kernel) covariance of a
/// least-squares estimate: H^+ Omega H^+ T/(T-k) with H = J^T J and Omega = sum over |l| <= L of (1 - |l|/(L+1)) sum_t
/// g_t g_{t-l}^T, where g_t = J_t^T r_t is the score of row t (rows in time order, `per_row` consecutive residuals
/// each). With `lags` < 0: Andrews-Monahan VAR(1) pre-whitening of the scores and Andrews' automatic AR(1) bandwidth L
/// = 1.1447 (4 rho^2 / (1 - rho)^4 T)^(1/3) on the whitened scores, clamped to [1, T/2]. Valid for independent
/// residuals as well (then close to s^2 H^-1).
HacCovariance hacCovariance(const Eigen::MatrixXd& J, const Eigen::VectorXd& r, int per_row, int lags = -1);

}  // namespace ctr::diagnosis::stats
