// Zarr arrays through load_volume: the input is the array's metadata (JSON), a NUL byte, and the bytes of
// its first chunk. Metadata with "zarr_format": 3 is a v3 array (zarr.json; the chunk, or the shard with
// its index, is c/0/0/0), any other a v2 array (.zarray; the chunk 0.0.0). The other chunks are missing:
// fill values. Stores declaring over 2^22 voxels are skipped: missing chunks make any shape valid, and
// filling a huge one is time, not a finding.
#include <nlohmann/json.hpp>

#include <cstring>

#include "fuzz_common.h"
#include "penumbra/data/io/volume_io.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto* nul = static_cast<const std::uint8_t*>(std::memchr(data, 0, size));
  const std::size_t meta_size = nul ? static_cast<std::size_t>(nul - data) : size;
  const auto meta = nlohmann::json::parse(data, data + meta_size, nullptr, false);
  if (meta.is_object() && meta.contains("shape") && meta["shape"].is_array()) {
    double voxels = 1;
    for (const auto& n : meta["shape"]) voxels *= n.is_number() ? std::abs(n.get<double>()) : 1;
    if (voxels > double(1 << 22)) return 0;
  }
  const bool v3 = meta.is_object() && meta.value("zarr_format", nlohmann::json()) == 3;
  const std::filesystem::path store = penumbra::fuzz::work_dir() / "in.zarr";
  std::filesystem::remove_all(store);  // the last input's files (v2 or v3) must not decide this one's format
  std::filesystem::create_directories(store / "c" / "0" / "0");
  penumbra::fuzz::write_input(v3 ? "in.zarr/zarr.json" : "in.zarr/.zarray", data, meta_size);
  const std::size_t chunk_at = nul ? meta_size + 1 : size;
  penumbra::fuzz::write_input(v3 ? "in.zarr/c/0/0/0" : "in.zarr/0.0.0", data + chunk_at, size - chunk_at);
  penumbra::fuzz::expect_error_or_result([&] { (void)penumbra::load_volume(store.string()); });
  return 0;
}
