// Volume files: raw (dimensions, type and endianness given by the caller), NRRD (attached and detached
// headers, raw and gzip encodings) and NIfTI-1 (.nii, .nii.gz). Every loader checks what it reads:
// truncated data, lying headers, unsupported types, zero or absurd dimensions and NaN voxels give an
// Error naming the file and what was expected.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>

#include "penumbra/data/volume.h"

namespace penumbra {

struct RawVolumeOptions {
  std::array<std::int64_t, 3> dims{0, 0, 0};
  ScalarType type = ScalarType::UInt8;
  bool big_endian = false;
  Vec3 spacing{1, 1, 1};
  std::uint64_t header_bytes = 0;  // bytes to skip at the start of the file
};

Volume load_raw_volume(const std::string& path, const RawVolumeOptions& options);
Volume load_nrrd_volume(const std::string& path);   // .nrrd or .nhdr
Volume load_nifti_volume(const std::string& path);  // .nii or .nii.gz

// Whether the file name has a volume extension (.raw, .nrrd, .nhdr, .nii, .nii.gz; any case).
bool is_volume_file(const std::string& path);

// Chooses the loader by extension (.raw needs `raw`; .nrrd/.nhdr; .nii/.nii.gz). The returned volume
// has its value range computed.
Volume load_volume(const std::string& path, const std::optional<RawVolumeOptions>& raw = std::nullopt);

}  // namespace penumbra
