// The real Dupont-lab recording (the data folder: tests/data_sets.hpp), shared by the diagnosis tests.
#pragma once

#include <fstream>
#include <optional>
#include <string>

#include "../data_sets.hpp"
#include "ctr/diagnosis/import.hpp"
#include "ctr/diagnosis/noise.hpp"

namespace ctr::diagnosis::test {

/// The real log (jointTipTrajectory_measured_short.txt) in the data folder, and its path.
inline const std::string kRealLogFile = "dupont-lab-ctr-trajectory-hjhdog1/jointTipTrajectory_measured_short.txt";
inline const std::string kRealLog = ctr_test::dataPath(kRealLogFile);

/// The real log imported with the Dupont-lab columns; empty when it is not there (the test then skips).
inline std::optional<io::Recording> realLog() {
  if (!std::ifstream(kRealLog)) return std::nullopt;
  return importTable(kRealLog, dupontLabImportOptions());
}

/// The noise of the log's EM tracker, given as a lab gives it (`--noise`): the log's own differences between
/// neighbouring rows are serially correlated (a filtered stream, or model error from row to row), so the noise cannot
/// be estimated from it and nothing is established without it.
inline GivenNoise realLogTrackerNoise() {
  return parseGivenNoise("tip_position=0.5mm,tip_tangent=0.3deg");
}

}  // namespace ctr::diagnosis::test
