// Private to pliant_raster: what is drawn on the CPU over a rendered picture (time, title,
// colour bar, probe markers with names, legend).
#pragma once
#include <array>

#include "pliant/raster/image.hpp"
#include "pliant/raster/render.hpp"
#include "view_math.hpp"

namespace pliant::raster::detail {

void draw_overlays(Image& image, const Frame& frame, const RenderOptions& options, const Layout& layout,
                   const Camera& camera, const std::array<double, 2>& range);

// The legend of the marks present: fixed nodes, prescribed-motion nodes, probes; one line at
// (x, y) in text scale s.
void draw_legend(Image& image, int x, int y, int s, bool fixed, bool driven, bool probes);

// "t = 0.400 s" with as many decimals as `step` (the spacing of the times shown) needs.
std::string time_label(double t, double step = 0);

}  // namespace pliant::raster::detail
