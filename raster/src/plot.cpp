// Plots drawn in software (see plot.hpp): axes with round ticks (linear or decades), grid,
// anti-aliased lines and markers clipped to the plot area, labels with units, a legend box.
#include "pliant/raster/plot.hpp"

#include <algorithm>
#include <array>
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

namespace {

// Series drawn over an earlier one (same style, the same points in the same order, each within
// half a pixel of it at this picture size): the index of that earlier series, else their own
// index. `exact[i]`: series i's points are identical to its leader's, not only close.
// The legend label of coincident series. Labels made of the same "key=value" fields in the same
// order (as `pliant study` names its runs) merge field by field, the values that differ joined by
// '|' when the series are identical and by '≈' when they only coincide to the pixel:
// "model=linear|stvk, nu=0.3" instead of "model=linear, nu=0.3 = model=stvk, nu=0.3", which soon
// outgrows the picture. Other labels are joined with `sep` (" = " or " ≈ ").
std::string joint_label(const std::vector<std::string>& labels, const char* sep) {
  if (labels.empty()) return {};
  auto fields = [](const std::string& l) {
    std::vector<std::pair<std::string, std::string>> out;
    std::size_t start = 0;
    while (start <= l.size()) {
      std::size_t end = l.find(", ", start);
      if (end == std::string::npos) end = l.size();
      const std::string f = l.substr(start, end - start);
      const std::size_t eq = f.find('=');
      if (eq == std::string::npos || eq == 0) return std::vector<std::pair<std::string, std::string>>{};
      out.emplace_back(f.substr(0, eq), f.substr(eq + 1));
      start = end + 2;
    }
    return out;
  };
  const auto first = fields(labels[0]);
  bool mergeable = labels.size() > 1 && !first.empty();
  std::vector<std::vector<std::string>> values(first.size());
  for (std::size_t k = 0; k < first.size(); ++k) values[k].push_back(first[k].second);
  for (std::size_t i = 1; mergeable && i < labels.size(); ++i) {
    const auto f = fields(labels[i]);
    if (f.size() != first.size()) mergeable = false;
    for (std::size_t k = 0; mergeable && k < f.size(); ++k) {
      if (f[k].first != first[k].first) mergeable = false;
      else if (std::find(values[k].begin(), values[k].end(), f[k].second) == values[k].end())
        values[k].push_back(f[k].second);
    }
  }
  std::string out;
  if (mergeable) {
    for (std::size_t k = 0; k < first.size(); ++k) {
      out += (k ? ", " : "") + first[k].first + "=";
      const char* join = std::string(sep) == " = " ? "|" : "\u2248";
      for (std::size_t j = 0; j < values[k].size(); ++j) out += (j ? join : "") + values[k][j];
    }
    return out;
  }
  for (const std::string& l : labels) out += (out.empty() ? "" : sep) + l;
  return out;
}

std::vector<std::size_t> coincident_leaders(const Plot& plot, const Scale& sx, const Scale& sy, std::vector<bool>& exact) {
  std::vector<std::size_t> leader(plot.series.size());
  exact.assign(plot.series.size(), true);
  const double tx = 0.5 / plot.width, ty = 0.5 / plot.height;  // the plot area is smaller than the picture
  for (std::size_t i = 0; i < plot.series.size(); ++i) {
    leader[i] = i;
    const PlotSeries& a = plot.series[i];
    for (std::size_t j = 0; j < i && leader[i] == i; ++j) {
      if (leader[j] != j) continue;
      const PlotSeries& b = plot.series[j];
      if (a.style != b.style || a.x.size() != b.x.size() || a.x.size() != a.y.size() || b.x.size() != b.y.size()) continue;
      bool close = true, same = true, any = false;
      for (std::size_t k = 0; k < a.x.size() && close; ++k) {
        const bool ua = usable(a.x[k], plot.x.log) && usable(a.y[k], plot.y.log);
        const bool ub = usable(b.x[k], plot.x.log) && usable(b.y[k], plot.y.log);
        close = ua == ub && (!ua || (std::abs(sx.to_unit(a.x[k]) - sx.to_unit(b.x[k])) <= tx &&
                                     std::abs(sy.to_unit(a.y[k]) - sy.to_unit(b.y[k])) <= ty));
        same = same && (!ua || (a.x[k] == b.x[k] && a.y[k] == b.y[k]));
        any = any || ua;
      }
      if (close && any) leader[i] = j, exact[i] = same;
    }
  }
  return leader;
}

Image draw_plot(const Plot& plot, bool legend_below, PlotLayout& out) {
  out = {};
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
  // Room on the right for half of the last x tick label, which is centred on the plot's edge.
  const int right = std::max(14 * s, (tx.empty() ? 0 : text_width(format_number(tx.back(), 3), s) / 2) + 4 * s);
  // Series that coincide (identical points, or within half a pixel) are drawn once, in the first
  // one's style, and named together in one legend entry, "linear = corotational" (identical) or
  // "linear ≈ corotational" (indistinguishable here): the others could not be seen.
  std::vector<bool> exact;
  const std::vector<std::size_t> leader = coincident_leaders(plot, sx, sy, exact);
  std::vector<std::vector<std::string>> names(plot.series.size());
  std::vector<bool> all_exact(plot.series.size(), true);
  for (std::size_t i = 0; i < plot.series.size(); ++i) {
    const std::string& l = plot.series[i].label;
    auto& v = names[leader[i]];
    if (!l.empty() && std::find(v.begin(), v.end(), l) == v.end()) v.push_back(l);
    if (!exact[i]) all_exact[leader[i]] = false;
  }
  std::vector<std::string> entry_label(plot.series.size());
  for (std::size_t i = 0; i < plot.series.size(); ++i)
    entry_label[i] = joint_label(names[i], all_exact[i] ? " = " : " \u2248 ");
  // The legend's entries, measured first: below the plot they take room from it.
  std::vector<std::size_t> listed;
  int lw = 0;
  for (std::size_t i = 0; plot.legend && i < plot.series.size(); ++i)
    if (leader[i] == i && !entry_label[i].empty()) {
      listed.push_back(i);
      lw = std::max(lw, text_width(entry_label[i], s));
      out.legend_labels.push_back(entry_label[i]);
    }
  const int row = text_height(s) + 4 * s, sample = 22 * s;
  const int entry_w = 6 * s + sample + 6 * s + lw + 8 * s;
  const bool below = !listed.empty() && legend_below;
  int legend_cols = 1, legend_h = 0;
  if (below) {
    legend_cols = std::clamp((W - 16 * s) / entry_w, 1, int(listed.size()));
    legend_h = (int(listed.size()) + legend_cols - 1) / legend_cols * row + 12 * s;
  }
  const int bottom = 6 * s + text_height(s) + 6 * s + text_height(s) + 8 * s + legend_h;
  const double L = left, T = top, R = W - right, B = H - bottom;
  out.area = {int(L), int(T), int(R), int(B)};
  out.legend_below = below;
  auto px = [&](double v) { return L + sx.to_unit(v) * (R - L); };
  auto py = [&](double v) { return B - sy.to_unit(v) * (B - T); };

  if (!plot.title.empty()) {  // centred over the plot area, moved left (or smaller) if it would leave the picture
    TextStyle title_style = ts;
    while (title_style.scale > 1 && text_width(plot.title, title_style.scale) > W - 4 * s) --title_style.scale;
    const int tw = text_width(plot.title, title_style.scale);
    draw_text(img, std::max(2 * s, std::min(int((L + R) / 2 - tw / 2.0), W - 2 * s - tw)),
              5 * s + (text_height(s) - text_height(title_style.scale)) / 2, plot.title, title_style);
  }
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
  // Axis titles centred on their axis; one longer than the picture's side is drawn smaller.
  const std::string xt = axis_title(plot.x), yt = axis_title(plot.y);
  TextStyle xts = ts, yts = ts;
  while (xts.scale > 1 && text_width(xt, xts.scale) > W - 4 * s) --xts.scale;
  while (yts.scale > 1 && text_width(yt, yts.scale) > H - 4 * s) --yts.scale;
  const int xw = text_width(xt, xts.scale), yw = text_width(yt, yts.scale);
  draw_text(img, std::clamp(int((L + R) / 2 - xw / 2.0), 2 * s, std::max(2 * s, W - 2 * s - xw)),
            H - legend_h - 8 * s - text_height(s), xt, xts);
  draw_text_vertical(img, 6 * s, std::clamp(int((T + B) / 2 - yw / 2.0), 2 * s, std::max(2 * s, H - 2 * s - yw)), yt,
                     yts);

  struct Ink {
    double x, y;
    int weight;      // 8: a data point, 1: a piece of line
    double r = 0;    // how far its ink reaches (marker radius or half the line width), pixels
  };
  std::vector<Ink> ink;  // where the series drew
  struct PointLabel {
    double x, y, radius;  // the point and its marker (pixels)
    const std::string* text;
    Rgba colour;
  };
  std::vector<PointLabel> pending;  // drawn once every marker is known, so that they avoid them
  for (std::size_t si = 0; si < plot.series.size(); ++si) {
    const PlotSeries& s_ = plot.series[si];
    const std::size_t lead = leader[si];
    const Rgba c = plot.series[lead].colour.value_or(palette(int(lead)));
    const PlotSeries& drawn = plot.series[lead];  // a coincident series is drawn once, as its leader
    const bool lines = s_.style != SeriesStyle::scatter, marks = s_.style != SeriesStyle::line;
    bool have_prev = false;
    double qx = 0, qy = 0;
    for (std::size_t i = 0; i < s_.x.size(); ++i) {
      if (!usable(s_.x[i], plot.x.log) || !usable(s_.y[i], plot.y.log)) {
        have_prev = false;  // a gap in the line
        continue;
      }
      const double x = px(s_.x[i]), y = py(s_.y[i]);
      const bool inside = x >= L - 0.5 && x <= R + 0.5 && y >= T - 0.5 && y <= B + 0.5;
      // A follower of a coincident group draws nothing but its own point labels.
      if (lead != si) {
        const std::string* own = i < s_.point_labels.size() && !s_.point_labels[i].empty() ? &s_.point_labels[i] : nullptr;
        const bool repeats = own && i < drawn.point_labels.size() && drawn.point_labels[i] == *own;
        if (inside && own && !repeats) pending.push_back({x, y, drawn.marker_size * k, own, c});
        continue;
      }
      if (lines && have_prev) {
        double x0 = qx, y0 = qy, x1 = x, y1 = y;
        if (clip(x0, y0, x1, y1, L, T, R, B)) {
          img.line(x0, y0, x1, y1, c, s_.line_width * k);
          // Every ~6 pixels of the line, for placing the legend.
          const int n = std::min(400, 1 + int(std::hypot(x1 - x0, y1 - y0) / 6));
          for (int j = 0; j <= n; ++j)
            ink.push_back({x0 + (x1 - x0) * j / n, y0 + (y1 - y0) * j / n, 1, s_.line_width * k / 2});
        }
      }
      if (marks && inside) marker(img, int(si), x, y, s_.marker_size * k, c);
      if (inside) {
        // A marker reaches up to 1.75 times its radius (diamonds: their round-capped strokes).
        const double reach = marks ? 1.8 * s_.marker_size * k : s_.line_width * k / 2;
        ink.push_back({x, y, 8, reach});
        out.points.push_back({x, y, reach, si});
      }
      if (inside && i < s_.point_labels.size() && !s_.point_labels[i].empty())
        pending.push_back({x, y, s_.marker_size * k, &s_.point_labels[i], c});
      qx = x;
      qy = y;
      have_prev = true;
    }
  }

  // Point labels: right of the point and a little up; else the first of right-down, left-up,
  // left-down that covers no marker and no label placed before (else the first place inside).
  std::vector<std::array<int, 4>> placed;  // x0, y0, x1, y1
  for (const Ink& p : ink)
    if (p.weight > 1) {
      const int r = int(std::ceil(4 * k));
      placed.push_back({int(p.x) - r, int(p.y) - r, int(p.x) + r + 1, int(p.y) + r + 1});
    }
  for (const PointLabel& pl : pending) {
    const int gap = int(std::lround(pl.radius)) + 2 * s, w = text_width(*pl.text, s), h = text_height(s);
    const int x = int(pl.x), y = int(pl.y);
    const int places[4][2] = {{x + gap, y - h + 2 * s}, {x + gap, y + s}, {x - gap - w, y - h + 2 * s}, {x - gap - w, y + s}};
    int chosen = -1, fallback = -1;
    for (int j = 0; j < 4 && chosen < 0; ++j) {
      const int lx = places[j][0], ly = places[j][1];
      if (lx < 0 || lx + w > W || ly < 0 || ly + h > H) continue;
      if (fallback < 0) fallback = j;
      bool free = true;
      for (const auto& r : placed) free = free && (lx + w <= r[0] || r[2] <= lx || ly + h <= r[1] || r[3] <= ly);
      if (free) chosen = j;
    }
    if (chosen < 0) chosen = std::max(fallback, 0);
    const int lx = places[chosen][0], ly = places[chosen][1];
    placed.push_back({lx, ly, lx + w, ly + h});
    draw_text(img, lx, ly, *pl.text, {pl.colour, s, true});
  }

  // One legend entry: the series' line and marker, then its label; (x, y) is the top left.
  auto draw_entry = [&](std::size_t series, int x, int y) {
    const PlotSeries& s_ = plot.series[series];
    const Rgba c = s_.colour.value_or(palette(int(series)));
    const double cy = y + text_height(s) / 2.0, x0 = x + 6 * s, x1 = x0 + sample;
    if (s_.style != SeriesStyle::scatter) img.line(x0, cy, x1, cy, c, s_.line_width * k);
    if (s_.style != SeriesStyle::line) marker(img, int(series), (x0 + x1) / 2, cy, s_.marker_size * k, c);
    draw_text(img, int(x1) + 6 * s, y, entry_label[series], ts);
  };
  const Rgba legend_frame{180, 182, 190, 255};
  if (below) {  // in rows of legend_cols entries under the x axis title, centred
    const int rows = (int(listed.size()) + legend_cols - 1) / legend_cols;
    const int bw = legend_cols * entry_w, bh = rows * row + 4 * s;
    const int bx = std::max(2 * s, (W - bw) / 2), by = H - legend_h + 4 * s;
    img.frame_rect(bx, by, bw, bh, legend_frame, 1);
    out.legend = {bx, by, bw, bh};
    for (std::size_t r = 0; r < listed.size(); ++r)
      draw_entry(listed[r], bx + int(r) % legend_cols * entry_w, by + 4 * s + int(r) / legend_cols * row);
  } else if (!listed.empty()) {
    const int bw = entry_w, bh = int(listed.size()) * row + 6 * s;
    // The corner of the plot area where the box hides the fewest data points, then the least
    // of the lines: top right, else top left, bottom right, bottom left. When every corner
    // hides a point, render_plot draws the plot again with the legend below it.
    const int margin = 6 * s;
    const int corners[4][2] = {{int(R) - bw - margin, int(T) + margin}, {int(L) + margin, int(T) + margin},
                               {int(R) - bw - margin, int(B) - bh - margin}, {int(L) + margin, int(B) - bh - margin}};
    int bx = corners[0][0], by = corners[0][1];
    long best_points = -1, best_lines = 0;
    for (const auto& corner : corners) {
      long points = 0, lines = 0;
      for (const Ink& p : ink)
        if (const double pad = p.r + 2;
            p.x >= corner[0] - pad && p.x <= corner[0] + bw + pad && p.y >= corner[1] - pad && p.y <= corner[1] + bh + pad)
          (p.weight > 1 ? points : lines) += 1;
      if (best_points < 0 || points < best_points || (points == best_points && lines < best_lines))
        best_points = points, best_lines = lines, bx = corner[0], by = corner[1];
    }
    out.legend = {bx, by, bw, bh};
    out.legend_hides_points = best_points > 0;
    if (out.legend_hides_points) return img;  // drawn again, legend below
    img.fill_rect(bx, by, bw, bh, {255, 255, 255, 255}, 0.9);
    img.frame_rect(bx, by, bw, bh, legend_frame, 1);
    for (std::size_t r = 0; r < listed.size(); ++r) draw_entry(listed[r], bx, by + 4 * s + int(r) * row);
  }
  return img;
}

}  // namespace

Image render_plot(const Plot& plot, PlotLayout* layout) {
  PlotLayout local;
  PlotLayout& out = layout ? *layout : local;
  Image img = draw_plot(plot, plot.legend_place == LegendPlace::below, out);
  if (out.legend_hides_points) {  // no corner of the plot area is free of data: below the plot
    img = draw_plot(plot, true, out);
  }
  return img;
}

Image render_plot(const Plot& plot) { return render_plot(plot, nullptr); }

void write_plot_png(const Plot& plot, const std::filesystem::path& path) { write_png(render_plot(plot), path, 6); }

}  // namespace pliant::raster
