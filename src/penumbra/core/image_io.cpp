#include "penumbra/core/image_io.h"

#include <png.h>

#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>
#include <vector>

#include "penumbra/core/error.h"
#include "penumbra/core/exr_io.h"
#include "penumbra/core/replace_file.h"

namespace penumbra {
namespace {

std::string extension_of(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return ext;
}

struct FileCloser {
  void operator()(FILE* f) const { if (f) std::fclose(f); }
};

void append_to_string(png_structp png, png_bytep data, png_size_t length) {
  static_cast<std::string*>(png_get_io_ptr(png))->append(reinterpret_cast<const char*>(data), length);
}

}  // namespace

std::string encode_png(const Image& image) {
  if (image.width() <= 0 || image.height() <= 0) throw Error("image is empty");
  std::string bytes;
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  png_infop info = png ? png_create_info_struct(png) : nullptr;
  if (!png || !info) {
    png_destroy_write_struct(&png, &info);
    throw Error("libpng could not start");
  }
  std::vector<unsigned char> row(static_cast<std::size_t>(image.width()) * 3);
  if (setjmp(png_jmpbuf(png))) {
    png_destroy_write_struct(&png, &info);
    throw Error("libpng failed while encoding");
  }
  png_set_write_fn(png, &bytes, append_to_string, nullptr);
  png_set_IHDR(png, info, static_cast<png_uint_32>(image.width()), static_cast<png_uint_32>(image.height()), 8,
               PNG_COLOR_TYPE_RGB, PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_set_sRGB(png, info, PNG_sRGB_INTENT_PERCEPTUAL);
  // Every row filtered by its difference from the row above and zlib at level 3: a 1920×1200 frame
  // in ~35 ms instead of ~100 (libpng's default: level 6, all five filters tried per row), and smaller
  // on the shipped scenes (cranium 131 against 145 kB, spheres-floor 192 against 208 kB); the
  // playback frames of a trajectory 3 % larger.
  png_set_compression_level(png, 3);
  png_set_filter(png, PNG_FILTER_TYPE_BASE, PNG_FILTER_UP);
  png_write_info(png, info);
  for (int y = 0; y < image.height(); ++y) {
    for (int x = 0; x < image.width(); ++x)
      for (int c = 0; c < 3; ++c)
        row[static_cast<std::size_t>(x) * 3 + c] = linear_to_srgb8(image.at(x, y)[c]);
    png_write_row(png, row.data());
  }
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
  return bytes;
}

namespace {

Image read_png_file(const std::string& path) {
  std::unique_ptr<FILE, FileCloser> file(std::fopen(path.c_str(), "rb"));
  if (!file) throw Error("cannot open: " + std::string(std::strerror(errno)));
  png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  png_infop info = png ? png_create_info_struct(png) : nullptr;
  if (!png || !info) {
    png_destroy_read_struct(&png, &info, nullptr);
    throw Error("libpng could not start");
  }
  std::vector<unsigned char> data;
  if (setjmp(png_jmpbuf(png))) {
    png_destroy_read_struct(&png, &info, nullptr);
    throw Error("not a valid PNG file");
  }
  png_set_user_limits(png, 1u << 16, 1u << 16);
  png_init_io(png, file.get());
  png_read_info(png, info);
  // Deflate expands data at most about 1032:1, so a file too small to hold the rows its header promises
  // is refused before they are allocated (a 30-byte file claiming 65536 x 65536 pixels).
  std::error_code size_error;
  const std::uintmax_t file_bytes = std::filesystem::file_size(path, size_error);
  const png_uint_32 stored_w = png_get_image_width(png, info), stored_h = png_get_image_height(png, info);
  const std::uintmax_t stored_rows = static_cast<std::uintmax_t>(png_get_rowbytes(png, info) + 1) * stored_h;  // + a filter byte a row
  if (!size_error && stored_rows / 1032 > file_bytes + 64) {
    png_destroy_read_struct(&png, &info, nullptr);
    throw Error("PNG file is truncated: its header says " + std::to_string(stored_w) + "x" + std::to_string(stored_h) +
                " pixels, more than its " + std::to_string(file_bytes) + " bytes can hold");
  }
  png_set_strip_16(png);
  png_set_palette_to_rgb(png);
  png_set_expand_gray_1_2_4_to_8(png);
  png_set_gray_to_rgb(png);
  png_set_strip_alpha(png);
  png_read_update_info(png, info);
  const int w = static_cast<int>(png_get_image_width(png, info));
  const int h = static_cast<int>(png_get_image_height(png, info));
  const std::size_t rowbytes = png_get_rowbytes(png, info);
  if (rowbytes != static_cast<std::size_t>(w) * 3) {
    png_destroy_read_struct(&png, &info, nullptr);
    throw Error("unsupported PNG layout");
  }
  data.resize(rowbytes * static_cast<std::size_t>(h));
  std::vector<png_bytep> rows(static_cast<std::size_t>(h));
  for (int y = 0; y < h; ++y) rows[static_cast<std::size_t>(y)] = data.data() + rowbytes * static_cast<std::size_t>(y);
  png_read_image(png, rows.data());
  png_destroy_read_struct(&png, &info, nullptr);
  Image img(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int c = 0; c < 3; ++c)
        img.at(x, y)[c] = srgb_to_linear(static_cast<float>(data[rowbytes * y + static_cast<std::size_t>(x) * 3 + c]) / 255.0f);
  return img;
}

// PFM: "PF\n<w> <h>\n<scale>\n" then float RGB rows bottom-to-top; negative scale = little-endian.
void write_pfm_file(const std::string& path, const Image& image) {
  std::ofstream out(path, std::ios::binary);
  if (!out) throw Error("cannot open for writing: " + std::string(std::strerror(errno)));
  out << "PF\n" << image.width() << " " << image.height() << "\n-1.0\n";
  for (int y = image.height() - 1; y >= 0; --y)
    out.write(reinterpret_cast<const char*>(&image.at(0, y)), static_cast<std::streamsize>(sizeof(Rgb)) * image.width());
  out.flush();
  if (!out) throw Error("write failed");
}

Image read_pfm_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error("cannot open: " + std::string(std::strerror(errno)));
  std::string magic;
  long long w = 0, h = 0;
  double scale = 0;
  in >> magic >> w >> h >> scale;
  if (!in || magic != "PF") throw Error("not a colour PFM file (expected magic 'PF')");
  if (w <= 0 || h <= 0 || w > 65536 || h > 65536) throw Error("PFM size out of range: " + std::to_string(w) + "x" + std::to_string(h));
  if (scale >= 0) throw Error("big-endian PFM is not supported (scale must be negative)");
  in.get();
  // the pixels the header promises must be in the file before they are allocated
  const std::streamoff pixels_at = in.tellg();
  in.seekg(0, std::ios::end);
  const std::streamoff file_bytes = in.tellg();
  in.seekg(pixels_at);
  const unsigned long long need = static_cast<unsigned long long>(w) * static_cast<unsigned long long>(h) * sizeof(Rgb);
  if (!in || pixels_at < 0 || static_cast<unsigned long long>(file_bytes - pixels_at) < need)
    throw Error("PFM file is truncated: its header says " + std::to_string(w) + "x" + std::to_string(h) + " pixels (" +
                std::to_string(need) + " bytes), the file holds " + std::to_string(file_bytes - pixels_at) + " after the header");
  Image img(static_cast<int>(w), static_cast<int>(h));
  for (int y = img.height() - 1; y >= 0; --y)
    in.read(reinterpret_cast<char*>(&img.at(0, y)), static_cast<std::streamsize>(sizeof(Rgb)) * img.width());
  if (!in) throw Error("PFM file is truncated");
  return img;
}

}  // namespace

void write_image(const std::string& path, const Image& image) {
  with_context(path, [&] {
    const std::string ext = extension_of(path);
    if (ext != ".png" && ext != ".pfm")
      throw Error("unknown image extension '" + ext + "' (expected .png or .pfm)");
    if (image.width() <= 0 || image.height() <= 0) throw Error("image is empty");
    if (ext == ".png") replace_file_contents(path, encode_png(image));
    else replace_file(path, [&](const std::string& temporary) { write_pfm_file(temporary, image); });
  });
}

Image read_image(const std::string& path) {
  return with_context(path, [&] {
    const std::string ext = extension_of(path);
    if (ext == ".png") return read_png_file(path);
    if (ext == ".pfm") return read_pfm_file(path);
    if (ext == ".exr") {  // the colour channels: premultiplied, so the picture over black
      const ExrImage exr = read_exr(path);
      Image img(exr.width, exr.height);
      for (std::size_t i = 0; i < img.pixels().size(); ++i) img.pixels()[i] = Rgb(exr.rgba[4 * i], exr.rgba[4 * i + 1], exr.rgba[4 * i + 2]);
      return img;
    }
    throw Error("unknown image extension '" + ext + "' (expected .png, .pfm or .exr)");
  });
}

}  // namespace penumbra
