// Plots as PNG, drawn in software (no GL, no font library; only libpng): line and scatter
// series, linear or log axes with round ticks, axis labels with units, a title and a legend.
// For `pliant study` (Pareto fronts, convergence curves) and anything else that needs a chart.
//
//   raster::Plot p;
//   p.title = "Convergence";
//   p.x = {"cell size", "m", /*log=*/true};
//   p.y = {"tip error", "m", /*log=*/true};
//   p.series.push_back({"corotational", xs, ys, raster::SeriesStyle::line_and_markers});
//   raster::write_plot_png(p, "out/convergence.png");
#pragma once
#include <array>
#include <cstddef>
#include <filesystem>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "pliant/raster/image.hpp"

namespace pliant::raster {

enum class SeriesStyle { line, scatter, line_and_markers };

struct PlotSeries {
  PlotSeries() = default;
  PlotSeries(std::string label_, std::vector<double> x_, std::vector<double> y_, SeriesStyle style_ = SeriesStyle::line)
      : label(std::move(label_)), x(std::move(x_)), y(std::move(y_)), style(style_) {}

  std::string label;                  // in the legend; empty = not listed
  std::vector<double> x, y;           // same length (else InputError)
  SeriesStyle style = SeriesStyle::line;
  std::optional<Rgba> colour;         // default: the palette colour of the series' index
  double line_width = 2.0;            // pixels at 800x600 (scaled with the picture)
  double marker_size = 4.0;           // radius in pixels at 800x600
  // Text beside each point (e.g. a run number), same order as x; empty or missing: none. Drawn
  // right of the marker and a little up, else in the first of right-down, left-up, left-down
  // that covers no marker and no other label, in the series colour over a white halo.
  std::vector<std::string> point_labels;
};

struct PlotAxis {
  PlotAxis() = default;
  PlotAxis(std::string label_, std::string unit_, bool log_ = false)
      : label(std::move(label_)), unit(std::move(unit_)), log(log_) {}

  std::string label;                  // e.g. "cell size"
  std::string unit;                   // e.g. "m"; shown as "cell size [m]"
  bool log = false;                   // base-10 log scale; non-positive values are left out
  std::optional<double> min, max;     // default: the data's range (padded, rounded)
};

// Where the legend goes: inside the plot area, in the corner where it hides the fewest data
// points (then the least of the lines), or below the x axis title in as many columns as fit
// (for many or long entries; the plot area shrinks by its height, the picture keeps its size).
// `inside` falls back to `below` when every corner would hide a data point: no point is hidden.
enum class LegendPlace { inside, below };

struct Plot {
  std::string title;                  // one line; drawn smaller when too long for the width
  PlotAxis x, y;
  std::vector<PlotSeries> series;
  bool legend = true;                 // lists the series that have a label
  LegendPlace legend_place = LegendPlace::inside;
  bool grid = true;
  int width = 800, height = 600;      // pixels
};

// Where render_plot put things, in pixels (top-left origin), for tests and tools.
struct PlotLayout {
  std::array<int, 4> area{};                 // the plot area: x0, y0, x1, y1
  std::optional<std::array<int, 4>> legend;  // the legend box: x, y, width, height (none: no legend)
  bool legend_below = false;                 // the legend is below the plot (asked for, or no free corner)
  bool legend_hides_points = false;          // internal: the best corner hid a point (never true on return)
  struct Point {
    double x = 0, y = 0;  // centre of a drawn data point (inside the plot area)
    double radius = 0;    // how far its marker reaches (half the line width for a line without markers)
    std::size_t series = 0;
  };
  std::vector<Point> points;
  std::vector<std::string> legend_labels;    // the legend's entries in order ("a = b", "a ≈ b" for coincident series)
};

// Non-finite points are left out, as are non-positive ones on a log axis. A plot with no point
// left gets axes [0, 1] (or [1, 10] when log). Series that coincide (same style, and each point
// identical or within half a pixel of the other's) are drawn once, in the first one's colour and
// marker, and named together in one legend entry: "linear = corotational" when identical,
// "linear ≈ corotational" when only indistinguishable at this size. Throws InputError on
// mismatched x/y lengths or a size outside [64, 16384].
Image render_plot(const Plot& plot);
Image render_plot(const Plot& plot, PlotLayout* layout);
void write_plot_png(const Plot& plot, const std::filesystem::path& path);

}  // namespace pliant::raster
