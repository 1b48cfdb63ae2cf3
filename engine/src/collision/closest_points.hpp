// Exact closest points between the shapes contact needs: a point, a segment (a capsule's axis, a
// sphere's path over a step) and a triangle (a face of a body's surface). Double precision,
// branchy scalar code (it runs on the few triangles Embree's BVH returns, not on the body).
// After Ericson, Real-Time Collision Detection (2005), §5.1.5 and §5.1.9, rewritten here.
#pragma once
#include <algorithm>
#include <array>
#include <cmath>

namespace pliant::detail {

using P3 = std::array<double, 3>;

inline P3 sub(const P3& a, const P3& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
inline P3 add(const P3& a, const P3& b) { return {a[0] + b[0], a[1] + b[1], a[2] + b[2]}; }
inline P3 mul(const P3& a, double s) { return {a[0] * s, a[1] * s, a[2] * s}; }
inline double dot(const P3& a, const P3& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
inline P3 cross(const P3& a, const P3& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
inline double norm2(const P3& a) { return dot(a, a); }

// A point of a triangle (a, b, c) as barycentric weights (w[0] a + w[1] b + w[2] c, sum 1, all >= 0).
struct TrianglePoint {
  P3 point{};
  std::array<double, 3> w{};
};

// The point of triangle (a, b, c) closest to p (Voronoi regions of vertices, edges, face).
inline TrianglePoint closest_on_triangle(const P3& p, const P3& a, const P3& b, const P3& c) {
  const P3 ab = sub(b, a), ac = sub(c, a), ap = sub(p, a);
  const double d1 = dot(ab, ap), d2 = dot(ac, ap);
  if (d1 <= 0 && d2 <= 0) return {a, {1, 0, 0}};
  const P3 bp = sub(p, b);
  const double d3 = dot(ab, bp), d4 = dot(ac, bp);
  if (d3 >= 0 && d4 <= d3) return {b, {0, 1, 0}};
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) {
    const double v = d1 / (d1 - d3);
    return {add(a, mul(ab, v)), {1 - v, v, 0}};
  }
  const P3 cp = sub(p, c);
  const double d5 = dot(ab, cp), d6 = dot(ac, cp);
  if (d6 >= 0 && d5 <= d6) return {c, {0, 0, 1}};
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) {
    const double w = d2 / (d2 - d6);
    return {add(a, mul(ac, w)), {1 - w, 0, w}};
  }
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) {
    const double w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
    return {add(b, mul(sub(c, b), w)), {0, 1 - w, w}};
  }
  const double denom = 1 / (va + vb + vc);
  const double v = vb * denom, w = vc * denom;
  return {add(a, add(mul(ab, v), mul(ac, w))), {1 - v - w, v, w}};
}

// Parameters s, t in [0, 1] of the closest points p1 + s (q1 - p1) and p2 + t (q2 - p2) of two
// segments (either may be a point).
inline void closest_segment_segment(const P3& p1, const P3& q1, const P3& p2, const P3& q2, double& s, double& t) {
  const P3 d1 = sub(q1, p1), d2 = sub(q2, p2), r = sub(p1, p2);
  const double a = dot(d1, d1), e = dot(d2, d2), f = dot(d2, r);
  const double tiny = 1e-300;
  if (a <= tiny && e <= tiny) {
    s = t = 0;
    return;
  }
  if (a <= tiny) {
    s = 0;
    t = std::clamp(f / e, 0.0, 1.0);
    return;
  }
  const double c = dot(d1, r);
  if (e <= tiny) {
    t = 0;
    s = std::clamp(-c / a, 0.0, 1.0);
    return;
  }
  const double b = dot(d1, d2), denom = a * e - b * b;
  s = denom > 0 ? std::clamp((b * f - c * e) / denom, 0.0, 1.0) : 0.0;
  t = (b * s + f) / e;
  if (t < 0) {
    t = 0;
    s = std::clamp(-c / a, 0.0, 1.0);
  } else if (t > 1) {
    t = 1;
    s = std::clamp((b - c) / a, 0.0, 1.0);
  }
}

// Closest points of a segment [p, q] (p == q: a point) and a triangle (a, b, c).
struct SegmentTriangle {
  double distance2 = 0;  // m^2
  double s = 0;          // on the segment: p + s (q - p)
  TrianglePoint on_triangle;
};

// The segment reduced to a point p (a sphere's axis, or its path over a step that did not move
// it): what closest_segment_triangle computes for p == q, with the same arithmetic (so the same
// bits) and without what cannot change its result there: the plane test (dp == dq) and the
// second end (the same point). The edges are still tried: their nearest points, computed another
// way than closest_on_triangle's, can come out closer by a rounding, and the general path takes them.
inline SegmentTriangle closest_point_triangle(const P3& p, const P3& a, const P3& b, const P3& c) {
  SegmentTriangle best;
  best.on_triangle = closest_on_triangle(p, a, b, c);
  best.distance2 = norm2(sub(p, best.on_triangle.point));
  const P3* corner[3] = {&a, &b, &c};
  for (int e = 0; e < 3; ++e) {
    const P3& u = *corner[e];
    const P3& v = *corner[(e + 1) % 3];
    // closest_segment_segment(p, p, u, v): s = 0, and t as it computes it.
    const P3 d2 = sub(v, u), r = sub(p, u);
    const double len2 = dot(d2, d2);
    const double t = len2 <= 1e-300 ? 0.0 : std::clamp(dot(d2, r) / len2, 0.0, 1.0);
    // x as the general path forms its segment point p + (q - p) s at s = 0: p itself when finite,
    // NaN when p has an infinity, as there.
    const P3 x = add(p, mul(sub(p, p), 0.0)), y = add(u, mul(d2, t));
    const double dist2 = norm2(sub(x, y));
    if (dist2 < best.distance2) {
      TrianglePoint tp{y, {0, 0, 0}};
      tp.w[std::size_t(e)] = 1 - t;
      tp.w[std::size_t((e + 1) % 3)] = t;
      best = {dist2, 0.0, tp};
    }
  }
  return best;
}

// The general case (p == q included: the tests compare closest_point_triangle with it).
inline SegmentTriangle closest_segment_triangle_general(const P3& p, const P3& q, const P3& a, const P3& b, const P3& c) {
  // Crossing: the segment meets the triangle's plane inside the triangle (distance 0).
  const P3 n = cross(sub(b, a), sub(c, a));
  const double dp = dot(n, sub(p, a)), dq = dot(n, sub(q, a));
  if ((dp <= 0 && dq >= 0) || (dp >= 0 && dq <= 0)) {
    if (dp != dq) {
      const double s = dp / (dp - dq);
      const P3 x = add(p, mul(sub(q, p), s));
      // Barycentric weights of x in the plane (signed areas against n).
      const double nn = dot(n, n);
      if (nn > 0) {
        const double wa = dot(n, cross(sub(b, x), sub(c, x))) / nn;
        const double wb = dot(n, cross(sub(c, x), sub(a, x))) / nn;
        const double wc = 1 - wa - wb;
        if (wa >= 0 && wb >= 0 && wc >= 0) return {0.0, s, {x, {wa, wb, wc}}};
      }
    }
  }
  // Otherwise the closest pair has an end of the segment or lies on an edge of the triangle.
  SegmentTriangle best;
  best.on_triangle = closest_on_triangle(p, a, b, c);
  best.distance2 = norm2(sub(p, best.on_triangle.point));
  best.s = 0;
  const TrianglePoint tq = closest_on_triangle(q, a, b, c);
  const double dq2 = norm2(sub(q, tq.point));
  if (dq2 < best.distance2) best = {dq2, 1.0, tq};
  const P3* corner[3] = {&a, &b, &c};
  for (int e = 0; e < 3; ++e) {
    const P3& u = *corner[e];
    const P3& v = *corner[(e + 1) % 3];
    double s, t;
    closest_segment_segment(p, q, u, v, s, t);
    const P3 x = add(p, mul(sub(q, p), s)), y = add(u, mul(sub(v, u), t));
    const double d2 = norm2(sub(x, y));
    if (d2 < best.distance2) {
      TrianglePoint tp{y, {0, 0, 0}};
      tp.w[std::size_t(e)] = 1 - t;
      tp.w[std::size_t((e + 1) % 3)] = t;
      best = {d2, s, tp};
    }
  }
  return best;
}

inline SegmentTriangle closest_segment_triangle(const P3& p, const P3& q, const P3& a, const P3& b, const P3& c) {
  return p == q ? closest_point_triangle(p, a, b, c) : closest_segment_triangle_general(p, q, a, b, c);
}

// Squared distance (m^2) between two triangles: 0 if they meet, else the smallest over the
// edges of each against the other (a closest pair of disjoint triangles always has a point on an
// edge of one of them).
inline double triangle_triangle_distance2(const std::array<P3, 3>& t, const std::array<P3, 3>& u) {
  double best = 1e300;
  for (int e = 0; e < 3; ++e) {
    best = std::min(best, closest_segment_triangle(t[std::size_t(e)], t[std::size_t((e + 1) % 3)], u[0], u[1], u[2]).distance2);
    best = std::min(best, closest_segment_triangle(u[std::size_t(e)], u[std::size_t((e + 1) % 3)], t[0], t[1], t[2]).distance2);
    if (best == 0) break;
  }
  return best;
}

}  // namespace pliant::detail
