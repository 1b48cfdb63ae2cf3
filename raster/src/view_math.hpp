// Private to pliant_raster: the geometry of a picture shared by the GL pass (renderer.cpp) and
// the CPU overlays: where the 3D view goes in the image (the space left by the colour bar, the
// time line and the legend), the camera matrices, the projection of points to pixels, and the
// ground grid.
#pragma once
#include <array>
#include <cmath>
#include <vector>

#include "pliant/raster/render.hpp"

namespace pliant::raster::detail {

struct V3 {
  double x = 0, y = 0, z = 0;
  V3() = default;
  V3(double a, double b, double c) : x(a), y(b), z(c) {}
  explicit V3(const Vec3d& v) : x(v[0]), y(v[1]), z(v[2]) {}
  Vec3d arr() const { return {x, y, z}; }
  V3 operator+(const V3& o) const { return {x + o.x, y + o.y, z + o.z}; }
  V3 operator-(const V3& o) const { return {x - o.x, y - o.y, z - o.z}; }
  V3 operator*(double s) const { return {x * s, y * s, z * s}; }
  V3 operator-() const { return {-x, -y, -z}; }
};
inline double dot(const V3& a, const V3& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
inline V3 cross(const V3& a, const V3& b) { return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x}; }
inline double norm(const V3& a) { return std::sqrt(dot(a, a)); }
inline V3 normalized(const V3& a) {
  const double n = norm(a);
  return n > 0 ? a * (1.0 / n) : V3{0, 0, 1};
}

// Pixel layout of a picture (top-left origin). The 3D view fits the bodies into `usable`.
struct Layout {
  int width = 0, height = 0;
  int text_scale = 1;
  bool colour_bar = false, top_line = false, legend = false;
  int usable_x0 = 0, usable_y0 = 0, usable_x1 = 0, usable_y1 = 0;  // [x0, x1) x [y0, y1)
  int bar_x = 0, bar_y = 0, bar_w = 0, bar_h = 0;                  // colour bar box (incl. labels)
};
Layout make_layout(const RenderOptions& options, Field field);

// A grid of lines on the ground plane (perpendicular to up, under the lowest point).
struct Grid {
  V3 origin;          // point of the plane at (a, b) = (0, 0)
  V3 e1, e2;          // in-plane unit axes
  double spacing = 1;
  double a0 = 0, a1 = 0, b0 = 0, b1 = 0;  // extent along e1, e2 (multiples of spacing)
  V3 at(double a, double b) const { return origin + e1 * a + e2 * b; }
};
Grid make_grid(const Bounds& bounds, const Vec3d& up);
// The same on a given plane (an obstacle): the bounds projected onto it, padded like the ground grid.
Grid make_plane_grid(const Bounds& bounds, const Vec3d& point, const Vec3d& normal);

// Camera matrices (column-major, as OpenGL loads them) for the whole image.
struct Camera {
  View view;
  std::array<double, 16> projection{}, modelview{};
  double near_plane = 0.01, far_plane = 100;
  int width = 0, height = 0;
  // Pixel coordinates (top-left origin, pixel centres at +0.5) of a world point; false if it
  // is behind the eye.
  bool project(const V3& p, double& px, double& py) const;
};
// The auto camera fits `fit` (points; the bounds' corners when empty).
Camera make_camera(const RenderOptions& options, const Bounds& bounds, const Layout& layout,
                   const std::vector<Grid>& grids, const std::vector<Vec3d>& fit = {});

// Everything geometric about one picture of one frame: layout, grid, camera.
struct Setup {
  Layout layout;
  Bounds framing;
  std::vector<Grid> grids;  // what options.grid draws: the ground grid, or one per obstacle
  bool obstacles = false;   // the grids are obstacles (drawn as solid patches)
  Camera camera;
};
Setup make_setup(const Frame& frame, const RenderOptions& options);

// The in-plane axes used for up (e1 along the world axis least aligned with up: x for z-up).
void plane_axes(const V3& up, V3& e1, V3& e2);

}  // namespace pliant::raster::detail
