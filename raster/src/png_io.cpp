// PNG files through libpng. Writing uses the classic API (to choose the zlib level and drop the
// alpha channel when every pixel is opaque, which makes files a quarter smaller); reading uses
// the simplified png_image API, which converts any PNG to 8-bit RGBA.
#include <png.h>

#include <algorithm>
#include <csetjmp>
#include <cstdio>
#include <fmt/format.h>
#include <vector>

#include "pliant/error.hpp"
#include "pliant/raster/image.hpp"

namespace pliant::raster {
namespace {

// Only plain data lives across setjmp here; the rows are prepared by the caller.
bool write_rows(std::FILE* f, int w, int h, bool rgba, int level, png_bytep* rows) {
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  if (!png) return false;
  png_infop info = png_create_info_struct(png);
  if (!info) {
    png_destroy_write_struct(&png, nullptr);
    return false;
  }
  if (setjmp(png_jmpbuf(png))) {
    png_destroy_write_struct(&png, &info);
    return false;
  }
  png_init_io(png, f);
  png_set_compression_level(png, level);
  // Fast levels: the Sub filter alone encodes rendered frames about 1.5x faster than the
  // adaptive choice, and smaller at these levels; higher levels keep the adaptive filters.
  if (level <= 3) png_set_filter(png, 0, PNG_FILTER_SUB);
  png_set_IHDR(png, info, png_uint_32(w), png_uint_32(h), 8, rgba ? PNG_COLOR_TYPE_RGBA : PNG_COLOR_TYPE_RGB,
               PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_write_info(png, info);
  png_write_image(png, rows);
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
  return true;
}

}  // namespace

void write_png(const Image& image, const std::filesystem::path& path, int compression) {
  if (image.empty()) throw InputError(fmt::format("{}: cannot write an empty image", path.string()));
  const int w = image.width(), h = image.height();
  bool opaque = true;
  for (std::size_t i = 3; i < image.bytes().size(); i += 4) opaque &= image.bytes()[i] == 255;
  const int channels = opaque ? 3 : 4;
  std::vector<png_byte> data(std::size_t(w) * h * channels);
  for (std::size_t p = 0, n = std::size_t(w) * h; p < n; ++p)
    for (int k = 0; k < channels; ++k) data[p * channels + k] = image.bytes()[p * 4 + k];
  std::vector<png_bytep> rows(h);
  for (int j = 0; j < h; ++j) rows[j] = data.data() + std::size_t(j) * w * channels;

  std::FILE* f = std::fopen(path.string().c_str(), "wb");
  if (!f) throw InputError(fmt::format("{}: cannot write (check that the folder exists and is writable)", path.string()));
  const bool ok = write_rows(f, w, h, !opaque, std::clamp(compression, 0, 9), rows.data());
  const bool closed = std::fclose(f) == 0;
  if (!ok || !closed) throw InputError(fmt::format("{}: error while writing the PNG file", path.string()));
}

Image read_png(const std::filesystem::path& path) {
  png_image img{};
  img.version = PNG_IMAGE_VERSION;
  if (!png_image_begin_read_from_file(&img, path.string().c_str()))
    throw InputError(fmt::format("{}: cannot read PNG: {}", path.string(), img.message));
  img.format = PNG_FORMAT_RGBA;
  Image out(int(img.width), int(img.height));
  if (!png_image_finish_read(&img, nullptr, out.data(), 0, nullptr)) {
    std::string msg = img.message;
    png_image_free(&img);
    throw InputError(fmt::format("{}: cannot read PNG: {}", path.string(), msg));
  }
  return out;
}

}  // namespace pliant::raster
