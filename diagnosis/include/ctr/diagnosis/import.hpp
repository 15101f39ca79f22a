/// @file import.hpp
/// @brief Converting lab recordings (whitespace or comma separated tables) into the recording CSV (docs/formats.md
/// "Importing lab tables"): column mapping, unit scaling, sign flips and angle unwrapping. A preset describes the
/// Dupont-lab format.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "ctr/io/recording.hpp"

namespace ctr::diagnosis {

/// @brief Where one recording column (docs/formats.md) comes from in the source table.
struct ColumnSource {
  int column = 0;      ///< 1-based column of the source table.
  double scale = 1.0;  ///< Value = scale * source + offset (e.g. 1e-3 for mm, -1 to flip an axis).
  double offset = 0.0;
};

/// @brief Options of importTable().
struct ImportOptions {
  int tubes = 0;                                ///< n; 0 infers it from the alpha_* mappings.
  std::map<std::string, ColumnSource> columns;  ///< Recording column name -> source (alpha_1, tip_x, time ...).
  std::vector<std::string> unwrap;              ///< Columns whose angles are wrapped (unwrapped on import).
  std::string delimiter;                        ///< "" = whitespace or comma, auto-detected.
  int skip_rows = 0;                            ///< Header lines to skip.
  bool normalize_tangent = true;                ///< Renormalise tip tangents to unit length.
};

/// @brief The Dupont-lab (hjhdog1/ConcentricTubes jointTipTrajectory) layout: time, alpha1..3 (wrapped rad),
/// beta1..3 (mm), tip x,y,z (mm, EM tracker frame), sensor axes (x axis anti-parallel to the tip tangent).
ImportOptions dupontLabImportOptions();

/// @brief Parses "alpha_1=2" / "beta_1=5*0.001" / "tip_tx=11*-1" / "time=1*1+0" into a mapping entry.
/// Throws std::invalid_argument.
std::pair<std::string, ColumnSource> parseColumnMapping(const std::string& text);

/// @brief Angles unwrapped in place (jumps larger than pi between consecutive finite values are removed).
void unwrapAngles(Eigen::Ref<Eigen::VectorXd> a);

/// @brief Reads a table and converts it. Throws io::InputError naming the file and line on malformed input.
io::Recording importTable(const std::string& path, const ImportOptions& options);
/// @brief Same from text (`source` names it in errors).
io::Recording importTableText(const std::string& text, const std::string& source, const ImportOptions& options);

}  // namespace ctr::diagnosis
