// HDF5 volumes (.h5, .hdf5) through Debian's libhdf5: one numeric dataset of three axes (z, y, x) or
// more (a leading c axis chosen by `channel`, any other read at 0), contiguous or chunked, with the
// filters libhdf5 decodes itself (deflate, shuffle, fletcher32, scale-offset, n-bit, szip where built);
// a filter it lacks (h5py's lzf, a Blosc plugin) is refused by name and number. `dataset` names the path
// inside the file; without it the file must hold exactly one dataset of three or more axes (else the
// message lists them). The voxel size comes from the attribute `element_size_um` (z, y, x: Fiji's and
// ilastik's convention) when present. libhdf5 converts the stored type and byte order to the volume's:
// uint8, uint16, int16 and float32 kept; int8 widened to int16; wider integers and float64 as float32.
// A window (a slab of `penumbra convert`, an MPI rank's brick) is a hyperslab of its slices: libhdf5
// reads and decodes only the chunks they lie in.
//
// libhdf5 is not hardened against corrupt files (a trial libFuzzer run found it allocating what a broken
// header claims within seconds), so it runs in a forked child with a memory budget and a time limit
// (child_process.h), as OpenVDB does: the child reads the voxels into a memfd shared with the parent and
// answers with their description through a pipe; a crash or a limit there is an Error here.
#include <hdf5.h>
#include <sys/mman.h>
#include <fcntl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <optional>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "penumbra/core/error.h"
#include "penumbra/data/io/child_process.h"
#include "penumbra/data/io/text_fields.h"
#include "penumbra/data/io/volume_io.h"
#include "penumbra/data/io/volume_placement.h"

namespace penumbra {

namespace {

using io_detail::printable;

// Closes an HDF5 identifier when it goes out of scope.
class Handle {
public:
  Handle(hid_t id, herr_t (*close)(hid_t)) : id_(id), close_(close) {}
  ~Handle() {
    if (id_ >= 0) close_(id_);
  }
  Handle(const Handle&) = delete;
  Handle& operator=(const Handle&) = delete;
  hid_t get() const { return id_; }
  bool ok() const { return id_ >= 0; }

private:
  hid_t id_;
  herr_t (*close_)(hid_t);
};

// libhdf5's error stack, innermost first, as one line (its own printing is switched off).
std::string hdf5_errors() {
  std::string text;
  H5Ewalk2(H5E_DEFAULT, H5E_WALK_UPWARD, [](unsigned, const H5E_error2_t* e, void* out) -> herr_t {
    auto& s = *static_cast<std::string*>(out);
    if (e->desc && *e->desc) s += (s.empty() ? "" : "; ") + std::string(e->desc);
    return 0;
  }, &text);
  H5Eclear2(H5E_DEFAULT);
  return text.empty() ? "no detail from libhdf5" : printable(text, 400);
}

struct Candidate {
  std::string path, description;
};

std::string shape_text(const std::vector<hsize_t>& dims) {
  std::string s;
  for (const hsize_t d : dims) s += (s.empty() ? "" : "x") + std::to_string(d);
  return s;
}

// Every numeric dataset of the file with its shape, for choosing one or listing them.
std::vector<Candidate> numeric_datasets(hid_t file, bool volumes_only) {
  struct Walk {
    std::vector<Candidate> found;
    bool volumes_only;
  } walk{{}, volumes_only};
  H5Ovisit2(file, H5_INDEX_NAME, H5_ITER_NATIVE, [](hid_t root, const char* name, const H5O_info_t* info, void* data) -> herr_t {
    if (info->type != H5O_TYPE_DATASET) return 0;
    auto& w = *static_cast<Walk*>(data);
    const Handle d(H5Dopen2(root, name, H5P_DEFAULT), H5Dclose);
    if (!d.ok()) return 0;
    const Handle type(H5Dget_type(d.get()), H5Tclose);
    const H5T_class_t cls = H5Tget_class(type.get());
    if (cls != H5T_INTEGER && cls != H5T_FLOAT) return 0;
    const Handle space(H5Dget_space(d.get()), H5Sclose);
    const int rank = H5Sget_simple_extent_ndims(space.get());
    if (rank < 0 || (w.volumes_only && rank < 3)) return 0;
    std::vector<hsize_t> dims(static_cast<std::size_t>(rank));
    H5Sget_simple_extent_dims(space.get(), dims.data(), nullptr);
    w.found.push_back({std::string("/") + name, shape_text(dims) + " " + (cls == H5T_FLOAT ? "float" : "integer") + std::to_string(8 * H5Tget_size(type.get()))});
    return 0;
  }, &walk, H5O_INFO_BASIC);
  H5Eclear2(H5E_DEFAULT);
  return walk.found;
}

std::string listing(const std::vector<Candidate>& c) {
  std::string s;
  for (std::size_t i = 0; i < c.size() && i < 20; ++i) s += (i ? ", " : "") + c[i].path + " (" + c[i].description + ")";
  if (c.size() > 20) s += ", and " + std::to_string(c.size() - 20) + " more";
  return s;
}

// The filters of a chunked dataset that this libhdf5 cannot decode, by name and number.
void check_filters(hid_t dataset) {
  const Handle dcpl(H5Dget_create_plist(dataset), H5Pclose);
  const int n = H5Pget_nfilters(dcpl.get());
  for (int i = 0; i < n; ++i) {
    unsigned flags = 0, config = 0;
    std::size_t n_values = 0;
    char name[128] = {};
    const H5Z_filter_t id = H5Pget_filter2(dcpl.get(), static_cast<unsigned>(i), &flags, &n_values, nullptr, sizeof name, name, &config);
    if (id < 0) continue;
    if (H5Zfilter_avail(id) <= 0) {
      const std::string known = id == 32000 ? "lzf (h5py's)" : id == 32001 ? "blosc" : id == 32004 ? "lz4" : id == 32015 ? "zstd" : id == 307 ? "bzip2" : "";
      throw Error("the dataset is compressed with filter " + std::to_string(id) + (known.empty() ? "" : " = " + known) +
                  (name[0] ? " (\"" + printable(name, 60) + "\")" : "") +
                  ", which Debian's libhdf5 cannot decode (deflate/gzip, shuffle, fletcher32, scale-offset and n-bit can be read)");
    }
  }
}

ScalarType storage_type(hid_t type) {
  const H5T_class_t cls = H5Tget_class(type);
  const std::size_t size = H5Tget_size(type);
  if (cls == H5T_INTEGER) {
    const bool is_signed = H5Tget_sign(type) == H5T_SGN_2;
    if (!is_signed && size == 1) return ScalarType::UInt8;
    if (!is_signed && size == 2) return ScalarType::UInt16;
    if (is_signed && size <= 2) return ScalarType::Int16;
    return ScalarType::Float32;
  }
  return ScalarType::Float32;
}

hid_t memory_type(ScalarType t) {
  switch (t) {
    case ScalarType::UInt8: return H5T_NATIVE_UINT8;
    case ScalarType::UInt16: return H5T_NATIVE_UINT16;
    case ScalarType::Int16: return H5T_NATIVE_INT16;
    case ScalarType::Float32: return H5T_NATIVE_FLOAT;
  }
  return H5T_NATIVE_FLOAT;
}

// The voxel size (x, y, z) from `element_size_um` (z, y, x), when the dataset carries it.
std::optional<std::array<double, 3>> element_size(hid_t dataset, std::vector<std::string>& notes) {
  if (H5Aexists(dataset, "element_size_um") <= 0) return std::nullopt;
  const Handle attr(H5Aopen(dataset, "element_size_um", H5P_DEFAULT), H5Aclose);
  const Handle space(H5Aget_space(attr.get()), H5Sclose);
  if (!attr.ok() || H5Sget_simple_extent_npoints(space.get()) != 3) {
    notes.push_back("attribute element_size_um is not 3 numbers: spacing 1 1 1");
    return std::nullopt;
  }
  double zyx[3] = {1, 1, 1};
  if (H5Aread(attr.get(), H5T_NATIVE_DOUBLE, zyx) < 0 || !(zyx[0] > 0 && zyx[1] > 0 && zyx[2] > 0) ||
      !std::isfinite(zyx[0] + zyx[1] + zyx[2])) {
    H5Eclear2(H5E_DEFAULT);
    notes.push_back("attribute element_size_um holds no positive sizes: spacing 1 1 1");
    return std::nullopt;
  }
  notes.push_back("spacing from element_size_um (micrometers)");
  return std::array<double, 3>{zyx[2], zyx[1], zyx[0]};
}

// What the child reads: the header only (the grid, for the parent to choose slices from), or the voxels
// of slices [first, first + count) along z (every slice when count is 0), as a hyperslab: libhdf5 reads
// and decodes only the chunks those slices lie in.
struct ChildRead {
  bool header_only = false;
  int first = 0, count = 0;
};

// The stored bytes of the chunk rows (along z) that slices [first, first + count) lie in: the dataset's
// storage in proportion, exact for a contiguous dataset and for chunks compressed alike.
std::uint64_t stored_bytes_of_slices(hid_t dataset, const std::vector<hsize_t>& dims, int first, int count) {
  const hsize_t storage = H5Dget_storage_size(dataset);
  const hsize_t z = dims[dims.size() - 3];
  if (z == 0) return 0;
  hsize_t rows = z, rows_read = static_cast<hsize_t>(count);
  const Handle dcpl(H5Dget_create_plist(dataset), H5Pclose);
  if (H5Pget_layout(dcpl.get()) == H5D_CHUNKED) {
    std::vector<hsize_t> chunk(dims.size(), 1);
    if (H5Pget_chunk(dcpl.get(), static_cast<int>(chunk.size()), chunk.data()) == static_cast<int>(chunk.size())) {
      const hsize_t cz = std::max<hsize_t>(chunk[chunk.size() - 3], 1);
      rows = (z + cz - 1) / cz;
      rows_read = (static_cast<hsize_t>(first + count) + cz - 1) / cz - static_cast<hsize_t>(first) / cz;
    }
  }
  H5Eclear2(H5E_DEFAULT);
  return static_cast<std::uint64_t>(static_cast<long double>(storage) * static_cast<long double>(rows_read) / static_cast<long double>(rows));
}

// In the child: reads the dataset's voxels into `memfd` (sized here) and returns what the parent needs:
// {"dims": [x, y, z] (the whole grid), "slices" (read), "type", "spacing": [x, y, z] or null, "notes",
// "channels", "channel", "stored_bytes" (read from the file)}; the header only when asked.
nlohmann::json read_in_child(const std::string& path, const std::string& dataset_name, int channel, const ChildRead& request, int memfd) {
  VolumeFileInfo out;
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);  // errors come back as messages, not printed
  if (H5Fis_hdf5(path.c_str()) <= 0) {
    H5Eclear2(H5E_DEFAULT);
    throw Error("not an HDF5 file (no HDF5 signature)");
  }
  const Handle file(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose);
  if (!file.ok()) throw Error("libhdf5 could not open it: " + hdf5_errors());

  std::string name = dataset_name;
  if (name.empty()) {
    const auto volumes = numeric_datasets(file.get(), true);
    if (volumes.empty()) {
      const auto all = numeric_datasets(file.get(), false);
      throw Error("no numeric dataset of three or more axes" + (all.empty() ? std::string() : " (found: " + listing(all) + ")"));
    }
    if (volumes.size() > 1) throw Error(std::to_string(volumes.size()) + " datasets could be volumes; 'dataset' chooses one: " + listing(volumes));
    name = volumes[0].path;
  }
  if (H5Lexists(file.get(), name.c_str(), H5P_DEFAULT) <= 0) {
    H5Eclear2(H5E_DEFAULT);
    throw Error("no dataset '" + printable(name, 200) + "' (datasets: " + listing(numeric_datasets(file.get(), false)) + ")");
  }
  const Handle dataset(H5Dopen2(file.get(), name.c_str(), H5P_DEFAULT), H5Dclose);
  if (!dataset.ok()) throw Error("'" + printable(name, 200) + "' is not a dataset: " + hdf5_errors());
  return with_context("dataset " + name, [&] {
    const Handle type(H5Dget_type(dataset.get()), H5Tclose);
    const H5T_class_t cls = H5Tget_class(type.get());
    if (cls != H5T_INTEGER && cls != H5T_FLOAT) throw Error("not numeric (expected integers or floats)");
    const Handle space(H5Dget_space(dataset.get()), H5Sclose);
    const int rank = H5Sget_simple_extent_ndims(space.get());
    if (rank < 3) throw Error("a " + std::to_string(rank) + "-D dataset (expected three axes, z y x, last)");
    std::vector<hsize_t> dims(static_cast<std::size_t>(rank));
    H5Sget_simple_extent_dims(space.get(), dims.data(), nullptr);
    check_filters(dataset.get());

    // the hyperslab: the leading axes fixed (a 4-D dataset's first axis is its channels), z y x whole
    std::vector<hsize_t> start(dims.size(), 0), count = dims;
    for (std::size_t k = 0; k + 3 < dims.size(); ++k) {
      count[k] = 1;
      if (k + 4 == dims.size() && dims[k] > 1) {  // the axis just before z: channels
        const hsize_t c = channel < 0 ? 0 : static_cast<hsize_t>(channel);
        if (c >= dims[k]) throw Error("'channel' " + std::to_string(c) + ": the dataset has " + std::to_string(dims[k]) + " channels");
        start[k] = c;
        out.channels = static_cast<int>(dims[k]);
        out.channel = static_cast<int>(c);
      } else if (dims[k] > 1) {
        out.notes.push_back("axis " + std::to_string(k) + " has " + std::to_string(dims[k]) + " entries: the first is loaded");
      }
    }
    if (channel >= 0 && out.channels == 1) throw Error("'channel' " + std::to_string(channel) + ": the dataset has no channel axis (4 axes, c z y x)");
    const std::array<std::int64_t, 3> xyz{static_cast<std::int64_t>(dims[dims.size() - 1]), static_cast<std::int64_t>(dims[dims.size() - 2]),
                                          static_cast<std::int64_t>(dims[dims.size() - 3])};
    with_context("shape " + shape_text(dims), [&] { return checked_voxel_count(xyz); });
    for (const auto d : xyz)
      if (d > std::numeric_limits<int>::max()) throw Error("an axis of " + std::to_string(d) + " voxels is too long");
    if (request.header_only) return nlohmann::json{{"dims", xyz}};
    const std::size_t z_axis = dims.size() - 3;
    const int first = request.count > 0 ? request.first : 0;
    const int slices = request.count > 0 ? request.count : static_cast<int>(xyz[2]);
    if (first < 0 || slices < 1 || first > xyz[2] - slices) throw Error("slices outside the dataset's z axis");
    start[z_axis] = static_cast<hsize_t>(first);
    count[z_axis] = static_cast<hsize_t>(slices);
    const std::size_t voxels = checked_voxel_count({xyz[0], xyz[1], slices});
    const ScalarType stored = storage_type(type.get());
    const std::size_t bytes = voxels * scalar_size(stored);
    if (::ftruncate(memfd, static_cast<off_t>(bytes)) != 0) throw Error("cannot hold " + std::to_string(bytes) + " bytes of voxels: " + std::strerror(errno));
    void* target = ::mmap(nullptr, bytes, PROT_READ | PROT_WRITE, MAP_SHARED, memfd, 0);
    if (target == MAP_FAILED) throw Error("cannot map " + std::to_string(bytes) + " bytes of voxels: " + std::strerror(errno));
    if (H5Sselect_hyperslab(space.get(), H5S_SELECT_SET, start.data(), nullptr, count.data(), nullptr) < 0)
      throw Error("could not select the voxels: " + hdf5_errors());
    const hsize_t memory_dims[3] = {count[z_axis], dims[dims.size() - 2], dims[dims.size() - 1]};
    const Handle memory(H5Screate_simple(3, memory_dims, nullptr), H5Sclose);
    const herr_t read = H5Dread(dataset.get(), memory_type(stored), memory.get(), space.get(), H5P_DEFAULT, target);
    ::munmap(target, bytes);
    if (read < 0) throw Error("libhdf5 could not read the voxels (a corrupt or truncated file?): " + hdf5_errors());
    const std::size_t size = H5Tget_size(type.get());
    const bool kept = (cls == H5T_INTEGER && size <= 2 && !(size == 1 && H5Tget_sign(type.get()) == H5T_SGN_2)) || (cls == H5T_FLOAT && size == 4);
    if (!kept)
      out.notes.push_back("stored as " + to_string(stored) + " (the file's " + (cls == H5T_FLOAT ? "float" : "integer") + std::to_string(8 * size) + ")");
    const auto spacing = element_size(dataset.get(), out.notes);
    return nlohmann::json{{"dims", xyz}, {"slices", slices}, {"type", to_string(stored)}, {"bytes", bytes},
                          {"stored_bytes", stored_bytes_of_slices(dataset.get(), dims, first, slices)},
                          {"spacing", spacing ? nlohmann::json(*spacing) : nlohmann::json(nullptr)},
                          {"notes", out.notes}, {"channels", out.channels}, {"channel", out.channel}};
  });
}

// Everything the pipe brings back, read to its end.
std::string read_all(int fd) {
  std::string text;
  char buffer[4096];
  for (;;) {
    const ssize_t n = ::read(fd, buffer, sizeof buffer);
    if (n > 0) text.append(buffer, static_cast<std::size_t>(n));
    else if (n == 0 || errno != EINTR) break;
  }
  return text;
}

void write_all(int fd, const std::string& text) {
  std::size_t done = 0;
  while (done < text.size()) {
    const ssize_t n = ::write(fd, text.data() + done, text.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return;
    done += static_cast<std::size_t>(n);
  }
}

class Fd {
public:
  explicit Fd(int fd) : fd_(fd) {}
  ~Fd() {
    if (fd_ >= 0) ::close(fd_);
  }
  Fd(const Fd&) = delete;
  Fd& operator=(const Fd&) = delete;
  int get() const { return fd_; }
  void close() {
    if (fd_ >= 0) ::close(fd_);
    fd_ = -1;
  }

private:
  int fd_;
};

// Runs read_in_child in a forked, limited process: its answer and wait status.
std::pair<std::string, int> answer_of_child(const std::string& path, const std::string& dataset_name, int channel,
                                            const ChildRead& request, int memfd, const io_detail::ChildLimits& limits) {
  int fds[2];
  if (::pipe2(fds, O_CLOEXEC) != 0) throw Error("cannot create a pipe for the HDF5 reader");  // no other child keeps it open
  Fd from_child(fds[0]), to_parent(fds[1]);
  const pid_t child = ::fork();
  if (child < 0) throw Error("cannot start the HDF5 reader process");
  if (child == 0) {  // the child: libhdf5 only, then _exit (no destructors of the parent's state)
    from_child.close();
    io_detail::limit_child(limits);
    std::string answer;
    try {
      answer = "V" + read_in_child(path, dataset_name, channel, request, memfd).dump();
    } catch (const std::bad_alloc&) {
      answer = "Elibhdf5 ran out of memory reading it (a corrupt size?)";
    } catch (const std::exception& e) {
      answer = std::string("E") + e.what();
    }
    write_all(to_parent.get(), answer);
    ::_exit(0);
  }
  to_parent.close();
  std::string answer = read_all(from_child.get());
  int status = 0;
  while (::waitpid(child, &status, 0) < 0 && errno == EINTR) {
  }
  return {std::move(answer), status};
}

// read_in_child's answer (an Error when it failed). A child that runs out of time is asked once more:
// one forked while another thread of this process held a lock it needs (or starved by a busy machine)
// can stall where a second child does not.
nlohmann::json read_in_process(const std::string& path, const std::string& dataset_name, int channel, const ChildRead& request, int memfd) {
  const io_detail::ChildLimits limits = io_detail::child_limits(path);
  auto [answer, status] = answer_of_child(path, dataset_name, channel, request, memfd, limits);
  if (answer.empty() && WIFEXITED(status) && WEXITSTATUS(status) == 5)
    std::tie(answer, status) = answer_of_child(path, dataset_name, channel, request, memfd, limits);
  if (!answer.empty() && answer[0] == 'E') throw Error(answer.substr(1));
  if (answer.empty() || answer[0] != 'V' || !WIFEXITED(status) || WEXITSTATUS(status) != 0)
    throw Error("libhdf5 failed reading it: its reader process " + io_detail::child_exit_text(status, limits) + " (a corrupt file?)");
  const nlohmann::json meta = nlohmann::json::parse(answer.substr(1), nullptr, false);
  if (meta.is_discarded() || !meta.contains("dims")) throw Error("the HDF5 reader process gave an incomplete answer");
  return meta;
}

}  // namespace

bool is_hdf5_path(const std::string& path) {
  return io_detail::ends_with_ci(path, ".h5") || io_detail::ends_with_ci(path, ".hdf5") || io_detail::ends_with_ci(path, ".he5");
}

Volume load_hdf5_volume(const std::string& path, const std::string& dataset_name, int channel, VolumeFileInfo* info,
                        const SliceChooser* choose, WindowRead* read) {
  VolumeFileInfo local;
  VolumeFileInfo& out = info ? *info : local;
  out.format = "hdf5";
  if (read) *read = WindowRead{};
  if (::access(path.c_str(), R_OK) != 0) throw Error(std::string("cannot read the file: ") + std::strerror(errno));
  const Fd memfd(::memfd_create("penumbra-hdf5", MFD_CLOEXEC));
  if (memfd.get() < 0) throw Error(std::string("cannot make shared memory for the HDF5 reader: ") + std::strerror(errno));
  // a window: the grid first (a header read), then its slices only
  ChildRead request;
  if (choose) {
    request.header_only = true;
    const auto grid = read_in_process(path, dataset_name, channel, request, memfd.get())["dims"].get<std::array<std::int64_t, 3>>();
    const SliceRange r = checked_slices(*choose, {static_cast<int>(grid[0]), static_cast<int>(grid[1]), static_cast<int>(grid[2])});
    request = ChildRead{false, r.first, r.count};
  }
  const nlohmann::json meta = read_in_process(path, dataset_name, channel, request, memfd.get());
  if (!meta.contains("slices")) throw Error("the HDF5 reader process gave an incomplete answer");
  const auto xyz = meta["dims"].get<std::array<std::int64_t, 3>>();
  const int slices = meta["slices"].get<int>();
  const ScalarType stored = scalar_type_from_string(meta["type"].get<std::string>());
  Volume volume(stored, {static_cast<int>(xyz[0]), static_cast<int>(xyz[1]), slices}, {1, 1, 1}, {0, 0, 0}, VoxelFill::Uninitialized);
  const std::size_t bytes = volume.voxel_count() * scalar_size(stored);
  if (meta["bytes"].get<std::size_t>() != bytes) throw Error("the HDF5 reader process gave an inconsistent answer");
  if (bytes > 0) {
    const void* voxels = ::mmap(nullptr, bytes, PROT_READ, MAP_SHARED, memfd.get(), 0);
    if (voxels == MAP_FAILED) throw Error(std::string("cannot map the voxels the HDF5 reader read: ") + std::strerror(errno));
    std::memcpy(volume.data(), voxels, bytes);
    ::munmap(const_cast<void*>(voxels), bytes);
  }
  out.notes = meta["notes"].get<std::vector<std::string>>();
  out.channels = meta["channels"].get<int>();
  out.channel = meta["channel"].get<int>();
  const std::array<double, 3> spacing = meta["spacing"].is_null() ? std::array<double, 3>{1, 1, 1} : meta["spacing"].get<std::array<double, 3>>();
  volume = place_volume(std::move(volume), Affine::diagonal(spacing, {0, 0, 0}), out);  // a window's origin is still the whole grid's here
  volume.recompute_range();
  if (slices < xyz[2]) volume.set_window(request.first, static_cast<int>(xyz[2]));
  if (read) read->bytes_read = meta["stored_bytes"].get<std::uint64_t>();
  return volume;
}

}  // namespace penumbra
