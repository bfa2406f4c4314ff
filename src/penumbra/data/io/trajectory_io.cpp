// Trajectory files: the reader by extension, the unit-cell conversion shared by the readers, and a
// list of files read as one trajectory. The format readers are trajectory_xtc.cpp, trajectory_dcd.cpp,
// trajectory_text.cpp (PDB, XYZ, GRO) and trajectory_mmcif.cpp (multi-model mmCIF).
#include "penumbra/data/io/trajectory_io.h"

#include <cmath>
#include <numbers>

#include "penumbra/data/io/text_fields.h"
#include "penumbra/data/io/trajectory_detail.h"

namespace penumbra {

namespace traj_detail {

bool cell_from_vectors(const double a[3], const double b[3], const double c[3], std::array<float, 6>& box) {
  const auto dot = [](const double* u, const double* v) { return u[0] * v[0] + u[1] * v[1] + u[2] * v[2]; };
  const double la = std::sqrt(dot(a, a)), lb = std::sqrt(dot(b, b)), lc = std::sqrt(dot(c, c));
  const double deg = 180.0 / std::numbers::pi;
  const double alpha = std::acos(dot(b, c) / (lb * lc)) * deg, beta = std::acos(dot(a, c) / (la * lc)) * deg,
               gamma = std::acos(dot(a, b) / (la * lb)) * deg;
  box = {static_cast<float>(la), static_cast<float>(lb), static_cast<float>(lc),
         static_cast<float>(alpha), static_cast<float>(beta), static_cast<float>(gamma)};
  // Only positive lengths and angles in (0°, 180°) make a cell (NaN fails every comparison).
  const bool ok = box[0] > 0 && box[1] > 0 && box[2] > 0 && box[3] > 0 && box[4] > 0 && box[5] > 0 && alpha < 180 &&
                  beta < 180 && gamma < 180;
  if (!ok) box = {};
  return ok;
}

namespace {

std::unique_ptr<TrajectoryFile> open_one(const std::string& path, std::size_t expected_atoms) {
  const std::string format = trajectory_file_format(path);
  if (format.empty())
    throw Error(path + ": unknown trajectory file extension (supported: .xtc, .dcd, .pdb, .ent, .cif, .mmcif, "
                       ".xyz, .gro; the text formats optionally gzip-compressed with .gz)");
  if (format == "xtc") return open_xtc(path, expected_atoms);
  if (format == "dcd") return open_dcd(path, expected_atoms);
  if (format == "mmcif") return open_mmcif(path, expected_atoms);
  return open_text_trajectory(path, format, expected_atoms);
}

// Files read one after another; only the file being read is open. Formats that store no time get the
// index in the whole list as time and step.
class TrajectoryList final : public TrajectoryReader {
public:
  TrajectoryList(const std::vector<std::string>& paths, std::size_t expected_atoms) {
    if (paths.empty()) throw Error("an empty list of trajectory files");
    for (const auto& p : paths) {
      auto r = open_one(p, expected_atoms);
      r->release();
      if (atoms_ != 0 && r->atom_count() != atoms_)
        throw Error(p + ": holds " + std::to_string(r->atom_count()) + " atoms per frame, but " + paths[0] + " holds " +
                    std::to_string(atoms_) + " (all files of a trajectory need the same atoms)");
      atoms_ = r->atom_count();
      if (formats_.find(r->format()) == std::string::npos) formats_ += (formats_.empty() ? "" : "+") + r->format();
      first_.push_back(frames_);
      frames_ += r->frame_count();
      files_.push_back(std::move(r));
    }
  }
  std::string format() const override { return formats_; }
  std::size_t frame_count() const override { return frames_; }
  std::size_t atom_count() const override { return atoms_; }
  std::size_t memory_bytes() const override {
    std::size_t n = 0;
    for (const auto& f : files_) n += f->memory_bytes();
    return n + files_.capacity() * sizeof(void*) + first_.capacity() * sizeof(std::size_t);
  }
  void read_frame(std::size_t index, TrajectoryFrame& out) override {
    if (index >= frames_)
      throw Error("trajectory frame " + std::to_string(index) + " does not exist (the " + std::to_string(files_.size()) +
                  " files hold " + std::to_string(frames_) + " frames)");
    std::size_t f = files_.size() - 1;
    while (first_[f] > index) --f;
    if (f != current_ && current_ < files_.size()) files_[current_]->release();
    current_ = f;
    files_[f]->read_frame(index - first_[f], out);
    if (!files_[f]->stores_time()) {
      out.time_ps = static_cast<double>(index);
      out.step = static_cast<std::int64_t>(index);
    }
  }

private:
  std::vector<std::unique_ptr<TrajectoryFile>> files_;
  std::vector<std::size_t> first_;  // index of each file's first frame in the list
  std::size_t frames_ = 0, atoms_ = 0, current_ = static_cast<std::size_t>(-1);
  std::string formats_;
};

}  // namespace
}  // namespace traj_detail

std::string trajectory_file_format(const std::string& path) {
  using io_detail::ends_with_ci;
  std::string_view name = path;
  if (ends_with_ci(name, ".xtc")) return "xtc";
  if (ends_with_ci(name, ".dcd")) return "dcd";
  if (ends_with_ci(name, ".gz")) name.remove_suffix(3);
  if (ends_with_ci(name, ".pdb") || ends_with_ci(name, ".ent")) return "pdb";
  if (ends_with_ci(name, ".cif") || ends_with_ci(name, ".mmcif")) return "mmcif";
  if (ends_with_ci(name, ".xyz")) return "xyz";
  if (ends_with_ci(name, ".gro")) return "gro";
  return "";
}

std::unique_ptr<TrajectoryReader> open_trajectory(const std::string& path, std::size_t expected_atoms) {
  return traj_detail::open_one(path, expected_atoms);
}

std::unique_ptr<TrajectoryReader> open_trajectory(const std::vector<std::string>& paths, std::size_t expected_atoms) {
  if (paths.size() == 1) return open_trajectory(paths[0], expected_atoms);
  return std::make_unique<traj_detail::TrajectoryList>(paths, expected_atoms);
}

}  // namespace penumbra
