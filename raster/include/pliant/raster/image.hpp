// Image: an 8-bit RGBA picture in memory (top row first), the currency of raster/: the OSMesa
// renderer reads back into one, text and overlays are drawn into one, plots and contact sheets
// are composed of them, and PNG files are written from (and, for tests, read into) one.
// 2D drawing here is anti-aliased by coverage and deterministic (no GL involved).
#pragma once
#include <cstdint>
#include <filesystem>
#include <vector>

namespace pliant::raster {

struct Rgba {
  std::uint8_t r = 0, g = 0, b = 0, a = 255;
  friend bool operator==(const Rgba&, const Rgba&) = default;
};

// From components in [0, 1] (clamped).
Rgba rgb(double r, double g, double b, double a = 1.0);

class Image {
 public:
  Image() = default;
  Image(int width, int height, Rgba fill = {255, 255, 255, 255});

  int width() const { return width_; }
  int height() const { return height_; }
  bool empty() const { return width_ <= 0 || height_ <= 0; }
  std::uint8_t* data() { return pixels_.data(); }
  const std::uint8_t* data() const { return pixels_.data(); }
  const std::vector<std::uint8_t>& bytes() const { return pixels_; }

  bool inside(int x, int y) const { return x >= 0 && y >= 0 && x < width_ && y < height_; }
  Rgba get(int x, int y) const;
  void set(int x, int y, Rgba c);                  // ignored outside
  void blend(int x, int y, Rgba c, double alpha);  // c over the pixel with opacity alpha * c.a

  void fill(Rgba c);
  void fill_rect(int x, int y, int w, int h, Rgba c, double alpha = 1.0);
  void frame_rect(int x, int y, int w, int h, Rgba c, int thickness = 1);
  // Copies `src` with its top-left corner at (x, y), clipped.
  void blit(const Image& src, int x, int y);
  // A box-filtered copy of size w x h (for thumbnails).
  Image resized(int w, int h) const;
  // Flips rows in place (OpenGL reads bottom-up).
  void flip_vertical();

  // Anti-aliased primitives, coordinates in pixels (pixel centres at +0.5).
  void line(double x0, double y0, double x1, double y1, Rgba c, double width = 1.0);
  void disc(double cx, double cy, double radius, Rgba c);
  void ring(double cx, double cy, double radius, Rgba c, double width = 1.0);

 private:
  int width_ = 0, height_ = 0;
  std::vector<std::uint8_t> pixels_;  // width * height * 4, rows top to bottom
};

// PNG files (libpng, 8-bit RGBA or RGB when every pixel is opaque). `compression` is zlib's
// level 0..9: 3 and below are fast (frames of a run), 9 is small (contact sheets).
// Errors (cannot open, cannot write) throw pliant::InputError naming the file.
void write_png(const Image& image, const std::filesystem::path& path, int compression = 6);
Image read_png(const std::filesystem::path& path);

}  // namespace pliant::raster
