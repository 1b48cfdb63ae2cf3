// The shipped implicit shapes: signed functions (negative inside, units m) that the CGAL mesher
// samples and that tests integrate. No CGAL here, so this file is compiled in both builds.
//
// Shapes (all centred near the origin):
//   "sphere"  radius 0.05 m.
//   "capsule" a rounded cylinder along x: axis segment x in [-0.07, 0.07], radius 0.03, so the
//             total length is 0.2 m and the diameter 0.06 m.
//   "organ"   a smooth, liver-like body of about 0.20 x 0.12 x 0.08 m (x, y, z), see organ_value.
#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "pliant/error.hpp"
#include "pliant/meshing.hpp"

namespace pliant {
namespace {

double length(double x, double y, double z) { return std::sqrt(x * x + y * y + z * z); }

// Axis-aligned ellipsoid with centre c and semi-axes r. Returns k0 (k0 - 1) / k1 with
// k0 = |(p - c) / r| and k1 = |(p - c) / r^2|: zero exactly on the ellipsoid, negative inside,
// and close to the Euclidean distance near the surface (so that the smooth-min radius below is
// a length in metres). At the centre itself (0/0) it returns -min(r).
double ellipsoid(const Vec3d& p, const Vec3d& c, const Vec3d& r) {
  const double x = p[0] - c[0], y = p[1] - c[1], z = p[2] - c[2];
  const double k0 = length(x / r[0], y / r[1], z / r[2]);
  const double k1 = length(x / (r[0] * r[0]), y / (r[1] * r[1]), z / (r[2] * r[2]));
  if (k1 == 0.0) return -std::min({r[0], r[1], r[2]});
  return k0 * (k0 - 1.0) / k1;
}

// Polynomial (quadratic) smooth minimum: equal to min(a, b) when |a - b| >= k, otherwise
// min(a, b) - h^2 k / 4 with h = (k - |a - b|) / k. C1-continuous; it fills the crease where
// two bodies meet with a fillet of size about k.
double smooth_min(double a, double b, double k) {
  const double h = std::max(k - std::abs(a - b), 0.0) / k;
  return std::min(a, b) - h * h * k * 0.25;
}

// "organ": the smooth union (smooth_min, k = 0.02 m) of two slightly flattened ellipsoids:
//   right lobe  centre ( 0.025, 0.000, 0.000), semi-axes (0.075, 0.060, 0.040)
//               -> x in [-0.05, 0.10], y in [-0.06, 0.06], z in [-0.04, 0.04]
//   left lobe   centre (-0.050, 0.010, 0.005), semi-axes (0.050, 0.040, 0.025)
//               -> x in [-0.10, 0.00], y in [-0.03, 0.05], z in [-0.02, 0.03]
// Overall 0.20 x 0.12 x 0.08 m, centred on the origin in x and z. The lobes overlap over 5 cm
// in x, so the junction is thick; the thinnest part is the left lobe's tip, 5 cm thick at its
// middle and with radius of curvature >= 1.25 cm at the tip. Volume about 9.2e-4 m^3.
double organ_value(const Vec3d& p) {
  const double right = ellipsoid(p, {0.025, 0.0, 0.0}, {0.075, 0.060, 0.040});
  const double left = ellipsoid(p, {-0.050, 0.010, 0.005}, {0.050, 0.040, 0.025});
  return smooth_min(right, left, 0.02);
}

double sphere_value(const Vec3d& p) { return length(p[0], p[1], p[2]) - 0.05; }

double capsule_value(const Vec3d& p) {
  const double x = std::clamp(p[0], -0.07, 0.07);  // closest point on the axis segment
  return length(p[0] - x, p[1], p[2]) - 0.03;
}

struct Shape {
  const char* name;
  double (*value)(const Vec3d&);
  double bounding_radius;  // a sphere about the origin that strictly contains the shape (m)
};

// Bounding radii: sphere 0.05, capsule 0.1, organ |(0.10, 0.06, 0.04)| = 0.123, with margin.
constexpr Shape kShapes[] = {
    {"organ", organ_value, 0.15},
    {"sphere", sphere_value, 0.07},
    {"capsule", capsule_value, 0.12},
};

const Shape& find_shape(const std::string& name) {
  for (const Shape& s : kShapes)
    if (name == s.name) return s;
  std::string known;
  for (const Shape& s : kShapes) known += std::string(known.empty() ? "" : ", ") + s.name;
  throw InputError("unknown implicit shape '" + name + "' (known shapes: " + known + ")");
}

}  // namespace

std::vector<std::string> implicit_shape_names() {
  std::vector<std::string> names;
  for (const Shape& s : kShapes) names.emplace_back(s.name);
  return names;
}

double implicit_shape_value(const std::string& name, const Vec3d& p) {
  return find_shape(name).value(p);
}

double implicit_shape_bounding_radius(const std::string& name) {
  return find_shape(name).bounding_radius;
}

}  // namespace pliant
