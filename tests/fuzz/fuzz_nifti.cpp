// Fuzz target: NIfTI loading through the project's wrapper (ctr::environments::readNifti + selectVoxels +
// selectedExtent). The bytes go to a temporary .nii (or .nii.gz when they start with the gzip magic) file.
#include <string>

#include "ctr/environments/nifti_source.hpp"
#include "ctr/io/input_error.hpp"
#include "fuzz_common.hpp"

CTR_FUZZ_TARGET(nifti) {
  const bool gz = size >= 2 && data[0] == 0x1f && data[1] == 0x8b;
  const std::string path = ctr::fuzz::writeScratch(gz ? "input.nii.gz" : "input.nii", data, size);
  try {
    const ctr::environments::NiftiVolume vol = ctr::environments::readNifti(path);
    (void)vol.extent();
    (void)vol.spacing();
    (void)vol.distinctValues(16);
    const std::vector<std::uint8_t> mask = ctr::environments::selectVoxels(vol, {});
    (void)ctr::environments::selectedExtent(vol, mask);
  } catch (const ctr::io::InputError&) {
  }
  return 0;
}
