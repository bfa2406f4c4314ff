// VTK image data: the four staged headsq files (.vti appended raw, appended zlib, VTK's default
// base64+zlib, legacy binary .vtk) must equal headsq.nhdr voxel for voxel; small .vti and .vtk files
// written here cover ascii, base64, zlib blocks, 64-bit headers, big-endian data, array choice and
// Direction; bad input of each kind must give a penumbra::Error naming the file and the problem.
#include <gtest/gtest.h>
#include <zlib.h>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include "penumbra/core/error.h"
#include "penumbra/data/io/volume_io.h"
#include "shared_data.h"
#include "test_volume_io_util.h"

using namespace penumbra;
using namespace penumbra::test;

namespace {

Volume load_vtk(const std::string& path, VolumeFileInfo* info = nullptr) { return load_volume(path, VolumeLoadOptions{}, info); }

void expect_error(const std::string& path, std::initializer_list<const char*> parts) {
  try {
    load_vtk(path);
    ADD_FAILURE() << "no penumbra::Error loading " << path;
  } catch (const Error& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find(path), std::string::npos) << "message lacks the file name: " << msg;
    for (const char* part : parts) EXPECT_NE(msg.find(part), std::string::npos) << "message lacks '" << part << "': " << msg;
  }
}

std::string base64(const Bytes& in) {
  static const char* k = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  for (std::size_t i = 0; i < in.size(); i += 3) {
    const unsigned b0 = in[i], b1 = i + 1 < in.size() ? in[i + 1] : 0, b2 = i + 2 < in.size() ? in[i + 2] : 0;
    const unsigned v = b0 << 16 | b1 << 8 | b2;
    out += k[v >> 18 & 63];
    out += k[v >> 12 & 63];
    out += i + 1 < in.size() ? k[v >> 6 & 63] : '=';
    out += i + 2 < in.size() ? k[v & 63] : '=';
  }
  return out;
}

Bytes zlib_block(const Bytes& in) {
  uLongf n = compressBound(static_cast<uLong>(in.size()));
  Bytes out(n);
  if (compress2(out.data(), &n, in.data(), static_cast<uLong>(in.size()), 6) != Z_OK) throw std::runtime_error("compress2");
  out.resize(n);
  return out;
}

// A header word (UInt32 or UInt64) in the given byte order.
Bytes word(std::uint64_t v, bool header64, bool big_endian) {
  return header64 ? to_bytes(std::vector<std::uint64_t>{v}, big_endian) : to_bytes(std::vector<std::uint32_t>{static_cast<std::uint32_t>(v)}, big_endian);
}

// VTK's uncompressed binary block: byte count then the bytes.
Bytes counted(const Bytes& data, bool header64 = false, bool big_endian = false) {
  return concat(word(data.size(), header64, big_endian), data);
}

// VTK's zlib block table and blocks (header and blocks returned apart, as VTK encodes them apart).
std::pair<Bytes, Bytes> zlib_blocks(const Bytes& data, std::size_t block, bool header64 = false, bool big_endian = false) {
  std::vector<Bytes> packed;
  for (std::size_t i = 0; i < data.size(); i += block)
    packed.push_back(zlib_block(Bytes(data.begin() + static_cast<std::ptrdiff_t>(i),
                                      data.begin() + static_cast<std::ptrdiff_t>(std::min(data.size(), i + block)))));
  Bytes header = concat(concat(word(packed.size(), header64, big_endian), word(block, header64, big_endian)),
                        word(data.size() % block, header64, big_endian));
  Bytes body;
  for (const auto& p : packed) header = concat(header, word(p.size(), header64, big_endian)), body = concat(body, p);
  return {header, body};
}

// A .vti document around the given arrays; `appended` (raw bytes) follows <AppendedData encoding="raw">.
std::string vti(const std::string& root, const std::string& image, const std::string& point_data, const std::string& appended = "",
                const std::string& appended_encoding = "raw") {
  std::string s = "<?xml version=\"1.0\"?>\n<!-- written by a test -->\n<VTKFile type=\"ImageData\" version=\"1.0\" " + root + ">\n"
                  "  <ImageData " + image + ">\n    <FieldData></FieldData>\n    <Piece Extent=\"0 2 0 1 0 1\">\n" + point_data +
                  "      <CellData>\n      </CellData>\n    </Piece>\n  </ImageData>\n";
  if (!appended.empty()) s += "  <AppendedData encoding=\"" + appended_encoding + "\">\n   _" + appended + "\n  </AppendedData>\n";
  return s + "</VTKFile>\n";
}

const std::string kImage = "WholeExtent=\"0 2 0 1 0 1\" Origin=\"1 2 3\" Spacing=\"0.5 0.25 2\"";
const std::vector<std::int16_t> kValues{-300, -2, 0, 1, 7, 100, 200, 300, 1000, 2000, 32767, -32768};

void expect_values(const Volume& v, const std::vector<std::int16_t>& values = kValues) {
  ASSERT_EQ(v.dims(), (std::array<int, 3>{3, 2, 2}));
  for (std::size_t i = 0; i < values.size(); ++i) EXPECT_EQ(v.value(i), values[i]) << "voxel " << i;
}

std::string ascii_values() {
  std::string s;
  for (const auto v : kValues) s += std::to_string(v) + " ";
  return s;
}

void check_headsq(const std::string& file) {
  SCOPED_TRACE(file);
  const std::string dir = shared_data_dir();
  const Volume ref = load_volume(dir + "/headsq.nhdr");
  VolumeFileInfo info;
  const Volume v = load_vtk(dir + "/" + file, &info);
  ASSERT_EQ(v.dims(), (std::array<int, 3>{64, 64, 93}));
  EXPECT_EQ(v.type(), ScalarType::Int16);
  EXPECT_EQ(v.spacing(), (Vec3{3.2f, 3.2f, 1.5f}));
  EXPECT_EQ(v.origin(), (Vec3{0, 0, 0}));
  ASSERT_EQ(ref.dims(), v.dims());
  ASSERT_EQ(ref.type(), v.type());
  EXPECT_EQ(std::memcmp(ref.data(), v.data(), v.voxel_count() * 2), 0) << "voxels differ from headsq.nhdr";
  EXPECT_EQ(v.min_value(), ref.min_value());
  EXPECT_EQ(v.max_value(), ref.max_value());
  EXPECT_EQ(v.max_value(), 3926);
  EXPECT_EQ(info.format, file.ends_with(".vtk") ? "vtk" : "vti");
  EXPECT_TRUE(info.orientation.empty());
  // Windows of slices (17 slices of 8 KiB from slice 41: 32 KiB zlib blocks cut at both ends) hold the whole read's voxels and
  // read only their part of the file: raw values only theirs, zlib blocks only theirs (base64 text is
  // decoded up to them, so only a window at the start reads little of it).
  const std::uint64_t file_bytes = std::filesystem::file_size(dir + "/" + file);
  for (const SliceRange slices : {SliceRange{41, 17}, SliceRange{0, 5}, SliceRange{87, 6}}) {
    SCOPED_TRACE(slices.first);
    WindowRead read;
    const Volume window = load_volume_window({dir + "/" + file}, VolumeLoadOptions{}, [&](const std::array<int, 3>&) { return slices; }, read);
    EXPECT_FALSE(read.whole);
    ASSERT_EQ(window.dims(), (std::array<int, 3>{64, 64, slices.count}));
    const std::size_t slice_bytes = 64 * 64 * 2;
    EXPECT_EQ(std::memcmp(window.data(), static_cast<const std::byte*>(v.data()) + slices.first * slice_bytes, slices.count * slice_bytes), 0);
    if (file == "headsq.vtk" || file == "headsq_appended_raw.vti") {
      EXPECT_EQ(read.bytes_read, slices.count * slice_bytes + (file == "headsq.vtk" ? 0 : 4));  // .vti: its byte-count header
    } else if (file == "headsq_appended_zlib.vti" || slices.first == 0) {  // base64 is decoded up to the window
      EXPECT_LT(read.bytes_read, file_bytes / 3);
    }
  }
}


// Every truncation of `bytes` and a flipped byte at every position must load or give an Error naming
// the file; counts which. (libFuzzer does this at length in fuzz/fuzz_vti.cpp and fuzz_vtk.cpp; this runs in every build.)
void sweep(const TempDir& dir, const std::string& name, const Bytes& bytes, int& loaded, int& refused) {
  int count = 0;
  const auto attempt = [&](const Bytes& b, const std::string& what) {
    // A fresh name each time, removed after: rewriting one file in place is slow on ext4 with discard.
    const std::string path = dir.file(std::to_string(count++) + "_" + name);
    write_file(path, b);
    try {
      const Volume v = load_volume(path, VolumeLoadOptions{});
      EXPECT_LE(v.min_value(), v.max_value());
      ++loaded;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
      ++refused;
    } catch (const std::exception& e) {
      ADD_FAILURE() << name << " " << what << ": non-penumbra exception: " << e.what();
    }
    std::filesystem::remove(path);
  };
  const std::size_t step = std::max<std::size_t>(1, bytes.size() / 300);
  for (std::size_t n = 0; n < bytes.size(); n += step) attempt(Bytes(bytes.begin(), bytes.begin() + static_cast<std::ptrdiff_t>(n)), "cut at " + std::to_string(n));
  for (std::size_t i = 0; i < bytes.size(); i += step) {
    Bytes b = bytes;
    b[i] = static_cast<std::uint8_t>(b[i] ^ (i % 3 == 0 ? 0xff : i % 3 == 1 ? 0x01 : 0x80));
    attempt(b, "byte " + std::to_string(i) + " flipped");
  }
}
}  // namespace

TEST(VtkStaged, HeadsqAppendedRaw) {
  SKIP_WITHOUT_SHARED_DATA("headsq_appended_raw.vti");
  check_headsq("headsq_appended_raw.vti");
}
TEST(VtkStaged, HeadsqAppendedZlib) {
  SKIP_WITHOUT_SHARED_DATA("headsq_appended_zlib.vti");
  check_headsq("headsq_appended_zlib.vti");
}
TEST(VtkStaged, HeadsqVtkDefaultBase64Zlib) {
  SKIP_WITHOUT_SHARED_DATA("headsq_vtkdefault.vti");
  check_headsq("headsq_vtkdefault.vti");
}
TEST(VtkStaged, HeadsqLegacyBinary) {
  SKIP_WITHOUT_SHARED_DATA("headsq.vtk");
  check_headsq("headsq.vtk");
}

TEST(VtkVti, AsciiArray) {
  TempDir dir;
  write_file(dir.file("a.vti"), vti("byte_order=\"LittleEndian\"", kImage,
                                    "      <PointData Scalars=\"s\">\n        <DataArray type=\"Int16\" Name=\"s\" format=\"ascii\">\n          " +
                                        ascii_values() + "\n        </DataArray>\n      </PointData>\n"));
  VolumeFileInfo info;
  const Volume v = load_vtk(dir.file("a.vti"), &info);
  expect_values(v);
  EXPECT_EQ(v.type(), ScalarType::Int16);
  EXPECT_EQ(v.spacing(), (Vec3{0.5f, 0.25f, 2}));
  EXPECT_EQ(v.origin(), (Vec3{1, 2, 3}));
  EXPECT_EQ(info.format, "vti");

  // Float64 with an information key before the values, as VTK 9 writes them.
  write_file(dir.file("d.vti"), vti("", kImage,
                                    "      <PointData>\n        <DataArray type=\"Float64\" Name=\"d\" format=\"ascii\">\n"
                                    "          <InformationKey name=\"L2_NORM_RANGE\" location=\"vtkDataArray\" length=\"2\">\n"
                                    "            <Value index=\"0\">0</Value>\n          </InformationKey>\n"
                                    "          0.5 -1.25 2 3 4 5 6 7 8 9 10 1e10\n        </DataArray>\n      </PointData>\n"));
  const Volume d = load_vtk(dir.file("d.vti"), &info);
  EXPECT_EQ(d.type(), ScalarType::Float32);
  EXPECT_EQ(d.value(0), 0.5f);
  EXPECT_EQ(d.value(1), -1.25f);
  EXPECT_EQ(d.value(11), 1e10f);
  EXPECT_TRUE(has_note(info, "Float64 values stored as float32"));
}

TEST(VtkVti, Base64UncompressedAndZlibHeaders) {
  TempDir dir;
  for (const bool header64 : {false, true})
    for (const bool big : {false, true}) {
      SCOPED_TRACE(std::string(header64 ? "UInt64" : "UInt32") + (big ? " BigEndian" : " LittleEndian"));
      const std::string root = std::string("byte_order=\"") + (big ? "BigEndian" : "LittleEndian") + "\" header_type=\"" +
                               (header64 ? "UInt64" : "UInt32") + "\"";
      const Bytes data = to_bytes(kValues, big);
      // Uncompressed: header and data encoded together.
      write_file(dir.file("b.vti"), vti(root, kImage,
                                        "      <PointData Scalars=\"s\">\n        <DataArray type=\"Int16\" Name=\"s\" format=\"binary\">\n          " +
                                            base64(counted(data, header64, big)) + "\n        </DataArray>\n      </PointData>\n"));
      expect_values(load_vtk(dir.file("b.vti")));
      // zlib in 10-byte blocks (the last one 4 bytes): header and blocks encoded apart, as VTK does.
      const auto [head, body] = zlib_blocks(data, 10, header64, big);
      write_file(dir.file("z.vti"), vti(root + " compressor=\"vtkZLibDataCompressor\"", kImage,
                                        "      <PointData Scalars=\"s\">\n        <DataArray type=\"Int16\" Name=\"s\" format=\"binary\">\n          " +
                                            base64(head) + base64(body) + "\n        </DataArray>\n      </PointData>\n"));
      expect_values(load_vtk(dir.file("z.vti")));
      // The same appended as base64.
      write_file(dir.file("ab.vti"), vti(root + " compressor=\"vtkZLibDataCompressor\"", kImage,
                                         "      <PointData Scalars=\"s\">\n        <DataArray type=\"Int16\" Name=\"s\" format=\"appended\" offset=\"0\"/>\n"
                                         "      </PointData>\n", base64(head) + base64(body), "base64"));
      expect_values(load_vtk(dir.file("ab.vti")));
    }
}

TEST(VtkVti, AppendedRawArrayChoice) {
  TempDir dir;
  // A 3-component Float32 array first, then the Int16 scalars, both appended raw.
  std::vector<float> vectors(36, 1.5f);
  const Bytes first = counted(to_bytes(vectors));
  const Bytes second = counted(to_bytes(kValues));
  const std::string arrays = "        <DataArray type=\"Float32\" Name=\"v\" NumberOfComponents=\"3\" format=\"appended\" offset=\"0\"/>\n"
                             "        <DataArray type=\"Int16\" Name=\"s\" format=\"appended\" offset=\"" + std::to_string(first.size()) + "\"/>\n";
  const Bytes raw = concat(first, second);
  write_file(dir.file("scalars.vti"), vti("", kImage, "      <PointData Scalars=\"s\">\n" + arrays + "      </PointData>\n",
                                          std::string(raw.begin(), raw.end())));
  expect_values(load_vtk(dir.file("scalars.vti")));
  // Without Scalars: the first one-component array.
  VolumeFileInfo info;
  write_file(dir.file("first.vti"), vti("", kImage, "      <PointData>\n" + arrays + "      </PointData>\n", std::string(raw.begin(), raw.end())));
  expect_values(load_vtk(dir.file("first.vti"), &info));
  EXPECT_TRUE(has_note(info, "first one-component array, 's'"));
  // Scalars naming the vector array: component 0.
  write_file(dir.file("vec.vti"), vti("", kImage, "      <PointData Scalars=\"v\">\n" + arrays + "      </PointData>\n", std::string(raw.begin(), raw.end())));
  const Volume v = load_vtk(dir.file("vec.vti"), &info);
  EXPECT_EQ(v.value(5), 1.5f);
  EXPECT_TRUE(has_note(info, "component 0 of 3"));
}

TEST(VtkVti, DirectionFlipsAndOblique) {
  TempDir dir;
  const std::string data = "      <PointData Scalars=\"s\">\n        <DataArray type=\"Int16\" Name=\"s\" format=\"ascii\">" + ascii_values() +
                           "</DataArray>\n      </PointData>\n";
  write_file(dir.file("flip.vti"), vti("", kImage + " Direction=\"-1 0 0 0 1 0 0 0 1\"", data));
  VolumeFileInfo info;
  const Volume v = load_vtk(dir.file("flip.vti"), &info);
  // x reversed: world x of voxel i is 1 - 0.5 * (2 - i), so the origin is 0.
  EXPECT_EQ(v.origin(), (Vec3{0, 2, 3}));
  EXPECT_EQ(v.spacing(), (Vec3{0.5f, 0.25f, 2}));
  EXPECT_EQ(v.value(0, 0, 0), kValues[2]);
  EXPECT_EQ(v.value(2, 0, 0), kValues[0]);
  EXPECT_EQ(v.value(0, 1, 1), kValues[11]);
  EXPECT_NE(info.orientation.find("x = -i, y = +j, z = +k"), std::string::npos) << info.orientation;

  // Swapped axes: index i steps along world y, j along x.
  write_file(dir.file("swapped.vti"), vti("", kImage + " Direction=\"0 1 0 1 0 0 0 0 1\"", data));
  const Volume w = load_vtk(dir.file("swapped.vti"), &info);
  ASSERT_EQ(w.dims(), (std::array<int, 3>{2, 3, 2}));
  EXPECT_EQ(w.spacing(), (Vec3{0.25f, 0.5f, 2}));
  EXPECT_EQ(w.origin(), (Vec3{1, 2, 3}));
  for (int k = 0; k < 2; ++k)
    for (int j = 0; j < 2; ++j)
      for (int i = 0; i < 3; ++i) EXPECT_EQ(w.value(j, i, k), kValues[static_cast<std::size_t>(i + 3 * j + 6 * k)]) << i << j << k;
  EXPECT_NE(info.orientation.find("x = +j, y = +i, z = +k"), std::string::npos) << info.orientation;

  // A rotation of 30° about z is resampled onto the world's axes, and says so.
  write_file(dir.file("oblique.vti"), vti("", kImage + " Direction=\"0.8660254 -0.5 0 0.5 0.8660254 0 0 0 1\"", data));
  const Volume o = load_vtk(dir.file("oblique.vti"), &info);
  EXPECT_EQ(o.spacing(), (Vec3{0.25f, 0.25f, 0.25f}));
  EXPECT_TRUE(has_note(info, "resampled trilinearly onto an axis-aligned grid"));
  EXPECT_EQ(info.orientation, "oblique: resampled onto LPS axes");
}

TEST(VtkVti, BadInput) {
  TempDir dir;
  const auto one = [&](const std::string& name, const std::string& text, std::initializer_list<const char*> parts) {
    SCOPED_TRACE(name);
    write_file(dir.file(name), text);
    expect_error(dir.file(name), parts);
  };
  const auto ascii = [](const std::string& type, const std::string& values) {
    return "      <PointData Scalars=\"s\">\n        <DataArray type=\"" + type + "\" Name=\"s\" format=\"ascii\">" + values +
           "</DataArray>\n      </PointData>\n";
  };
  const auto binary = [](const std::string& text) {
    return "      <PointData Scalars=\"s\">\n        <DataArray type=\"Int16\" Name=\"s\" format=\"binary\">" + text +
           "</DataArray>\n      </PointData>\n";
  };
  const Bytes data = to_bytes(kValues);
  one("short_ascii.vti", vti("", kImage, ascii("Int16", "1 2 3")), {"ASCII", "12 values"});
  one("long_ascii.vti", vti("", kImage, ascii("Int16", ascii_values() + " 5")), {"more than the 12 values"});
  one("range_ascii.vti", vti("", kImage, ascii("UInt8", "1 2 3 4 5 6 7 8 9 10 11 256")), {"'256' is not a UInt8"});
  one("type.vti", vti("", kImage, ascii("Int128", ascii_values())), {"type 'Int128'", "expected Int8"});
  const auto image = [](const std::string& extent, const std::string& piece) {
    return "<VTKFile type=\"ImageData\"><ImageData WholeExtent=\"" + extent + "\"><Piece>" + piece + "</Piece></ImageData></VTKFile>";
  };
  one("bigger_extent.vti", image("0 2 0 1 0 2", binary(base64(counted(data)))), {"header says 24 bytes", "needs 18 values, 36 bytes"});
  one("lying_count.vti", vti("", kImage, binary(base64(counted(Bytes(data.begin(), data.end() - 2))))), {"header says 22 bytes", "needs 12 values, 24 bytes"});
  one("truncated_b64.vti", vti("", kImage, binary(base64(counted(data)).substr(0, 20))), {"at most 11 bytes", "truncated"});
  one("bad_b64.vti", vti("", kImage, binary("AAAA@@@@" + base64(data))), {"bad base64 data: character '@'"});
  const auto [head, body] = zlib_blocks(data, 10);
  Bytes corrupt = body;
  corrupt[4] ^= 0xff, corrupt[5] ^= 0x55;
  one("corrupt_zlib.vti", vti("compressor=\"vtkZLibDataCompressor\"", kImage, binary(base64(head) + base64(corrupt))), {"zlib block"});
  one("lying_blocks.vti", vti("compressor=\"vtkZLibDataCompressor\"", kImage,
                              binary(base64(concat(concat(concat(word(3, false, false), word(1u << 30, false, false)), word(0, false, false)),
                                                  Bytes(12, 1))))),
      {"zlib header describes 3 blocks", "needs 12 values"});
  one("many_blocks.vti", vti("compressor=\"vtkZLibDataCompressor\"", kImage,
                             binary(base64(concat(concat(word(4000000000u, false, false), word(8, false, false)), word(0, false, false))))),
      {"claims 4000000000 blocks"});
  one("lz4.vti", vti("compressor=\"vtkLZ4DataCompressor\"", kImage, binary("")), {"compressor 'vtkLZ4DataCompressor' is not supported"});
  one("zero.vti", image("0 2 0 -1 0 1", binary("")), {"empty along axis 1"});
  one("absurd.vti", image("0 999999 0 999999 0 999999", binary("AAAA")), {"extent 1000000x1000000x1000000"});
  one("polydata.vti", "<VTKFile type=\"PolyData\"></VTKFile>", {"VTKFile type is 'PolyData'", "expected ImageData"});
  one("notxml.vti", "just text", {"not a VTK XML file"});
  one("html.vti", "<html><body></body></html>", {"first element is <html>"});
  one("unclosed.vti", "<VTKFile type=\"ImageData\"><ImageData WholeExtent=\"0 1", {"has no closing quote"});
  one("celldata.vti", "<VTKFile type=\"ImageData\"><ImageData WholeExtent=\"0 2 0 1 0 1\"><Piece Extent=\"0 2 0 1 0 1\"><CellData Scalars=\"c\">"
                      "<DataArray type=\"Int16\" Name=\"c\" format=\"ascii\">1 2</DataArray></CellData></Piece></ImageData></VTKFile>",
      {"only cell data", "point data"});
  one("pieces.vti", "<VTKFile type=\"ImageData\"><ImageData WholeExtent=\"0 2 0 1 0 1\"><Piece Extent=\"0 2 0 1 0 0\"></Piece>"
                    "<Piece Extent=\"0 2 0 1 1 1\"></Piece></ImageData></VTKFile>", {"2 pieces", "single-piece"});
  one("no_appended.vti", vti("", kImage, "      <PointData Scalars=\"s\"><DataArray type=\"Int16\" Name=\"s\" format=\"appended\" offset=\"0\"/></PointData>\n"),
      {"no <AppendedData>"});
  one("no_marker.vti", "<VTKFile type=\"ImageData\"><ImageData WholeExtent=\"0 0 0 0 0 0\"><Piece><PointData><DataArray type=\"UInt8\" Name=\"s\" "
                       "format=\"appended\" offset=\"0\"/></PointData></Piece></ImageData><AppendedData encoding=\"raw\">xyz",
      {"'_'"});
  one("nan.vti", vti("", kImage, ascii("Float32", "1 2 3 4 5 6 7 8 9 10 11 nan")), {"NaN"});
}

TEST(VtkVti, TruncatedStagedFile) {
  SKIP_WITHOUT_SHARED_DATA("headsq_appended_zlib.vti");
  TempDir dir;
  for (const char* name : {"headsq_appended_raw.vti", "headsq_appended_zlib.vti", "headsq_vtkdefault.vti", "headsq.vtk"}) {
    SCOPED_TRACE(name);
    const Bytes bytes = read_file(shared_data_dir() + "/" + name);
    write_file(dir.file(name), Bytes(bytes.begin(), bytes.begin() + static_cast<std::ptrdiff_t>(bytes.size() * 2 / 3)));
    expect_error(dir.file(name), {});
  }
}

TEST(VtkLegacy, AsciiAndBinary) {
  TempDir dir;
  write_file(dir.file("a.vtk"), "# vtk DataFile Version 3.0\n\nASCII\nDATASET STRUCTURED_POINTS\nDIMENSIONS 3 2 2\n"
                                "ASPECT_RATIO 0.5 0.25 2\nORIGIN 1 2 3\nPOINT_DATA 12\nSCALARS s short 1\nLOOKUP_TABLE default\n" +
                                    ascii_values() + "\nVECTORS v float\n1 2 3\n");
  VolumeFileInfo info;
  const Volume a = load_vtk(dir.file("a.vtk"), &info);
  expect_values(a);
  EXPECT_EQ(a.type(), ScalarType::Int16);
  EXPECT_EQ(a.spacing(), (Vec3{0.5f, 0.25f, 2}));
  EXPECT_EQ(a.origin(), (Vec3{1, 2, 3}));
  EXPECT_EQ(info.format, "vtk");

  // BINARY: big-endian, unsigned_short, CRLF line ends, VTK 9's METADATA trailer, a negative z spacing.
  const std::vector<std::uint16_t> u{0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 65535};
  const std::string head = "# vtk DataFile Version 5.1\r\ntitle\r\nBINARY\r\nDATASET STRUCTURED_POINTS\r\nDIMENSIONS 3 2 2\r\n"
                           "SPACING 1 1 -2\r\nORIGIN 0 0 10\r\nPOINT_DATA 12\r\nSCALARS u unsigned_short\r\nLOOKUP_TABLE default\r\n";
  const std::string trailer = "\nMETADATA\nINFORMATION 0\n\n";
  write_file(dir.file("b.vtk"), concat(concat(Bytes(head.begin(), head.end()), to_bytes(u, true)), Bytes(trailer.begin(), trailer.end())));
  const Volume b = load_vtk(dir.file("b.vtk"), &info);
  EXPECT_EQ(b.type(), ScalarType::UInt16);
  EXPECT_EQ(b.spacing(), (Vec3{1, 1, 2}));
  EXPECT_EQ(b.origin(), (Vec3{0, 0, 8}));  // z runs 10, 8: reversed, it starts at 8
  EXPECT_EQ(b.value(0, 0, 0), 6);
  EXPECT_EQ(b.value(2, 1, 0), 65535);
  EXPECT_EQ(b.value(0, 0, 1), 0);
  EXPECT_NE(info.orientation.find("z = -k"), std::string::npos) << info.orientation;

  // Other types: char widens to int16, int and double become float32.
  write_file(dir.file("c.vtk"), "# vtk DataFile Version 2.0\nc\nASCII\nDATASET STRUCTURED_POINTS\nDIMENSIONS 2 1 1\nPOINT_DATA 2\n"
                                "SCALARS c char\nLOOKUP_TABLE default\n-128 127\n");
  const Volume c = load_vtk(dir.file("c.vtk"));
  EXPECT_EQ(c.type(), ScalarType::Int16);
  EXPECT_EQ(c.value(0), -128);
  write_file(dir.file("i.vtk"), "# vtk DataFile Version 2.0\ni\nASCII\nDATASET STRUCTURED_POINTS\nDIMENSIONS 2 1 1\nPOINT_DATA 2\n"
                                "SCALARS i int\nLOOKUP_TABLE default\n-100000 16777217\n");
  const Volume i = load_vtk(dir.file("i.vtk"), &info);
  EXPECT_EQ(i.type(), ScalarType::Float32);
  EXPECT_EQ(i.value(0), -100000);
  EXPECT_TRUE(has_note(info, "values beyond 2^24 rounded"));
}

TEST(VtkLegacy, BadInput) {
  TempDir dir;
  const auto one = [&](const std::string& name, const std::string& text, std::initializer_list<const char*> parts) {
    SCOPED_TRACE(name);
    write_file(dir.file(name), text);
    expect_error(dir.file(name), parts);
  };
  const std::string start = "# vtk DataFile Version 3.0\nt\n";
  const std::string grid = "DATASET STRUCTURED_POINTS\nDIMENSIONS 3 2 2\nSPACING 1 1 1\nORIGIN 0 0 0\n";
  one("points.vtk", start + "ASCII\n" + grid + "POINT_DATA 10\nSCALARS s short\nLOOKUP_TABLE default\n" + ascii_values(),
      {"POINT_DATA 10 but DIMENSIONS 3x2x2 make 12 points"});
  one("short_ascii.vtk", start + "ASCII\n" + grid + "POINT_DATA 12\nSCALARS s short\nLOOKUP_TABLE default\n1 2 3 4 5 6 7 8 9 10 11\n",
      {"ASCII data has 11 values but 12 are needed"});
  one("word.vtk", start + "ASCII\n" + grid + "POINT_DATA 12\nSCALARS s float\nLOOKUP_TABLE default\n1 2 3 4 5 6 x 8 9 10 11 12\n",
      {"ASCII value 6 'x' is not a number"});
  one("truncated.vtk", start + "BINARY\n" + grid + "POINT_DATA 12\nSCALARS s short\nLOOKUP_TABLE default\n" + std::string(20, '\0'),
      {"BINARY data has 20 bytes", "24 bytes", "truncated"});
  one("type.vtk", start + "ASCII\n" + grid + "POINT_DATA 12\nSCALARS s bit\nLOOKUP_TABLE default\n1\n", {"SCALARS type 'bit'"});
  one("polydata.vtk", start + "ASCII\nDATASET POLYDATA\nPOINTS 1 float\n0 0 0\n", {"DATASET POLYDATA is not supported", "STRUCTURED_POINTS"});
  one("zero.vtk", start + "ASCII\nDATASET STRUCTURED_POINTS\nDIMENSIONS 3 0 2\nPOINT_DATA 0\n", {"DIMENSIONS value 0"});
  one("absurd.vtk", start + "BINARY\nDATASET STRUCTURED_POINTS\nDIMENSIONS 100000 100000 100000\nPOINT_DATA 1000000000000000\n"
                            "SCALARS s short\nLOOKUP_TABLE default\n", {"POINT_DATA"});
  one("absurd2.vtk", start + "BINARY\nDATASET STRUCTURED_POINTS\nDIMENSIONS 100000 100000 100000\nPOINT_DATA 1000\n"
                             "SCALARS s short\nLOOKUP_TABLE default\n", {"DIMENSIONS 100000x100000x100000"});
  one("no_lut.vtk", start + "ASCII\n" + grid + "POINT_DATA 12\nSCALARS s short\n" + ascii_values(), {"expected LOOKUP_TABLE"});
  one("cells.vtk", start + "ASCII\n" + grid + "CELL_DATA 2\nSCALARS c short\nLOOKUP_TABLE default\n1 2\n", {"CELL_DATA", "not supported"});
  one("vectors.vtk", start + "ASCII\n" + grid + "POINT_DATA 12\nVECTORS v float\n", {"VECTORS as the first point attribute"});
  one("magic.vtk", "# vtk\n", {"not a legacy VTK file"});
  one("mode.vtk", start + "TEXT\n", {"'TEXT' (expected ASCII or BINARY)"});
  one("nodims.vtk", start + "ASCII\nDATASET STRUCTURED_POINTS\nPOINT_DATA 12\nSCALARS s short\nLOOKUP_TABLE default\n1\n", {"without DIMENSIONS"});
  one("empty.vtk", "", {"empty file"});
}

TEST(VtkBad, CutAndFlippedFilesGiveErrorsNotCrashes) {
  TempDir dir;
  const Bytes data = to_bytes(kValues);
  const auto [head, body] = zlib_blocks(data, 10);
  const std::string appended = "      <PointData Scalars=\"s\">\n        <DataArray type=\"Int16\" Name=\"s\" format=\"appended\" offset=\"0\"/>\n"
                               "      </PointData>\n";
  const Bytes raw = counted(data);
  const std::string vtk_head = "# vtk DataFile Version 5.1\nt\nBINARY\nDATASET STRUCTURED_POINTS\nDIMENSIONS 3 2 2\nSPACING 1 1 1\n"
                               "ORIGIN 0 0 0\nPOINT_DATA 12\nSCALARS s short\nLOOKUP_TABLE default\n";
  const std::vector<std::pair<std::string, std::string>> files{
      {"zlib.vti", vti("compressor=\"vtkZLibDataCompressor\"", kImage, appended, base64(head) + base64(body), "base64")},
      {"raw.vti", vti("", kImage, appended, std::string(raw.begin(), raw.end()))},
      {"ascii.vti", vti("", kImage, "      <PointData><DataArray type=\"Int16\" Name=\"s\" format=\"ascii\">" + ascii_values() +
                                        "</DataArray></PointData>\n")},
      {"binary.vtk", vtk_head + std::string(reinterpret_cast<const char*>(to_bytes(kValues, true).data()), 24) + "\nMETADATA\n"}};
  int loaded = 0, refused = 0;
  for (const auto& [name, text] : files) sweep(dir, name, Bytes(text.begin(), text.end()), loaded, refused);
  EXPECT_GT(loaded, 50);
  EXPECT_GT(refused, 50);
}
