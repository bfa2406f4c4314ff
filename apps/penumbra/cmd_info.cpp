// `penumbra info FILE [--bins N] [--assembly N] [--series S] [--channel C]`: for a volume its format,
// dimensions, type, spacing, affine, orientation, bounds, value range, histogram, the series of a DICOM input
// and the channels of a TIFF stack (a folder or several .dcm files are one DICOM input); for a molecule or particle file its atoms, assembly, spheres and bounds;
// for a trajectory (.xtc, .dcd, or --trajectory FILE) what info_trajectory.h says.
#include <cstdio>

#include "commands.h"
#include "info_trajectory.h"
#include "inputs.h"
#include "penumbra/core/error.h"
#include "penumbra/core/timer.h"
#include "penumbra/data/io/particle_io.h"
#include "penumbra/data/io/trajectory_io.h"
#include "penumbra/data/io/volume_io.h"
#include "penumbra/data/volume_stats.h"

namespace penumbra::cli {

void add_info_command(CLI::App& app) {
  struct Options {
    std::vector<std::string> files;
    std::string file;  // the first of them
    VolumeLoadOptions choice;  // --series, --channel, --level, --dataset, --grid
    int bins = 16;
    int assembly = 0;
    bool trajectory = false;
    long long frame = -1;
    std::string positions;
    bool read_all = false;
  };
  auto o = std::make_shared<Options>();
  CLI::App* cmd = app.add_subcommand("info", "Describe a volume (.nrrd, .nhdr, .nii, .nii.gz, .tif, .tiff, .vti, .vtk, .vdb, a folder of DICOM "
                                             "slices or .dcm files), a particle file (.pdb, .cif, .gro, .xyz) "
                                             "or a trajectory (.xtc, .dcd; .pdb, .cif, .xyz, .gro with --trajectory)");
  cmd->add_option("file", o->files, "Volume, particle or trajectory file (several: the slices of one DICOM series)")->required();
  add_volume_choice_options(*cmd, o->choice);
  cmd->add_option("--bins", o->bins, "Histogram bins (volumes)")->check(CLI::Range(1, 1024));
  cmd->add_option("--assembly", o->assembly, "Biological assembly to build (particle files; 0 = as deposited)")->check(CLI::Range(0, 1000000));
  cmd->add_flag("--trajectory", o->trajectory, "Read FILE as a trajectory (multi-model PDB or mmCIF, multi-frame XYZ or GRO; .xtc and .dcd always are)");
  cmd->add_option("--frame", o->frame, "Trajectory frame to describe (from 0)")->check(CLI::NonNegativeNumber);
  cmd->add_option("--positions", o->positions, "Write the frame's positions (angstrom) to this .npy (float32, atoms x 3) or .txt file");
  cmd->add_flag("--read-all", o->read_all, "Read every frame of the trajectory and report the frames per second");
  cmd->callback([o] {
    o->file = o->files.front();
    if (o->files.size() > 1 && !is_volume_file(o->file))
      throw penumbra::Error("several files are described together only as the slices of one DICOM series (.dcm)");
    const std::string traj_format = trajectory_file_format(o->file);
    const bool particles = o->trajectory || traj_format == "xtc" || traj_format == "dcd" || !particle_file_format(o->file).empty();
    if (particles && chooses_part(o->choice))
      throw penumbra::Error("--series, --channel, --level, --dataset and --grid are for volumes: " + o->file + " is not one");
    if (o->trajectory || traj_format == "xtc" || traj_format == "dcd") {
      if (o->assembly != 0) throw penumbra::Error("--assembly: not for trajectories");
      info_trajectory({o->file, o->frame, o->positions, o->read_all});
      return;
    }
    if (o->frame >= 0 || !o->positions.empty() || o->read_all)
      throw penumbra::Error("--frame, --positions and --read-all are for trajectories: " + o->file +
                            " is not an .xtc or .dcd (give --trajectory for a multi-frame .pdb, .xyz or .gro)");
    if (!particle_file_format(o->file).empty()) {
      ParticleLoadOptions lo;
      lo.assembly = o->assembly;
      ParticleFileInfo info;
      const ParticleSet p = load_particles(o->file, lo, &info);
      const Box3 b = p.bounds();
      std::printf("file        %s\n", o->file.c_str());
      std::printf("format      %s\n", info.format.c_str());
      std::printf("atoms       %zu in the first model (%zu of unknown element)\n", info.atoms_in_file, info.unknown_elements);
      std::printf("assembly    %d (%d operators)\n", o->assembly, info.operators);
      std::printf("spheres     %zu (%zu bytes in memory)\n", p.size(), p.memory_bytes());
      std::printf("bounds      [%g %g %g] .. [%g %g %g] (angstrom)\n", b.lo.x, b.lo.y, b.lo.z, b.hi.x, b.hi.y, b.hi.z);
      return;
    }
    if (o->assembly != 0) throw penumbra::Error("--assembly: " + o->file + " is not a particle file");
    VolumeFileInfo info;
    Timer read;
    const Volume v = load_volume(o->files, o->choice, &info);
    const double read_ms = read.elapsed_ms();
    const Box3 b = v.bounds();
    std::printf("file        %s\n", o->file.c_str());
    if (o->files.size() > 1) std::printf("            (and %zu more files)\n", o->files.size() - 1);
    std::printf("format      %s (read in %.1f ms)\n", info.format.c_str(), read_ms);
    for (std::size_t i = 0; i < info.series.size(); ++i)
      std::printf("%s %s %s\n", i == 0 ? "series     " : "           ", static_cast<int>(i) == info.series_index ? "*" : " ", info.series[i].c_str());
    if (info.channels > 1) std::printf("channels    %d (channel %d loaded)\n", info.channels, info.channel);
    std::printf("dimensions  %d x %d x %d (%zu voxels)\n", v.dims()[0], v.dims()[1], v.dims()[2], v.voxel_count());
    std::printf("type        %s (%zu bytes in memory)\n", to_string(v.type()).c_str(), v.memory_bytes());
    std::printf("spacing     %g %g %g\n", v.spacing().x, v.spacing().y, v.spacing().z);
    std::printf("origin      %g %g %g\n", v.origin().x, v.origin().y, v.origin().z);
    // NRRD, NIfTI and DICOM place voxels in a patient frame (LPS, mm); the others in their own world and unit
    const bool patient = info.format == "nrrd" || info.format == "nifti" || info.format == "dicom";
    if (info.affine)
      std::printf("affine      %s (file voxel index to world%s)\n", info.affine->str().c_str(), patient ? ", LPS mm" : ", the file's own unit");
    if (!info.orientation.empty()) std::printf("orientation %s\n", info.orientation.c_str());
    std::printf("bounds      [%g %g %g] .. [%g %g %g]\n", b.lo.x, b.lo.y, b.lo.z, b.hi.x, b.hi.y, b.hi.z);
    for (const auto& note : info.notes) std::printf("note        %s\n", note.c_str());
    const VolumeHistogram h = compute_histogram(v, o->bins);
    std::printf("range       %g .. %g (mean %g)\n", h.lo, h.hi, h.mean);
    std::printf("histogram\n");
    std::uint64_t peak = 1;
    for (auto c : h.counts) peak = std::max(peak, c);
    const double width = (static_cast<double>(h.hi) - h.lo) / static_cast<double>(h.counts.size());
    for (std::size_t i = 0; i < h.counts.size(); ++i) {
      const int bar = static_cast<int>(40.0 * static_cast<double>(h.counts[i]) / static_cast<double>(peak));
      std::printf("  %10.4g .. %-10.4g %12llu %s\n", h.lo + width * static_cast<double>(i), h.lo + width * static_cast<double>(i + 1),
                  static_cast<unsigned long long>(h.counts[i]), std::string(static_cast<std::size_t>(bar), '#').c_str());
    }
  });
}

}  // namespace penumbra::cli
