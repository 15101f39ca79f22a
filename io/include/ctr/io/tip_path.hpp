/// @file tip_path.hpp
/// @brief A path of tip targets (CSV) for the inverse kinematics (`ctr ik --targets`, docs/ik.md): the tip columns of
/// the recording format (docs/formats.md "Tip path"), so a recording's measured tip path can be used as targets.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "ctr/io/input_error.hpp"

namespace ctr::io {

/// @brief Tip targets in the order to reach them.
///
/// Columns: `tip_x, tip_y, tip_z` (m, base frame; required in every row), optional `tip_tx, tip_ty, tip_tz` (desired
/// tip direction, a unit vector; all three or none per row, empty cells: no direction for that row), optional `time`
/// (s, increasing). The recording's other columns (alpha_k, beta_k, twist_k) are ignored; unknown columns are ignored
/// with a warning. Blank and '#' lines are skipped.
struct TipPath {
  Eigen::MatrixXd position;   ///< rows x 3.
  Eigen::MatrixXd direction;  ///< rows x 3 (NaN rows: no direction), or 0 columns when the file has none.
  Eigen::VectorXd time;       ///< rows, or size 0 if absent.
  std::vector<int> lines;     ///< 1-based line of each row.
  std::vector<std::string> warnings;
  int rows() const { return static_cast<int>(position.rows()); }
  bool hasDirection() const { return direction.cols() > 0; }
  bool hasTime() const { return time.size() > 0; }
};

/// @brief Reads a tip path. Throws InputError naming the file, line and column.
TipPath loadTipPath(const std::string& path);
/// @brief Same from text (`source` names it in errors).
TipPath parseTipPath(const std::string& text, const std::string& source);

}  // namespace ctr::io
