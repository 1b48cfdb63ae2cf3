// Colour maps, round numbers and display units (see colormap.hpp).
#include "pliant/raster/colormap.hpp"

#include <algorithm>
#include <cmath>
#include <fmt/format.h>

namespace pliant::raster {

Rgba viridis(double t) {
  // Viridis (van der Walt & Smith, matplotlib; CC0) sampled at t = 0, 0.1, ..., 1.
  static constexpr double kTable[11][3] = {
      {0.267004, 0.004874, 0.329415}, {0.282623, 0.140926, 0.457517}, {0.253935, 0.265254, 0.529983},
      {0.206756, 0.371758, 0.553117}, {0.163625, 0.471133, 0.558148}, {0.127568, 0.566949, 0.550556},
      {0.134692, 0.658636, 0.517649}, {0.266941, 0.748751, 0.440573}, {0.477504, 0.821444, 0.318195},
      {0.741388, 0.873449, 0.149561}, {0.993248, 0.906157, 0.143936}};
  if (!std::isfinite(t)) t = 0;
  const double s = std::clamp(t, 0.0, 1.0) * 10.0;
  const int i = std::min(int(s), 9);
  const double f = s - i;
  // Catmull-Rom through the samples: smooth like the full 256-entry table.
  auto at = [&](int k, int c) { return kTable[std::clamp(k, 0, 10)][c]; };
  double out[3];
  for (int c = 0; c < 3; ++c) {
    const double p0 = at(i - 1, c), p1 = at(i, c), p2 = at(i + 1, c), p3 = at(i + 2, c);
    out[c] = 0.5 * (2 * p1 + (-p0 + p2) * f + (2 * p0 - 5 * p1 + 4 * p2 - p3) * f * f +
                    (-p0 + 3 * p1 - 3 * p2 + p3) * f * f * f);
  }
  return rgb(out[0], out[1], out[2]);
}

Rgba palette(int i) {
  static constexpr Rgba kTableau[10] = {{31, 119, 180, 255}, {255, 127, 14, 255}, {44, 160, 44, 255},
                                        {214, 39, 40, 255},  {148, 103, 189, 255}, {140, 86, 75, 255},
                                        {227, 119, 194, 255}, {127, 127, 127, 255}, {188, 189, 34, 255},
                                        {23, 190, 207, 255}};
  return kTableau[((i % 10) + 10) % 10];
}

double nice_number(double x, bool ceil) {
  if (!(x > 0) || !std::isfinite(x)) return x;
  const double e = std::floor(std::log10(x));
  const double p = std::pow(10.0, e);
  const double f = x / p;  // in [1, 10)
  static constexpr double kSteps[] = {1, 1.2, 1.5, 2, 2.5, 3, 4, 5, 6, 8, 10};
  static constexpr double kRound[] = {1, 2, 2.5, 5, 10};
  if (ceil) {
    for (double s : kSteps)
      if (f <= s * (1 + 1e-9)) return s * p;
    return 10 * p;
  }
  double best = 1;
  for (double s : kRound)
    if (std::abs(f - s) < std::abs(f - best)) best = s;
  return best * p;
}

std::vector<double> nice_ticks(double lo, double hi, int count) {
  std::vector<double> ticks;
  if (!(hi > lo) || !std::isfinite(lo) || !std::isfinite(hi)) {
    if (std::isfinite(lo)) ticks.push_back(lo);
    return ticks;
  }
  const double step = nice_number((hi - lo) / std::max(count - 1, 1), false);
  const double first = std::ceil(lo / step - 1e-9) * step;
  for (double v = first; v <= hi + step * 1e-9; v += step) ticks.push_back(std::abs(v) < step * 1e-9 ? 0.0 : v);
  return ticks;
}

DisplayUnit display_unit(const std::string& base, double max_abs) {
  if (base != "m" && base != "Pa" && base != "s" && base != "N" && base != "J") return {base, 1.0};
  struct Prefix {
    const char* name;
    double scale;
  };
  static constexpr Prefix kPrefixes[] = {{"G", 1e9}, {"M", 1e6}, {"k", 1e3}, {"", 1}, {"m", 1e-3}, {"\u00B5", 1e-6}, {"n", 1e-9}};
  const bool big_ok = base == "Pa" || base == "N" || base == "J";  // no km, no Ms
  if (!(max_abs > 0) || !std::isfinite(max_abs)) return {base, 1.0};
  for (const Prefix& p : kPrefixes) {
    if (p.scale > 1 && !big_ok) continue;
    if (max_abs >= p.scale * 0.999) return {std::string(p.name) + base, 1.0 / p.scale};
  }
  return {"n" + base, 1e9};
}

std::string format_number(double v, int digits) {
  if (v == 0 || !std::isfinite(v)) return v == 0 ? "0" : fmt::format("{}", v);
  const double a = std::abs(v);
  if (a >= 1e5 || a < 1e-3) return fmt::format("{:.{}g}", v, digits);
  std::string s = fmt::format("{:.{}g}", v, digits);
  if (s.find('e') != std::string::npos) {  // %g chose an exponent for e.g. 1.2e+03 with 2 digits
    s = fmt::format("{:.{}f}", v, 0);
  }
  return s;
}

}  // namespace pliant::raster
