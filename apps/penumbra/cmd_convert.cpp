// `penumbra convert IN... -o OUT.zarr`: any volume penumbra reads (a DICOM folder, a TIFF stack, NRRD,
// NIfTI, VTI, HDF5, a Zarr store; --series, --channel, --level, --dataset, --grid choose as for render)
// written as an OME-Zarr 0.4 pyramid (zarr_writer.h), with a progress line on a terminal.
#include <unistd.h>

#include <cstdio>

#include "commands.h"
#include "inputs.h"
#include "penumbra/core/error.h"
#include "penumbra/core/timer.h"
#include "penumbra/data/io/volume_io.h"
#include "penumbra/data/io/zarr_writer.h"

namespace penumbra::cli {

void add_convert_command(CLI::App& app) {
  struct Options {
    std::vector<std::string> files;
    std::string out;
    VolumeLoadOptions choice;  // --series, --channel, --level, --dataset, --grid
    OmeZarrWriteOptions write;
  };
  auto o = std::make_shared<Options>();
  CLI::App* cmd = app.add_subcommand("convert", "Write a volume as an OME-Zarr pyramid (napari, ome-zarr-py and zarr open it)");
  cmd->add_option("input", o->files, "A volume file, a folder of DICOM slices or .dcm files")->required();
  cmd->add_option("-o,--output", o->out, "The OME-Zarr folder to write (must not exist)")->required();
  cmd->add_option("--chunk", o->write.chunk, "Chunk edge in voxels (default 64)")->check(CLI::Range(8, 512));
  cmd->add_option("--codec", o->write.codec, "Blosc compressor: lz4 (default), zstd or zlib");
  cmd->add_option("--clevel", o->write.clevel, "Compression level 1-9 (default 5)")->check(CLI::Range(1, 9));
  cmd->add_option("--unit", o->write.unit, "The axes' unit in the metadata (e.g. millimeter, micrometer; default none)");
  add_volume_choice_options(*cmd, o->choice);
  cmd->callback([o] {
    Timer timer;
    VolumeFileInfo info;
    Volume v = load_volume(o->files, o->choice, &info);
    if (v.is_bricked()) v = v.densified(std::size_t{16} << 30);
    const double read_ms = timer.elapsed_ms();
    const bool terminal = ::isatty(STDERR_FILENO) != 0;
    o->write.name = std::filesystem::path(o->files.front()).filename().string();
    o->write.progress = [terminal](int level, int levels, std::size_t done, std::size_t chunks) {
      if (terminal) std::fprintf(stderr, "\rconvert: level %d of %d, chunk %zu of %zu   ", level + 1, levels, done, chunks);
      else if (done == chunks) std::fprintf(stderr, "convert: level %d of %d written (%zu chunks)\n", level + 1, levels, chunks);
    };
    const OmeZarrWritten w = write_ome_zarr(v, o->out, o->write);
    if (terminal) std::fprintf(stderr, "\n");
    const auto& d = v.dims();
    std::printf("%s: %d x %d x %d %s from %s (read in %.0f ms), %d levels, %llu chunk files, %.1f MiB, %.0f ms in all\n", o->out.c_str(),
                d[0], d[1], d[2], to_string(v.type()).c_str(), info.format.c_str(), read_ms, w.levels,
                static_cast<unsigned long long>(w.chunk_files), static_cast<double>(w.bytes) / (1 << 20), timer.elapsed_ms());
  });
}

}  // namespace penumbra::cli
