// OpenVDB grids (.vdb) through the OpenVDB library (Debian libopenvdb-dev), kept sparse.
//
// A .vdb file holds named grids; one scalar grid (float, or double made float) becomes a bricked
// Volume (data/volume.h) without densifying its box:
// - the grid: the box of its active voxels, its low corner moved down to a multiple of 8 in index
//   space so that penumbra's bricks of 8³ cells start where OpenVDB's 8³ leaf nodes do;
// - a brick is stored unless one value fills its reach (its voxels and one more on each side, which
//   central differences read): tiles and background count block by block, leaf nodes voxel by voxel;
//   a flat brick shares the single stored brick of its value (background, a level set's inside);
// - world placement from the grid's transform when it is an axis-aligned positive scale and translation;
//   any other transform is an Error (a sparse grid is not reordered or resampled, volume_placement.h).
//
// OpenVDB's reader is not hardened against corrupt files: fuzzing found it allocating what a broken
// header claims and copying gigabytes before failing. So it runs in a child process (fork) with an
// memory budget and a time limit; the child sends the grid and its bricks back through a pipe, the parent checks
// every count it reads and turns a crash, a limit or a short answer into an Error. The child uses no
// TBB (the parent's thread pool does not survive fork): its walks over the grid are serial.
//
// Which grid: `grid` names one (or gives its index from 0); by default the float grid named "density",
// else the first scalar grid. The notes list every grid in the file with its type, class and active
// voxels, and how much memory the sparse volume takes against a dense one.
#include <sys/wait.h>
#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <sstream>

#include <openvdb/io/File.h>
#include <openvdb/openvdb.h>

#include "penumbra/core/error.h"
#include "penumbra/data/io/child_process.h"
#include "penumbra/data/io/volume_io.h"
#include "penumbra/data/io/volume_placement.h"

namespace penumbra {
namespace {

std::string mib(std::size_t bytes) {
  std::ostringstream s;
  s.precision(bytes < (std::size_t{10} << 20) ? 2 : 0);
  s << std::fixed << static_cast<double>(bytes) / (1 << 20) << " MiB";
  return s.str();
}

std::string grid_class_name(openvdb::GridClass c) {
  switch (c) {
    case openvdb::GRID_LEVEL_SET: return "level set";
    case openvdb::GRID_FOG_VOLUME: return "fog volume";
    case openvdb::GRID_STAGGERED: return "staggered";
    default: return "unknown class";
  }
}

bool is_scalar(const openvdb::GridBase& g) { return g.isType<openvdb::FloatGrid>() || g.isType<openvdb::DoubleGrid>(); }

// The grid `choice` names (a name, or an index from 0), or the default one.
std::size_t choose_grid(const openvdb::GridPtrVec& grids, const std::string& choice) {
  auto listed = [&] {
    std::string s;
    for (std::size_t i = 0; i < grids.size(); ++i)
      s += (i ? ", " : "") + std::to_string(i) + ": '" + grids[i]->getName() + "' (" + grids[i]->valueType() + ")";
    return s;
  };
  if (grids.empty()) throw Error("the file holds no grids");
  if (!choice.empty()) {
    for (std::size_t i = 0; i < grids.size(); ++i)
      if (grids[i]->getName() == choice) return i;
    if (choice.find_first_not_of("0123456789") == std::string::npos && choice.size() < 10) {
      const std::size_t i = std::stoul(choice);
      if (i < grids.size()) return i;
    }
    throw Error("no grid '" + choice + "' (the file holds " + listed() + ")");
  }
  for (std::size_t i = 0; i < grids.size(); ++i)
    if (grids[i]->getName() == "density" && is_scalar(*grids[i])) return i;
  for (std::size_t i = 0; i < grids.size(); ++i)
    if (is_scalar(*grids[i])) return i;
  throw Error("no scalar grid (float or double) in the file (it holds " + listed() + ")");
}

// The loaded grid as float, whatever its scalar type.
openvdb::FloatGrid::Ptr as_float_grid(const openvdb::GridBase::Ptr& g) {
  if (auto f = openvdb::gridPtrCast<openvdb::FloatGrid>(g)) return f;
  auto d = openvdb::gridPtrCast<openvdb::DoubleGrid>(g);
  if (!d) throw Error("grid '" + g->getName() + "' holds " + g->valueType() + " values (expected float or double)");
  auto f = openvdb::FloatGrid::create(static_cast<float>(d->background()));
  f->setTransform(d->transform().copy());
  f->setGridClass(d->getGridClass());
  f->setName(d->getName());
  auto acc = f->getAccessor();
  for (auto it = d->cbeginValueAll(); it; ++it) {  // inactive values too: a level set's inside
    const float v = static_cast<float>(*it);
    if (it.isVoxelValue()) {
      if (v != f->background() || it.isValueOn()) acc.setValue(it.getCoord(), v);
      if (!it.isValueOn()) acc.setValueOff(it.getCoord());
    } else if (v != f->background() || it.isValueOn()) {
      f->fill(it.getBoundingBox(), v, it.isValueOn());
    }
  }
  return f;
}

// Per 8³ block of the grid (index space, from the aligned low corner): a leaf node, or the one value of
// the tile or background that covers it.
struct BlockMap {
  std::array<int, 3> blocks;
  std::vector<std::uint8_t> leaf;
  std::vector<float> value;
  std::size_t at(int x, int y, int z) const { return (static_cast<std::size_t>(z) * blocks[1] + y) * blocks[0] + x; }
};

BlockMap map_blocks(const openvdb::FloatGrid& grid, const openvdb::Coord& lo, const std::array<int, 3>& dims) {
  BlockMap m;
  for (int a = 0; a < 3; ++a) m.blocks[a] = (dims[a] + 7) / 8;
  const std::size_t n = static_cast<std::size_t>(m.blocks[0]) * m.blocks[1] * m.blocks[2];
  m.leaf.assign(n, 0);
  m.value.assign(n, 0.0f);
  auto acc = grid.getConstUnsafeAccessor();
  for (int z = 0; z < m.blocks[2]; ++z)
    for (int y = 0; y < m.blocks[1]; ++y)
      for (int x = 0; x < m.blocks[0]; ++x) {
        const openvdb::Coord c = lo + openvdb::Coord(8 * x, 8 * y, 8 * z);
        const std::size_t i = m.at(x, y, z);
        m.leaf[i] = acc.probeConstLeaf(c) != nullptr;
        if (!m.leaf[i]) m.value[i] = acc.getValue(c);
      }
  return m;
}

// World placement: origin and spacing from the grid's linear transform when it is an axis-aligned
// positive scale (+ translation), within kAxisCosineTolerance; any other transform (a flip, an axis swap,
// a rotation, a frustum) is an Error, as a sparse grid is neither reordered nor resampled.
void place(const openvdb::math::Transform& t, const openvdb::Coord& lo, Vec3& origin, Vec3& spacing) {
  if (!t.isLinear()) throw Error("the grid's transform (" + t.mapType() + ") is not linear, which penumbra cannot place a sparse grid by");
  const openvdb::Mat4d m = t.baseMap()->getAffineMap()->getMat4();  // OpenVDB's row-vector convention: world = index · m
  Affine affine;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) affine.linear[r][c] = m(c, r);
  const openvdb::Vec3d o = t.indexToWorld(lo);
  for (int r = 0; r < 3; ++r) affine.offset[r] = o[r];
  const auto permutation = axis_permutation(affine);
  if (!permutation || !permutation->identity())
    throw Error("the grid's transform " + affine.str() + " (" + t.mapType() +
                ") is not an axis-aligned positive scale: a sparse grid cannot be reordered or resampled onto the world's axes");
  for (int a = 0; a < 3; ++a) {
    spacing[a] = static_cast<float>(std::abs(affine.linear[a][a]));
    origin[a] = static_cast<float>(o[a]);
  }
}

// ---- Before OpenVDB: the file's layout, checked here. -------------------------------------------------

// Walks the header and the grid descriptors (their byte ranges) without OpenVDB: OpenVDB reads a file
// cut inside its last grid's voxels without complaint, leaving the missing voxels undefined. Files
// written with grid offsets (io::File, every tool's default) have each grid's end recorded; it must lie
// inside the file, each grid after the one before.
void check_layout(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  in.seekg(0, std::ios::end);
  const auto size = static_cast<std::int64_t>(in.tellg());
  in.seekg(0);
  auto need = [&](bool ok, const std::string& what) {
    if (!ok || !in) throw Error("not a complete OpenVDB file (" + what + ")");
  };
  auto u32 = [&] {
    std::uint32_t v = 0;
    in.read(reinterpret_cast<char*>(&v), 4);
    return v;
  };
  auto i64 = [&] {
    std::int64_t v = 0;
    in.read(reinterpret_cast<char*>(&v), 8);
    return v;
  };
  auto skip_string = [&](const char* what) {
    const std::uint32_t n = u32();
    need(static_cast<std::int64_t>(n) <= size - in.tellg(), std::string(what) + " runs past the end of the file");
    in.seekg(n, std::ios::cur);
  };
  need(i64() == 0x56444220, "no OpenVDB magic number at its start");
  const std::uint32_t version = u32();
  need(version >= 220 && version < 1000, "file format version " + std::to_string(version) + ", expected 220 or later");
  (void)u32();  // library major
  (void)u32();  // library minor
  char offsets = 0;
  in.get(offsets);
  in.seekg(36, std::ios::cur);  // UUID
  const std::uint32_t entries = u32();
  need(entries < 100000, "file metadata count " + std::to_string(entries));
  for (std::uint32_t e = 0; e < entries; ++e) {
    skip_string("a metadata name");
    skip_string("a metadata type");
    skip_string("a metadata value");
  }
  const std::uint32_t grids = u32();
  need(grids < 100000, "grid count " + std::to_string(grids));
  if (!offsets) return;  // written as a stream: no recorded ranges to check
  std::int64_t at = in.tellg();
  for (std::uint32_t g = 0; g < grids; ++g) {
    skip_string("a grid name");
    skip_string("a grid type");
    skip_string("a grid's parent name");
    const std::int64_t grid = i64(), block = i64(), end = i64();
    need(static_cast<bool>(in), "grid " + std::to_string(g) + "'s descriptor is cut");
    need(grid >= at && block >= grid && end >= block,
         "grid " + std::to_string(g) + " claims bytes " + std::to_string(grid) + " ... " + std::to_string(end) + " out of order");
    need(end <= size, "grid " + std::to_string(g) + " ends at byte " + std::to_string(end) + " but the file has " +
                          std::to_string(size) + ": truncated");
    in.seekg(end);
    at = end;
  }
}

// ---- The child: OpenVDB parses the file, the bricks go back through a pipe. -------------------------

// Buffered writes to the pipe.
class PipeWriter {
public:
  explicit PipeWriter(int fd) : fd_(fd) {}
  ~PipeWriter() { flush(); }
  void bytes(const void* p, std::size_t n) {
    const auto* c = static_cast<const char*>(p);
    buffer_.insert(buffer_.end(), c, c + n);
    if (buffer_.size() > (1u << 20)) flush();
  }
  template <class T> void put(const T& v) { bytes(&v, sizeof v); }
  void text(const std::string& s) {
    put(static_cast<std::uint32_t>(s.size()));
    bytes(s.data(), s.size());
  }
  void flush() {
    std::size_t done = 0;
    while (done < buffer_.size()) {
      const ssize_t n = ::write(fd_, buffer_.data() + done, buffer_.size() - done);
      if (n < 0 && errno == EINTR) continue;
      if (n <= 0) ::_exit(3);  // the parent went away
      done += static_cast<std::size_t>(n);
    }
    buffer_.clear();
  }

private:
  int fd_;
  std::vector<char> buffer_;
};

// The active voxels' box, walked serially (OpenVDB's own evaluation runs on TBB, which a forked child
// must not use): leaf nodes' active voxels and active tiles above them.
openvdb::CoordBBox active_box(const openvdb::FloatGrid& grid) {
  openvdb::CoordBBox box;
  for (auto leaf = grid.tree().cbeginLeaf(); leaf; ++leaf) leaf->evalActiveBoundingBox(box, true);
  auto tile = grid.tree().cbeginValueOn();
  tile.setMaxDepth(openvdb::FloatTree::ValueOnCIter::LEAF_DEPTH - 1);
  for (; tile; ++tile)
    if (tile.isTileValue()) box.expand(tile.getBoundingBox());
  return box;
}

// Runs in the child: reads the grid and writes 'V', the grid and every brick (0 + its value when one
// value fills its reach, else 1 + its 9³ voxels), or 'E' and a message.
void parse_in_child(const std::string& path, const std::string& grid_choice, PipeWriter& out) {
  openvdb::GridBase::Ptr base;
  openvdb::GridPtrVecPtr described;
  try {
    openvdb::io::File file(path);
    file.open(false);  // no delayed loading: the file is read now, not mapped for later
    described = file.readAllGridMetadata();
    const std::size_t chosen = choose_grid(*described, grid_choice);
    base = file.readGrid((*described)[chosen]->getName());
    file.close();
  } catch (const openvdb::Exception& e) {
    throw Error(std::string("OpenVDB cannot read it: ") + e.what());
  }
  std::vector<std::string> notes;
  for (const auto& g : *described) {
    const auto active = g->getMetadata<openvdb::Int64Metadata>(openvdb::GridBase::META_FILE_VOXEL_COUNT);
    notes.push_back("grid '" + g->getName() + "': " + g->valueType() + ", " + grid_class_name(g->getGridClass()) +
                    (active ? ", " + std::to_string(active->value()) + " active voxels" : ""));
  }
  const openvdb::FloatGrid::Ptr grid = as_float_grid(base);
  notes.push_back("loaded grid '" + grid->getName() + "'" +
                  (grid->getGridClass() == openvdb::GRID_LEVEL_SET
                       ? " (a level set: signed distance in world units, negative inside; its surface is the isosurface at 0)"
                       : ""));

  const openvdb::CoordBBox box = active_box(*grid);
  if (box.empty()) throw Error("grid '" + grid->getName() + "' has no active voxels");
  constexpr int kFar = 1 << 30;  // index coordinates beyond this are taken as a lying file
  for (int a = 0; a < 3; ++a)
    if (box.min()[a] < -kFar || box.max()[a] > kFar)
      throw Error("grid '" + grid->getName() + "' has active voxels at index " + std::to_string(box.min()[a]) + " ... " +
                  std::to_string(box.max()[a]) + " (expected within ±2^30)");
  openvdb::Coord lo = box.min();
  for (int a = 0; a < 3; ++a) lo[a] = (lo[a] >= 0 ? lo[a] / 8 : -((-lo[a] + 7) / 8)) * 8;  // down to a leaf-node corner
  std::array<std::int64_t, 3> extent;
  for (int a = 0; a < 3; ++a) extent[a] = static_cast<std::int64_t>(box.max()[a]) - lo[a] + 1;
  (void)checked_voxel_count(extent);
  const std::array<int, 3> dims{static_cast<int>(extent[0]), static_cast<int>(extent[1]), static_cast<int>(extent[2])};
  Vec3 origin, spacing;
  place(grid->transform(), lo, origin, spacing);
  const BlockMap blocks = map_blocks(*grid, lo, dims);

  out.put('V');
  out.put(static_cast<std::uint8_t>(grid->getGridClass() == openvdb::GRID_LEVEL_SET ? 1 : 0));
  for (int a = 0; a < 3; ++a) out.put(static_cast<std::int32_t>(dims[a]));
  for (int a = 0; a < 3; ++a) out.put(spacing[a]);
  for (int a = 0; a < 3; ++a) out.put(origin[a]);
  out.put(static_cast<std::uint32_t>(notes.size()));
  for (const auto& n : notes) out.text(n);

  constexpr int C = Volume::kBrickCells, N = Volume::kBrickSide;
  auto acc = grid->getConstUnsafeAccessor();
  std::vector<float> voxels(Volume::kBrickVoxels);
  const auto bricks = Volume::bricks(dims);
  for (int bz = 0; bz < bricks[2]; ++bz)
    for (int by = 0; by < bricks[1]; ++by)
      for (int bx = 0; bx < bricks[0]; ++bx) {
        // The reach: voxels 8b - 1 ... 8b + 9 per axis, clamped to the grid. Blocks without a leaf hold
        // one value; leaf blocks are read voxel by voxel where the reach covers them.
        const int b[3] = {bx, by, bz};
        int r0[3], r1[3];
        for (int a = 0; a < 3; ++a) {
          r0[a] = std::max(C * b[a] - 1, 0);
          r1[a] = std::min(C * b[a] + C + 1, dims[a] - 1);
        }
        std::optional<float> one;
        bool flat = true;
        for (int z = r0[2] / 8; flat && z <= r1[2] / 8; ++z)
          for (int y = r0[1] / 8; flat && y <= r1[1] / 8; ++y)
            for (int x = r0[0] / 8; flat && x <= r1[0] / 8; ++x) {
              const std::size_t i = blocks.at(x, y, z);
              if (!blocks.leaf[i]) {
                flat = !one || *one == blocks.value[i];
                one = blocks.value[i];
                continue;
              }
              const int q0[3] = {std::max(r0[0], 8 * x), std::max(r0[1], 8 * y), std::max(r0[2], 8 * z)};
              const int q1[3] = {std::min(r1[0], 8 * x + 7), std::min(r1[1], 8 * y + 7), std::min(r1[2], 8 * z + 7)};
              for (int k = q0[2]; flat && k <= q1[2]; ++k)
                for (int j = q0[1]; flat && j <= q1[1]; ++j)
                  for (int i2 = q0[0]; flat && i2 <= q1[0]; ++i2) {
                    const float v = acc.getValue(lo.offsetBy(i2, j, k));
                    flat = !one || *one == v;
                    one = v;
                  }
            }
        if (flat && one) {
          out.put(std::uint8_t{0});
          out.put(*one);
          continue;
        }
        float* o = voxels.data();
        for (int z = 0; z < N; ++z)
          for (int y = 0; y < N; ++y)
            for (int x = 0; x < N; ++x)
              *o++ = acc.getValue(lo.offsetBy(std::min(C * bx + x, dims[0] - 1), std::min(C * by + y, dims[1] - 1),
                                              std::min(C * bz + z, dims[2] - 1)));
        out.put(std::uint8_t{1});
        out.bytes(voxels.data(), voxels.size() * sizeof(float));
      }
}

// ---- The parent: reads what the child wrote, checking every count. ----------------------------------

class PipeReader {
public:
  explicit PipeReader(int fd) : fd_(fd) {}
  bool bytes(void* p, std::size_t n) {
    auto* c = static_cast<char*>(p);
    while (n > 0) {
      if (pos_ == end_) {
        const ssize_t got = ::read(fd_, buffer_, sizeof buffer_);
        if (got < 0 && errno == EINTR) continue;
        if (got <= 0) return false;
        pos_ = 0;
        end_ = static_cast<std::size_t>(got);
      }
      const std::size_t take = std::min(n, end_ - pos_);
      std::memcpy(c, buffer_ + pos_, take);
      pos_ += take;
      c += take;
      n -= take;
    }
    return true;
  }
  template <class T> bool get(T& v) { return bytes(&v, sizeof v); }
  bool text(std::string& s, std::size_t max) {
    std::uint32_t n = 0;
    if (!get(n) || n > max) return false;
    s.resize(n);
    return bytes(s.data(), n);
  }

private:
  int fd_;
  char buffer_[1 << 16];
  std::size_t pos_ = 0, end_ = 0;
};

struct ParsedGrid {
  std::array<int, 3> dims{};
  Vec3 spacing, origin;
  std::vector<std::string> notes;
  bool level_set = false;
  std::vector<float> shared;           // per brick: its one value (a stored brick: unused)
  std::vector<std::size_t> stored_at;  // per brick: its first voxel in `stored`, or npos when shared
  std::vector<float> stored;
  bool complete = false;  // the answer read to its end
};

// Reads the child's answer; false when it ends early or breaks a bound.
bool read_answer(PipeReader& in, ParsedGrid& g, std::string& error) {
  char kind = 0;
  if (!in.get(kind)) return false;
  if (kind == 'E') return in.text(error, 1 << 16);
  if (kind != 'V') return false;
  std::uint8_t level_set = 2;
  if (!in.get(level_set) || level_set > 1) return false;
  g.level_set = level_set == 1;
  std::int32_t d[3];
  for (int a = 0; a < 3; ++a)
    if (!in.get(d[a])) return false;
  (void)checked_voxel_count({d[0], d[1], d[2]});
  g.dims = {d[0], d[1], d[2]};
  for (int a = 0; a < 3; ++a)
    if (!in.get(g.spacing[a])) return false;
  for (int a = 0; a < 3; ++a)
    if (!in.get(g.origin[a])) return false;
  std::uint32_t notes = 0;
  if (!in.get(notes) || notes > 10000) return false;
  g.notes.resize(notes);
  for (auto& n : g.notes)
    if (!in.text(n, 1 << 16)) return false;
  const auto b = Volume::bricks(g.dims);
  const std::size_t count = static_cast<std::size_t>(b[0]) * b[1] * b[2];
  g.shared.assign(count, 0.0f);
  g.stored_at.assign(count, std::string::npos);
  for (std::size_t i = 0; i < count; ++i) {
    std::uint8_t tag = 2;
    if (!in.get(tag) || tag > 1) return false;
    if (tag == 0) {
      if (!in.get(g.shared[i])) return false;
      continue;
    }
    g.stored_at[i] = g.stored.size();
    g.stored.resize(g.stored.size() + Volume::kBrickVoxels);
    if (!in.bytes(g.stored.data() + g.stored_at[i], Volume::kBrickVoxels * sizeof(float))) return false;
  }
  char extra;
  return !in.get(extra);  // nothing after the last brick
}

// Forks the limited child that parses the file and reads its answer into `parsed`; the child's wait
// status. An Error the child reports, or an answer that breaks a bound, is thrown here.
int read_in_child_process(const std::string& path, const std::string& grid_choice, const io_detail::ChildLimits& limits,
                          ParsedGrid& parsed) {
  int fds[2];
  if (::pipe2(fds, O_CLOEXEC) != 0) throw Error("cannot create a pipe for the OpenVDB reader");  // no other child keeps it open
  const pid_t child = ::fork();
  if (child < 0) {
    ::close(fds[0]);
    ::close(fds[1]);
    throw Error("cannot start the OpenVDB reader process");
  }
  if (child == 0) {  // the child: OpenVDB only, then _exit (no destructors of the parent's state)
    ::close(fds[0]);
    io_detail::limit_child(limits);
    {
      PipeWriter w(fds[1]);
      try {
        parse_in_child(path, grid_choice, w);
      } catch (const std::bad_alloc&) {
        w.put('E');
        w.text("OpenVDB ran out of memory reading it (it asked for more than " + mib(limits.memory_budget) +
               ", the budget for a file of this size: a corrupt size?)");
      } catch (const std::exception& e) {
        w.put('E');
        w.text(e.what());
      }
    }
    ::close(fds[1]);
    ::_exit(0);
  }
  ::close(fds[1]);
  std::string child_error, bound_error;
  {
    PipeReader r(fds[0]);
    try {
      parsed.complete = read_answer(r, parsed, child_error);
    } catch (const Error& e) {
      bound_error = e.what();
    }
    char sink[4096];
    while (::read(fds[0], sink, sizeof sink) > 0) {  // let the child finish writing before waiting for it
    }
  }
  ::close(fds[0]);
  int status = 0;
  while (::waitpid(child, &status, 0) < 0 && errno == EINTR) {
  }
  if (!child_error.empty()) throw Error(child_error);
  if (!bound_error.empty()) throw Error(bound_error);
  return status;
}

}  // namespace

Volume load_vdb_volume(const std::string& path, const std::string& grid_choice, VolumeFileInfo* info) {
  static std::once_flag initialised;
  std::call_once(initialised, [] { openvdb::initialize(); });
  VolumeFileInfo local;
  VolumeFileInfo& out = info ? *info : local;
  out.format = "vdb";
  {
    std::ifstream probe(path, std::ios::binary);
    if (!probe) throw Error("cannot open the file");
  }
  check_layout(path);

  const io_detail::ChildLimits limits = io_detail::child_limits(path);
  ParsedGrid parsed;
  int status = 0;
  // A child that runs out of time is asked once more: one forked while another thread of this process
  // held a lock it needs (or starved by a busy machine) can stall where a second child does not.
  for (int attempt = 0; attempt < 2; ++attempt) {
    parsed = ParsedGrid{};
    status = read_in_child_process(path, grid_choice, limits, parsed);
    if (!(WIFEXITED(status) && WEXITSTATUS(status) == 5)) break;
  }
  if (WIFSIGNALED(status))
    throw Error("OpenVDB failed reading it (its reader process ended on signal " + std::to_string(WTERMSIG(status)) +
                "): a corrupt or truncated file?");
  if (WIFEXITED(status) && WEXITSTATUS(status) == 4)
    throw Error("OpenVDB needed more than " + mib(limits.memory_budget) +
                " reading it (the budget for a file of this size, more than any compression gives back): a corrupt size?");
  if (WIFEXITED(status) && WEXITSTATUS(status) == 5)
    throw Error("OpenVDB took more than " + std::to_string(static_cast<int>(limits.seconds)) + " s reading it, twice: a corrupt file?");
  if (!parsed.complete || !WIFEXITED(status) || WEXITSTATUS(status) != 0)
    throw Error("OpenVDB failed reading it (its reader process gave an incomplete answer)");

  const auto& dims = parsed.dims;
  const auto b = Volume::bricks(dims);
  auto brick_index = [&](const std::array<int, 3>& c) { return (static_cast<std::size_t>(c[2]) * b[1] + c[1]) * b[0] + c[0]; };
  Volume volume = Volume::bricked(
      dims, parsed.spacing, parsed.origin,
      [&](const std::array<int, 3>& c) -> std::optional<float> {
        const std::size_t i = brick_index(c);
        if (parsed.stored_at[i] != std::string::npos) return std::nullopt;
        return parsed.shared[i];
      },
      [&](const std::array<int, 3>& c, float* voxels) {
        std::memcpy(voxels, parsed.stored.data() + parsed.stored_at[brick_index(c)], Volume::kBrickVoxels * sizeof(float));
      });
  volume.set_level_set(parsed.level_set);
  out.affine = Affine::diagonal({parsed.spacing.x, parsed.spacing.y, parsed.spacing.z}, {parsed.origin.x, parsed.origin.y, parsed.origin.z});
  out.notes = std::move(parsed.notes);
  const std::size_t stored = parsed.stored.size() / Volume::kBrickVoxels;
  out.notes.push_back("sparse: " + std::to_string(stored) + " of " + std::to_string(parsed.shared.size()) +
                      " bricks of 8³ cells stored, " + mib(volume.memory_bytes()) + " (dense: " +
                      mib(volume.voxel_count() * sizeof(float)) + ")");
  return volume;
}

}  // namespace penumbra
