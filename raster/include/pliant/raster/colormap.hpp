// Colour maps and value formatting shared by pictures and plots: a perceptual, colour-blind
// safe map (viridis, tabulated) for fields, a qualitative palette for plot series, and "nice"
// numbers and SI-prefixed units for colour bars and axes.
#pragma once
#include <string>
#include <vector>

#include "pliant/raster/image.hpp"

namespace pliant::raster {

// Viridis at t in [0, 1] (clamped): dark purple -> blue -> green -> yellow.
Rgba viridis(double t);

// The i-th colour of a 10-colour qualitative palette (Tableau 10), cycling.
Rgba palette(int i);

// A round number near x: 1, 2, 2.5, 5 or 10 times a power of ten; `ceil` rounds up, else to
// the nearest.
double nice_number(double x, bool ceil);

// Ticks at round steps covering [lo, hi] (about `count` of them), all inside [lo, hi].
std::vector<double> nice_ticks(double lo, double hi, int count = 5);

// A display unit for values up to `max_abs` of a quantity in `base_unit` ("m", "Pa", "s", "N",
// "J"): picks the SI prefix so that numbers read between 0.1 and 1000, e.g. 0.012 m -> "mm"
// with factor 1000. Other units are returned unchanged with factor 1.
struct DisplayUnit {
  std::string name;   // "mm", "kPa", ...
  double factor = 1;  // value in base unit * factor = value in this unit
};
DisplayUnit display_unit(const std::string& base_unit, double max_abs);

// Short label of a number: up to `digits` significant digits, no trailing zeros, exponent form
// for very large or small magnitudes ("0.25", "120", "1.5e-06").
std::string format_number(double v, int digits = 3);

}  // namespace pliant::raster
