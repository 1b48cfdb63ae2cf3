// Private to pliant_raster: what is drawn on the CPU over a rendered picture (time, title,
// colour bar, probe markers with names, legend).
#pragma once
#include <algorithm>
#include <array>
#include <string>

#include "pliant/raster/image.hpp"
#include "pliant/raster/render.hpp"
#include "view_math.hpp"

namespace pliant::raster::detail {

// Colours of the node marks, shared by the GL pass (renderer.cpp) and the legend: bright, off
// the viridis map (which runs from dark purple through teal and green to yellow), each over a
// dark outline.
inline constexpr Rgba kFixedColour{255, 40, 200, 255};   // magenta
inline constexpr Rgba kDrivenColour{255, 128, 0, 255};   // orange
inline constexpr Rgba kMarkOutline{20, 20, 26, 255};
// Pixels: the bright dot's diameter and the width of the outline around it, in text scale s.
inline double mark_diameter(int s) { return std::max(4.0, 3.5 * s); }
inline double mark_outline(int s) { return std::max(1.5, 1.0 * s); }

void draw_overlays(Image& image, const Frame& frame, const RenderOptions& options, const Layout& layout,
                   const Camera& camera, const std::array<double, 2>& range);

// The legend of the marks present: fixed nodes, prescribed-motion nodes, probes; one line at
// (x, y) in text scale s.
void draw_legend(Image& image, int x, int y, int s, bool fixed, bool driven, bool probes);

// The world axes as the camera sees them, bottom left (RenderOptions::axes), and a scale bar of a
// round length, true at the depth of the view's target, bottom right (RenderOptions::scale_bar).
void draw_axes(Image& image, const Layout& layout, const Camera& camera);
void draw_scale_bar(Image& image, const Layout& layout, const Camera& camera);
std::string length_label(double metres);  // "10 cm", "2 m", "5 mm", "500 µm"

// "t = 0.400 s" with as many decimals as `step` (the spacing of the times shown) needs.
std::string time_label(double t, double step = 0);

}  // namespace pliant::raster::detail
