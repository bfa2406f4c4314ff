// Chooses a volume loader by file extension and puts the path in front of any error it raises.
#include "penumbra/data/io/volume_io.h"

#include "penumbra/core/error.h"
#include "penumbra/data/io/text_fields.h"

namespace penumbra {

using io_detail::ends_with_ci;

bool is_volume_file(const std::string& path) {
  for (const char* ext : {".raw", ".nrrd", ".nhdr", ".nii", ".nii.gz"})
    if (ends_with_ci(path, ext)) return true;
  return false;
}

Volume load_volume(const std::string& path, const std::optional<RawVolumeOptions>& raw) {
  return with_context(path, [&] {
    // Each loader already ran recompute_range(), which rejects NaN/inf voxels and sets the range,
    // so the volume is returned as is rather than scanned twice.
    if (ends_with_ci(path, ".raw")) {
      if (!raw) throw Error("raw files need the 'raw' block: dims, type, endian");
      return load_raw_volume(path, *raw);
    }
    if (ends_with_ci(path, ".nrrd") || ends_with_ci(path, ".nhdr")) return load_nrrd_volume(path);
    if (ends_with_ci(path, ".nii") || ends_with_ci(path, ".nii.gz")) return load_nifti_volume(path);
    throw Error("unknown volume file extension (supported: .raw, .nrrd, .nhdr, .nii, .nii.gz)");
  });
}

}  // namespace penumbra
