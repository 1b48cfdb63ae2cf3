// Tool poses along keyframes, and the ends of a tool's axis.
#include <algorithm>
#include <cmath>

#include "pliant/tool.hpp"

namespace pliant {
namespace {

Quatd normalised(const Quatd& q) {
  const double n = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
  return {q[0] / n, q[1] / n, q[2] / n, q[3] / n};
}

// Spherical linear interpolation along the shorter arc.
Quatd slerp(Quatd a, Quatd b, double s) {
  a = normalised(a);
  b = normalised(b);
  double c = a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3];
  if (c < 0) {
    c = -c;
    for (double& x : b) x = -x;
  }
  double wa = 1 - s, wb = s;
  if (c < 0.9995) {  // else nearly equal: linear, then normalised
    const double theta = std::acos(c), sn = std::sin(theta);
    wa = std::sin((1 - s) * theta) / sn;
    wb = std::sin(s * theta) / sn;
  }
  return normalised({wa * a[0] + wb * b[0], wa * a[1] + wb * b[1], wa * a[2] + wb * b[2], wa * a[3] + wb * b[3]});
}

}  // namespace

ToolPose tool_pose_at(const std::vector<ToolKeyframeDef>& k, double t) {
  if (k.empty()) return {};
  if (t <= k.front().time) return {k.front().position, normalised(k.front().orientation)};
  if (t >= k.back().time) return {k.back().position, normalised(k.back().orientation)};
  const auto it = std::upper_bound(k.begin(), k.end(), t, [](double x, const ToolKeyframeDef& f) { return x < f.time; });
  const ToolKeyframeDef& b = *it;
  const ToolKeyframeDef& a = *(it - 1);
  const double s = (t - a.time) / (b.time - a.time);
  ToolPose p;
  for (int i = 0; i < 3; ++i) p.position[std::size_t(i)] = a.position[std::size_t(i)] + s * (b.position[std::size_t(i)] - a.position[std::size_t(i)]);
  p.orientation = slerp(a.orientation, b.orientation, s);
  return p;
}

void tool_axis(const ToolShapeDef& shape, const ToolPose& pose, Vec3d& a, Vec3d& b) {
  a = b = pose.position;
  if (shape.kind != ToolShapeDef::Kind::capsule) return;
  // The local z axis rotated by q = (w, x, y, z): third column of the rotation matrix.
  const Quatd q = normalised(pose.orientation);
  const double w = q[0], x = q[1], y = q[2], z = q[3];
  const Vec3d axis{2 * (x * z + w * y), 2 * (y * z - w * x), 1 - 2 * (x * x + y * y)};
  for (int i = 0; i < 3; ++i) {
    a[std::size_t(i)] -= 0.5 * shape.length * axis[std::size_t(i)];
    b[std::size_t(i)] += 0.5 * shape.length * axis[std::size_t(i)];
  }
}

}  // namespace pliant
