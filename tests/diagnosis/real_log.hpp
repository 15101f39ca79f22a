// The real Dupont-lab recording (../shared beside the checkout), shared by the diagnosis tests.
#pragma once

#include <fstream>
#include <optional>
#include <string>

#include "ctr/diagnosis/import.hpp"

namespace ctr::diagnosis::test {

/// Path of the real log (jointTipTrajectory_measured_short.txt).
inline const std::string kRealLog =
    std::string(CTR_SHARED_DIR) + "/data/dupont-lab-ctr-trajectory-hjhdog1/jointTipTrajectory_measured_short.txt";

/// The real log imported with the Dupont-lab columns; empty when it is not there (the test then skips).
inline std::optional<io::Recording> realLog() {
  if (!std::ifstream(kRealLog)) return std::nullopt;
  return importTable(kRealLog, dupontLabImportOptions());
}

}  // namespace ctr::diagnosis::test
