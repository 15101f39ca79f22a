/// @file recording.hpp
/// @brief Recording CSV (docs/formats.md): commanded actuation + measured twist / tip position / tip tangent.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "ctr/io/input_error.hpp"
#include "ctr/model/configuration.hpp"

namespace ctr::io {

/// @brief One recording: rows in the order taken. Missing measurements are NaN.
struct Recording {
  int tubes = 0;
  std::vector<Configuration> commands;  ///< alpha_i, beta_i per row.
  Eigen::MatrixXd twist;                ///< rows x (tubes-1); NaN where not measured. Empty (0 cols) if absent.
  Eigen::MatrixXd tip_position;         ///< rows x 3, or 0 cols if absent.
  Eigen::MatrixXd tip_tangent;          ///< rows x 3, or 0 cols if absent.
  Eigen::VectorXd time;                 ///< rows, or size 0 if absent.
  std::vector<std::string> warnings;    ///< E.g. unknown columns ignored.
  std::vector<int> lines;               ///< 1-based line of each row in the file read (empty if not read).
  int rows() const { return static_cast<int>(commands.size()); }
  /// @brief Line of row r (0-based) in the file it was read from (blank and comment lines counted); 0 if unknown.
  int lineOf(int r) const { return r >= 0 && r < static_cast<int>(lines.size()) ? lines[static_cast<std::size_t>(r)] : 0; }
  bool hasTwist() const { return twist.cols() > 0; }
  bool hasTipPosition() const { return tip_position.cols() > 0; }
  bool hasTipTangent() const { return tip_tangent.cols() > 0; }
  bool hasTime() const { return time.size() > 0; }
};

/// @brief Reads a recording. `tubes` < 0 infers n from the alpha_* columns. Throws InputError with line/column.
/// `require_measurement` demands at least one measured quantity (docs/formats.md); actuation files pass false.
Recording loadRecording(const std::string& path, int tubes = -1, bool require_measurement = true);
/// @brief Same from text.
Recording parseRecording(const std::string& text, const std::string& source, int tubes = -1,
                         bool require_measurement = true);
/// @brief CSV text with the recording columns (docs/formats.md) the recording has.
std::string recordingToCsv(const Recording& rec);
/// @brief Writes atomically (temporary file + rename): no partial file on failure.
void saveRecording(const Recording& rec, const std::string& path);

}  // namespace ctr::io
