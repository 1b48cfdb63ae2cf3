// The CPU side of raster/: PNG round trips, the bitmap font, round numbers and display units,
// the colour map, and plots (non-blank, labelled, errors on bad series).
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <filesystem>

#include "pliant/error.hpp"
#include "pliant/raster/colormap.hpp"
#include "pliant/raster/image.hpp"
#include "pliant/raster/plot.hpp"
#include "pliant/raster/text.hpp"

namespace {
// Removes this process's scratch folder when the tests end.
struct ScratchCleanup : ::testing::Environment {
  void TearDown() override {
    std::error_code ec;
    std::filesystem::remove_all(std::filesystem::temp_directory_path() / ("pliant_test_image_" + std::to_string(::getpid())), ec);
  }
};
const auto* const kCleanup = ::testing::AddGlobalTestEnvironment(new ScratchCleanup);

using namespace pliant;
using namespace pliant::raster;
namespace fs = std::filesystem;

fs::path scratch() {
  const fs::path p = fs::temp_directory_path() / ("pliant_test_image_" + std::to_string(::getpid()));
  fs::create_directories(p);
  return p;
}

std::size_t ink(const Image& img, int x0, int y0, int x1, int y1, Rgba background) {
  std::size_t n = 0;
  for (int y = std::max(y0, 0); y < std::min(y1, img.height()); ++y)
    for (int x = std::max(x0, 0); x < std::min(x1, img.width()); ++x) n += !(img.get(x, y) == background);
  return n;
}

TEST(Png, RoundTripOpaqueAndTranslucent) {
  Image a(37, 21, {10, 20, 30, 255});
  a.set(3, 4, {200, 100, 50, 255});
  write_png(a, scratch() / "a.png");
  EXPECT_EQ(read_png(scratch() / "a.png").bytes(), a.bytes());
  Image b(5, 7, {1, 2, 3, 128});
  write_png(b, scratch() / "b.png");
  EXPECT_EQ(read_png(scratch() / "b.png").bytes(), b.bytes());
  EXPECT_THROW(write_png(a, scratch() / "no" / "such" / "dir.png"), InputError);
  EXPECT_THROW(read_png(scratch() / "absent.png"), InputError);
}

TEST(Text, DrawsWhereMeasured) {
  Image img(200, 40);
  const std::string s = "t = 0.25 s [kPa] \u00B5m\u00B2";
  const int w = text_width(s, 2), h = text_height(2);
  EXPECT_EQ(w, (int(std::string("t = 0.25 s [kPa] xxx").size()) * 6 - 1) * 2);
  EXPECT_EQ(h, 20);
  draw_text(img, 5, 5, s, {{0, 0, 0, 255}, 2, false});
  const Rgba white{255, 255, 255, 255};
  EXPECT_GT(ink(img, 5, 5, 5 + w, 5 + h, white), 100u);
  EXPECT_EQ(ink(img, 5 + w, 0, 200, 40, white), 0u);
  EXPECT_EQ(ink(img, 0, 5 + h, 200, 40, white), 0u);
  Image v(40, 200);
  draw_text_vertical(v, 5, 5, "abc", {{0, 0, 0, 255}, 2, false});
  EXPECT_GT(ink(v, 5, 5, 5 + text_height(2), 5 + text_width("abc", 2), white), 20u);
  EXPECT_EQ(ink(v, 5 + text_height(2), 0, 40, 200, white), 0u);
}

TEST(Numbers, NiceTicksAndUnits) {
  EXPECT_DOUBLE_EQ(nice_number(0.0137, true), 0.015);
  EXPECT_DOUBLE_EQ(nice_number(7.2, true), 8);
  EXPECT_DOUBLE_EQ(nice_number(7.2, false), 5);
  EXPECT_THAT(nice_ticks(0, 1, 6), ::testing::ElementsAre(0, 0.2, 0.4, 0.6000000000000001, 0.8, 1));
  EXPECT_EQ(display_unit("m", 0.015).name, "mm");
  EXPECT_DOUBLE_EQ(display_unit("m", 0.015).factor, 1000);
  EXPECT_EQ(display_unit("m", 2e-6).name, "\u00B5m");
  EXPECT_EQ(display_unit("m", 3.0).name, "m");
  EXPECT_EQ(display_unit("m", 3000.0).name, "m");  // no km
  EXPECT_EQ(display_unit("Pa", 2.5e4).name, "kPa");
  EXPECT_EQ(display_unit("Pa", 2.5e7).name, "MPa");
  EXPECT_EQ(format_number(0.25), "0.25");
  EXPECT_EQ(format_number(1200), "1200");
  EXPECT_EQ(format_number(0), "0");
}

TEST(Colormap, ViridisEndsAndMonotoneLightness) {
  EXPECT_EQ(viridis(0), (Rgba{68, 1, 84, 255}));
  EXPECT_EQ(viridis(1), (Rgba{253, 231, 37, 255}));
  double last = -1;
  for (int i = 0; i <= 20; ++i) {
    const Rgba c = viridis(i / 20.0);
    const double y = 0.2126 * c.r + 0.7152 * c.g + 0.0722 * c.b;
    EXPECT_GT(y, last);
    last = y;
  }
}

TEST(Plot, RendersSeriesAxesAndLegend) {
  Plot p;
  p.title = "Convergence";
  p.x = {"cell size", "m", true};
  p.y = {"tip error", "m", true};
  PlotSeries a{"corotational", {0.1, 0.05, 0.025, 0.0125}, {1e-2, 2.6e-3, 6.4e-4, 1.6e-4}, SeriesStyle::line_and_markers};
  PlotSeries b{"linear", {0.1, 0.05, 0.025, 0.0125}, {3e-2, 2e-2, 1.7e-2, 1.6e-2}, SeriesStyle::scatter};
  PlotSeries c{"", {0.1, 0.0}, {1e-3, -1}, SeriesStyle::line};  // non-positive values are left out on log axes
  p.series = {a, b, c};
  const Image img = render_plot(p);
  EXPECT_EQ(img.width(), 800);
  EXPECT_EQ(img.height(), 600);
  const Rgba white{255, 255, 255, 255};
  EXPECT_GT(ink(img, 0, 0, 800, 600, white), 5000u);
  // The series colours are present.
  auto has = [&](Rgba want) {
    for (int y = 0; y < img.height(); ++y)
      for (int x = 0; x < img.width(); ++x)
        if (img.get(x, y) == want) return true;
    return false;
  };
  EXPECT_TRUE(has(palette(0)));
  EXPECT_TRUE(has(palette(1)));
  // The x label sits at the bottom, the y label at the left.
  EXPECT_GT(ink(img, 200, 560, 600, 600, white), 100u);
  EXPECT_GT(ink(img, 0, 150, 30, 450, white), 100u);
  write_plot_png(p, scratch() / "plot.png");
  EXPECT_EQ(read_png(scratch() / "plot.png").width(), 800);

  Plot linear;
  linear.x = {"time", "s"};
  linear.y = {"energy", "J"};
  linear.series.push_back({"kinetic", {0, 1, 2, 3}, {0, 1, 4, 9}});
  linear.width = 400;
  linear.height = 300;
  EXPECT_EQ(render_plot(linear).width(), 400);
  Plot empty;
  EXPECT_EQ(render_plot(empty).height(), 600);
}

TEST(Plot, LegendAvoidsTheData) {
  Plot p;
  p.x = {"x", "m"};
  p.y = {"y", "m"};
  p.x.min = p.y.min = 0;
  p.x.max = p.y.max = 20;
  std::vector<double> xs, ys;
  for (int i = 0; i <= 20; ++i) xs.push_back(i), ys.push_back(i);  // corner to corner: the top right is taken
  p.series.push_back({"rising", xs, ys, SeriesStyle::line_and_markers});
  p.series.back().point_labels = {"first"};
  const Image img = render_plot(p);
  const Rgba frame{180, 182, 190, 255};  // the legend box's outline
  auto count = [&](int x0, int y0, int x1, int y1) {
    std::size_t n = 0;
    for (int y = y0; y < y1; ++y)
      for (int x = x0; x < x1; ++x) n += img.get(x, y) == frame;
    return n;
  };
  EXPECT_GT(count(0, 0, 400, 300), 100u);  // top left
  EXPECT_EQ(count(400, 0, 800, 600) + count(0, 300, 400, 600), 0u);
  // The point label is drawn beside the first point (bottom left), in the series colour.
  const Rgba c = palette(0);
  std::size_t labelled = 0;
  for (int y = 400; y < 600; ++y)
    for (int x = 0; x < 400; ++x) labelled += img.get(x, y) == c;
  EXPECT_GT(labelled, 20u);
}

TEST(Plot, LegendBelowTheAxisTitle) {
  Plot p;
  p.x = {"x", "m"};
  p.y = {"y", "m"};
  p.legend_place = LegendPlace::below;
  for (int i = 0; i < 6; ++i) p.series.push_back({"series " + std::to_string(i), {0, 1}, {double(i), double(i + 1)}});
  const Image img = render_plot(p);
  EXPECT_EQ(img.height(), 600);
  // The legend's frame: only in the band under the x axis title, whose ink sits above it.
  const Rgba frame{180, 182, 190, 255};
  int top = 600;
  for (int y = 0; y < 600; ++y)
    for (int x = 0; x < 800; ++x)
      if (img.get(x, y) == frame) top = std::min(top, y);
  EXPECT_GT(top, 400);
  EXPECT_LT(top, 560);
  EXPECT_GT(ink(img, 0, top, 800, 600, Rgba{255, 255, 255, 255}), 500u);  // entries
  // A title too long for the width is drawn smaller, inside the picture.
  p.title = std::string(100, 'x');
  const Image t = render_plot(p);
  EXPECT_GT(ink(t, 0, 0, 800, 38, Rgba{255, 255, 255, 255}), 300u);  // above the plot area (y = 40)
  EXPECT_EQ(ink(t, 0, 0, 2, 38, Rgba{255, 255, 255, 255}) + ink(t, 798, 0, 800, 38, Rgba{255, 255, 255, 255}), 0u);
}

// No data point (its marker included) under the legend box, and no legend ink over a point.
void expect_legend_clear_of_points(const Plot& p, const std::string& what) {
  PlotLayout layout;
  const Image img = render_plot(p, &layout);
  EXPECT_EQ(img.width(), p.width) << what;
  EXPECT_EQ(img.height(), p.height) << what;
  ASSERT_TRUE(layout.legend.has_value()) << what;
  ASSERT_FALSE(layout.points.empty()) << what;
  const auto [lx, ly, lw, lh] = *layout.legend;
  for (const auto& pt : layout.points) {
    const bool apart = pt.x + pt.radius < lx || pt.x - pt.radius > lx + lw || pt.y + pt.radius < ly || pt.y - pt.radius > ly + lh;
    EXPECT_TRUE(apart) << what << ": point (" << pt.x << ", " << pt.y << ") of series " << pt.series << " under the legend at ("
                       << lx << ", " << ly << ", " << lw << "x" << lh << ")";
  }
  // The pixels agree: when the legend went below the plot, its outline colour appears nowhere
  // in the plot area.
  const Rgba frame{180, 182, 190, 255};
  if (layout.legend_below) {
    const auto [x0, y0, x1, y1] = layout.area;
    EXPECT_LE(y1, ly) << what;
    std::size_t n = 0;
    for (int y = y0; y <= y1; ++y)
      for (int x = x0; x <= x1; ++x) n += img.get(x, y) == frame;
    EXPECT_EQ(n, 0u) << what;
  }
}

TEST(Plot, LegendGoesBelowWhenEveryCornerHasData) {
  // The data of docs/images/accuracy/volume_mesh-convergence.png, where the legend in the top
  // right corner hid the springs points: every corner of this plot has points.
  Plot p;
  p.title = "compression_volume: convergence of volume_change (vs analytic)";
  p.x = {"mesh: number of tets", "", true};
  p.y = {"|relative error| of volume_change", "%", true};
  const std::vector<double> tets = {160, 1280, 10240, 81920};
  p.series.push_back({"model=linear, poisson=0.49", tets, {0.6, 0.26, 0.24, 0.23}, SeriesStyle::line_and_markers});
  p.series.push_back({"model=corotational, poisson=0.49", tets, {2.2, 1.2, 0.54, 0.3}, SeriesStyle::line_and_markers});
  p.series.push_back({"model=stvk, poisson=0.49", tets, {34, 32, 30, 29}, SeriesStyle::line_and_markers});
  p.series.push_back({"model=springs, poisson=0.49", tets, {3300, 3250, 3200, 3180}, SeriesStyle::line_and_markers});
  PlotLayout layout;
  render_plot(p, &layout);
  EXPECT_TRUE(layout.legend_below);
  EXPECT_EQ(layout.points.size(), 16u);
  expect_legend_clear_of_points(p, "volume_mesh");
  write_plot_png(p, scratch() / "legend_below.png");
  if (const char* keep = std::getenv("PLIANT_KEEP_PLOTS")) write_plot_png(p, fs::path(keep) / "legend_below.png");

  // Points in all four corners on linear axes, with every marker shape.
  Plot q;
  q.x = {"x", "m"};
  q.y = {"y", "m"};
  for (int i = 0; i < 4; ++i) {
    std::vector<double> xs, ys;
    for (int j = 0; j <= 10; ++j) xs.push_back(j), ys.push_back(i % 2 ? 10 - j : j + 0.3 * i);
    q.series.push_back({"series " + std::to_string(i), xs, ys, SeriesStyle::line_and_markers});
  }
  expect_legend_clear_of_points(q, "corners");
  // A corner that is free keeps the legend inside.
  Plot r;
  r.x = {"x", "m"};
  r.y = {"y", "m"};
  r.series.push_back({"low", {0, 1, 2, 3, 4}, {0, 0.1, 0.2, 0.3, 0.4}, SeriesStyle::scatter});
  r.y.max = 4;
  PlotLayout inside;
  render_plot(r, &inside);
  EXPECT_FALSE(inside.legend_below);
  expect_legend_clear_of_points(r, "free corner");
}

TEST(Plot, LegendNeverHidesAPointOfRandomData) {
  std::uint32_t seed = 12345;
  auto next = [&] {  // a small LCG: the same data on every machine
    seed = seed * 1664525u + 1013904223u;
    return (seed >> 8) / double(1u << 24);
  };
  for (int trial = 0; trial < 40; ++trial) {
    Plot p;
    p.x = {"x", "m", trial % 3 == 0};
    p.y = {"y", "Pa", trial % 2 == 0};
    p.width = trial % 4 == 0 ? 400 : 800;
    p.height = trial % 4 == 0 ? 300 : 600;
    const int n_series = 1 + trial % 4, n_points = 2 + int(next() * 12);
    for (int k = 0; k < n_series; ++k) {
      std::vector<double> xs, ys;
      for (int j = 0; j < n_points; ++j) {
        xs.push_back(p.x.log ? std::pow(10.0, 4 * next()) : 10 * next());
        ys.push_back(p.y.log ? std::pow(10.0, 3 * next()) : 10 * next());
      }
      p.series.push_back({"series number " + std::to_string(k), xs, ys,
                          k % 2 ? SeriesStyle::scatter : SeriesStyle::line_and_markers});
    }
    expect_legend_clear_of_points(p, "trial " + std::to_string(trial));
  }
}

TEST(Plot, CoincidentSeriesShareOneLegendEntry) {
  Plot p;
  p.x = {"cells", "", true};
  p.y = {"error", "%", true};
  const std::vector<double> x = {10, 20, 40}, same = {5, 2.5, 1.2};
  p.series.push_back({"linear", x, same, SeriesStyle::line_and_markers});
  p.series.push_back({"corotational", x, same, SeriesStyle::line_and_markers});
  p.series.push_back({"springs", x, {50, 40, 30}, SeriesStyle::line_and_markers});
  p.series.push_back({"stvk", x, same, SeriesStyle::line_and_markers});
  p.series.push_back({"linear", x, {7, 6, 5}, SeriesStyle::scatter});  // same points as none
  PlotLayout layout;
  const Image img = render_plot(p, &layout);
  EXPECT_THAT(layout.legend_labels, ::testing::ElementsAre("linear = corotational = stvk", "springs", "linear"));
  // Drawn once, in the first one's colour: the colours of the hidden ones are nowhere.
  auto has = [&](Rgba want) {
    for (int y = 0; y < img.height(); ++y)
      for (int x = 0; x < img.width(); ++x)
        if (img.get(x, y) == want) return true;
    return false;
  };
  EXPECT_TRUE(has(palette(0)));
  EXPECT_FALSE(has(palette(1)));
  EXPECT_TRUE(has(palette(2)));
  EXPECT_FALSE(has(palette(3)));
  EXPECT_TRUE(has(palette(4)));
  // Not coincident: another style, or one point different.
  p.series[1].style = SeriesStyle::scatter;
  p.series[3].y[2] = 1.3;
  render_plot(p, &layout);
  EXPECT_EQ(layout.legend_labels.size(), 5u);
  if (const char* keep = std::getenv("PLIANT_KEEP_PLOTS")) {
    p.series[1].style = SeriesStyle::line_and_markers;
    p.series[3].y[2] = 1.2;
    write_plot_png(p, fs::path(keep) / "coincident.png");
  }
  // Close enough to be one line at this size (the slender bar study: linear and corotational
  // differ in the 5th digit): drawn once, named "model=linear≈corotational" (key=value labels merge
  // field by field); the same data on a taller axis range
  // where they part by more than half a pixel stay apart.
  Plot near;
  near.x = {"mesh: number of tets", ""};
  near.y = {"|relative error|", "%"};
  near.series.push_back({"model=linear", {60, 120}, {0.859656189, 0.458648368}, SeriesStyle::line_and_markers});
  near.series.push_back({"model=corotational", {60, 120}, {0.859670445, 0.458495598}, SeriesStyle::line_and_markers});
  const Image ni = render_plot(near, &layout);
  EXPECT_THAT(layout.legend_labels, ::testing::ElementsAre("model=linear\u2248corotational"));
  auto present = [](const Image& img, Rgba want) {
    for (int y = 0; y < img.height(); ++y)
      for (int x = 0; x < img.width(); ++x)
        if (img.get(x, y) == want) return true;
    return false;
  };
  EXPECT_FALSE(present(ni, palette(1)));
  near.y.min = 0.4586;
  near.y.max = 0.4587;
  near.series[0].y = {0.45864, 0.45865};
  near.series[1].y = {0.45863, 0.45865};
  render_plot(near, &layout);
  EXPECT_EQ(layout.legend_labels.size(), 2u);
  if (const char* keep = std::getenv("PLIANT_KEEP_PLOTS")) {
    near.y.min.reset();
    near.y.max.reset();
    near.series[0].y = {0.859656189, 0.458648368};
    near.series[1].y = {0.859670445, 0.458495598};
    write_plot_png(near, fs::path(keep) / "near.png");
  }
}

TEST(Plot, BadSeriesAreErrors) {
  Plot p;
  p.title = "t";
  p.series.push_back({"s", {1, 2, 3}, {1, 2}});
  EXPECT_THROW(render_plot(p), InputError);
  Plot q;
  q.width = 10;
  EXPECT_THROW(render_plot(q), InputError);
}

TEST(Plot, CoincidentStudyLabelsMergeFieldByField) {
  // The runs of a study are named "key=value, key=value": coincident ones merge per field, so the
  // legend stays as short as one run's name (the cantilever_trade study had four labels of 50
  // characters joined end to end, cut off at the picture's edge).
  Plot p;
  p.x = {"mesh: number of tets", ""};
  p.y = {"|relative error|", "%"};
  p.series.push_back({"tets=5, precision=float, courant=0.3", {1, 2}, {10, 5}, SeriesStyle::line_and_markers});
  p.series.push_back({"tets=5, precision=double, courant=0.3", {1, 2}, {10, 5}, SeriesStyle::line_and_markers});
  p.series.push_back({"tets=5, precision=float, courant=0.9", {1, 2}, {10, 5}, SeriesStyle::line_and_markers});
  p.series.push_back({"tets=6, precision=float, courant=0.3", {1, 2}, {20, 9}, SeriesStyle::line_and_markers});
  p.series.push_back({"linear", {1, 2}, {30, 15}, SeriesStyle::line_and_markers});
  p.series.push_back({"model=x", {1, 2}, {30, 15}, SeriesStyle::line_and_markers});  // fields differ: joined
  PlotLayout layout;
  render_plot(p, &layout);
  EXPECT_THAT(layout.legend_labels, ::testing::ElementsAre("tets=5, precision=float|double, courant=0.3|0.9",
                                                           "tets=6, precision=float, courant=0.3", "linear = model=x"));
}

}  // namespace
