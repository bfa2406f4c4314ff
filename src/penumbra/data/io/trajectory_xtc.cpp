// GROMACS .xtc reader, written from the format's description (GROMACS manual, "File formats: xtc";
// the xdr3dfcoord scheme of Frans van Hoesel's xdrfile library).
//
// Every value is XDR: big-endian 4-byte ints and IEEE floats. A frame is
//   magic 1995 | natoms | step | time (ps) | box 3×3 (nm, row i = cell vector i) | natoms again
// then, for natoms ≤ 9, 3·natoms plain floats; otherwise the compressed block
//   precision | minint[3] | maxint[3] | smallidx | byte count n | n bytes, padded to a multiple of 4.
// The compressed bits (read most significant bit first) hold integer coordinates x·precision. Per
// "large" atom: its three ints, offset by minint, packed as one number in the bits of the product of the
// three ranges (or each in its own bit count where a range passes 2²⁴); then a flag bit, and if set, 5
// bits holding the run length (a multiple of 3, the number of ints in the run of close atoms that
// follow) plus whether the small-difference size grows or shrinks by one step (run % 3 − 1). The run
// persists until a flag changes it. Each close atom is three small differences to the previous one,
// packed in `smallidx` bits with each difference in [0, magicints[smallidx]). The first close atom is
// written before the large one (water: an H, then O, then the other H compress better than O, H, H).
//
// The frame index is built at open by reading each frame's header and skipping its byte count.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <vector>

#include "penumbra/data/io/file_checks.h"
#include "penumbra/data/io/trajectory_detail.h"

namespace penumbra::traj_detail {
namespace {

constexpr std::int32_t kXtcMagic = 1995;
constexpr std::size_t kHeaderBytes = 56;      // magic .. second natoms
constexpr std::size_t kCompressedHead = 36;   // precision .. byte count

// The sizes of small differences, about 2^(1/3) apart; an index i ≥ 9 packs three of them in i bits.
constexpr std::array<std::int32_t, 73> kMagicInts = {
    0,       0,       0,       0,       0,       0,       0,       0,       0,       8,        10,       12,      16,
    20,      25,      32,      40,      50,      64,      80,      101,     128,     161,      203,      256,     322,
    406,     512,     645,     812,     1024,    1290,    1625,    2048,    2580,    3250,     4096,     5060,    6501,
    8192,    10321,   13003,   16384,   20642,   26007,   32768,   41285,   52015,   65536,    82570,    104031,  131072,
    165140,  208063,  262144,  330280,  416127,  524287,  660561,  832255,  1048576, 1321122,  1664510,  2097152, 2642245,
    3329021, 4194304, 5284491, 6658042, 8388607, 10568983, 13316085, 16777216};
constexpr int kFirstIdx = 9;
constexpr int kLastIdx = static_cast<int>(kMagicInts.size());

std::uint32_t be32(const unsigned char* p) {
  return (std::uint32_t{p[0]} << 24) | (std::uint32_t{p[1]} << 16) | (std::uint32_t{p[2]} << 8) | std::uint32_t{p[3]};
}
std::int32_t be_int(const unsigned char* p) { return static_cast<std::int32_t>(be32(p)); }
float be_float(const unsigned char* p) {
  const std::uint32_t u = be32(p);
  float f;
  std::memcpy(&f, &u, 4);
  return f;
}

// Bits of the compressed block, most significant first; reading past the end is an Error.
class BitReader {
public:
  BitReader(const unsigned char* data, std::size_t bytes) : data_(data), bits_(std::uint64_t{bytes} * 8) {}
  std::uint32_t get(int n) {  // n ≤ 32
    if (pos_ + static_cast<std::uint64_t>(n) > bits_)
      throw Error("the compressed coordinates end early (corrupt data or a wrong byte count)");
    std::uint64_t v = 0;
    while (n > 0) {
      const int avail = 8 - static_cast<int>(pos_ & 7);
      const int take = std::min(avail, n);
      const unsigned byte = data_[pos_ >> 3];
      v = (v << take) | ((byte >> (avail - take)) & ((1u << take) - 1));
      pos_ += static_cast<std::uint64_t>(take);
      n -= take;
    }
    return static_cast<std::uint32_t>(v);
  }
  // Three ints packed as one number of `bits` bits, read in 8-bit pieces, least significant first;
  // nums[2] = N mod sizes[2], nums[1] = (N / sizes[2]) mod sizes[1], nums[0] = the rest.
  void get_ints(int bits, const std::uint32_t sizes[3], std::int64_t nums[3]) {
    std::uint32_t bytes[12] = {};
    int nbytes = 0;
    while (bits > 8) {
      bytes[nbytes++] = get(8);
      bits -= 8;
    }
    if (bits > 0) bytes[nbytes++] = get(bits);
    for (int i = 2; i > 0; --i) {
      std::uint64_t num = 0;
      for (int j = nbytes - 1; j >= 0; --j) {
        num = (num << 8) | bytes[j];
        const std::uint64_t q = num / sizes[i];
        bytes[j] = static_cast<std::uint32_t>(q);
        num -= q * sizes[i];
      }
      nums[i] = static_cast<std::int64_t>(num);
    }
    nums[0] = static_cast<std::int32_t>(bytes[0] | (bytes[1] << 8) | (bytes[2] << 16) | (bytes[3] << 24));
  }

private:
  const unsigned char* data_;
  std::uint64_t bits_, pos_ = 0;
};

// Bits needed for values in [0, size): the bit length of size (at most 32).
int bits_of(std::uint32_t size) {
  int n = 0;
  std::uint64_t v = 1;
  while (size >= v && n < 32) {
    ++n;
    v <<= 1;
  }
  return n;
}

// Bits of the product of three sizes (each ≤ 2²⁴): its bit length.
int bits_of_product(const std::uint32_t sizes[3]) {
  std::uint64_t lo = std::uint64_t{sizes[0]} * sizes[1];      // < 2⁴⁸
  const std::uint64_t l0 = (lo & 0xffffffu) * sizes[2];         // < 2⁴⁸
  const std::uint64_t l1 = (lo >> 24) * sizes[2] + (l0 >> 24);  // product = l1·2²⁴ + (l0 mod 2²⁴)
  if (l1 == 0) {
    int n = 0;
    for (std::uint64_t v = l0; v; v >>= 1) ++n;
    return n;
  }
  int n = 24;
  for (std::uint64_t v = l1; v; v >>= 1) ++n;
  return n;
}

// Decodes the compressed block into natoms integer triples, scaled into Å.
void decode_coords(const unsigned char* head, const unsigned char* data, std::size_t nbytes, std::size_t natoms,
                   std::vector<Vec3>& out) {
  const float precision = be_float(head);
  std::int64_t minint[3], maxint[3];
  for (int d = 0; d < 3; ++d) {
    minint[d] = be_int(head + 4 + 4 * d);
    maxint[d] = be_int(head + 16 + 4 * d);
  }
  int smallidx = be_int(head + 28);
  if (!(std::isfinite(precision) && precision > 0))
    throw Error("the precision " + num(precision) + " is not a positive number");
  std::uint32_t sizeint[3];
  bool large = false;
  for (int d = 0; d < 3; ++d) {
    const std::int64_t range = maxint[d] - minint[d] + 1;
    if (range < 1 || range > (std::int64_t{1} << 32) - 1)
      throw Error("the integer range [" + std::to_string(minint[d]) + ", " + std::to_string(maxint[d]) + "] is empty or too large");
    sizeint[d] = static_cast<std::uint32_t>(range);
    large = large || sizeint[d] > 0xffffffu;
  }
  int bitsizeint[3] = {0, 0, 0}, bitsize = 0;
  if (large)
    for (int d = 0; d < 3; ++d) bitsizeint[d] = bits_of(sizeint[d]);
  else
    bitsize = bits_of_product(sizeint);
  if (smallidx < kFirstIdx || smallidx >= kLastIdx)
    throw Error("the small-difference index " + std::to_string(smallidx) + " is outside [9, 72]");
  std::int64_t smaller = kMagicInts[static_cast<std::size_t>(std::max(kFirstIdx, smallidx - 1))] / 2;
  std::int64_t smallnum = kMagicInts[static_cast<std::size_t>(smallidx)] / 2;
  std::uint32_t sizesmall[3];
  std::fill(sizesmall, sizesmall + 3, static_cast<std::uint32_t>(kMagicInts[static_cast<std::size_t>(smallidx)]));

  // GROMACS divides by the precision in float (1/precision rounded to float, times the int); MDAnalysis
  // then multiplies by 10 in float. Doing the same gives bit-identical positions.
  const float inv_precision = static_cast<float>(1.0 / precision);
  out.resize(natoms);
  std::size_t emitted = 0;
  const auto emit = [&](const std::int64_t c[3]) {
    if (emitted >= natoms) throw Error("the compressed coordinates hold more than " + std::to_string(natoms) + " atoms");
    out[emitted++] = {static_cast<float>(c[0]) * inv_precision * 10.0f, static_cast<float>(c[1]) * inv_precision * 10.0f,
                      static_cast<float>(c[2]) * inv_precision * 10.0f};
  };
  BitReader bits(data, nbytes);
  int run = 0;
  std::size_t i = 0;
  while (i < natoms) {
    std::int64_t cur[3], prev[3];
    if (large) {
      for (int d = 0; d < 3; ++d) cur[d] = bits.get(bitsizeint[d]);
    } else {
      bits.get_ints(bitsize, sizeint, cur);
    }
    ++i;
    for (int d = 0; d < 3; ++d) {
      cur[d] += minint[d];
      prev[d] = cur[d];
    }
    int is_smaller = 0;
    if (bits.get(1) == 1) {
      run = static_cast<int>(bits.get(5));
      is_smaller = run % 3;
      run -= is_smaller;
      --is_smaller;
    }
    if (run > 0) {
      for (int k = 0; k < run; k += 3) {
        bits.get_ints(smallidx, sizesmall, cur);
        ++i;
        for (int d = 0; d < 3; ++d) cur[d] += prev[d] - smallnum;
        if (k == 0) {  // the close atom came first in the file: swap back
          for (int d = 0; d < 3; ++d) std::swap(cur[d], prev[d]);
          emit(prev);
        } else {
          std::copy(cur, cur + 3, prev);
        }
        emit(cur);
      }
    } else {
      emit(cur);
    }
    smallidx += is_smaller;
    if (smallidx < kFirstIdx || smallidx >= kLastIdx)
      throw Error("the small-difference index leaves [9, 72] at atom " + std::to_string(i) + " (corrupt data)");
    if (is_smaller < 0) {
      smallnum = smaller;
      smaller = smallidx > kFirstIdx ? kMagicInts[static_cast<std::size_t>(smallidx - 1)] / 2 : 0;
    } else if (is_smaller > 0) {
      smaller = smallnum;
      smallnum = kMagicInts[static_cast<std::size_t>(smallidx)] / 2;
    }
    std::fill(sizesmall, sizesmall + 3, static_cast<std::uint32_t>(kMagicInts[static_cast<std::size_t>(smallidx)]));
  }
  if (emitted != natoms)
    throw Error("the compressed coordinates hold " + std::to_string(emitted) + " atoms, but the header says " + std::to_string(natoms));
}

class XtcReader final : public TrajectoryFile {
public:
  XtcReader(std::string path, std::size_t expected_atoms) : path_(std::move(path)) {
    with_context(path_, [&] { build_index(expected_atoms); });
  }
  std::string format() const override { return "xtc"; }
  std::size_t frame_count() const override { return offsets_.size(); }
  std::size_t atom_count() const override { return natoms_; }
  bool stores_time() const override { return true; }
  void release() override {
    file_.close();
    std::vector<unsigned char>().swap(buffer_);
  }
  std::size_t memory_bytes() const override {
    return offsets_.capacity() * sizeof(std::uint64_t) + buffer_.capacity();
  }

  void read_frame(std::size_t index, TrajectoryFrame& out) override {
    with_context(path_, [&] {
      if (index >= offsets_.size())
        throw Error(frame_str(index) + " does not exist (the file holds " + std::to_string(offsets_.size()) + " frames)");
      with_context(frame_str(index), [&] { read(index, out); });
    });
  }

private:
  // Frame sizes: the header plus either 3·natoms floats or the compressed head and padded bytes.
  void build_index(std::size_t expected_atoms) {
    const std::uint64_t size = io_detail::regular_file_size(path_);
    if (size == 0) throw Error("empty file (expected a GROMACS .xtc trajectory)");
    file_ = BinaryFile(path_);
    std::uint64_t offset = 0;
    unsigned char head[kHeaderBytes + kCompressedHead];
    while (offset < size) {
      const std::size_t k = offsets_.size();
      const std::string where = frame_str(k) + " (at byte " + std::to_string(offset) + ")";
      if (size - offset < kHeaderBytes)
        throw Error(where + " is truncated: " + std::to_string(size - offset) + " bytes left, a frame header needs " +
                    std::to_string(kHeaderBytes));
      file_.seek(offset);
      if (!file_.read(head, kHeaderBytes)) throw Error(where + ": cannot read the frame header");
      if (be_int(head) != kXtcMagic)
        throw Error(where + ": expected the XTC magic number 1995, found " + std::to_string(be_int(head)) +
                    (k == 0 ? " (not an .xtc file?)" : " (corrupt data, or the previous frame's byte count is wrong)"));
      const std::int32_t natoms = be_int(head + 4), natoms2 = be_int(head + 52);
      if (natoms <= 0 || natoms != natoms2)
        throw Error(where + ": the atom counts " + std::to_string(natoms) + " and " + std::to_string(natoms2) +
                    " in the header are not one positive number");
      if (k == 0) {
        natoms_ = static_cast<std::size_t>(natoms);
        check_atoms(k, natoms_, expected_atoms);
      } else if (static_cast<std::size_t>(natoms) != natoms_) {
        throw Error(frame_str(k) + " holds " + std::to_string(natoms) + " atoms, frame 0 holds " + std::to_string(natoms_));
      }
      std::uint64_t frame_bytes = kHeaderBytes + 12ull * static_cast<std::uint64_t>(natoms);
      if (natoms > 9) {
        if (size - offset < kHeaderBytes + kCompressedHead)
          throw Error(where + " is truncated inside its compressed-coordinate header");
        if (!file_.read(head + kHeaderBytes, kCompressedHead)) throw Error(where + ": cannot read the frame header");
        const std::int32_t nbytes = be_int(head + kHeaderBytes + 32);
        // Each atom takes at least one bit, so the byte count bounds the atom count (and vice versa
        // the file size bounds the byte count) before anything is allocated.
        if (nbytes <= 0 || static_cast<std::uint64_t>(natoms) > 8ull * static_cast<std::uint64_t>(nbytes))
          throw Error(where + ": the compressed byte count " + std::to_string(nbytes) + " cannot hold " +
                      std::to_string(natoms) + " atoms");
        frame_bytes = kHeaderBytes + kCompressedHead + ((static_cast<std::uint64_t>(nbytes) + 3) & ~std::uint64_t{3});
      }
      if (frame_bytes > size - offset)
        throw Error(where + " is truncated: it needs " + io_detail::bytes_str(frame_bytes) + " but the file ends after " +
                    io_detail::bytes_str(size - offset));
      offsets_.push_back(offset);
      offset += frame_bytes;
    }
    file_.close();
  }

  void read(std::size_t index, TrajectoryFrame& out) {
    if (!file_.is_open()) file_ = BinaryFile(path_);
    const std::uint64_t offset = offsets_[index];
    const std::uint64_t end = index + 1 < offsets_.size() ? offsets_[index + 1] : io_detail::regular_file_size(path_);
    if (end < offset + kHeaderBytes) throw Error("the file changed since it was opened");
    buffer_.resize(static_cast<std::size_t>(end - offset));
    file_.seek(offset);
    if (!file_.read(buffer_.data(), buffer_.size())) throw Error("cannot read the frame (the file changed since it was opened?)");
    const unsigned char* p = buffer_.data();
    if (be_int(p) != kXtcMagic || static_cast<std::size_t>(be_int(p + 4)) != natoms_)
      throw Error("the frame header changed since the file was opened");
    out.step = be_int(p + 8);
    out.time_ps = be_float(p + 12);
    double v[3][3];
    bool any = false;
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) {
        v[r][c] = be_float(p + 16 + 12 * r + 4 * c);
        any = any || v[r][c] != 0;
      }
    out.has_box = any && cell_from_vectors(v[0], v[1], v[2], out.box);
    if (out.has_box)
      for (int d = 0; d < 3; ++d) out.box[static_cast<std::size_t>(d)] *= 10.0f;  // nm → Å, in float as MDAnalysis
    else
      out.box = {};
    if (natoms_ <= 9) {
      out.positions.resize(natoms_);
      for (std::size_t a = 0; a < natoms_; ++a)
        for (int d = 0; d < 3; ++d) {
          const float x = be_float(p + kHeaderBytes + 12 * a + 4 * static_cast<std::size_t>(d));
          out.positions[a][d] = x * 10.0f;
        }
      return;
    }
    const std::size_t nbytes = static_cast<std::size_t>(be_int(p + kHeaderBytes + 32));
    if (kHeaderBytes + kCompressedHead + nbytes > buffer_.size()) throw Error("the frame changed since the file was opened");
    decode_coords(p + kHeaderBytes, p + kHeaderBytes + kCompressedHead, nbytes, natoms_, out.positions);
  }

  std::string path_;
  std::size_t natoms_ = 0;
  std::vector<std::uint64_t> offsets_;
  std::vector<unsigned char> buffer_;
  BinaryFile file_;
};

}  // namespace

std::unique_ptr<TrajectoryFile> open_xtc(const std::string& path, std::size_t expected_atoms) {
  return std::make_unique<XtcReader>(path, expected_atoms);
}

}  // namespace penumbra::traj_detail
