// Image: RGBA pixels and the 2D primitives the overlays, sheets and plots are drawn with. The
// anti-aliased shapes compute each pixel's coverage from its distance to the shape (a 1-pixel
// ramp), which is deterministic and good enough for lines, markers and text halos.
#include "pliant/raster/image.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

namespace pliant::raster {

Rgba rgb(double r, double g, double b, double a) {
  auto q = [](double v) { return std::uint8_t(std::lround(std::clamp(v, 0.0, 1.0) * 255.0)); };
  return {q(r), q(g), q(b), q(a)};
}

Image::Image(int width, int height, Rgba fill_colour)
    : width_(std::max(width, 0)), height_(std::max(height, 0)), pixels_(std::size_t(width_) * height_ * 4) {
  fill(fill_colour);
}

Rgba Image::get(int x, int y) const {
  if (!inside(x, y)) return {0, 0, 0, 0};
  const std::uint8_t* p = &pixels_[(std::size_t(y) * width_ + x) * 4];
  return {p[0], p[1], p[2], p[3]};
}

void Image::set(int x, int y, Rgba c) {
  if (!inside(x, y)) return;
  std::uint8_t* p = &pixels_[(std::size_t(y) * width_ + x) * 4];
  p[0] = c.r;
  p[1] = c.g;
  p[2] = c.b;
  p[3] = c.a;
}

void Image::blend(int x, int y, Rgba c, double alpha) {
  if (!inside(x, y)) return;
  const double a = std::clamp(alpha, 0.0, 1.0) * (c.a / 255.0);
  if (a <= 0) return;
  std::uint8_t* p = &pixels_[(std::size_t(y) * width_ + x) * 4];
  auto mix = [a](std::uint8_t dst, std::uint8_t src) {
    return std::uint8_t(std::lround(dst + (double(src) - dst) * a));
  };
  p[0] = mix(p[0], c.r);
  p[1] = mix(p[1], c.g);
  p[2] = mix(p[2], c.b);
  p[3] = std::uint8_t(std::lround(p[3] + (255.0 - p[3]) * a));
}

void Image::fill(Rgba c) {
  for (std::size_t i = 0; i < pixels_.size(); i += 4) {
    pixels_[i] = c.r;
    pixels_[i + 1] = c.g;
    pixels_[i + 2] = c.b;
    pixels_[i + 3] = c.a;
  }
}

void Image::fill_rect(int x, int y, int w, int h, Rgba c, double alpha) {
  const int x0 = std::max(x, 0), y0 = std::max(y, 0);
  const int x1 = std::min(x + w, width_), y1 = std::min(y + h, height_);
  for (int j = y0; j < y1; ++j)
    for (int i = x0; i < x1; ++i) {
      if (alpha >= 1.0 && c.a == 255) set(i, j, c);
      else blend(i, j, c, alpha);
    }
}

void Image::frame_rect(int x, int y, int w, int h, Rgba c, int t) {
  fill_rect(x, y, w, t, c);
  fill_rect(x, y + h - t, w, t, c);
  fill_rect(x, y + t, t, h - 2 * t, c);
  fill_rect(x + w - t, y + t, t, h - 2 * t, c);
}

void Image::blit(const Image& src, int x, int y) {
  for (int j = 0; j < src.height(); ++j) {
    const int ty = y + j;
    if (ty < 0 || ty >= height_) continue;
    for (int i = 0; i < src.width(); ++i) {
      const int tx = x + i;
      if (tx < 0 || tx >= width_) continue;
      set(tx, ty, src.get(i, j));
    }
  }
}

Image Image::resized(int w, int h) const {
  Image out(w, h);
  if (empty() || w <= 0 || h <= 0) return out;
  const double sx = double(width_) / w, sy = double(height_) / h;
  for (int j = 0; j < h; ++j) {
    const double y0 = j * sy, y1 = (j + 1) * sy;
    for (int i = 0; i < w; ++i) {
      const double x0 = i * sx, x1 = (i + 1) * sx;
      double acc[4] = {0, 0, 0, 0}, area = 0;
      for (int yy = int(y0); yy < std::min(int(std::ceil(y1)), height_); ++yy) {
        const double wy = std::min(y1, yy + 1.0) - std::max(y0, double(yy));
        for (int xx = int(x0); xx < std::min(int(std::ceil(x1)), width_); ++xx) {
          const double wx = std::min(x1, xx + 1.0) - std::max(x0, double(xx));
          const double wgt = wx * wy;
          if (wgt <= 0) continue;
          const std::uint8_t* p = &pixels_[(std::size_t(yy) * width_ + xx) * 4];
          for (int k = 0; k < 4; ++k) acc[k] += wgt * p[k];
          area += wgt;
        }
      }
      if (area > 0)
        out.set(i, j, {std::uint8_t(std::lround(acc[0] / area)), std::uint8_t(std::lround(acc[1] / area)),
                       std::uint8_t(std::lround(acc[2] / area)), std::uint8_t(std::lround(acc[3] / area))});
    }
  }
  return out;
}

void Image::flip_vertical() {
  const std::size_t row = std::size_t(width_) * 4;
  for (int j = 0; j < height_ / 2; ++j)
    std::swap_ranges(pixels_.begin() + std::ptrdiff_t(j * row), pixels_.begin() + std::ptrdiff_t((j + 1) * row),
                     pixels_.begin() + std::ptrdiff_t((height_ - 1 - j) * row));
}

// Coverage of a pixel at distance d from a shape's edge (d < 0 inside): a 1-pixel ramp.
static double coverage(double d) { return std::clamp(0.5 - d, 0.0, 1.0); }

void Image::line(double x0, double y0, double x1, double y1, Rgba c, double width) {
  const double hw = std::max(width, 0.5) * 0.5;
  const double dx = x1 - x0, dy = y1 - y0, len2 = dx * dx + dy * dy;
  auto dist = [&](double px, double py) {
    double t = len2 > 0 ? ((px - x0) * dx + (py - y0) * dy) / len2 : 0.0;
    t = std::clamp(t, 0.0, 1.0);
    const double qx = x0 + t * dx - px, qy = y0 + t * dy - py;
    return std::sqrt(qx * qx + qy * qy);
  };
  const double pad = hw + 1.5;
  // Walk the major axis; on each column (row) only the band around the line is visited.
  if (std::abs(dx) >= std::abs(dy)) {
    const int i0 = int(std::floor(std::min(x0, x1) - pad)), i1 = int(std::ceil(std::max(x0, x1) + pad));
    const double slope = dx != 0 ? dy / dx : 0.0;
    const double band = pad * std::sqrt(1 + slope * slope);
    for (int i = std::max(i0, 0); i <= std::min(i1, width_ - 1); ++i) {
      const double cx = i + 0.5;
      const double t = std::clamp(cx, std::min(x0, x1), std::max(x0, x1));
      const double cy = dx != 0 ? y0 + (t - x0) * slope : y0;
      for (int j = std::max(int(std::floor(cy - band)), 0); j <= std::min(int(std::ceil(cy + band)), height_ - 1); ++j) {
        const double a = coverage(dist(cx, j + 0.5) - hw);
        if (a > 0) blend(i, j, c, a);
      }
    }
  } else {
    const int j0 = int(std::floor(std::min(y0, y1) - pad)), j1 = int(std::ceil(std::max(y0, y1) + pad));
    const double slope = dx / dy;
    const double band = pad * std::sqrt(1 + slope * slope);
    for (int j = std::max(j0, 0); j <= std::min(j1, height_ - 1); ++j) {
      const double cy = j + 0.5;
      const double t = std::clamp(cy, std::min(y0, y1), std::max(y0, y1));
      const double cx = x0 + (t - y0) * slope;
      for (int i = std::max(int(std::floor(cx - band)), 0); i <= std::min(int(std::ceil(cx + band)), width_ - 1); ++i) {
        const double a = coverage(dist(i + 0.5, cy) - hw);
        if (a > 0) blend(i, j, c, a);
      }
    }
  }
}

void Image::disc(double cx, double cy, double r, Rgba c) {
  for (int j = std::max(int(std::floor(cy - r - 1)), 0); j <= std::min(int(std::ceil(cy + r + 1)), height_ - 1); ++j)
    for (int i = std::max(int(std::floor(cx - r - 1)), 0); i <= std::min(int(std::ceil(cx + r + 1)), width_ - 1); ++i) {
      const double d = std::hypot(i + 0.5 - cx, j + 0.5 - cy) - r;
      const double a = coverage(d);
      if (a > 0) blend(i, j, c, a);
    }
}

void Image::ring(double cx, double cy, double r, Rgba c, double width) {
  const double hw = std::max(width, 0.5) * 0.5;
  for (int j = std::max(int(std::floor(cy - r - hw - 1)), 0); j <= std::min(int(std::ceil(cy + r + hw + 1)), height_ - 1); ++j)
    for (int i = std::max(int(std::floor(cx - r - hw - 1)), 0); i <= std::min(int(std::ceil(cx + r + hw + 1)), width_ - 1); ++i) {
      const double d = std::abs(std::hypot(i + 0.5 - cx, j + 0.5 - cy) - r) - hw;
      const double a = coverage(d);
      if (a > 0) blend(i, j, c, a);
    }
}

}  // namespace pliant::raster
