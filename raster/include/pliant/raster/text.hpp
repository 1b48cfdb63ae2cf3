// Text in pictures without a font library: an embedded 5x7 bitmap font (ASCII 32..126, plus
// µ ² ³ ° · × ≈ and the en dash from UTF-8), drawn at an integer scale. A glyph cell is 6 x 10
// units (5 columns + 1 gap; 7 rows above the baseline, 2 for descenders, 1 gap).
#pragma once
#include <string_view>

#include "pliant/raster/image.hpp"

namespace pliant::raster {

struct TextStyle {
  Rgba colour{20, 20, 24, 255};
  int scale = 1;              // pixels per font unit
  bool halo = false;          // a 1-unit outline in halo_colour (readable over any background)
  Rgba halo_colour{255, 255, 255, 255};
};

int text_width(std::string_view utf8, int scale = 1);   // pixels
int text_height(int scale = 1);                           // pixels, one line (10 units)

// Draws one line with its top-left corner at (x, y). '\n' starts a new line.
void draw_text(Image& image, int x, int y, std::string_view utf8, const TextStyle& style = {});
// Rotated 90 degrees counter-clockwise (reads bottom to top); (x, y) is the top-left corner of
// the rotated box, which is text_height wide and text_width tall.
void draw_text_vertical(Image& image, int x, int y, std::string_view utf8, const TextStyle& style = {});

}  // namespace pliant::raster
