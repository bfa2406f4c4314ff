// CHARMM / NAMD / X-PLOR .dcd reader, written from the format's description (CHARMM dynamc.doc,
// "DCD"; the layout MDAnalysis documents for its DCDFile).
//
// A DCD is a Fortran unformatted file: each record is framed by its byte count, before and after
// (4-byte markers; 8-byte ones from some compilers). Little- or big-endian, told by the first marker (84).
//   record 1 (84 bytes): "CORD", then 20 ints ICNTRL: [0] NSET frames, [1] ISTART first step,
//            [2] NSAVC steps between frames, [8] NAMNF fixed atoms, [9] DELTA (float32 time step in
//            AKMA units; X-PLOR files: a double over [9..10]), [10] unit cell present, [11] 4D,
//            [19] CHARMM version (0: X-PLOR, which has neither unit cell nor 4D)
//   record 2: NTITLE, then NTITLE 80-character lines
//   record 3: NATOM
//   per frame: [unit cell: 6 doubles] X (NATOM float32) Y Z [W when 4D], positions in Å.
// Files with fixed atoms (NAMNF > 0) store only the free atoms after frame 0; they are refused here.
//
// Unit cell and time follow MDAnalysis 2.4 (coordinates/DCD.py): the cell is stored as
// (A, gamma, B, beta, alpha, C); angles within [−1, 1] are cosines (CHARMM, NAMD > 2.5) turned into
// degrees as 90 − asin(c)·90/(π/2); a negative entry or an angle above 180 means the six numbers are
// the lower triangle of the box matrix (new CHARMM); otherwise angles are degrees (NAMD 2.5).
// dt = DELTA · NSAVC AKMA time units, 1 AKMA = 0.04888821 ps; time of frame k = (k + ISTART/NSAVC)·dt.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <numbers>
#include <vector>

#include "penumbra/data/io/file_checks.h"
#include "penumbra/data/io/trajectory_detail.h"

namespace penumbra::traj_detail {
namespace {

constexpr double kAkmaPs = 0.04888821;

class DcdReader final : public TrajectoryFile {
public:
  DcdReader(std::string path, std::size_t expected_atoms) : path_(std::move(path)) {
    with_context(path_, [&] { read_header(expected_atoms); });
  }
  std::string format() const override { return "dcd"; }
  std::size_t frame_count() const override { return frames_; }
  std::size_t atom_count() const override { return natoms_; }
  bool stores_time() const override { return true; }
  void release() override {
    file_.close();
    std::vector<unsigned char>().swap(buffer_);
  }
  std::size_t memory_bytes() const override { return buffer_.capacity(); }

  void read_frame(std::size_t index, TrajectoryFrame& out) override {
    with_context(path_, [&] {
      if (index >= frames_)
        throw Error(frame_str(index) + " does not exist (the file holds " + std::to_string(frames_) + " frames)");
      with_context(frame_str(index), [&] { read(index, out); });
    });
  }

private:
  std::uint64_t marker_at(const unsigned char* p) const {
    if (marker_bytes_ == 8) {
      std::uint64_t v = 0;
      for (int i = 0; i < 8; ++i) v |= std::uint64_t{p[i]} << (8 * (swap_ ? 7 - i : i));
      return v;
    }
    return static_cast<std::uint32_t>(int_at(p));
  }
  std::int32_t int_at(const unsigned char* p) const {
    std::uint32_t v = swap_ ? (std::uint32_t{p[0]} << 24) | (std::uint32_t{p[1]} << 16) | (std::uint32_t{p[2]} << 8) | p[3]
                            : (std::uint32_t{p[3]} << 24) | (std::uint32_t{p[2]} << 16) | (std::uint32_t{p[1]} << 8) | p[0];
    return static_cast<std::int32_t>(v);
  }
  float float_at(const unsigned char* p) const {
    const std::uint32_t u = static_cast<std::uint32_t>(int_at(p));
    float f;
    std::memcpy(&f, &u, 4);
    return f;
  }
  double double_at(const unsigned char* p) const {
    std::uint64_t u = 0;
    for (int i = 0; i < 8; ++i) u |= std::uint64_t{p[swap_ ? 7 - i : i]} << (8 * i);
    double d;
    std::memcpy(&d, &u, 8);
    return d;
  }

  // Reads one record at `offset` into `buf`, checking both markers; returns the offset after it.
  std::uint64_t read_record(std::uint64_t offset, std::vector<unsigned char>& buf, const char* what, std::uint64_t max_bytes) {
    const std::string where = std::string(what) + " record at byte " + std::to_string(offset);
    unsigned char m[8];
    if (size_ - offset < marker_bytes_) throw Error(where + ": the file ends before it");
    file_.seek(offset);
    if (!file_.read(m, marker_bytes_)) throw Error(where + ": cannot read its length");
    const std::uint64_t n = marker_at(m);
    if (n > max_bytes || n > size_ - offset - marker_bytes_ || size_ - offset - marker_bytes_ - n < marker_bytes_)
      throw Error(where + ": its length " + std::to_string(n) + " runs past the end of the file or is implausible");
    buf.resize(static_cast<std::size_t>(n));
    if (!file_.read(buf.data(), buf.size()) || !file_.read(m, marker_bytes_)) throw Error(where + ": cannot read it");
    if (marker_at(m) != n) throw Error(where + ": the closing length " + std::to_string(marker_at(m)) + " differs from the opening " + std::to_string(n));
    return offset + 2 * marker_bytes_ + n;
  }

  void read_header(std::size_t expected_atoms) {
    size_ = io_detail::regular_file_size(path_);
    if (size_ < 8) throw Error("file too short for a DCD header (" + io_detail::bytes_str(size_) + ")");
    file_ = BinaryFile(path_);
    unsigned char first[12];
    if (!file_.read(first, std::min<std::size_t>(12, static_cast<std::size_t>(size_)))) throw Error("cannot read the DCD header");
    // The first marker is 84 (the header's length): tells byte order and marker width.
    const auto le32 = [&](const unsigned char* p) { return std::uint32_t{p[0]} | (std::uint32_t{p[1]} << 8) | (std::uint32_t{p[2]} << 16) | (std::uint32_t{p[3]} << 24); };
    const auto be32 = [&](const unsigned char* p) { return std::uint32_t{p[3]} | (std::uint32_t{p[2]} << 8) | (std::uint32_t{p[1]} << 16) | (std::uint32_t{p[0]} << 24); };
    if (le32(first) == 84 && std::memcmp(first + 4, "CORD", 4) == 0) {
      swap_ = false;
    } else if (be32(first) == 84 && std::memcmp(first + 4, "CORD", 4) == 0) {
      swap_ = true;
    } else if (size_ >= 12 && le32(first) == 84 && le32(first + 4) == 0 && std::memcmp(first + 8, "CORD", 4) == 0) {
      marker_bytes_ = 8;
    } else if (size_ >= 12 && be32(first + 4) == 84 && be32(first) == 0 && std::memcmp(first + 8, "CORD", 4) == 0) {
      marker_bytes_ = 8;
      swap_ = true;
    } else {
      throw Error("not a DCD file: expected a first record of 84 bytes starting with \"CORD\"");
    }
    std::vector<unsigned char> rec;
    std::uint64_t offset = read_record(0, rec, "header", 84);
    if (rec.size() != 84) throw Error("the header record holds " + std::to_string(rec.size()) + " bytes, expected 84");
    std::int32_t icntrl[20];
    for (int i = 0; i < 20; ++i) icntrl[i] = int_at(rec.data() + 4 + 4 * i);
    const std::int32_t nset = icntrl[0];
    istart_ = icntrl[1];
    nsavc_ = icntrl[2];
    const bool charmm = icntrl[19] != 0;
    delta_ = charmm ? float_at(rec.data() + 4 + 36) : double_at(rec.data() + 4 + 36);
    has_cell_ = charmm && icntrl[10] != 0;
    four_d_ = charmm && icntrl[11] != 0;
    if (icntrl[8] != 0)
      throw Error("the file has " + std::to_string(icntrl[8]) + " fixed atoms (NAMNF), which are not supported");
    if (nset < 0) throw Error("the header's frame count NSET is negative (" + std::to_string(nset) + ")");

    offset = read_record(offset, rec, "title", 1u << 20);
    if (rec.size() < 4) throw Error("the title record is shorter than 4 bytes");
    const std::int32_t ntitle = int_at(rec.data());
    if (ntitle < 0 || 4 + 80ull * static_cast<std::uint64_t>(ntitle) != rec.size())
      throw Error("the title record holds " + std::to_string(rec.size()) + " bytes, which is not 4 + 80 x NTITLE (" + std::to_string(ntitle) + ")");
    offset = read_record(offset, rec, "atom count", 4);
    if (rec.size() != 4) throw Error("the atom-count record holds " + std::to_string(rec.size()) + " bytes, expected 4");
    const std::int32_t natoms = int_at(rec.data());
    if (natoms <= 0) throw Error("the atom count NATOM is " + std::to_string(natoms) + " (expected a positive number)");
    natoms_ = static_cast<std::size_t>(natoms);
    first_frame_ = offset;
    frame_bytes_ = (has_cell_ ? 48 + 2 * marker_bytes_ : 0) + (four_d_ ? 4 : 3) * (4ull * natoms_ + 2 * marker_bytes_);
    check_atoms(0, natoms_, expected_atoms);
    if (size_ - offset < frame_bytes_ && nset > 0)
      throw Error(frame_str(0) + " is truncated: a frame of " + std::to_string(natoms_) + " atoms needs " +
                  io_detail::bytes_str(frame_bytes_) + ", the file holds " + io_detail::bytes_str(size_ - offset) + " after the header");
    const std::uint64_t whole = (size_ - offset) / frame_bytes_, rest = (size_ - offset) % frame_bytes_;
    if (nset == 0) {  // some writers leave NSET 0 until they close the file: trust the size
      if (rest != 0) throw Error(frame_str(whole) + " is truncated (" + io_detail::bytes_str(rest) + " of " + io_detail::bytes_str(frame_bytes_) + ")");
      frames_ = static_cast<std::size_t>(whole);
    } else {
      if (whole < static_cast<std::uint64_t>(nset))
        throw Error(frame_str(whole) + (rest ? " is truncated" : " is missing") + ": the header says NSET = " + std::to_string(nset) +
                    " frames of " + io_detail::bytes_str(frame_bytes_) + ", but the file holds " + std::to_string(whole) + " whole frames" +
                    (rest ? " and " + io_detail::bytes_str(rest) : std::string()));
      if (whole > static_cast<std::uint64_t>(nset) || rest != 0)
        throw Error("the header says NSET = " + std::to_string(nset) + " frames, but the file holds " + std::to_string(whole) +
                    " frames of " + io_detail::bytes_str(frame_bytes_) + (rest ? " and " + io_detail::bytes_str(rest) : std::string()) +
                    " (" + frame_str(static_cast<std::size_t>(nset)) + " onwards is not announced)");
      frames_ = static_cast<std::size_t>(nset);
    }
    if (frames_ == 0) throw Error("the file holds no frames (NSET is 0 and nothing follows the header)");
    file_.close();
  }

  void read(std::size_t index, TrajectoryFrame& out) {
    if (!file_.is_open()) file_ = BinaryFile(path_);
    const std::uint64_t offset = first_frame_ + index * frame_bytes_;
    buffer_.resize(static_cast<std::size_t>(frame_bytes_));
    file_.seek(offset);
    if (!file_.read(buffer_.data(), buffer_.size())) throw Error("cannot read the frame (the file changed since it was opened?)");
    const unsigned char* p = buffer_.data();
    const auto record = [&](std::uint64_t bytes, const char* what) {
      if (marker_at(p) != bytes || marker_at(p + marker_bytes_ + bytes) != bytes)
        throw Error(std::string("the ") + what + " record's length markers are " + std::to_string(marker_at(p)) + " and " +
                    std::to_string(marker_at(p + marker_bytes_ + bytes)) + ", expected " + std::to_string(bytes) + " (corrupt frame)");
      const unsigned char* body = p + marker_bytes_;
      p += 2 * marker_bytes_ + bytes;
      return body;
    };
    out.box = {};
    out.has_box = false;
    if (has_cell_) {
      const unsigned char* c = record(48, "unit cell");
      double h[6];
      for (int i = 0; i < 6; ++i) h[i] = double_at(c + 8 * i);
      out.has_box = cell_from_dcd(h, out.box);
    }
    out.positions.resize(natoms_);
    static const char* kAxes[3] = {"X", "Y", "Z"};
    for (int d = 0; d < 3; ++d) {
      const unsigned char* x = record(4ull * natoms_, kAxes[d]);
      for (std::size_t a = 0; a < natoms_; ++a) out.positions[a][d] = float_at(x + 4 * a);
    }
    if (four_d_) record(4ull * natoms_, "W");
    const double dt = static_cast<double>(delta_) * kAkmaPs * nsavc_;
    out.time_ps = nsavc_ != 0 ? (static_cast<double>(index) + static_cast<double>(istart_) / nsavc_) * dt : static_cast<double>(index);
    out.step = static_cast<std::int64_t>(istart_) + static_cast<std::int64_t>(index) * nsavc_;
  }

  // The stored (A, gamma, B, beta, alpha, C) as MDAnalysis 2.4 reads it (see the top of the file).
  static bool cell_from_dcd(const double h[6], std::array<float, 6>& box) {
    double uc[6] = {h[0], h[2], h[5], h[4], h[3], h[1]};
    const auto cosine = [](double c) { return c >= -1.0 && c <= 1.0; };
    if (cosine(uc[3]) && cosine(uc[4]) && cosine(uc[5])) {
      for (int i = 3; i < 6; ++i) uc[i] = 90.0 - std::asin(uc[i]) * 90.0 / (std::numbers::pi / 2);
    } else if (std::any_of(uc, uc + 6, [](double v) { return v < 0; }) || uc[3] > 180 || uc[4] > 180 || uc[5] > 180) {
      const double e1[3] = {h[0], h[1], h[3]}, e2[3] = {h[1], h[2], h[4]}, e3[3] = {h[3], h[4], h[5]};
      return cell_from_vectors(e1, e2, e3, box);
    }
    for (int i = 0; i < 6; ++i) box[static_cast<std::size_t>(i)] = static_cast<float>(uc[i]);
    // A cell of zero lengths is "no cell" (MDAnalysis' writer stores zeros when there is none).
    return box[0] > 0 && box[1] > 0 && box[2] > 0;
  }

  std::string path_;
  std::uint64_t size_ = 0, first_frame_ = 0, frame_bytes_ = 0;
  std::size_t natoms_ = 0, frames_ = 0, marker_bytes_ = 4;
  bool swap_ = false, has_cell_ = false, four_d_ = false;
  std::int32_t istart_ = 0, nsavc_ = 0;
  double delta_ = 0;
  std::vector<unsigned char> buffer_;
  BinaryFile file_;
};

}  // namespace

std::unique_ptr<TrajectoryFile> open_dcd(const std::string& path, std::size_t expected_atoms) {
  return std::make_unique<DcdReader>(path, expected_atoms);
}

}  // namespace penumbra::traj_detail
