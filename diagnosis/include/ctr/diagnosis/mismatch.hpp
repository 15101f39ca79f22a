/// @file mismatch.hpp
/// @brief Locating where a model and a recording differ, with statistical tests: residuals beyond the noise binned
/// over configuration variables, dependence on the direction of approach (hysteresis), and scaling of the
/// residual size with the concentrated moments, actuator speed, time (drift), or none (constant).
#pragma once

#include <string>
#include <vector>

#include "ctr/diagnosis/forward_model.hpp"
#include "ctr/diagnosis/residuals.hpp"
#include "ctr/io/recording.hpp"

namespace ctr::diagnosis {

/// @brief Options of locateMismatch().
struct MismatchOptions {
  int bins = 12;  ///< Bins per configuration variable.
  /// Family-wise false-alarm rate of all the tests of a report: shared equally by the global test, the bins, the
  /// direction tests and the scaling tests, and within each family by Bonferroni over its tests. Tests against an
  /// estimated noise are F tests with the estimate's degrees of freedom.
  double alpha = 0.01;
  int max_bin_reports = 3;  ///< Most significant bins reported per variable.
};

/// @brief One configuration variable of the recording (relative rotation or translation) per row.
struct ConfigVariable {
  /// "alpha_2-alpha_1" (rotation of tube 2 relative to tube 1; "alpha_2" when alpha_1 is 0 throughout, as in the
  /// paper's sweeps) or "beta_3" (translation of tube 3).
  std::string name;
  bool angle = false;         ///< Relative rotation, wrapped to [-pi, pi).
  Eigen::VectorXd value;      ///< Per row.
  Eigen::VectorXd direction;  ///< Direction of approach per row (+1, -1; 0 before the first move).
  Eigen::VectorXd speed;      ///< |d value / dt| per row (NaN without time).
};

/// @brief The configuration variables that vary in a recording.
std::vector<ConfigVariable> configVariables(const io::Recording& rec);

/// @brief One located mismatch (docs/formats.md `mismatch` entries, plus detail).
struct MismatchFinding {
  std::string
      signature;  ///< exceeds_noise | direction_dependent | scales_with_moment | scales_with_speed | drift | constant
  std::string variable;  ///< Configuration variable (or "moment", "speed", "time").
  std::string quantity;  ///< Measured quantity the test used.
  double p_value = 1.0;
  double statistic = 0.0;  ///< Test statistic (chi-square, correlation ...).
  std::string where;       ///< Human-readable location.
};

/// @brief Mean residual of one bin and direction (for plots: residual vs configuration split by direction).
struct BinSummary {
  std::string variable, quantity;
  double lo = 0, hi = 0;  ///< Bin edges (rad or m).
  int direction = 0;      ///< +1, -1 (0 = both).
  int count = 0;
  double mean = 0;  ///< Mean signed residual of the first component (twist) or mean norm (vectors).
  double rms = 0;   ///< RMS residual (per-component for twist, per-row norm for vectors).
};

/// @brief Result of locateMismatch().
struct MismatchReport {
  std::vector<MismatchFinding> findings;  ///< Significant findings, most significant first.
  std::vector<MismatchFinding> tests;     ///< Every test run (significant or not).
  std::vector<BinSummary> bins;           ///< Binned residual tables.
  double global_p_value = 1.0;            ///< Residuals consistent with the noise (chi-square)?
  bool exceeds_noise = false;
};

/// @brief The residuals of some rows tested against the noise.
struct NoiseTest {
  double chi = 0.0;      ///< Sum of squared residuals over the noise variance.
  int dof = 0;           ///< Independent components summed (rowDof).
  double ratio = 1.0;    ///< chi / dof (1 when nothing was summed).
  double p_value = 1.0;  ///< That the residuals are no larger than the noise: per quantity an F test of its mean
                         ///< square with the noise estimate's degrees of freedom (chi-square when the noise is
                         ///< given), Bonferroni over the quantities.
};

/// @brief Tests the residuals of the rows flagged in `use` (empty: all) against the noise.
NoiseTest testAgainstNoise(const io::Recording& rec, const Residuals& r, const NoiseLevels& noise,
                           const std::vector<char>& use = {});

/// @brief Runs the tests on residuals `r` of a model whose prediction is `p` (moments per row), given noise levels.
MismatchReport locateMismatch(const io::Recording& rec, const Prediction& p, const Residuals& r,
                              const NoiseLevels& noise, const MismatchOptions& options = {});

}  // namespace ctr::diagnosis
