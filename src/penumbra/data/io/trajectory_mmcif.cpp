// Multi-model mmCIF trajectories (.cif, .mmcif, optionally .gz): each model (_atom_site.pdbx_PDB_model_num)
// is one frame; time and step are the frame index; the unit cell is _cell (a b c alpha beta gamma) unless
// absent or the placeholder 1 1 1 90 90 90.
//
// gemmi parses a CIF document whole, so this reader does not stream: at open it reads the file (gzip
// inflated), parses it, keeps only the _atom_site items, builds gemmi's structure, copies every model's
// positions into one float array (atoms × models × 3) and drops the rest; memory_bytes() is that array.
// The atoms of a model are taken in gemmi's order (chains, residues, atoms), as molecule_gemmi.cpp packs
// the first model of a topology, so frame k's atom i is atom i of load_particles on the same file. Every
// model must hold the first model's atoms (count, then names, residues and chains in order).
#include <zlib.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <exception>
#include <new>
#include <vector>

#include "penumbra/data/io/file_checks.h"
#include "penumbra/data/io/text_fields.h"
#include "penumbra/data/io/trajectory_detail.h"

#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wconversion"
#pragma GCC diagnostic ignored "-Wshadow"
#pragma GCC diagnostic ignored "-Wpedantic"
#pragma GCC diagnostic ignored "-Wsign-conversion"
#include <gemmi/cif.hpp>
#include <gemmi/mmcif.hpp>
#include <gemmi/model.hpp>
#pragma GCC diagnostic pop

namespace penumbra::traj_detail {
namespace {

using io_detail::printable;

constexpr std::uint64_t kMaxTextBytes = 4ull << 30;  // as load_particles

// The whole file as text; gzip is inflated (zlib reads plain files as they are).
std::string read_text(const std::string& path) {
  if (io_detail::regular_file_size(path) == 0) throw Error("empty file");
  const bool gz = io_detail::ends_with_ci(path, ".gz");
  if (gz) {
    unsigned char magic[2] = {0, 0};
    BinaryFile f(path);
    if (!f.read(magic, 2) || magic[0] != 0x1f || magic[1] != 0x8b)
      throw Error("not gzip data (the name ends in .gz but the file does not start with the gzip magic 1f 8b)");
  }
  gzFile f = gzopen(path.c_str(), "rb");
  if (!f) throw Error("cannot open the file");
  std::string text;
  int err = Z_OK;
  const char* msg = nullptr;
  try {
    constexpr unsigned kChunk = 1u << 20;
    for (int n = 1; n > 0;) {
      const std::size_t old = text.size();
      if (old + kChunk > kMaxTextBytes) throw Error("the text is longer than " + io_detail::bytes_str(kMaxTextBytes));
      text.resize(old + kChunk);
      n = gzread(f, text.data() + old, kChunk);
      text.resize(old + static_cast<std::size_t>(std::max(n, 0)));
    }
    msg = gzerror(f, &err);
  } catch (...) {
    gzclose(f);
    throw;
  }
  const std::string what = err != Z_OK && msg ? msg : "";
  gzclose(f);
  if (err != Z_OK) throw Error("corrupt or truncated gzip data (" + what + ")");
  return text;
}

bool tag_starts_with(const std::string& tag, std::string_view prefix) {
  if (tag.size() < prefix.size()) return false;
  for (std::size_t i = 0; i < prefix.size(); ++i)
    if (std::tolower(static_cast<unsigned char>(tag[i])) != prefix[i]) return false;
  return true;
}

// Only the _atom_site items stay: gemmi then builds no assemblies, entities or anything else it could
// trip on. gemmi 0.5.7 reads integers with an int accumulator and no overflow check (undefined
// behaviour), so a value whose leading digits exceed the int range is refused, as molecule_gemmi.cpp does.
void keep_atom_site(gemmi::cif::Block& block) {
  const auto tag_of = [](const gemmi::cif::Item& item) -> const std::string* {
    if (item.type == gemmi::cif::ItemType::Pair) return &item.pair[0];
    if (item.type == gemmi::cif::ItemType::Loop && !item.loop.tags.empty()) return &item.loop.tags[0];
    return nullptr;
  };
  auto& items = block.items;
  items.erase(std::remove_if(items.begin(), items.end(),
                             [&](const gemmi::cif::Item& item) {
                               const std::string* tag = tag_of(item);
                               return !tag || !tag_starts_with(*tag, "_atom_site.");
                             }),
              items.end());
  const auto check = [](const std::string& value, const std::string& tag, int line) {
    std::size_t i = 0;
    while (i < value.size() && (value[i] == ' ' || value[i] == '\t')) ++i;
    if (i < value.size() && (value[i] == '-' || value[i] == '+')) ++i;
    std::int64_t n = 0;
    for (; i < value.size() && value[i] >= '0' && value[i] <= '9'; ++i)
      if ((n = n * 10 + (value[i] - '0')) > INT32_MAX)
        throw Error("line " + std::to_string(line) + ": " + printable(tag, 60) + " value '" + printable(value, 40) +
                    "' holds a number beyond the int range");
  };
  for (const gemmi::cif::Item& item : items) {
    if (item.type == gemmi::cif::ItemType::Pair) check(item.pair[1], item.pair[0], item.line_number);
    else
      for (std::size_t v = 0; v < item.loop.values.size(); ++v)
        check(item.loop.values[v], item.loop.tags[v % item.loop.tags.size()], item.line_number);
  }
}

// _cell.length_a … angle_gamma; false when a value is absent or null (? or .), or for the placeholder
// 1 1 1 90 90 90; an Error for a value that is not a number or a cell that is not one.
bool read_cell(const gemmi::cif::Block& block, std::array<float, 6>& box) {
  static const char* const kTags[6] = {"_cell.length_a", "_cell.length_b", "_cell.length_c",
                                       "_cell.angle_alpha", "_cell.angle_beta", "_cell.angle_gamma"};
  for (std::size_t i = 0; i < 6; ++i) {
    const std::string* v = block.find_value(kTags[i]);
    if (!v || gemmi::cif::is_null(*v)) return false;
    const double d = gemmi::cif::as_number(*v);
    if (!std::isfinite(d) || std::abs(d) > 1e30)
      throw Error(std::string(kTags[i]) + " '" + printable(*v, 40) + "' is not a finite number");
    box[i] = static_cast<float>(d);
  }
  if (box[0] == 1 && box[1] == 1 && box[2] == 1 && box[3] == 90 && box[4] == 90 && box[5] == 90) return false;
  for (std::size_t i = 0; i < 6; ++i)
    if (!(box[i] > 0) || (i >= 3 && box[i] >= 180))
      throw Error("_cell holds " + num(box[0]) + " " + num(box[1]) + " " + num(box[2]) + " " + num(box[3]) + " " +
                  num(box[4]) + " " + num(box[5]) + " (expected positive lengths and angles in (0, 180) degrees)");
  return true;
}

struct AtomRef {
  const gemmi::Chain* chain;
  const gemmi::Residue* res;
  const gemmi::Atom* atom;
};

std::vector<AtomRef> atoms_of(const gemmi::Model& model) {
  std::vector<AtomRef> out;
  for (const gemmi::Chain& chain : model.chains)
    for (const gemmi::Residue& res : chain.residues)
      for (const gemmi::Atom& atom : res.atoms) out.push_back({&chain, &res, &atom});
  return out;
}

std::string describe(const AtomRef& a) {
  return "'" + printable(a.atom->name, 8) + "' of " + printable(a.res->name, 8) + " " + a.res->seqid.str() + " in chain " +
         printable(a.chain->name, 8);
}

class MmcifReader final : public TrajectoryFile {
public:
  MmcifReader(const std::string& path, std::size_t expected_atoms) {
    with_context(path, [&] {
      try {
        load(path, expected_atoms);
      } catch (const Error&) {
        throw;
      } catch (const std::bad_alloc&) {
        throw Error("out of memory while parsing (gemmi holds the whole mmCIF document and structure at once)");
      } catch (const std::exception& e) {
        throw Error(std::string("mmCIF parse error: ") + e.what());  // gemmi and PEGTL report std::runtime_error
      }
    });
  }
  std::string format() const override { return "mmcif"; }
  std::size_t frame_count() const override { return frames_; }
  std::size_t atom_count() const override { return atoms_; }
  bool stores_time() const override { return false; }
  void release() override {}  // the positions are the index: they stay
  std::size_t memory_bytes() const override { return xyz_.capacity() * sizeof(float); }
  void read_frame(std::size_t index, TrajectoryFrame& out) override {
    if (index >= frames_)
      throw Error(path_ + ": " + frame_str(index) + " does not exist (the file holds " + std::to_string(frames_) + " models)");
    out.positions.resize(atoms_);
    const float* p = xyz_.data() + index * atoms_ * 3;
    for (std::size_t i = 0; i < atoms_; ++i, p += 3) out.positions[i] = Vec3{p[0], p[1], p[2]};
    out.time_ps = static_cast<double>(index);
    out.step = static_cast<std::int64_t>(index);
    out.has_box = has_box_;
    out.box = box_;
  }

private:
  void load(const std::string& path, std::size_t expected_atoms) {
    path_ = path;
    gemmi::Structure st;
    {
      const std::string text = read_text(path);
      if (io_detail::trim(text).empty()) throw Error("empty file (only blanks)");
      gemmi::cif::Document doc = gemmi::cif::read_memory(text.data(), text.size(), path.c_str());
      if (doc.blocks.empty()) throw Error("not mmCIF: no data block (expected data_… with an _atom_site loop)");
      has_box_ = read_cell(doc.blocks[0], box_);
      if (!has_box_) box_ = {};
      for (gemmi::cif::Block& block : doc.blocks) keep_atom_site(block);
      st = gemmi::make_structure(doc);
    }
    if (st.models.empty())
      throw Error("no atoms (expected an _atom_site loop with type_symbol, label_alt_id, label_asym_id, Cartn_x, Cartn_y, "
                  "Cartn_z, occupancy, B_iso_or_equiv, auth_seq_id; one model per pdbx_PDB_model_num)");
    const std::vector<AtomRef> first = atoms_of(st.models[0]);
    atoms_ = first.size();
    frames_ = st.models.size();
    if (atoms_ == 0) throw Error("model " + printable(st.models[0].name, 20) + " holds no atoms");
    check_atoms(0, atoms_, expected_atoms);
    xyz_.reserve(frames_ * atoms_ * 3);
    for (std::size_t k = 0; k < frames_; ++k) {
      const std::string model = "model " + printable(st.models[k].name, 20) + " (" + frame_str(k) + ")";
      const std::vector<AtomRef> atoms = k == 0 ? first : atoms_of(st.models[k]);
      if (atoms.size() != atoms_)
        throw Error(model + " holds " + std::to_string(atoms.size()) + " atoms, model " + printable(st.models[0].name, 20) +
                    " holds " + std::to_string(atoms_) + " (every model must hold the same atoms)");
      for (std::size_t i = 0; i < atoms_; ++i) {
        const AtomRef& a = atoms[i];
        const AtomRef& f = first[i];
        if (a.atom->name != f.atom->name || a.res->name != f.res->name || !(a.res->seqid == f.res->seqid) ||
            a.chain->name != f.chain->name)
          throw Error(model + ": atom " + std::to_string(i + 1) + " is " + describe(a) + ", but in model " +
                      printable(st.models[0].name, 20) + " it is " + describe(f) +
                      " (every model must hold the same atoms in the same order)");
        const gemmi::Position& p = a.atom->pos;
        for (const double v : {p.x, p.y, p.z})
          if (!std::isfinite(v) || std::abs(v) > 1e30)
            throw Error(model + ": atom " + std::to_string(i + 1) + " (" + describe(a) + "): coordinates are not finite numbers");
        xyz_.insert(xyz_.end(), {static_cast<float>(p.x), static_cast<float>(p.y), static_cast<float>(p.z)});
      }
    }
  }

  std::string path_;
  std::size_t frames_ = 0, atoms_ = 0;
  std::vector<float> xyz_;  // frame-major: frame k, atom i at (k * atoms_ + i) * 3
  bool has_box_ = false;
  std::array<float, 6> box_{};
};

}  // namespace

std::unique_ptr<TrajectoryFile> open_mmcif(const std::string& path, std::size_t expected_atoms) {
  return std::make_unique<MmcifReader>(path, expected_atoms);
}

}  // namespace penumbra::traj_detail
