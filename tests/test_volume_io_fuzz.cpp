// Fuzz-style robustness: valid small NRRD and NIfTI files are corrupted in deterministic ways (byte
// flips, truncation, digits spliced into the header) and loaded. Each load must either succeed with a
// sensible volume or throw penumbra::Error: no crash, no other exception, no sanitizer report.
#include <gtest/gtest.h>

#include <algorithm>
#include <string>

#include "penumbra/core/error.h"
#include "penumbra/core/rng.h"
#include "penumbra/data/io/volume_io.h"
#include "test_volume_io_util.h"

using namespace penumbra;
using namespace penumbra::test;

namespace {

struct Seed {
  std::string name;  // file name, which selects the loader
  Bytes bytes;
  std::size_t header_bytes;  // corruptions favour the header, where parsers live
  bool gzip_after = false;   // corrupt the plain bytes, then compress: bad headers inside valid gzip
};

std::vector<Seed> seeds() {
  std::vector<Seed> out;
  std::vector<std::int16_t> values(6 * 5 * 4);
  for (std::size_t i = 0; i < values.size(); ++i) values[i] = static_cast<std::int16_t>(i * 131 % 2000 - 700);
  const Bytes data = to_bytes(values);

  const std::string fields = "type: short\ndimension: 3\nsizes: 6 5 4\nspacings: 1 2 3\nendian: little\n";
  const Bytes raw_nrrd = nrrd_file(fields + "encoding: raw\n", data);
  out.push_back({"f.nrrd", raw_nrrd, raw_nrrd.size() - data.size()});
  const Bytes gz = gzip(data);
  const Bytes gz_nrrd = nrrd_file("type: short\ndimension: 3\nsizes: 6 5 4\nspace dimension: 3\n"
                                  "space directions: (1,0,0) (0,2,0) (0,0,3)\nspace origin: (1,2,3)\n"
                                  "endian: little\nencoding: gzip\n",
                                  gz);
  out.push_back({"g.nrrd", gz_nrrd, gz_nrrd.size() - gz.size()});
  const std::string nhdr = "NRRD0004\n" + fields + "encoding: raw\ndata file: f.raw\n";
  out.push_back({"d.nhdr", Bytes(nhdr.begin(), nhdr.end()), nhdr.size()});

  NiftiSpec spec;
  spec.dim = {3, 6, 5, 4, 1, 1, 1, 1};
  spec.qoffset = {1, 2, 3};
  const Bytes nii = nifti_file(spec, data);
  out.push_back({"n.nii", nii, 352});
  const Bytes nii_gz = gzip(nii);
  out.push_back({"n.nii.gz", nii_gz, nii_gz.size()});
  out.push_back({"p.nii.gz", nii, 352, true});
  return out;
}

Bytes corrupt(const Seed& seed, std::uint64_t iteration) {
  Bytes b = seed.bytes;
  auto rnd = [&](std::uint64_t k, std::uint64_t n) { return n ? hash_keys(0xF022, iteration, k) % n : 0; };
  const std::size_t region = rnd(1, 4) == 0 ? b.size() : std::max<std::size_t>(seed.header_bytes, 1);
  switch (rnd(2, 5)) {
    case 0:  // a few random bytes
    case 1: {
      const std::uint64_t flips = 1 + rnd(3, 4);
      for (std::uint64_t f = 0; f < flips; ++f) b[rnd(10 + f, region)] = static_cast<std::uint8_t>(rnd(20 + f, 256));
      break;
    }
    case 2:  // truncation
      b.resize(rnd(3, b.size()));
      break;
    case 3: {  // digits spliced in: sizes, offsets and dims grow
      const std::string digits = std::to_string(rnd(4, 1000000000));
      b.insert(b.begin() + static_cast<std::ptrdiff_t>(rnd(5, region)), digits.begin(), digits.end());
      break;
    }
    default: {  // a byte set to something a parser notices
      const char specials[] = {'\n', '\0', ':', ' ', '%', '-', '(', ')', '#', '9', '\xff'};
      b[rnd(6, region)] = static_cast<std::uint8_t>(specials[rnd(7, sizeof specials)]);
      break;
    }
  }
  return b;
}

}  // namespace

TEST(VolumeIoFuzz, CorruptedFilesGiveErrorsNotCrashes) {
  TempDir dir;
  const auto all = seeds();
  std::vector<std::int16_t> values(6 * 5 * 4, 3);
  write_file(dir.file("f.raw"), to_bytes(values));  // data of the detached header

  int loaded = 0, refused = 0;
  for (std::uint64_t it = 0; it < 3000; ++it) {
    const Seed& seed = all[it % all.size()];
    // A fresh name each time, removed after: rewriting one file in place is slow on ext4 with discard.
    const std::string path = dir.file(std::to_string(it) + "_" + seed.name);
    const Bytes bad = corrupt(seed, it);
    write_file(path, seed.gzip_after ? gzip(bad) : bad);
    try {
      const Volume v = load_volume(path);
      ++loaded;
      EXPECT_GT(v.dims()[0], 0);
      EXPECT_GT(v.dims()[1], 0);
      EXPECT_GT(v.dims()[2], 0);
      EXPECT_GT(v.memory_bytes(), 0u);
      EXPECT_LE(v.min_value(), v.max_value());
    } catch (const Error& e) {
      ++refused;
      EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
    } catch (const std::exception& e) {
      ADD_FAILURE() << "iteration " << it << " (" << seed.name << "): non-penumbra exception: " << e.what();
    }
    std::filesystem::remove(path);
  }
  // Both outcomes must occur, or the corruptions are too weak or too strong to test anything.
  EXPECT_GT(loaded, 50);
  EXPECT_GT(refused, 50);
}

TEST(VolumeIoFuzz, UncorruptedSeedsLoad) {
  TempDir dir;
  std::vector<std::int16_t> values(6 * 5 * 4, 3);
  write_file(dir.file("f.raw"), to_bytes(values));
  for (const Seed& seed : seeds()) {
    write_file(dir.file(seed.name), seed.gzip_after ? gzip(seed.bytes) : seed.bytes);
    const Volume v = load_volume(dir.file(seed.name));
    EXPECT_EQ(v.dims(), (std::array<int, 3>{6, 5, 4})) << seed.name;
  }
}
