// CPU overlays on a rendered picture: the time, a title, the colour bar in display units
// (mm, kPa, ...), probe markers (a ring and a cross, drawn through the body so that buried
// probes stay visible) with their names, and a legend of the marks.
#include "overlay.hpp"

#include <algorithm>
#include <cmath>
#include <fmt/format.h>

#include "pliant/raster/colormap.hpp"
#include "pliant/raster/text.hpp"

namespace pliant::raster {

namespace {
const Rgba kInk{24, 26, 32, 255};
const Rgba kProbe{214, 39, 40, 255};
}  // namespace

void draw_colour_bar(Image& img, int x, int y, int w, int h, Field field, std::array<double, 2> range, int s,
                     bool horizontal) {
  s = std::max(s, 1);
  const double lo = range[0], hi = range[1] > range[0] ? range[1] : range[0] + 1;
  const DisplayUnit unit = display_unit(field_unit(field), std::max(std::abs(lo), std::abs(hi)));
  const std::string title = unit.name.empty() ? std::string(field_title(field))
                                              : fmt::format("{} [{}]", field_title(field), unit.name);
  TextStyle ts{kInk, s, true};
  std::vector<double> ticks = nice_ticks(lo * unit.factor, hi * unit.factor, horizontal ? 6 : 6);
  if (!horizontal) {
    // Title right-aligned on the box's right edge (it may reach left of the box), bar below.
    draw_text(img, x + w - text_width(title, s), y, title, ts);
    const int bx = x + 4 * s, bw = 10 * s, by = y + 14 * s, bh = std::max(h - 14 * s - 6 * s, 10);
    for (int j = 0; j < bh; ++j) {
      const Rgba c = viridis(1.0 - (j + 0.5) / bh);
      img.fill_rect(bx, by + j, bw, 1, c);
    }
    img.frame_rect(bx - 1, by - 1, bw + 2, bh + 2, kInk, 1);
    for (double t : ticks) {
      const double f = (t / unit.factor - lo) / (hi - lo);
      const int ty = by + int(std::lround((1 - f) * (bh - 1)));
      img.fill_rect(bx + bw, ty, 3 * s, std::max(1, s / 2), kInk);
      const std::string label = format_number(t, 3);
      draw_text(img, bx + bw + 5 * s, ty - text_height(s) / 2, label, ts);
    }
  } else {
    draw_text(img, x, y, title, ts);
    const int bx = x + 2 * s, bw = std::max(w - 4 * s, 10), by = y + 12 * s, bh = 8 * s;
    for (int i = 0; i < bw; ++i) img.fill_rect(bx + i, by, 1, bh, viridis((i + 0.5) / bw));
    img.frame_rect(bx - 1, by - 1, bw + 2, bh + 2, kInk, 1);
    for (double t : ticks) {
      const double f = (t / unit.factor - lo) / (hi - lo);
      const int tx = bx + int(std::lround(f * (bw - 1)));
      img.fill_rect(tx, by + bh, std::max(1, s / 2), 3 * s, kInk);
      const std::string label = format_number(t, 3);
      draw_text(img, std::clamp(tx - text_width(label, s) / 2, 0, img.width() - text_width(label, s)),
                by + bh + 4 * s, label, ts);
    }
  }
}

namespace detail {

std::string time_label(double t, double step) {
  int decimals = 3;
  if (step > 0) {  // enough to tell frames apart: 0.05 -> 2 decimals, 0.136 -> 2, 0.005 -> 3
    decimals = int(std::ceil(-std::log10(step) - 1e-9));
    const double scaled = step * std::pow(10.0, decimals);
    if (std::abs(scaled - std::round(scaled)) > 1e-6 * scaled) ++decimals;
    decimals = std::clamp(decimals, 0, 6);
  }
  if (std::abs(t) >= 100) decimals = std::min(decimals, 1);
  return fmt::format("t = {:.{}f} s", t, decimals);
}

void draw_overlays(Image& img, const Frame& frame, const RenderOptions& o, const Layout& L, const Camera& cam,
                   const std::array<double, 2>& range) {
  const int s = L.text_scale;
  TextStyle ts{kInk, s, true};
  // Probes: through the body, so that buried ones show.
  if (o.marks) {
    for (const ProbeMark& p : frame.probes) {
      double px = 0, py = 0;
      if (!cam.project(V3(p.position), px, py)) continue;
      const double r = 4.0 * s;
      img.ring(px, py, r + s * 0.6, {255, 255, 255, 200}, 1.2 * s);
      img.ring(px, py, r, kProbe, 1.2 * s);
      img.line(px - 1.8 * r, py, px - 0.5 * r, py, kProbe, s);
      img.line(px + 0.5 * r, py, px + 1.8 * r, py, kProbe, s);
      img.line(px, py - 1.8 * r, px, py - 0.5 * r, kProbe, s);
      img.line(px, py + 0.5 * r, px, py + 1.8 * r, kProbe, s);
      if (o.probe_labels) draw_text(img, int(px + 2.2 * r), int(py - 2.4 * r), p.name, {kProbe, s, true});
    }
  }
  if (o.time_label || !o.title.empty()) {
    std::string line = o.time_label && frame.has_time ? time_label(frame.time) : "";
    if (!o.title.empty()) line += (line.empty() ? "" : "   ") + o.title;
    draw_text(img, 6 * s, 3 * s, line, ts);
  }
  if (L.colour_bar) draw_colour_bar(img, L.bar_x, L.bar_y, L.bar_w, L.bar_h, frame.field, range, s);
  if (o.axes) draw_axes(img, L, cam);
  if (o.scale_bar) draw_scale_bar(img, L, cam);
  if (L.legend) {
    bool fixed = false, driven = false;
    for (const auto& b : frame.bodies) {
      fixed = fixed || !b.topology->fixed.empty();
      driven = driven || !b.topology->driven.empty();
    }
    draw_legend(img, 6 * s, L.height - 12 * s, s, fixed, driven, !frame.probes.empty());
  }
}

void draw_axes(Image& img, const Layout& L, const Camera& cam) {
  const int s = L.text_scale;
  const auto& m = cam.modelview;  // rows: the camera's right, up and backwards directions
  const V3 right{m[0], m[4], m[8]}, up{m[1], m[5], m[9]}, back{m[2], m[6], m[10]};
  const double len = 16.0 * s;
  const double ox = 10.0 * s + len, oy = L.height - (L.legend ? 14.0 * s : 0.0) - 8.0 * s - len;
  static const Rgba kAxis[3] = {{214, 39, 40, 255}, {44, 160, 44, 255}, {31, 119, 180, 255}};
  static const char* kName[3] = {"x", "y", "z"};
  int order[3] = {0, 1, 2};  // axes pointing away from the viewer first, so that nearer ones are on top
  const V3 axis[3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  std::sort(order, order + 3, [&](int a, int b) { return dot(axis[a], back) < dot(axis[b], back); });
  img.disc(ox, oy, 1.6 * s, kInk);
  for (int k : order) {
    const double dx = dot(axis[k], right), dy = -dot(axis[k], up);  // pixels grow downwards
    const double ex = ox + len * dx, ey = oy + len * dy;
    img.line(ox, oy, ex, ey, kAxis[k], 1.5 * s);
    const double n = std::hypot(dx, dy);
    const double lx = n > 0.2 ? ex + 4.0 * s * dx / n : ex + 4.0 * s, ly = n > 0.2 ? ey + 4.0 * s * dy / n : ey;
    draw_text(img, int(lx - text_width(kName[k], s) / 2.0), int(ly - text_height(s) / 2.0), kName[k], {kAxis[k], s, true});
  }
}

// "10 cm", "2 m", "500 um": a round length in the unit that reads best.
std::string length_label(double m) {
  if (m >= 1) return fmt::format("{:g} m", m);
  if (m >= 0.01) return fmt::format("{:g} cm", std::round(m * 1e4) / 1e2);
  if (m >= 1e-3) return fmt::format("{:g} mm", std::round(m * 1e5) / 1e2);
  return fmt::format("{:g} \u00B5m", std::round(m * 1e8) / 1e2);
}

void draw_scale_bar(Image& img, const Layout& L, const Camera& cam) {
  const int s = L.text_scale;
  // Metres per pixel at the target's depth: the usable part of the image spans the field of view.
  const V3 eye(cam.view.position), target(cam.view.target);
  const double dist = norm(target - eye);
  const double uh = std::max(L.usable_y1 - L.usable_y0, 1);
  const double m_per_px = dist * 2 * std::tan(cam.view.fov_deg * std::acos(-1.0) / 360) / uh;
  if (!(m_per_px > 0) || !std::isfinite(m_per_px)) return;
  // The largest 1, 2 or 5 x 10^k no longer than about a sixth of the width.
  const double want = L.width / 6.0 * m_per_px;
  const double p = std::pow(10.0, std::floor(std::log10(want)));
  const double length = want >= 5 * p ? 5 * p : want >= 2 * p ? 2 * p : p;
  const double px = length / m_per_px;
  const std::string label = length_label(length);
  const int x1 = L.width - 10 * s, x0 = int(std::lround(x1 - px)), y = L.height - 8 * s;
  const Rgba white{255, 255, 255, 230};
  img.fill_rect(x0 - s, y - 3 * s, x1 - x0 + 2 * s, 4 * s, white);
  img.fill_rect(x0, y - 2 * s, x1 - x0, 2 * s, kInk);
  img.fill_rect(x0, y - 5 * s, std::max(1, s / 2 + 1), 5 * s, kInk);  // end ticks
  img.fill_rect(x1 - std::max(1, s / 2 + 1), y - 5 * s, std::max(1, s / 2 + 1), 5 * s, kInk);
  draw_text(img, (x0 + x1) / 2 - text_width(label, s) / 2, y - 5 * s - text_height(s), label, {kInk, s, true});
}

void draw_legend(Image& img, int x, int y, int s, bool fixed, bool driven, bool probes) {
  TextStyle ts{kInk, s, true};
  const double cy = y + 4.5 * s;
  auto item = [&](const char* text) {
    draw_text(img, x, y, text, ts);
    x += text_width(text, s) + 14 * s;
  };
  // The marks as the renderer draws them (GL points, square under multisampling): a bright
  // square over a dark outline.
  auto mark = [&](Rgba c) {
    const int d = int(std::lround(mark_diameter(s))), o = int(std::lround(mark_outline(s)));
    const int top = int(std::lround(cy - d / 2.0));
    img.fill_rect(x, top - o, d + 2 * o, d + 2 * o, kMarkOutline);
    img.fill_rect(x + o, top, d, d, c);
    x += d + 2 * o + 3 * s;
  };
  if (fixed) {
    mark(kFixedColour);
    item("fixed");
  }
  if (driven) {
    mark(kDrivenColour);
    item("prescribed motion");
  }
  if (probes) {
    img.ring(x + 3 * s, cy, 2.6 * s, kProbe, s);
    x += 9 * s;
    item("probe");
  }
}

}  // namespace detail
}  // namespace pliant::raster
