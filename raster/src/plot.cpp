// Plots drawn in software (see plot.hpp): axes with round ticks (linear or decades), grid,
// anti-aliased lines and markers clipped to the plot area, labels with units, a legend box.
#include "pliant/raster/plot.hpp"

#include <algorithm>
#include <cmath>
#include <fmt/format.h>

#include "pliant/error.hpp"
#include "pliant/raster/colormap.hpp"
#include "pliant/raster/text.hpp"

namespace pliant::raster {
namespace {

const Rgba kInk{30, 32, 38, 255};
const Rgba kGrid{222, 224, 230, 255};

struct Scale {
  double lo = 0, hi = 1;
  bool log = false;
  double to_unit(double v) const {  // [lo, hi] -> [0, 1]
    if (log) return (std::log10(v) - std::log10(lo)) / (std::log10(hi) - std::log10(lo));
    return (v - lo) / (hi - lo);
  }
};

bool usable(double v, bool log) { return std::isfinite(v) && (!log || v > 0); }

Scale make_scale(const PlotAxis& axis, const std::vector<double>& values) {
  Scale s;
  s.log = axis.log;
  double lo = 1e300, hi = -1e300;
  for (double v : values)
    if (usable(v, axis.log)) {
      lo = std::min(lo, v);
      hi = std::max(hi, v);
    }
  if (lo > hi) {
    lo = axis.log ? 1 : 0;
    hi = axis.log ? 10 : 1;
  }
  if (axis.log) {
    if (axis.min && *axis.min > 0) lo = *axis.min;
    if (axis.max && *axis.max > 0) hi = *axis.max;
    if (!(hi > lo)) {
      lo /= 2;
      hi = hi * 2;
    }
    // Whole decades when the data spans more than one, else a little padding.
    if (std::log10(hi) - std::log10(lo) >= 1) {
      if (!axis.min) lo = std::pow(10.0, std::floor(std::log10(lo) + 1e-9));
      if (!axis.max) hi = std::pow(10.0, std::ceil(std::log10(hi) - 1e-9));
    } else {
      if (!axis.min) lo /= 1.15;
      if (!axis.max) hi *= 1.15;
    }
  } else {
    if (axis.min) lo = *axis.min;
    if (axis.max) hi = *axis.max;
    if (!(hi > lo)) {
      const double d = lo != 0 ? std::abs(lo) * 0.1 : 1;
      lo -= d;
      hi += d;
    }
    const double pad = 0.04 * (hi - lo);
    if (!axis.min) lo -= pad;
    if (!axis.max) hi += pad;
    // Snap to round values when that costs little.
    const double step = nice_number((hi - lo) / 5, false);
    if (!axis.min) lo = std::floor(lo / step + 1e-9) * step;
    if (!axis.max) hi = std::ceil(hi / step - 1e-9) * step;
  }
  s.lo = lo;
  s.hi = hi;
  return s;
}

std::vector<double> ticks_of(const Scale& s) {
  if (!s.log) return nice_ticks(s.lo, s.hi, 6);
  std::vector<double> t;
  const int e0 = int(std::floor(std::log10(s.lo) - 1e-9)), e1 = int(std::ceil(std::log10(s.hi) + 1e-9));
  const int decades = e1 - e0;
  const int every = std::max(1, (decades + 7) / 8);  // at most ~8 decade labels
  for (int e = e0; e <= e1; ++e) {
    if ((e - e0) % every) continue;
    for (double m : decades <= 2 ? std::vector<double>{1, 2, 5} : std::vector<double>{1}) {
      const double v = m * std::pow(10.0, e);
      if (v >= s.lo * (1 - 1e-9) && v <= s.hi * (1 + 1e-9)) t.push_back(v);
    }
  }
  return t;
}

// Unlabelled minor ticks of a log axis: 2..9 times each decade, when there are few decades.
std::vector<double> minor_ticks_of(const Scale& s) {
  std::vector<double> t;
  if (!s.log) return t;
  const int e0 = int(std::floor(std::log10(s.lo) - 1e-9)), e1 = int(std::ceil(std::log10(s.hi) + 1e-9));
  if (e1 - e0 > 6) return t;
  for (int e = e0; e <= e1; ++e)
    for (int m = 2; m <= 9; ++m) {
      const double v = m * std::pow(10.0, e);
      if (v >= s.lo * (1 - 1e-9) && v <= s.hi * (1 + 1e-9)) t.push_back(v);
    }
  return t;
}

std::string axis_title(const PlotAxis& a) {
  return a.unit.empty() ? a.label : fmt::format("{} [{}]", a.label, a.unit);
}

// Liang-Barsky: clips the segment to the rectangle; false if nothing is left.
bool clip(double& x0, double& y0, double& x1, double& y1, double L, double T, double R, double B) {
  double t0 = 0, t1 = 1;
  const double dx = x1 - x0, dy = y1 - y0;
  const double p[4] = {-dx, dx, -dy, dy}, q[4] = {x0 - L, R - x0, y0 - T, B - y0};
  for (int i = 0; i < 4; ++i) {
    if (p[i] == 0) {
      if (q[i] < 0) return false;
      continue;
    }
    const double r = q[i] / p[i];
    if (p[i] < 0) t0 = std::max(t0, r);
    else t1 = std::min(t1, r);
    if (t0 > t1) return false;
  }
  const double ax = x0 + t0 * dx, ay = y0 + t0 * dy;
  x1 = x0 + t1 * dx;
  y1 = y0 + t1 * dy;
  x0 = ax;
  y0 = ay;
  return true;
}

void marker(Image& img, int shape, double x, double y, double r, Rgba c) {
  switch (shape % 4) {
    case 0: img.disc(x, y, r, c); break;
    case 1: img.fill_rect(int(std::lround(x - r)), int(std::lround(y - r)), int(std::lround(2 * r)), int(std::lround(2 * r)), c); break;
    case 2:  // triangle (outline thick enough to read as filled at small sizes)
      img.line(x, y - r * 1.15, x - r, y + r * 0.75, c, r * 0.9);
      img.line(x - r, y + r * 0.75, x + r, y + r * 0.75, c, r * 0.9);
      img.line(x + r, y + r * 0.75, x, y - r * 1.15, c, r * 0.9);
      break;
    default:  // diamond
      img.line(x, y - r * 1.2, x, y + r * 1.2, c, r * 1.1);
      img.line(x - r * 0.6, y, x + r * 0.6, y, c, r * 1.3);
  }
}

}  // namespace

Image render_plot(const Plot& plot) {
  if (plot.width < 64 || plot.height < 64 || plot.width > 16384 || plot.height > 16384)
    throw InputError(fmt::format("plot \"{}\": size {}x{} must be in [64, 16384] pixels", plot.title, plot.width, plot.height));
  std::vector<double> xs, ys;
  for (const PlotSeries& s : plot.series) {
    if (s.x.size() != s.y.size())
      throw InputError(fmt::format("plot \"{}\": series \"{}\" has {} x values and {} y values", plot.title, s.label,
                                   s.x.size(), s.y.size()));
    for (std::size_t i = 0; i < s.x.size(); ++i)
      if (usable(s.x[i], plot.x.log) && usable(s.y[i], plot.y.log)) {
        xs.push_back(s.x[i]);
        ys.push_back(s.y[i]);
      }
  }
  const Scale sx = make_scale(plot.x, xs), sy = make_scale(plot.y, ys);
  const std::vector<double> tx = ticks_of(sx), ty = ticks_of(sy);

  const int W = plot.width, H = plot.height;
  const int s = std::max(1, int(std::lround(std::min(W, H) / 400.0)));
  const double k = std::min(W, H) / 600.0;  // line and marker scale
  Image img(W, H, {255, 255, 255, 255});
  TextStyle ts{kInk, s, false};

  int ylab_w = 0;
  for (double v : ty) ylab_w = std::max(ylab_w, text_width(format_number(v, 3), s));
  const int left = 8 * s + text_height(s) + 6 * s + ylab_w + 6 * s;
  const int top = (plot.title.empty() ? 8 * s : 20 * s);
  const int right = 14 * s;
  const int bottom = 6 * s + text_height(s) + 6 * s + text_height(s) + 8 * s;
  const double L = left, T = top, R = W - right, B = H - bottom;
  auto px = [&](double v) { return L + sx.to_unit(v) * (R - L); };
  auto py = [&](double v) { return B - sy.to_unit(v) * (B - T); };

  if (!plot.title.empty()) draw_text(img, int((L + R) / 2 - text_width(plot.title, s) / 2.0), 5 * s, plot.title, ts);
  const Rgba minor_grid{238, 239, 243, 255};
  for (double v : minor_ticks_of(sx)) {
    const int x = int(std::lround(px(v)));
    if (plot.grid) img.fill_rect(x, int(T), 1, int(B - T), minor_grid);
    img.fill_rect(x, int(B), 1, 2 * s, kInk);
  }
  for (double v : minor_ticks_of(sy)) {
    const int y = int(std::lround(py(v)));
    if (plot.grid) img.fill_rect(int(L), y, int(R - L), 1, minor_grid);
    img.fill_rect(int(L) - 2 * s, y, 2 * s, 1, kInk);
  }
  if (plot.grid) {
    for (double v : tx) img.fill_rect(int(std::lround(px(v))), int(T), 1, int(B - T), kGrid);
    for (double v : ty) img.fill_rect(int(L), int(std::lround(py(v))), int(R - L), 1, kGrid);
  }
  img.frame_rect(int(L), int(T), int(R - L) + 1, int(B - T) + 1, kInk, 1);
  for (double v : tx) {
    const int x = int(std::lround(px(v)));
    img.fill_rect(x, int(B), 1, 4 * s, kInk);
    const std::string lab = format_number(v, 3);
    draw_text(img, x - text_width(lab, s) / 2, int(B) + 6 * s, lab, ts);
  }
  for (double v : ty) {
    const int y = int(std::lround(py(v)));
    img.fill_rect(int(L) - 4 * s, y, 4 * s, 1, kInk);
    const std::string lab = format_number(v, 3);
    draw_text(img, int(L) - 6 * s - text_width(lab, s), y - text_height(s) / 2, lab, ts);
  }
  const std::string xt = axis_title(plot.x), yt = axis_title(plot.y);
  draw_text(img, int((L + R) / 2 - text_width(xt, s) / 2.0), H - 8 * s - text_height(s), xt, ts);
  draw_text_vertical(img, 6 * s, int((T + B) / 2 - text_width(yt, s) / 2.0), yt, ts);

  for (std::size_t si = 0; si < plot.series.size(); ++si) {
    const PlotSeries& s_ = plot.series[si];
    const Rgba c = s_.colour.value_or(palette(int(si)));
    const bool lines = s_.style != SeriesStyle::scatter, marks = s_.style != SeriesStyle::line;
    bool have_prev = false;
    double qx = 0, qy = 0;
    for (std::size_t i = 0; i < s_.x.size(); ++i) {
      if (!usable(s_.x[i], plot.x.log) || !usable(s_.y[i], plot.y.log)) {
        have_prev = false;  // a gap in the line
        continue;
      }
      const double x = px(s_.x[i]), y = py(s_.y[i]);
      if (lines && have_prev) {
        double x0 = qx, y0 = qy, x1 = x, y1 = y;
        if (clip(x0, y0, x1, y1, L, T, R, B)) img.line(x0, y0, x1, y1, c, s_.line_width * k);
      }
      if (marks && x >= L - 0.5 && x <= R + 0.5 && y >= T - 0.5 && y <= B + 0.5)
        marker(img, int(si), x, y, s_.marker_size * k, c);
      qx = x;
      qy = y;
      have_prev = true;
    }
  }

  if (plot.legend) {
    std::vector<std::size_t> listed;
    int lw = 0;
    for (std::size_t i = 0; i < plot.series.size(); ++i)
      if (!plot.series[i].label.empty()) {
        listed.push_back(i);
        lw = std::max(lw, text_width(plot.series[i].label, s));
      }
    if (!listed.empty()) {
      const int row = text_height(s) + 4 * s, sample = 22 * s;
      const int bw = 6 * s + sample + 6 * s + lw + 8 * s, bh = int(listed.size()) * row + 6 * s;
      const int bx = int(R) - bw - 6 * s, by = int(T) + 6 * s;
      img.fill_rect(bx, by, bw, bh, {255, 255, 255, 255}, 0.9);
      img.frame_rect(bx, by, bw, bh, {180, 182, 190, 255}, 1);
      for (std::size_t r = 0; r < listed.size(); ++r) {
        const PlotSeries& s_ = plot.series[listed[r]];
        const Rgba c = s_.colour.value_or(palette(int(listed[r])));
        const double cy = by + 4 * s + r * row + text_height(s) / 2.0;
        const double x0 = bx + 6 * s, x1 = x0 + sample;
        if (s_.style != SeriesStyle::scatter) img.line(x0, cy, x1, cy, c, s_.line_width * k);
        if (s_.style != SeriesStyle::line) marker(img, int(listed[r]), (x0 + x1) / 2, cy, s_.marker_size * k, c);
        draw_text(img, int(x1) + 6 * s, by + 4 * s + int(r) * row, s_.label, ts);
      }
    }
  }
  return img;
}

void write_plot_png(const Plot& plot, const std::filesystem::path& path) { write_png(render_plot(plot), path, 6); }

}  // namespace pliant::raster
