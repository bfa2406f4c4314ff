// `penumbra convert IN... -o OUT.zarr`: any volume penumbra reads (a DICOM folder, a TIFF stack, NRRD,
// NIfTI, VTI, HDF5, a Zarr store; --series, --channel, --level, --dataset, --grid choose as for render),
// or a procedural one (--procedural), written as an OME-Zarr 0.4 pyramid (zarr_writer.h) with a
// progress line on a terminal.
//
// The pyramid streams (OmeZarrStreamWriter): DICOM series, NRRD, NIfTI and TIFF files, HDF5 datasets and
// Zarr stores (reads_slices_in_part) are read a slab of slices at a time (load_volume_window: a DICOM
// series decodes the slab's slices, raw data seeks, gzip data decompresses up to the slab, a TIFF stack
// decodes the slab's pages, an HDF5 hyperslab and a Zarr store read the chunks of the slab's rows) and a
// procedural ct-body is made a slab at a time, so that none is ever held whole; other formats (VTK image
// data, OpenVDB) are read whole first.
#include <unistd.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cstdio>
#include <filesystem>

#include "commands.h"
#include "inputs.h"
#include "penumbra/core/error.h"
#include "penumbra/core/parallel.h"
#include "penumbra/core/timer.h"
#include "penumbra/data/ct_body.h"
#include "penumbra/data/io/volume_io.h"
#include "penumbra/data/io/zarr_writer.h"
#include "penumbra/data/procedural.h"

namespace penumbra::cli {

namespace {

// Slices read or made at a time: about this many bytes (at least one slice).
constexpr std::int64_t kSlabBytes = std::int64_t{16} << 20;

std::int64_t slab_slices(std::int64_t slice_bytes, std::int64_t slices) {
  return std::clamp<std::int64_t>(kSlabBytes / std::max<std::int64_t>(slice_bytes, 1), 1, slices);
}

// What was converted, for the summary line.
struct Converted {
  std::array<std::int64_t, 3> dims{};
  ScalarType type = ScalarType::UInt8;
  std::string from;        // the format or "procedural NAME"
  bool streamed = false;   // read or made a slab at a time
  std::uint64_t buffer_bytes = 0;
  OmeZarrWritten written;
};

Converted write_whole(const Volume& volume, const std::string& from, const std::string& out, const OmeZarrWriteOptions& options) {
  const auto& d = volume.dims();
  OmeZarrStreamWriter writer(out, volume.type(), {d[0], d[1], d[2]}, volume.spacing(), volume.origin(), options);
  writer.add_slices(volume.data(), d[2]);
  return {{d[0], d[1], d[2]}, volume.type(), from, false, writer.buffer_bytes(), writer.finish()};
}

// A ct-body of any size, made a slab at a time.
Converted stream_ct_body(const CtBodyParams& p, const std::string& out, const OmeZarrWriteOptions& options) {
  const CtBodyGrid grid = ct_body_grid(p);
  const std::array<std::int64_t, 3> dims{p.dims[0], p.dims[1], p.dims[2]};
  const auto vec = [](const std::array<double, 3>& a) { return Vec3(static_cast<float>(a[0]), static_cast<float>(a[1]), static_cast<float>(a[2])); };
  OmeZarrStreamWriter writer(out, ScalarType::UInt16, dims, vec(grid.spacing), vec(grid.origin), options);
  const std::int64_t slice = dims[0] * dims[1];
  // ct-body paints slices in parallel: at least two a core, however large a slice
  const std::int64_t slab = std::max(slab_slices(slice * 2, dims[2]), std::min<std::int64_t>(dims[2], 2 * ThreadLimit::current_max()));
  std::vector<std::uint16_t> voxels(static_cast<std::size_t>(slab * slice));
  CtBodySlices body(p);
  for (std::int64_t first = 0; first < dims[2]; first += slab) {
    const std::int64_t count = std::min(slab, dims[2] - first);
    body.make(static_cast<int>(first), static_cast<int>(count), voxels.data());
    writer.add_slices(reinterpret_cast<const std::byte*>(voxels.data()), count);
  }
  return {dims, ScalarType::UInt16, "procedural ct-body", true, writer.buffer_bytes() + voxels.size() * 2, writer.finish()};
}

// A file reads_slices_in_part accepts, a slab at a time; one its reader cannot read in part (an NRRD or NIfTI file
// whose z is another file axis, a Zarr level whose z scale is negative) is read whole.
Converted stream_slabs(const std::vector<std::string>& files, const VolumeLoadOptions& choice, const std::string& format,
                       const std::string& out, const OmeZarrWriteOptions& options) {
  std::array<int, 3> dims{};
  std::int64_t first = 0, slab = 0;
  const SliceChooser choose = [&](const std::array<int, 3>& d) {
    dims = d;
    if (slab == 0) slab = slab_slices(std::int64_t{d[0]} * d[1] * 4, d[2]);  // the type is not known yet: 4 bytes a voxel at most
    return SliceRange{static_cast<int>(first), static_cast<int>(std::min<std::int64_t>(slab, d[2] - first))};
  };
  const WindowPass pass;  // gzip data decompressed once, slab after slab
  WindowRead read;
  Volume part = load_volume_window(files, choice, choose, read);
  if (read.whole) {
    VolumeFileInfo info;
    return write_whole(load_volume(files, choice, &info), info.format, out, options);
  }
  // The window's origin is its first slice's, here the whole grid's.
  OmeZarrStreamWriter writer(out, part.type(), {dims[0], dims[1], dims[2]}, part.spacing(), part.origin(), options);
  std::uint64_t held = 0;
  while (true) {
    writer.add_slices(part.data(), part.dims()[2]);
    held = std::max<std::uint64_t>(held, part.memory_bytes());
    first += part.dims()[2];
    if (first >= dims[2]) break;
    read = {};
    part = Volume();  // freed before the next slab is read: one slab is held at a time
    part = load_volume_window(files, choice, choose, read);
  }
  const ScalarType type = part.type();
  return {{dims[0], dims[1], dims[2]}, type, format, true, writer.buffer_bytes() + held, writer.finish()};
}


}  // namespace

void add_convert_command(CLI::App& app) {
  struct Options {
    std::vector<std::string> files;
    std::string procedural;
    std::string out;
    VolumeLoadOptions choice;  // --series, --channel, --level, --dataset, --grid
    OmeZarrWriteOptions write;
  };
  auto o = std::make_shared<Options>();
  CLI::App* cmd = app.add_subcommand("convert", "Write a volume as an OME-Zarr pyramid (napari, ome-zarr-py and zarr open it)");
  cmd->add_option("input", o->files, "A volume file, a folder of DICOM slices or .dcm files");
  cmd->add_option("--procedural", o->procedural,
                  "A procedural volume as a scene file names it, e.g. '{\"name\": \"ct-body\", \"dims\": [4096, 4096, 2048]}' "
                  "(ct-body dims up to 16384, made a slab at a time)");
  cmd->add_option("-o,--output", o->out, "The OME-Zarr folder to write (must not exist)")->required();
  cmd->add_option("--chunk", o->write.chunk, "Chunk edge in voxels (default 64)")->check(CLI::Range(8, 512));
  cmd->add_option("--codec", o->write.codec, "Blosc compressor: lz4 (default), zstd or zlib");
  cmd->add_option("--clevel", o->write.clevel, "Compression level 1-9 (default 5)")->check(CLI::Range(1, 9));
  cmd->add_option("--unit", o->write.unit, "The axes' unit in the metadata (e.g. millimeter, micrometer; default none)");
  add_volume_choice_options(*cmd, o->choice);
  cmd->callback([o] {
    if (o->files.empty() == o->procedural.empty()) throw Error("convert: give one input: volume files or --procedural");
    Timer timer;
    const bool terminal = ::isatty(STDERR_FILENO) != 0;
    o->write.progress = [terminal, &timer, last_tenth = -1](std::int64_t done, std::int64_t slices, std::uint64_t bytes) mutable {
      const double seconds = timer.elapsed_ms() / 1000;
      if (terminal) {
        const double left = done > 0 ? seconds * static_cast<double>(slices - done) / static_cast<double>(done) : 0;
        std::fprintf(stderr, "\rconvert: slice %lld of %lld (%3.0f%%), %.0f MiB written, %.0f s, %.0f s left   ", static_cast<long long>(done),
                     static_cast<long long>(slices), 100.0 * static_cast<double>(done) / static_cast<double>(slices),
                     static_cast<double>(bytes) / (1 << 20), seconds, left);
      } else if (const int tenth = static_cast<int>(10 * done / slices); tenth != last_tenth) {
        last_tenth = tenth;
        std::fprintf(stderr, "convert: %d%% of %lld slices, %.0f MiB written, %.0f s\n", 10 * tenth, static_cast<long long>(slices),
                     static_cast<double>(bytes) / (1 << 20), seconds);
      }
    };
    Converted c;
    if (!o->procedural.empty()) {
      nlohmann::json spec;
      try {
        spec = nlohmann::json::parse(o->procedural);
      } catch (const nlohmann::json::exception& e) {
        throw Error("--procedural: not JSON (" + std::string(e.what()) + ")");
      }
      if (!spec.is_object() || !spec.contains("name") || !spec["name"].is_string())
        throw Error("--procedural: expected an object with a \"name\" (e.g. {\"name\": \"ct-body\"})");
      o->write.name = spec["name"].get<std::string>();
      if (o->write.name == "ct-body") c = stream_ct_body(ct_body_params(spec, 16384), o->out, o->write);
      else c = write_whole(make_procedural_volume(spec), "procedural " + o->write.name, o->out, o->write);
    } else {
      o->write.name = std::filesystem::path(o->files.front()).filename().string();
      const std::string& in = o->files.front();
      if (reads_slices_in_part(o->files, o->choice)) {
        VolumeLoadOptions choice = o->choice;
        if (is_zarr_store(in) && choice.level < 0) choice.level = 0;  // streamed: the finest, however large
        c = stream_slabs(o->files, choice, volume_format(o->files), o->out, o->write);
      } else {
        VolumeFileInfo info;
        Volume v = load_volume(o->files, o->choice, &info);
        if (v.is_bricked()) v = v.densified(std::size_t{16} << 30);
        c = write_whole(v, info.format, o->out, o->write);
      }
    }
    if (terminal) std::fprintf(stderr, "\n");
    std::printf("%s: %lld x %lld x %lld %s from %s (%s), %d levels, %llu chunk files, %.1f MiB, %.0f ms in all, %.1f MiB of slabs "
                "and rows held\n",
                o->out.c_str(), static_cast<long long>(c.dims[0]), static_cast<long long>(c.dims[1]), static_cast<long long>(c.dims[2]),
                to_string(c.type).c_str(), c.from.c_str(), c.streamed ? "streamed" : "read whole", c.written.levels,
                static_cast<unsigned long long>(c.written.chunk_files), static_cast<double>(c.written.bytes) / (1 << 20), timer.elapsed_ms(),
                static_cast<double>(c.buffer_bytes) / (1 << 20));
  });
}

}  // namespace penumbra::cli
