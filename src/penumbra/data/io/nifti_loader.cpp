// NIfTI-1 volumes (.nii, .nii.gz). niftilib interprets the header (qform, scaling, byte order), but
// two of its habits make it unsafe on bad files: it prints to stderr whatever the debug level, and
// nifti_image_load accepts a truncated file, filling the missing voxels with zeros (nifti_read_buffer
// only warns "number missing ... (set to 0)"). So the raw 348-byte header is checked here first
// (3-D, supported datatype, sane voxel count and spacing, enough bytes on disk) and the voxels are
// read here with zlib, which reads plain files too, counting every byte and checking the gzip trailer.
// Orientation is nibabel's: the sform when sform_code > 0, else the qform when qform_code > 0, else
// nibabel's base affine (x flipped, the grid centred on 0); its RAS is turned into LPS and the voxels are
// placed by it (volume_placement.h).
#include <zlib.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <memory>
#include <mutex>
#include <optional>
#include <type_traits>
#include <vector>

#include <nifti1_io.h>

#include "penumbra/data/io/file_checks.h"
#include "penumbra/data/io/parked_stream.h"
#include "penumbra/data/io/volume_io.h"
#include "penumbra/data/io/volume_placement.h"

namespace penumbra {

namespace {

using io_detail::bytes_str;

// niftilib keeps its debug level and error state in globals.
std::mutex nifti_mutex;

struct NiftiFree {
  void operator()(nifti_image* nim) const { nifti_image_free(nim); }
};

struct GzClose {
  void operator()(gzFile_s* f) const { gzclose(f); }
};
using GzFile = std::unique_ptr<gzFile_s, GzClose>;

// Where the last window of a .nii.gz ended (parked_stream.h).
io_detail::ParkedStream<GzFile> parked;

std::string dims_str(const short* dim) {
  std::string s;
  const int nd = dim[0] >= 1 && dim[0] <= 7 ? dim[0] : 0;
  for (int i = 1; i <= nd; ++i) {
    if (i > 1) s += 'x';
    s += std::to_string(dim[i]);
  }
  return s.empty() ? "none" : s;
}

// zlib's message for the last error, without the "path: " it puts in front.
std::string gz_message(gzFile_s* f, const std::string& path) {
  int code = Z_OK;
  const char* raw = gzerror(f, &code);
  std::string msg = code == Z_OK || !raw ? "unexpected end of file" : raw;
  if (msg.rfind(path + ": ", 0) == 0) msg.erase(0, path.size() + 2);
  return msg;
}

// Reads exactly n bytes (in chunks, as gzread takes an unsigned int); Error when the stream ends early.
void read_exact(gzFile_s* f, const std::string& path, void* dst, std::uint64_t n, const char* what) {
  auto* out = static_cast<unsigned char*>(dst);
  std::uint64_t done = 0;
  while (done < n) {
    const auto chunk = static_cast<unsigned>(std::min<std::uint64_t>(n - done, 1u << 30));
    const int got = gzread(f, out + done, chunk);
    if (got <= 0) break;
    done += static_cast<std::uint64_t>(got);
  }
  if (done != n)
    throw Error(std::string("truncated or corrupt file: read ") + bytes_str(done) + " of the " + bytes_str(n) + " of " +
                what + " (" + gz_message(f, path) + ")");
}

int voxel_bytes(int datatype) {
  switch (datatype) {
    case DT_UINT8: case DT_INT8: return 1;
    case DT_INT16: case DT_UINT16: return 2;
    case DT_INT32: case DT_UINT32: case DT_FLOAT32: return 4;
    case DT_FLOAT64: return 8;
    default:
      throw Error(std::string("NIfTI datatype ") + nifti_datatype_string(datatype) + " (" + std::to_string(datatype) +
                  ") is not supported (expected uint8, int8, int16, uint16, int32, uint32, float32 or float64)");
  }
}

// The penumbra type a datatype is stored as without scaling; Float32 for the converted ones
// (int32/uint32 above 2^24 lose precision as float32, which a renderer does not show).
ScalarType nifti_storage_type(int datatype) {
  switch (datatype) {
    case DT_UINT8: return ScalarType::UInt8;
    case DT_INT8:  // int8 fits int16 exactly, at half the memory of float32
    case DT_INT16: return ScalarType::Int16;
    case DT_UINT16: return ScalarType::UInt16;
    default: return ScalarType::Float32;
  }
}

// What the raw header promises, checked before niftilib sees the file.
struct RawHeader {
  nifti_1_header h{};
  std::array<std::int64_t, 3> dims{};
  std::uint64_t offset = 0;  // vox_offset
  std::uint64_t data_bytes = 0;
};

RawHeader check_raw_header(gzFile_s* f, const std::string& path) {
  RawHeader r;
  read_exact(f, path, &r.h, sizeof r.h, "NIfTI-1 header");
  nifti_1_header& h = r.h;
  if (h.sizeof_hdr != 348) {
    swap_nifti_header(&h, 1);  // a header written on a machine of the other byte order
    if (h.sizeof_hdr != 348)
      throw Error("not a NIfTI-1 file (header size field is not 348; NIfTI-2 and other formats are not supported)");
  }
  if (std::memcmp(h.magic, "n+1", 4) != 0)
    throw Error("not a single-file NIfTI-1 image (magic is not \"n+1\")");
  const int nd = h.dim[0];
  if (!(nd == 3 || (nd == 4 && h.dim[4] == 1)))
    throw Error("NIfTI image has " + std::to_string(nd) + " dimensions (" + dims_str(h.dim) +
                "; expected 3, or 4 with a single time point)");
  r.dims = {h.dim[1], h.dim[2], h.dim[3]};
  const std::size_t count = with_context("NIfTI dims " + dims_str(h.dim), [&] { return checked_voxel_count(r.dims); });
  r.data_bytes = static_cast<std::uint64_t>(count) * static_cast<std::uint64_t>(voxel_bytes(h.datatype));
  for (int a = 1; a <= 3; ++a)
    if (!(std::abs(h.pixdim[a]) > 0) || !std::isfinite(h.pixdim[a]))
      throw Error("NIfTI pixdim[" + std::to_string(a) + "] is " + std::to_string(h.pixdim[a]) +
                  " (expected a positive spacing)");
  if (!(h.vox_offset >= 352 && h.vox_offset < static_cast<float>(1 << 30)))
    throw Error("NIfTI vox_offset " + std::to_string(h.vox_offset) + " is not a byte offset of at least 352");
  r.offset = static_cast<std::uint64_t>(h.vox_offset);
  return r;
}

template <class Src>
void convert(const void* src, Volume& volume, float slope, float inter, bool scale) {
  const Src* in = static_cast<const Src*>(src);
  const std::size_t n = volume.voxel_count();
  if (volume.type() == ScalarType::Int16 && !scale) {  // int8 widened
    auto* out = volume.data_as<std::int16_t>();
    for (std::size_t i = 0; i < n; ++i) out[i] = static_cast<std::int16_t>(in[i]);
    return;
  }
  auto* out = volume.data_as<float>();
  for (std::size_t i = 0; i < n; ++i) {
    double v = static_cast<double>(in[i]);
    if (scale) v = v * slope + inter;
    if (std::abs(v) > std::numeric_limits<float>::max())
      throw Error("voxel " + std::to_string(i) + " value " + std::to_string(v) + " is outside the float32 range");
    out[i] = static_cast<float>(v);  // NaN passes through and is rejected by recompute_range
  }
}

// The index-to-world affine as nibabel reads it (img.affine: sform, else qform, else the base affine),
// in RAS, turned into LPS.
Affine nifti_affine(const nifti_image& nim, const RawHeader& raw, VolumeFileInfo& info) {
  Affine a;
  const auto from_mat44 = [&](const mat44& m) {
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) a.linear[r][c] = m.m[r][c];
      a.offset[r] = m.m[r][3];
    }
  };
  if (nim.sform_code > 0) {
    from_mat44(nim.sto_xyz);
    info.notes.push_back("placed by the sform (sform_code " + std::to_string(nim.sform_code) + ")");
  } else if (nim.qform_code > 0) {
    for (int d = 1; d <= 3; ++d)
      if (raw.h.pixdim[d] < 0)  // niftilib would take 1 instead; nibabel refuses the file
        throw Error("NIfTI pixdim[" + std::to_string(d) + "] is " + std::to_string(raw.h.pixdim[d]) +
                    " with a qform (expected a positive spacing: the qform's flips are its quaternion and qfac)");
    from_mat44(nim.qto_xyz);
    info.notes.push_back("placed by the qform (qform_code " + std::to_string(nim.qform_code) + "; sform_code 0)");
  } else {
    std::array<double, 3> steps{}, origin{};
    for (int d = 0; d < 3; ++d) {
      steps[d] = std::abs(raw.h.pixdim[d + 1]) * (d == 0 ? -1.0 : 1.0);
      origin[d] = -0.5 * static_cast<double>(raw.dims[d] - 1) * steps[d];
    }
    a = Affine::diagonal(steps, origin);
    info.notes.push_back("neither sform nor qform is set: placed by nibabel's base affine (x flipped, the grid centred on 0)");
  }
  for (int r = 0; r < 2; ++r) {  // RAS -> LPS
    for (double& v : a.linear[r]) v = -v;
    a.offset[r] = -a.offset[r];
  }
  return a;
}

}  // namespace

Volume load_nifti_volume(const std::string& path, VolumeFileInfo& info) { return load_nifti_volume(path, nullptr, nullptr, info); }

Volume load_nifti_volume(const std::string& path, const SliceChooser* choose, WindowRead* read, VolumeFileInfo& info) {
  if (read) *read = WindowRead{};
  const std::uint64_t file_bytes = io_detail::regular_file_size(path);
  if (file_bytes == 0) throw Error("empty file (expected a NIfTI-1 header)");
  // gzopen reads plain files as they are, so one reader serves .nii and .nii.gz.
  GzFile file(gzopen(path.c_str(), "rb"));
  if (!file) throw Error("cannot open the file for reading");
  gzbuffer(file.get(), 1u << 17);
  const RawHeader raw = check_raw_header(file.get(), path);
  const bool compressed = gzdirect(file.get()) == 0;
  if (compressed ? !io_detail::deflate_could_hold(file_bytes, raw.offset + raw.data_bytes)
                 : file_bytes < raw.offset + raw.data_bytes)
    throw Error("NIfTI file has " + bytes_str(file_bytes) + (compressed ? " compressed" : "") + " but the header needs " +
                bytes_str(raw.offset + raw.data_bytes) + " (" + std::to_string(raw.offset) + " header bytes + " +
                dims_str(raw.h.dim) + " voxels of " + std::to_string(voxel_bytes(raw.h.datatype)) +
                " bytes); the file is truncated or the header lies");

  std::unique_ptr<nifti_image, NiftiFree> nim;
  {
    std::lock_guard lock(nifti_mutex);
    nifti_set_debug_level(0);  // errors are reported through Error, not stderr
    nim.reset(nifti_image_read(path.c_str(), 0));
  }
  if (!nim) throw Error("niftilib could not read the NIfTI-1 header");
  if (nim->datatype != raw.h.datatype || nim->nvox != raw.data_bytes / static_cast<std::uint64_t>(nim->nbyper) ||
      nim->nx != raw.dims[0] || nim->ny != raw.dims[1] || nim->nz != raw.dims[2] ||
      static_cast<std::uint64_t>(nim->iname_offset) != raw.offset)
    throw Error("niftilib read the NIfTI header differently from its raw fields (dims " + dims_str(raw.h.dim) + ")");

  // Slope 0 means "no scaling" in NIfTI (niftilib already turns non-finite slopes and intercepts into
  // 0, so the check below is only a guard); (1, 0) is the identity, so the stored type is kept.
  const float slope = nim->scl_slope, inter = nim->scl_inter;
  const bool scale = slope != 0 && !(slope == 1 && inter == 0);
  if (scale && !(std::isfinite(slope) && std::isfinite(inter))) throw Error("NIfTI scaling is not finite");
  const Affine affine = nifti_affine(*nim, raw, info);
  const ScalarType stored = nifti_storage_type(nim->datatype);
  const ScalarType type = scale ? ScalarType::Float32 : stored;
  const std::array<int, 3> dims{static_cast<int>(raw.dims[0]), static_cast<int>(raw.dims[1]), static_cast<int>(raw.dims[2])};

  // A window whose slices are the file's own (its z the file's third axis, reversed or not) reads only
  // them; any other is read whole and cut below.
  const auto permutation = axis_permutation(affine);
  const FileWindow window = file_window(choose, dims, permutation);
  const bool in_part = window.in_part;
  const int file_first = window.file_first, file_count = window.count;
  Volume volume(type, {dims[0], dims[1], file_count});

  // Skip any extensions and the slices before the window, then read the voxels straight into the
  // volume when no conversion is needed.
  const std::uint64_t slice_bytes = raw.data_bytes / static_cast<std::uint64_t>(dims[2]);
  const std::uint64_t wanted = slice_bytes * static_cast<std::uint64_t>(file_count);
  const std::uint64_t start = raw.offset + slice_bytes * static_cast<std::uint64_t>(file_first);
  z_off_t counted_from = 0;  // the compressed bytes read before this window's
  std::uint64_t resumed_at = 0;
  if (compressed && in_part)
    if (std::optional<GzFile> resumed = parked.resume(path, path, start, resumed_at)) {
      file = std::move(*resumed);
      counted_from = gzoffset(file.get());
    }
  if (gzseek(file.get(), static_cast<z_off_t>(start), SEEK_SET) < 0)  // forward from where a resumed stream stands
    throw Error("cannot seek to slice " + std::to_string(file_first) + " (" + gz_message(file.get(), path) + ")");
  const int dt = nim->datatype;
  const bool direct = !scale && (dt == DT_UINT8 || dt == DT_INT16 || dt == DT_UINT16 || dt == DT_FLOAT32);
  std::vector<std::byte> buffer(direct ? 0 : static_cast<std::size_t>(wanted));
  void* data = direct ? static_cast<void*>(volume.data()) : static_cast<void*>(buffer.data());
  read_exact(file.get(), path, data, wanted, in_part ? "chosen slices' voxel data" : "voxel data");
  const bool to_the_end = file_first + file_count == dims[2];
  if (read) read->bytes_read = compressed ? static_cast<std::uint64_t>(gzoffset(file.get()) - counted_from) : wanted;
  if (compressed && in_part && !to_the_end) parked.park(path, path, std::move(file), start + wanted);
  if (compressed && to_the_end) {
    // Reading on to the end makes zlib check the gzip trailer: a cut or corrupt stream fails here
    // (gzread returns 0 for a cut stream, so the error state is what tells).
    unsigned char extra = 0;
    int code = Z_OK;
    if (gzread(file.get(), &extra, 1) < 0 || (gzerror(file.get(), &code), code != Z_OK))
      throw Error("corrupt compressed data after the voxels (" + gz_message(file.get(), path) + ")");
  }
  if (nim->byteorder != nifti_short_order() && nim->swapsize > 1)
    nifti_swap_Nbytes(static_cast<std::size_t>(volume.voxel_count()), nim->swapsize, data);

  if (!direct) {
    switch (nim->datatype) {
      case DT_UINT8: convert<std::uint8_t>(data, volume, slope, inter, scale); break;
      case DT_INT8: convert<std::int8_t>(data, volume, slope, inter, scale); break;
      case DT_INT16: convert<std::int16_t>(data, volume, slope, inter, scale); break;
      case DT_UINT16: convert<std::uint16_t>(data, volume, slope, inter, scale); break;
      case DT_INT32: convert<std::int32_t>(data, volume, slope, inter, scale); break;
      case DT_UINT32: convert<std::uint32_t>(data, volume, slope, inter, scale); break;
      case DT_FLOAT32: convert<float>(data, volume, slope, inter, scale); break;
      case DT_FLOAT64: convert<double>(data, volume, slope, inter, scale); break;
      default: throw Error("unsupported NIfTI datatype");
    }
  }
  if (in_part) return place_window(std::move(volume), affine, dims, *permutation, window, info);
  volume = keep_chosen_slices(place_volume(std::move(volume), affine, info), choose, window, read);
  volume.recompute_range();  // rejects NaN/inf voxels and gives the volume its range
  return volume;
}

}  // namespace penumbra
