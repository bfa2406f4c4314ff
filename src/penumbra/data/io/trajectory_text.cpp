// Text trajectories: multi-model PDB, multi-frame XYZ and multi-frame GROMACS .gro, plain or gzip.
//
// At open the file is read once, line by line (gzip inflated as a stream, never held whole), and each
// frame's start is noted: its offset in the (decompressed) text, its line number, and what the frame
// header says (GRO time and step, PDB unit cell). A frame is read by seeking to its offset: a plain
// seek for plain files; for gzip, zlib inflates again from the start when seeking backwards (memory
// stays at zlib's buffers; reading in order costs one pass).
//
// - PDB (wwPDB format 3.3): MODEL … ENDMDL blocks, each one frame; a file without MODEL is one frame.
//   Positions from ATOM/HETATM columns 31–54 (Å). CRYST1 (a, b, c, α, β, γ) sets the cell of the
//   frames after it (one before MODEL 1 applies to all; one inside a model to that model); the
//   placeholder 1 1 1 90 90 90 means no cell. Reading stops at END.
// - XYZ: per frame a count line, a comment, then `element x y z` (Å) per atom.
// - GRO: per frame a title (`t= <ps>` and `step= <n>` read when present), a count line, fixed-width atom
//   lines (x y z in nm in %8.3f-like fields from column 21), and a box line (3 or 9 numbers, nm).
#include <zlib.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <vector>

#include "penumbra/data/io/file_checks.h"
#include "penumbra/data/io/text_fields.h"
#include "penumbra/data/io/trajectory_detail.h"

namespace penumbra::traj_detail {
namespace {

using io_detail::parse_number;
using io_detail::printable;
using io_detail::split_fields;
using io_detail::trim;

constexpr std::size_t kMaxLine = 1u << 20;  // longer "lines" mean binary data, not a text trajectory

std::string quote_text(std::string_view s) { return "'" + printable(s, 60) + (s.size() > 60 ? "...'" : "'"); }

// Lines of a plain or gzip file with their offsets in the (decompressed) text, and seeking.
class TextSource {
public:
  TextSource(const std::string& path, bool gz) {
    if (gz) {
      unsigned char magic[2] = {0, 0};
      BinaryFile f(path);
      if (!f.read(magic, 2) || magic[0] != 0x1f || magic[1] != 0x8b)
        throw Error("not gzip data (the name ends in .gz but the file does not start with the gzip magic 1f 8b)");
    }
    f_ = gzopen(path.c_str(), "rb");
    if (!f_) throw Error("cannot open the file");
    gzbuffer(f_, 1u << 17);
  }
  ~TextSource() { gzclose(f_); }
  TextSource(const TextSource&) = delete;
  TextSource& operator=(const TextSource&) = delete;

  // The next line without its line break; false at the end of the text.
  bool next(std::string& line) {
    line.clear();
    line_start_ = next_offset_;
    bool any = false;
    for (;;) {
      if (pos_ == end_ && !refill()) break;
      any = true;
      const char* b = buf_.data() + pos_;
      const void* nl = std::memchr(b, '\n', end_ - pos_);
      const std::size_t n = nl ? static_cast<std::size_t>(static_cast<const char*>(nl) - b) : end_ - pos_;
      if (line.size() + n > kMaxLine)
        throw Error("line " + std::to_string(line_no_ + 1) + " is longer than " + io_detail::bytes_str(kMaxLine) + " (not a text file?)");
      line.append(b, n);
      pos_ += n;
      next_offset_ += n;
      if (nl) {
        ++pos_;
        ++next_offset_;
        break;
      }
    }
    if (!any) return false;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    ++line_no_;
    return true;
  }
  std::uint64_t line_start() const { return line_start_; }  // of the line last returned
  std::uint64_t line_no() const { return line_no_; }        // of the line last returned, from 1
  // Continues at `offset`, the start of line `line_no` (both as next() reported them).
  // Within the buffered text it only moves in the buffer: zlib is already past it, and asking zlib to
  // go back would inflate again from the start.
  void seek(std::uint64_t offset, std::uint64_t line_no) {
    if (offset >= buf_start_ && offset <= buf_start_ + end_) {
      pos_ = static_cast<std::size_t>(offset - buf_start_);
    } else {
      if (gzseek(f_, static_cast<z_off_t>(offset), SEEK_SET) < 0) throw Error("cannot seek to offset " + std::to_string(offset));
      pos_ = end_ = 0;
      buf_start_ = stream_pos_ = offset;
    }
    next_offset_ = offset;
    line_no_ = line_no - 1;
  }
  std::size_t memory_bytes() const { return buf_.capacity() + (1u << 17) * 3 + (1u << 15); }  // ours + zlib's (input, output, window)

private:
  bool refill() {
    // A stream that ends early still hands over what it inflated; the error shows at the next read.
    const int n = gzread(f_, buf_.data(), static_cast<unsigned>(buf_.size()));
    int err = Z_OK;
    const char* msg = gzerror(f_, &err);
    if (n <= 0 && err != Z_OK && err != Z_STREAM_END)
      throw Error(std::string("corrupt or truncated gzip data after line ") + std::to_string(line_no_) + " (" +
                  (err == Z_BUF_ERROR ? "unexpected end of the compressed stream" : msg ? msg : "error") + ")");
    pos_ = 0;
    end_ = static_cast<std::size_t>(std::max(n, 0));
    buf_start_ = stream_pos_;
    stream_pos_ += end_;
    return n > 0;
  }

  gzFile f_ = nullptr;
  std::vector<char> buf_ = std::vector<char>(1u << 16);
  std::size_t pos_ = 0, end_ = 0;
  std::uint64_t next_offset_ = 0, line_start_ = 0, line_no_ = 0;
  std::uint64_t buf_start_ = 0, stream_pos_ = 0;  // offsets of buf_[0] and of zlib's next byte
};

struct FrameEntry {
  std::uint64_t offset = 0, line = 1;  // of the frame's first line (PDB: its MODEL line, or the file's start)
  double time_ps = 0;
  std::int64_t step = 0;
  bool has_box = false;
  std::array<float, 6> box{};
};

float coordinate(std::string_view token, const char* axis, std::uint64_t line) {
  double v = 0;
  if (!parse_number(token, v) || !std::isfinite(v) || std::abs(v) > 1e30)
    throw Error("line " + std::to_string(line) + ": " + axis + " coordinate " + quote_text(token) + " is not a finite number");
  return static_cast<float>(v);
}

bool parse_count(std::string_view s, std::uint64_t& n) {
  double v = 0;
  if (!parse_number(s, v) || v < 0 || v > 1e12 || v != std::floor(v)) return false;
  n = static_cast<std::uint64_t>(v);
  return true;
}

// A number after `key` in a GRO title ("t= 0.20000 step= 100"); false when absent.
bool title_value(std::string_view title, std::string_view key, double& v) {
  for (std::size_t at = title.find(key); at != std::string_view::npos; at = title.find(key, at + 1)) {
    if (at > 0 && !std::isspace(static_cast<unsigned char>(title[at - 1]))) continue;  // "step=" is not "t="
    const auto fields = split_fields(title.substr(at + key.size()));
    if (!fields.empty() && parse_number(fields[0], v) && std::isfinite(v)) return true;
  }
  return false;
}

class TextReader final : public TrajectoryFile {
public:
  TextReader(std::string path, std::string format, std::size_t expected_atoms)
      : path_(std::move(path)), format_(std::move(format)), gz_(io_detail::ends_with_ci(path_, ".gz")) {
    with_context(path_, [&] {
      if (io_detail::regular_file_size(path_) == 0) throw Error("empty file");
      source_ = std::make_unique<TextSource>(path_, gz_);
      indexing_ = true;
      if (format_ == "pdb") index_pdb(expected_atoms);
      else if (format_ == "xyz") index_xyz(expected_atoms);
      else index_gro(expected_atoms);
      if (frames_.empty()) throw Error("no frames (expected " + std::string(format_ == "pdb" ? "ATOM/HETATM records" : "a frame") + ")");
      indexing_ = false;
      source_.reset();
    });
  }
  std::string format() const override { return format_; }
  std::size_t frame_count() const override { return frames_.size(); }
  std::size_t atom_count() const override { return natoms_; }
  bool stores_time() const override { return format_ == "gro"; }
  void release() override { source_.reset(); }
  std::size_t memory_bytes() const override {
    return frames_.capacity() * sizeof(FrameEntry) + line_.capacity() + (source_ ? source_->memory_bytes() : 0);
  }

  void read_frame(std::size_t index, TrajectoryFrame& out) override {
    with_context(path_, [&] {
      if (index >= frames_.size())
        throw Error(frame_str(index) + " does not exist (the file holds " + std::to_string(frames_.size()) + " frames)");
      with_context(frame_str(index), [&] {
        if (!source_) source_ = std::make_unique<TextSource>(path_, gz_);
        const FrameEntry& e = frames_[index];
        source_->seek(e.offset, e.line);
        out.positions.resize(natoms_);
        out.time_ps = e.time_ps;
        out.step = e.step;
        out.has_box = e.has_box;
        out.box = e.box;
        if (format_ == "pdb") read_pdb(out);
        else if (format_ == "xyz") read_xyz(out);
        else read_gro(out);
      });
    });
  }

private:
  // The next line; while indexing, an unreadable stream (truncated gzip) is blamed on the frame being indexed.
  bool next() {
    if (!indexing_) return source_->next(line_);
    return with_context(frame_str(frames_.size()), [&] { return source_->next(line_); });
  }
  std::string at_line() const { return "line " + std::to_string(source_->line_no()); }
  [[noreturn]] void ends_early(std::size_t frame, std::uint64_t got, std::uint64_t want) const {
    throw Error(frame_str(frame) + " is truncated: the file ends after " + std::to_string(got) + " of its " +
                std::to_string(want) + " atom lines");
  }
  // A frame of `count` atoms: the first sets the atom count, the others must agree.
  void add_frame(FrameEntry e, std::uint64_t count, std::size_t expected_atoms) {
    const std::size_t k = frames_.size();
    if (count == 0) throw Error(frame_str(k) + " (line " + std::to_string(e.line) + ") holds no atoms");
    check_atoms(k, count, expected_atoms);
    if (k == 0) natoms_ = static_cast<std::size_t>(count);
    else if (count != natoms_)
      throw Error(frame_str(k) + " (line " + std::to_string(e.line) + ") holds " + std::to_string(count) + " atoms, frame 0 holds " + std::to_string(natoms_));
    frames_.push_back(e);
  }

  // ------------------------------------------------------------------------------------------ XYZ
  void index_xyz(std::size_t expected_atoms) {
    while (next()) {
      if (trim(line_).empty()) continue;
      const std::size_t k = frames_.size();
      FrameEntry e{source_->line_start(), source_->line_no(), static_cast<double>(k), static_cast<std::int64_t>(k), false, {}};
      std::uint64_t n = 0;
      if (!parse_count(line_, n))
        throw Error(frame_str(k) + ", " + at_line() + ": expected the atom count, found " + quote_text(line_) +
                    (k > 0 ? "; is the previous frame's atom count right?" : ""));
      if (!next()) throw Error(frame_str(k) + " is truncated: the file ends after its atom count (no comment line)");
      for (std::uint64_t i = 0; i < n; ++i)
        if (!next()) ends_early(k, i, n);
      add_frame(e, n, expected_atoms);
    }
  }
  void read_xyz(TrajectoryFrame& out) {
    next();
    next();  // the count (checked when indexing) and the comment
    for (std::size_t i = 0; i < natoms_; ++i) {
      if (!next()) throw Error("the file changed since it was opened");
      const auto t = split_fields(line_);
      if (t.size() < 4) throw Error(at_line() + ": expected 'element x y z', found " + quote_text(line_));
      const std::uint64_t l = source_->line_no();
      out.positions[i] = {coordinate(t[1], "x", l), coordinate(t[2], "y", l), coordinate(t[3], "z", l)};
    }
  }

  // ------------------------------------------------------------------------------------------ GRO
  void index_gro(std::size_t expected_atoms) {
    while (next()) {
      const std::size_t k = frames_.size();
      FrameEntry e{source_->line_start(), source_->line_no(), static_cast<double>(k), static_cast<std::int64_t>(k), false, {}};
      double v = 0;
      if (title_value(line_, "t=", v)) e.time_ps = v;
      if (title_value(line_, "step=", v) && std::abs(v) < 9e18) e.step = static_cast<std::int64_t>(v);
      const bool blank_title = trim(line_).empty();
      if (!next()) {
        if (blank_title && k > 0) break;  // blank lines at the end
        throw Error(frame_str(k) + " is truncated: the file ends after the title (no atom count)");
      }
      std::uint64_t n = 0;
      if (!parse_count(line_, n))
        throw Error(frame_str(k) + ", " + at_line() + ": expected the atom count, found " + quote_text(line_) +
                    (k > 0 ? "; is the previous frame's atom count right?" : ""));
      for (std::uint64_t i = 0; i < n; ++i)
        if (!next()) ends_early(k, i, n);
      if (!next()) throw Error(frame_str(k) + " is truncated: the file ends before its box line");
      const auto f = split_fields(line_);
      double b[9] = {};
      bool ok = f.size() == 3 || f.size() == 9;
      for (std::size_t i = 0; ok && i < f.size(); ++i) ok = parse_number(f[i], b[i]) && std::isfinite(b[i]);
      if (!ok)
        throw Error(frame_str(k) + ", " + at_line() + ": expected the box line (3 or 9 numbers) after " + std::to_string(n) +
                    " atoms, found " + quote_text(line_) + "; is the atom count right?");
      gro_box(b, f.size(), e);
      add_frame(e, n, expected_atoms);
    }
  }
  // As MDAnalysis' GROReader: v1(x) v2(y) v3(z) [v1(y) v1(z) v2(x) v2(z) v3(x) v3(y)], nm → Å in float.
  static void gro_box(const double b[9], std::size_t n, FrameEntry& e) {
    if (n == 3) {
      e.box = {static_cast<float>(b[0]) * 10.0f, static_cast<float>(b[1]) * 10.0f, static_cast<float>(b[2]) * 10.0f, 90, 90, 90};
      e.has_box = e.box[0] > 0 && e.box[1] > 0 && e.box[2] > 0;
    } else {
      const double x[3] = {b[0], b[3], b[4]}, y[3] = {b[5], b[1], b[6]}, z[3] = {b[7], b[8], b[2]};
      e.has_box = cell_from_vectors(x, y, z, e.box);
      for (std::size_t d = 0; d < 3; ++d) e.box[d] *= 10.0f;
    }
    if (!e.has_box) e.box = {};
  }
  void read_gro(TrajectoryFrame& out) {
    next();
    next();  // the title and count (checked when indexing)
    std::size_t width = 0;
    for (std::size_t i = 0; i < natoms_; ++i) {
      if (!next()) throw Error("the file changed since it was opened");
      if (width == 0) {  // GROMACS writes x y z as %(p+5).pf: the digits after the first decimal point give p
        const std::size_t dot = line_.size() > 20 ? line_.find('.', 20) : std::string::npos;
        std::size_t decimals = 0;
        while (dot != std::string::npos && dot + 1 + decimals < line_.size() &&
               std::isdigit(static_cast<unsigned char>(line_[dot + 1 + decimals])))
          ++decimals;
        if (decimals < 1 || decimals > 18)
          throw Error(at_line() + ": cannot tell the coordinate field width (GROMACS writes x y z as %8.3f from column 21)");
        width = decimals + 5;
      }
      if (line_.size() < 20 + 3 * width)
        throw Error(at_line() + ": atom line is truncated (" + std::to_string(line_.size()) + " columns; expected x y z in " +
                    std::to_string(width) + "-column fields from column 21)");
      const std::string_view s = line_;
      const std::uint64_t l = source_->line_no();
      out.positions[i] = {coordinate(s.substr(20, width), "x", l) * 10.0f, coordinate(s.substr(20 + width, width), "y", l) * 10.0f,
                          coordinate(s.substr(20 + 2 * width, width), "z", l) * 10.0f};
    }
  }

  // ------------------------------------------------------------------------------------------ PDB
  static std::string_view record(std::string_view line) { return line.substr(0, std::min<std::size_t>(6, line.size())); }
  static bool is_atom(std::string_view rec) { return rec == "ATOM  " || rec == "HETATM"; }
  static bool is_end(std::string_view rec) { return trim(rec) == "END"; }

  void index_pdb(std::size_t expected_atoms) {
    bool in_model = false, cell = false;
    std::array<float, 6> box{};
    FrameEntry current;
    std::uint64_t count = 0;
    const auto close_model = [&] {
      add_frame(current, count, expected_atoms);
      in_model = false;
    };
    while (next()) {
      const std::string_view rec = record(line_);
      if (trim(rec) == "MODEL") {
        if (in_model) close_model();  // tolerated: a MODEL without the previous ENDMDL
        models_ = true;
        in_model = true;
        count = 0;
        const std::size_t k = frames_.size();
        current = FrameEntry{source_->line_start(), source_->line_no(), static_cast<double>(k), static_cast<std::int64_t>(k), cell, cell ? box : std::array<float, 6>{}};
      } else if (trim(rec) == "ENDMDL") {
        if (!in_model) throw Error(at_line() + ": ENDMDL without a MODEL before it");
        close_model();
      } else if (is_atom(rec)) {
        if (models_ && !in_model) continue;  // outside any model: not part of a frame
        if (line_.size() < 54)
          throw Error(frame_str(frames_.size()) + ", " + at_line() + ": ATOM/HETATM line has " + std::to_string(line_.size()) +
                      " columns; x y z need columns 31-54 (truncated?)");
        ++count;
      } else if (rec == "CRYST1") {
        cell = pdb_cell(box);
        if (in_model) {
          current.has_box = cell;
          current.box = cell ? box : std::array<float, 6>{};
        }
      } else if (is_end(rec)) {
        break;
      }
    }
    if (in_model)
      throw Error(frame_str(frames_.size()) + " (MODEL at line " + std::to_string(current.line) +
                  ") is truncated: the file ends before its ENDMDL");
    if (!models_) add_frame(FrameEntry{0, 1, 0, 0, cell, cell ? box : std::array<float, 6>{}}, count, expected_atoms);
  }
  // CRYST1 a b c alpha beta gamma in columns 7-54; false for the placeholder 1 1 1 90 90 90.
  bool pdb_cell(std::array<float, 6>& box) const {
    static constexpr std::size_t kAt[7] = {6, 15, 24, 33, 40, 47, 54};
    for (std::size_t i = 0; i < 6; ++i) {
      double v = 0;
      if (line_.size() < kAt[i + 1] || !parse_number(std::string_view(line_).substr(kAt[i], kAt[i + 1] - kAt[i]), v) || !std::isfinite(v))
        throw Error(at_line() + ": CRYST1 record " + quote_text(line_) + " does not hold a b c alpha beta gamma in columns 7-54");
      box[i] = static_cast<float>(v);
    }
    const bool placeholder = box[0] == 1 && box[1] == 1 && box[2] == 1 && box[3] == 90 && box[4] == 90 && box[5] == 90;
    return !placeholder && box[0] > 0 && box[1] > 0 && box[2] > 0;
  }
  void read_pdb(TrajectoryFrame& out) {
    if (models_) next();  // the MODEL line
    std::size_t i = 0;
    while (i < natoms_ && next()) {
      const std::string_view rec = record(line_);
      if (trim(rec) == "ENDMDL" || trim(rec) == "MODEL" || is_end(rec)) break;
      if (!is_atom(rec)) continue;
      const std::string_view s = line_;
      const std::uint64_t l = source_->line_no();
      out.positions[i++] = {coordinate(s.substr(30, 8), "x", l), coordinate(s.substr(38, 8), "y", l), coordinate(s.substr(46, 8), "z", l)};
    }
    if (i != natoms_) throw Error("the file changed since it was opened");
  }

  std::string path_, format_;
  bool gz_ = false, models_ = false, indexing_ = false;
  std::size_t natoms_ = 0;
  std::vector<FrameEntry> frames_;
  std::unique_ptr<TextSource> source_;
  std::string line_;
};

}  // namespace

std::unique_ptr<TrajectoryFile> open_text_trajectory(const std::string& path, const std::string& format, std::size_t expected_atoms) {
  return std::make_unique<TextReader>(path, format, expected_atoms);
}

}  // namespace penumbra::traj_detail
