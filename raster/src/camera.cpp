// Where things go in a picture: the layout of the image, the automatic camera (fits the bounds
// into the free part of the image from a 3/4 view above, or front/side/top), the scene's own
// camera, the projection matrices, and the ground grid.
#include <algorithm>
#include <cmath>

#include "pliant/raster/colormap.hpp"
#include "view_math.hpp"

namespace pliant::raster {
namespace detail {

Layout make_layout(const RenderOptions& o, Field field) {
  Layout L;
  L.width = o.width;
  L.height = o.height;
  L.text_scale = o.text_scale > 0 ? o.text_scale : std::max(1, int(std::lround(o.height / 360.0)));
  const int s = L.text_scale;
  L.colour_bar = o.colour_bar && field != Field::none;
  L.top_line = o.time_label || !o.title.empty() || L.colour_bar;
  L.legend = o.legend && o.marks;
  L.usable_x0 = 0;
  L.usable_y0 = std::max(L.top_line ? 16 * s : 0, std::min(o.caption_height, o.height / 3));
  L.usable_x1 = o.width;
  L.usable_y1 = o.height - (L.legend ? 14 * s : 0);
  if (L.colour_bar) {
    L.bar_w = 56 * s;
    L.bar_x = o.width - L.bar_w - 4 * s;
    L.bar_y = 3 * s;
    L.bar_h = std::min(int(o.height * 0.7), o.height - L.bar_y - 10 * s - (L.legend ? 14 * s : 0));
    L.bar_h = std::max(L.bar_h, 40 * s);
    L.usable_x1 = L.bar_x - 2 * s;
  }
  if (L.usable_x1 - L.usable_x0 < o.width / 3) L.usable_x1 = o.width;  // tiny pictures: overlap
  if (L.usable_y1 - L.usable_y0 < o.height / 3) {
    L.usable_y0 = 0;
    L.usable_y1 = o.height;
  }
  return L;
}

void plane_axes(const V3& up, V3& e1, V3& e2) {
  const double a[3] = {std::abs(up.x), std::abs(up.y), std::abs(up.z)};
  V3 helper = a[0] <= a[1] && a[0] <= a[2] ? V3{1, 0, 0} : a[1] <= a[2] ? V3{0, 1, 0} : V3{0, 0, 1};
  e1 = normalized(helper - up * dot(helper, up));
  e2 = cross(up, e1);
}

static void corners(const Bounds& b, V3 out[8]) {
  for (int i = 0; i < 8; ++i)
    out[i] = {(i & 1) ? b.max[0] : b.min[0], (i & 2) ? b.max[1] : b.min[1], (i & 4) ? b.max[2] : b.min[2]};
}

static Bounds usable_bounds(const Bounds& in) {
  Bounds b = in;
  if (b.empty()) {
    b.min = {-0.5, -0.5, -0.5};
    b.max = {0.5, 0.5, 0.5};
  }
  double ext = 0;
  for (int k = 0; k < 3; ++k) ext = std::max(ext, b.max[k] - b.min[k]);
  if (!(ext > 0)) ext = 1e-3;
  for (int k = 0; k < 3; ++k)  // flat bounds: give them a little thickness
    if (b.max[k] - b.min[k] < 1e-6 * ext) {
      b.min[k] -= 1e-6 * ext;
      b.max[k] += 1e-6 * ext;
    }
  return b;
}

Grid make_grid(const Bounds& in, const Vec3d& up_in) {
  const Bounds b = usable_bounds(in);
  const V3 up = normalized(V3(up_in));
  Grid g;
  plane_axes(up, g.e1, g.e2);
  V3 c[8];
  corners(b, c);
  double lo_h = 1e300, hi_h = -1e300, a0 = 1e300, a1 = -1e300, b0 = 1e300, b1 = -1e300;
  for (const V3& p : c) {
    lo_h = std::min(lo_h, dot(p, up));
    hi_h = std::max(hi_h, dot(p, up));
    a0 = std::min(a0, dot(p, g.e1));
    a1 = std::max(a1, dot(p, g.e1));
    b0 = std::min(b0, dot(p, g.e2));
    b1 = std::max(b1, dot(p, g.e2));
  }
  const double extent = std::max({a1 - a0, b1 - b0, hi_h - lo_h});
  g.spacing = nice_number(extent / 8, false);
  const double pad = std::max(0.35 * extent, 2 * g.spacing);
  g.a0 = std::floor((a0 - pad) / g.spacing) * g.spacing;
  g.a1 = std::ceil((a1 + pad) / g.spacing) * g.spacing;
  g.b0 = std::floor((b0 - pad) / g.spacing) * g.spacing;
  g.b1 = std::ceil((b1 + pad) / g.spacing) * g.spacing;
  g.origin = up * (lo_h - 0.01 * extent);
  return g;
}

Grid make_plane_grid(const Bounds& in, const Vec3d& point, const Vec3d& normal) {
  const Bounds b = usable_bounds(in);
  const V3 n = normalized(V3(normal)), p0(point);
  Grid g;
  plane_axes(n, g.e1, g.e2);
  V3 c[8];
  corners(b, c);
  double a0 = 1e300, a1 = -1e300, b0 = 1e300, b1 = -1e300, ext = 0;
  for (const V3& p : c) {
    a0 = std::min(a0, dot(p - p0, g.e1));
    a1 = std::max(a1, dot(p - p0, g.e1));
    b0 = std::min(b0, dot(p - p0, g.e2));
    b1 = std::max(b1, dot(p - p0, g.e2));
  }
  for (int k = 0; k < 3; ++k) ext = std::max(ext, b.max[k] - b.min[k]);
  const double extent = std::max({a1 - a0, b1 - b0, ext});
  g.spacing = nice_number(extent / 8, false);
  const double pad = std::max(0.35 * extent, 2 * g.spacing);
  g.a0 = std::floor((a0 - pad) / g.spacing) * g.spacing;
  g.a1 = std::ceil((a1 + pad) / g.spacing) * g.spacing;
  g.b0 = std::floor((b0 - pad) / g.spacing) * g.spacing;
  g.b1 = std::ceil((b1 + pad) / g.spacing) * g.spacing;
  g.origin = p0;
  return g;
}

namespace {

// Column-major 4x4 helpers.
std::array<double, 16> look_at(const V3& eye, const V3& target, const V3& up_hint) {
  const V3 f = normalized(target - eye);
  const V3 r = normalized(cross(f, up_hint));
  const V3 u = cross(r, f);
  std::array<double, 16> m{};
  m[0] = r.x; m[4] = r.y; m[8] = r.z;   m[12] = -dot(r, eye);
  m[1] = u.x; m[5] = u.y; m[9] = u.z;   m[13] = -dot(u, eye);
  m[2] = -f.x; m[6] = -f.y; m[10] = -f.z; m[14] = dot(f, eye);
  m[15] = 1;
  return m;
}

std::array<double, 16> frustum(double l, double r, double b, double t, double n, double f) {
  std::array<double, 16> m{};
  m[0] = 2 * n / (r - l);
  m[5] = 2 * n / (t - b);
  m[8] = (r + l) / (r - l);
  m[9] = (t + b) / (t - b);
  m[10] = -(f + n) / (f - n);
  m[11] = -1;
  m[14] = -2 * f * n / (f - n);
  return m;
}

// Distance from the target that fits every point into [-tx, tx] x [-ty, ty] (tangent units).
double fit_distance(const std::vector<V3>& c, const V3& center, const V3& r, const V3& u, const V3& f, double tx,
                    double ty) {
  double d = 0;
  for (std::size_t i = 0; i < c.size(); ++i) {
    const V3 q = c[i] - center;
    const double x = dot(q, r), y = dot(q, u), z = dot(q, f);
    d = std::max({d, std::abs(x) / tx - z, std::abs(y) / ty - z, -z + 1e-9});
  }
  return d;
}

View auto_view(const RenderOptions& o, const Bounds& in, const Layout& L, const std::vector<Vec3d>& fit) {
  const Bounds b = usable_bounds(in);
  const V3 up = normalized(V3(o.up));
  V3 e1, e2;
  plane_axes(up, e1, e2);
  const double pi = std::acos(-1.0);
  V3 d;  // from the target towards the eye
  V3 cam_up = up;
  switch (o.preset) {
    case CameraPreset::front: d = -e2; break;
    case CameraPreset::side: d = e1; break;
    case CameraPreset::top:
      d = up;
      cam_up = e2;
      break;
    default: {
      const double az = 30 * pi / 180, el = 25 * pi / 180;
      d = (e1 * std::sin(az) - e2 * std::cos(az)) * std::cos(el) + up * std::sin(el);
    }
  }
  if (o.azimuth_deg || o.elevation_deg) {  // an explicit view direction (RenderOptions)
    const double az = o.azimuth_deg.value_or(30) * pi / 180, el = o.elevation_deg.value_or(25) * pi / 180;
    d = (e1 * std::sin(az) - e2 * std::cos(az)) * std::cos(el) + up * std::sin(el);
    // Looking (nearly) straight down or up, world up is along the view: the picture's up is then
    // the ground direction the camera faces (as for the top preset at azimuth 0).
    cam_up = std::abs(std::cos(el)) < 1e-3 ? e2 * std::cos(az) - e1 * std::sin(az) : up;
  }
  d = normalized(d);
  View v;
  v.fov_deg = 30;
  v.up = cam_up.arr();
  const V3 f = -d;
  const V3 r = normalized(cross(f, cam_up));
  const V3 u = cross(r, f);
  const double uw = std::max(L.usable_x1 - L.usable_x0, 1), uh = std::max(L.usable_y1 - L.usable_y0, 1);
  const double margin = 0.84;  // of the usable area, on each side of the fitted points
  const double ty = std::tan(v.fov_deg * pi / 360) * margin, tx = ty * uw / uh;
  std::vector<V3> c;
  if (fit.empty()) {
    V3 k[8];
    corners(b, k);
    c.assign(k, k + 8);
  } else {
    for (const Vec3d& p : fit) c.emplace_back(p);
  }
  V3 center = (V3(b.min) + V3(b.max)) * 0.5;
  double dist = fit_distance(c, center, r, u, f, tx, ty);
  for (int it = 0; it < 4; ++it) {  // recentre the projected points, then refit
    double x0 = 1e300, x1 = -1e300, y0 = 1e300, y1 = -1e300;
    for (std::size_t i = 0; i < c.size(); ++i) {
      const V3 q = c[i] - center;
      const double z = dist + dot(q, f);
      x0 = std::min(x0, dot(q, r) / z);
      x1 = std::max(x1, dot(q, r) / z);
      y0 = std::min(y0, dot(q, u) / z);
      y1 = std::max(y1, dot(q, u) / z);
    }
    center = center + r * (0.5 * (x0 + x1) * dist) + u * (0.5 * (y0 + y1) * dist);
    dist = fit_distance(c, center, r, u, f, tx, ty);
  }
  v.target = center.arr();
  v.position = (center + d * dist).arr();
  return v;
}

}  // namespace

bool Camera::project(const V3& p, double& px, double& py) const {
  const auto& M = modelview;
  const auto& P = projection;
  const double e[4] = {M[0] * p.x + M[4] * p.y + M[8] * p.z + M[12], M[1] * p.x + M[5] * p.y + M[9] * p.z + M[13],
                       M[2] * p.x + M[6] * p.y + M[10] * p.z + M[14], 1.0};
  double c[4];
  for (int i = 0; i < 4; ++i) c[i] = P[i] * e[0] + P[4 + i] * e[1] + P[8 + i] * e[2] + P[12 + i] * e[3];
  if (!(c[3] > 0)) return false;
  px = (c[0] / c[3] * 0.5 + 0.5) * width;
  py = (1 - (c[1] / c[3] * 0.5 + 0.5)) * height;
  return std::isfinite(px) && std::isfinite(py);
}

Camera make_camera(const RenderOptions& o, const Bounds& bounds, const Layout& L, const std::vector<Grid>& grids,
                   const std::vector<Vec3d>& fit) {
  Camera cam;
  cam.width = L.width;
  cam.height = L.height;
  if (o.preset == CameraPreset::scene && o.camera && !o.azimuth_deg && !o.elevation_deg) {
    cam.view.position = o.camera->position;
    cam.view.target = o.camera->target;
    cam.view.up = o.camera->up;
    cam.view.fov_deg = o.camera->fov_deg;
  } else {
    cam.view = auto_view(o, bounds, L, fit);
  }
  const V3 eye(cam.view.position), target(cam.view.target);
  cam.modelview = look_at(eye, target, V3(cam.view.up));
  // Near and far planes from everything drawn: the bounds and the grid.
  const V3 f = normalized(target - eye);
  double dmin = 1e300, dmax = -1e300;
  auto depth = [&](const V3& p) {
    const double z = dot(p - eye, f);
    dmin = std::min(dmin, z);
    dmax = std::max(dmax, z);
  };
  V3 c[8];
  corners(usable_bounds(bounds), c);
  for (const V3& p : c) depth(p);
  for (const Grid& grid : grids) {
    depth(grid.at(grid.a0, grid.b0));
    depth(grid.at(grid.a1, grid.b0));
    depth(grid.at(grid.a0, grid.b1));
    depth(grid.at(grid.a1, grid.b1));
  }
  depth(target);
  dmax = std::max(dmax, 1e-6);
  cam.far_plane = dmax * 1.05 + 1e-9;
  cam.near_plane = dmin > dmax * 1e-3 ? dmin * 0.9 : dmax * 1e-3;
  // An off-centre frustum: the view's field of view spans the usable part of the image, and the
  // target sits at its centre; the rest of the image (colour bar, top line) extends it.
  const double pi = std::acos(-1.0);
  const double uw = std::max(L.usable_x1 - L.usable_x0, 1), uh = std::max(L.usable_y1 - L.usable_y0, 1);
  const double ty = std::tan(cam.view.fov_deg * pi / 360), tx = ty * uw / uh;
  const double px_x = 2 * tx / uw, px_y = 2 * ty / uh;  // tangent per pixel
  const double n = cam.near_plane;
  const double l = -(tx + L.usable_x0 * px_x) * n, r = (tx + (L.width - L.usable_x1) * px_x) * n;
  const double t = (ty + L.usable_y0 * px_y) * n, b = -(ty + (L.height - L.usable_y1) * px_y) * n;
  cam.projection = frustum(l, r, b, t, n, cam.far_plane);
  return cam;
}

Setup make_setup(const Frame& frame, const RenderOptions& o) {
  Setup s;
  s.layout = make_layout(o, frame.field);
  s.framing = o.framing && !o.framing->empty() ? *o.framing : bounds_of(frame);
  s.obstacles = !frame.obstacles.empty();
  if (s.obstacles)
    for (const ObstacleMark& ob : frame.obstacles) s.grids.push_back(make_plane_grid(s.framing, ob.point, ob.normal));
  else
    s.grids.push_back(make_grid(s.framing, o.up));
  // The auto camera fits the given points, else the frame's own surface (not the bounds: the
  // corners of a round body's box reach far beyond it), else the framing box.
  const std::vector<Vec3d> fit = !o.framing_points.empty() ? o.framing_points
                                 : o.framing                ? std::vector<Vec3d>{}
                                                            : framing_sample(frame, 20000);
  s.camera = make_camera(o, s.framing, s.layout, o.grid ? s.grids : std::vector<Grid>{}, fit);
  return s;
}

}  // namespace detail

View resolve_view(const Frame& frame, const RenderOptions& options) {
  return detail::make_setup(frame, options).camera.view;
}

}  // namespace pliant::raster
