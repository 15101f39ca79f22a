// Fuzz target: recording CSV (ctr::io::parseRecording with n inferred and with n fixed, and the CSV round trip of
// accepted recordings).
#include <string>

#include "ctr/io/recording.hpp"
#include "fuzz_common.hpp"

CTR_FUZZ_TARGET(recording_csv) {
  if (size == 0) return 0;
  // First byte: tube count (-1 = infer, 1..4) and whether a measurement is required.
  const int sel = data[0];
  const int tubes = (sel & 7) > 4 ? -1 : ((sel & 7) == 0 ? -1 : (sel & 7));
  const bool require = (sel & 8) == 0;
  const std::string text(reinterpret_cast<const char*>(data + 1), size - 1);
  try {
    const ctr::io::Recording rec = ctr::io::parseRecording(text, "fuzz.csv", tubes, require);
    (void)ctr::io::parseRecording(ctr::io::recordingToCsv(rec), "roundtrip.csv", rec.tubes, false);
  } catch (const ctr::io::InputError&) {
  }
  return 0;
}
