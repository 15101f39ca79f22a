// The public data sets the tests read (io/data.hpp): one folder, CTR_DATA or the one chosen at configure time, and one
// message when a data set is missing (the test then skips).
#pragma once

#include <filesystem>
#include <string>

#include "ctr/io/data.hpp"

namespace ctr_test {

/// The path of `relative` (e.g. "med-mpd/Lungs/Patient1/vessels.nii.gz") in the data folder.
inline std::string dataPath(const std::string& relative) {
  return ctr::io::expandDataPath("${CTR_DATA}/" + relative);
}

/// Whether that file or folder is there.
inline bool haveData(const std::string& relative) {
  return std::filesystem::exists(dataPath(relative));
}

/// The message a test skips with when it is not.
inline std::string missingData(const std::string& relative) {
  return ctr::io::missingDataMessage("${CTR_DATA}/" + relative);
}

}  // namespace ctr_test
