// The contact pass of a tool against a level (tool_contact.hpp). Detection: Embree's BVH gives
// the triangles whose boxes meet a ball around everything the tool's axis swept over the window;
// an exact distance test keeps those the tool's swept volume reaches (a sphere sweeps a capsule;
// a capsule's axis sweeps the quadrilateral between its two positions, tested as two triangles).
// Response (thesis ch. 6 §2.2): for each touched triangle, the point closest to the tool's axis
// is carried onto the tool's surface by moving the free vertices with weights b_k (the point's
// barycentric coordinates): dx_k = b_k d / sum_j b_j^2, the smallest displacement (least squares)
// that moves the point by d; a triangle whose free corners would move more than kMaxCornerPush |d|
// (a point on a held corner, tool_contact.hpp) is skipped. Vertices the tool moved lose their
// velocity into the tool.
#include "tool_contact.hpp"

#include <algorithm>
#include <cmath>
#include <type_traits>

#include "closest_points.hpp"
#include "pliant/error.hpp"
#include "pliant/kernels/node_passes.hpp"
#include "pliant/scheduler/executor.hpp"

namespace pliant::detail {
namespace {

template <class T>
P3 vertex(const Level<T>& L, std::int32_t n) {
  return {double(L.x[0][std::size_t(n)]), double(L.x[1][std::size_t(n)]), double(L.x[2][std::size_t(n)])};
}

P3 to_body(const Vec3d& p, const Vec3d& origin) { return {p[0] - origin[0], p[1] - origin[1], p[2] - origin[2]}; }

}  // namespace

template <class T>
LevelContact<T> make_level_contact(EmbreeDevice& device, const Level<T>& L, int body, int level, Executor& exec,
                                   const ToolPose& pose) {
  LevelContact<T> lc;
  lc.body = body;
  lc.level = level;
  lc.from = pose;
  std::vector<std::int32_t> vertex_of(L.node_count, -1);
  for (const auto& t : L.boundary)
    for (std::int32_t n : t) vertex_of[std::size_t(n)] = 0;
  for (std::size_t n = 0; n < L.node_count; ++n)
    if (vertex_of[n] == 0) {
      vertex_of[n] = std::int32_t(lc.surface_nodes.size());
      lc.surface_nodes.push_back(std::int32_t(n));
    }
  lc.triangles.reserve(L.boundary.size());
  for (const auto& t : L.boundary)
    lc.triangles.push_back({vertex_of[std::size_t(t[0])], vertex_of[std::size_t(t[1])], vertex_of[std::size_t(t[2])]});
  double edges = 0;
  for (const auto& t : L.boundary)
    for (int e = 0; e < 3; ++e) {
      double d2 = 0;
      for (int k = 0; k < 3; ++k) {
        const double d = double(L.x[k][std::size_t(t[std::size_t(e)])]) - double(L.x[k][std::size_t(t[std::size_t((e + 1) % 3)])]);
        d2 += d * d;
      }
      edges += std::sqrt(d2);
    }
  lc.margin = L.boundary.empty() ? 0.0 : 0.25 * edges / (3.0 * double(L.boundary.size()));
  lc.bvh = std::make_unique<SurfaceBvh>(device, lc.triangles, lc.surface_nodes.size());
  float* v = lc.bvh->vertices();
  for (std::size_t i = 0; i < lc.surface_nodes.size(); ++i)
    for (int k = 0; k < 3; ++k) v[4 * i + std::size_t(k)] = float(L.x[k][std::size_t(lc.surface_nodes[i])]);
  std::string error;
  if (!lc.bvh->refit(exec, error)) throw InputError("building the collision surface of a body: " + error);
  lc.candidates.reserve(lc.triangles.size());
  lc.hits.reserve(lc.triangles.size());
  lc.held.assign(lc.surface_nodes.size(), 0);
  lc.push.assign(lc.surface_nodes.size(), {0, 0, 0});
  lc.depth.assign(lc.surface_nodes.size(), 0);
  lc.held_vertices.reserve(lc.surface_nodes.size());
  lc.unresolved.reserve(lc.triangles.size());
  note_simulated_surface(lc, L);
  return lc;
}

template <class T>
void note_simulated_surface(LevelContact<T>& lc, const Level<T>& L) {
  lc.simulated.clear();
  for (std::size_t i = 0; i < lc.surface_nodes.size(); ++i)
    if (L.state[std::size_t(lc.surface_nodes[i])] != kNodeInactive) lc.simulated.push_back(std::int32_t(i));
  if (lc.simulated.size() == lc.surface_nodes.size()) lc.simulated.clear();  // all: the contiguous loop
}

// Whether some surface vertex has moved more than lc.margin from where the BVH last saw it (step 1
// of find_tool_contacts, every query). A double level sums the squared distance in double; a
// float one in float, against the margin's square shrunk by 1e-5, far more than float's rounding
// of that sum (3 differences, 3 squares, 2 additions: under 1e-6 relative), so a vertex beyond
// the margin is never missed, and one just within it may refit a query early, which changes no
// contact (the candidates are a superset of the hits either way, and sorted). The loop has no
// dependent chain (an or, not a running max) and runs in vector lanes, bound by the gathers of the
// positions through `node`: on the default scene (1 thread, perf samples) find_tool_contacts went
// from 0.99 % to 0.86 % of the run, about 0.75 us a step.
// Only the simulated vertices when some are not (LevelContact::simulated): a level of an adaptive
// body stepping a region of a few hundred tets read its whole surface at every tick (the 50k-tet
// organ at its finest cap: 8% of a frame's stepping, perf samples).
template <class T>
bool left_margin(const LevelContact<T>& lc, const Level<T>& L) {
  const float* vb = lc.bvh->vertices();
  const T *x0 = L.x[0].data(), *x1 = L.x[1].data(), *x2 = L.x[2].data();
  if (!lc.simulated.empty()) {
    const double limit = std::is_same_v<T, float> ? lc.margin * lc.margin * (1 - 1e-5) : lc.margin * lc.margin;
    for (const std::int32_t i : lc.simulated) {
      const auto v = std::size_t(lc.surface_nodes[std::size_t(i)]);
      const auto b = 4 * std::size_t(i);
      if constexpr (std::is_same_v<T, float>) {
        const float d0 = x0[v] - vb[b], d1 = x1[v] - vb[b + 1], d2 = x2[v] - vb[b + 2];
        if (d0 * d0 + d1 * d1 + d2 * d2 > float(limit)) return true;
      } else {
        const double d0 = x0[v] - double(vb[b]), d1 = x1[v] - double(vb[b + 1]), d2 = x2[v] - double(vb[b + 2]);
        if (d0 * d0 + d1 * d1 + d2 * d2 > limit) return true;
      }
    }
    return false;
  }
  const std::size_t n = lc.surface_nodes.size();
  const std::int32_t* node = lc.surface_nodes.data();
  if constexpr (std::is_same_v<T, float>) {
    const float limit = float(lc.margin * lc.margin * (1 - 1e-5));
    int far = 0;
    for (std::size_t i = 0; i < n; ++i) {
      const auto v = std::size_t(node[i]);
      const float d0 = x0[v] - vb[4 * i], d1 = x1[v] - vb[4 * i + 1], d2 = x2[v] - vb[4 * i + 2];
      far |= int(d0 * d0 + d1 * d1 + d2 * d2 > limit);
    }
    return far != 0;
  } else {
    const double limit = lc.margin * lc.margin;
    int far = 0;
    for (std::size_t i = 0; i < n; ++i) {
      const auto v = std::size_t(node[i]);
      const double d0 = x0[v] - double(vb[4 * i]), d1 = x1[v] - double(vb[4 * i + 1]), d2 = x2[v] - double(vb[4 * i + 2]);
      far |= int(d0 * d0 + d1 * d1 + d2 * d2 > limit);
    }
    return far != 0;
  }
}

template <class T>
bool find_tool_contacts(LevelContact<T>& lc, const Level<T>& L, const ToolShapeDef& shape, const ToolPose& from,
                        const ToolPose& to, const Vec3d& origin, Executor& exec, std::string& error) {
  // 1. The BVH follows the surface: refit once a vertex has left its box's margin.
  float* vb = lc.bvh->vertices();
  ++lc.queries;
  if (left_margin(lc, L)) {
    for (std::size_t i = 0; i < lc.surface_nodes.size(); ++i)
      for (int k = 0; k < 3; ++k) vb[4 * i + std::size_t(k)] = float(L.x[k][std::size_t(lc.surface_nodes[i])]);
    if (!lc.bvh->refit(exec, error)) return false;
    ++lc.refits;
  }

  // 2. The tool's axis at the start and end of the window, body frame.
  Vec3d wa0, wb0, wa1, wb1;
  tool_axis(shape, from, wa0, wb0);
  tool_axis(shape, to, wa1, wb1);
  const P3 a0 = to_body(wa0, origin), b0 = to_body(wb0, origin), a1 = to_body(wa1, origin), b1 = to_body(wb1, origin);
  const double r = shape.radius;
  P3 centre = mul(add(add(a0, b0), add(a1, b1)), 0.25);
  double reach = 0;
  for (const P3* p : {&a0, &b0, &a1, &b1}) reach = std::max(reach, std::sqrt(norm2(sub(*p, centre))));
  // Embree's boxes are in float: widen the ball by a few float ulps of the coordinates involved.
  const double coord = std::max({std::abs(centre[0]), std::abs(centre[1]), std::abs(centre[2])}) + reach + r;
  const float ball_centre[3] = {float(centre[0]), float(centre[1]), float(centre[2])};
  lc.bvh->triangles_near(ball_centre, float((reach + r + lc.margin) * (1 + 1e-5) + 1e-6 * coord), lc.candidates);

  // 3. Exact test against the swept volume: within r of what the axis swept.
  const bool moved = norm2(sub(a0, a1)) + norm2(sub(b0, b1)) > 0;
  const bool capsule = shape.kind == ToolShapeDef::Kind::capsule;
  lc.hits.clear();
  for (std::uint32_t t : lc.candidates) {
    const auto& tri = lc.triangles[t];
    // Only the simulated surface: a triangle with an inactive corner is not part of it (a
    // multiresolution level where another level is active; its inactive corners sit where they
    // last were), and one without a free corner cannot be moved.
    bool any_free = false, any_inactive = false;
    for (std::int32_t i : tri) {
      const std::uint8_t s = L.state[std::size_t(lc.surface_nodes[std::size_t(i)])];
      any_free |= s == kNodeFree;
      any_inactive |= s == kNodeInactive;
    }
    if (!any_free || any_inactive) continue;
    const P3 p0 = vertex(L, lc.surface_nodes[std::size_t(tri[0])]), p1 = vertex(L, lc.surface_nodes[std::size_t(tri[1])]),
             p2 = vertex(L, lc.surface_nodes[std::size_t(tri[2])]);
    double d2;
    if (!moved) {
      d2 = closest_segment_triangle(a1, b1, p0, p1, p2).distance2;
    } else if (!capsule) {
      d2 = closest_segment_triangle(a0, a1, p0, p1, p2).distance2;
    } else {
      const std::array<P3, 3> tri_p{p0, p1, p2};
      d2 = std::min(triangle_triangle_distance2({a0, b0, b1}, tri_p), triangle_triangle_distance2({a0, b1, a1}, tri_p));
    }
    if (d2 <= r * r) lc.hits.push_back(t);
  }
  return true;
}

template <class T>
bool resolve_tool_contact(LevelContact<T>& lc, Level<T>& L, const ToolShapeDef& shape, const ToolPose& to,
                          const Vec3d& origin, double dt, Executor& exec, std::string& error) {
  // A level that steps no tet (a multiresolution level where others are active) has no simulated
  // surface: no triangle there has every corner simulated and one free (step 3), so the tool
  // touches nothing on it. Its contact pass is skipped (it would read every surface vertex for the
  // BVH's margin check: on the 50k-tet organ at its coarsest, a third of the stepping time); the BVH
  // is checked again at the level's next query.
  if (L.stepped_count == 0) {
    for (std::int32_t i : lc.held_vertices) {
      lc.held[std::size_t(i)] = 0;
      lc.push[std::size_t(i)] = {0, 0, 0};
      lc.depth[std::size_t(i)] = 0;
    }
    lc.held_vertices.clear();
    lc.hits.clear();
    lc.unresolved.clear();
    lc.force = {0, 0, 0};
    lc.work = 0;
    lc.contacts = 0;
    lc.max_penetration = 0;
    lc.from = to;
    return true;
  }
  if (!find_tool_contacts(lc, L, shape, lc.from, to, origin, exec, error)) return false;
  Vec3d wa0, wb0, wa1, wb1;
  tool_axis(shape, lc.from, wa0, wb0);
  tool_axis(shape, to, wa1, wb1);
  const P3 a0 = to_body(wa0, origin), b0 = to_body(wb0, origin), a1 = to_body(wa1, origin), b1 = to_body(wb1, origin);
  const double r = shape.radius;

  // 4. Response: each touched triangle's point nearest the axis goes onto the tool's surface.
  for (std::int32_t i : lc.held_vertices) {
    lc.held[std::size_t(i)] = 0;
    lc.push[std::size_t(i)] = {0, 0, 0};
    lc.depth[std::size_t(i)] = 0;
  }
  lc.held_vertices.clear();
  lc.unresolved.clear();
  for (int iteration = 0; iteration < kContactIterations; ++iteration) {
    for (std::uint32_t t : lc.hits) {
      const auto& tri = lc.triangles[t];
      std::int32_t node[3];
      P3 p[3];
      double w[3];
      for (int k = 0; k < 3; ++k) {
        node[k] = lc.surface_nodes[std::size_t(tri[std::size_t(k)])];
        p[k] = vertex(L, node[k]);
      }
      const SegmentTriangle st = closest_segment_triangle(a1, b1, p[0], p[1], p[2]);
      if (st.distance2 >= r * r) continue;
      const P3 axis_point = add(a1, mul(sub(b1, a1), st.s));
      const P3 normal_out = cross(sub(p[1], p[0]), sub(p[2], p[0]));  // outward (boundary orientation)
      const double nn = std::sqrt(norm2(normal_out));
      if (!(nn > 0)) continue;
      const P3 n_out = mul(normal_out, 1 / nn);
      const P3 from_axis = sub(st.on_triangle.point, axis_point);
      const double dist = std::sqrt(st.distance2);
      // The axis went through the triangle in this window: behind its plane now, over the
      // triangle (the nearest point inside it, not on an edge or corner), and in front of the
      // plane at the window's start. Only then is the point pushed through to the tool's far side.
      const bool beside = st.on_triangle.w[0] == 0 || st.on_triangle.w[1] == 0 || st.on_triangle.w[2] == 0;
      const P3 axis_point0 = add(a0, mul(sub(b0, a0), st.s));
      const bool crossed = dot(from_axis, n_out) >= 0 && !beside && dot(sub(axis_point0, st.on_triangle.point), n_out) > 0;
      P3 d;
      if (!crossed && dist > 1e-12 * r) {
        // The axis is outside the body in front of the triangle, or beside it (a tool wider than
        // the body meeting a side face at its edge), or was already behind the plane (a triangle
        // the tool has turned over): push radially onto the tool's surface.
        d = mul(from_axis, (r - dist) / dist);
      } else {
        // A deep push: along the inward normal, to a tool radius beyond the axis. (Taken whenever
        // the axis was behind the plane, it sent a side face's top edge a radius into a body
        // narrower than the tool, and a top triangle the tool had turned over 2r through a 3 cm
        // bar: two stress scenes exploded.)
        d = mul(n_out, -(r + dot(sub(axis_point, st.on_triangle.point), mul(n_out, -1.0))));
      }
      double sum_w2 = 0;
      for (int k = 0; k < 3; ++k) {
        w[k] = L.state[std::size_t(node[k])] == kNodeFree ? st.on_triangle.w[std::size_t(k)] : 0.0;
        sum_w2 += w[k] * w[k];
      }
      // The point is (almost) on corners that are not free: no move of the free ones that stays
      // within kMaxCornerPush |d| carries it out, so the triangle is left to its neighbours; if
      // they have not carried it out by the last pass, an adaptive body refines there
      // (LevelContact::unresolved).
      double largest = 0;
      for (int k = 0; k < 3; ++k) largest = std::max(largest, w[k]);
      if (sum_w2 < 1e-12 || !(largest <= kMaxCornerPush * sum_w2)) {
        if (iteration + 1 == kContactIterations) lc.unresolved.push_back(st.on_triangle.point);
        continue;
      }
      for (int k = 0; k < 3; ++k) {
        if (w[k] == 0) continue;
        const double s = w[k] / sum_w2;
        const auto n = std::size_t(node[k]);
        for (int c = 0; c < 3; ++c) L.x[c][n] = T(double(L.x[c][n]) + s * d[std::size_t(c)]);
        const auto i = std::size_t(tri[std::size_t(k)]);
        for (int c = 0; c < 3; ++c) lc.push[i][std::size_t(c)] += s * d[std::size_t(c)];
        lc.depth[i] = std::max(lc.depth[i], r - dist);
        if (!lc.held[i]) lc.held_vertices.push_back(std::int32_t(i));
        lc.held[i] = std::max<std::uint8_t>(lc.held[i], crossed ? kHeldDeep : kHeldRadial);
      }
    }
  }
  std::sort(lc.held_vertices.begin(), lc.held_vertices.end());

  // 4b. A vertex pushed radially only comes out by what the window's motion brought it in or, if
  // more, kRecoverySpeed c_p dt (at most the depth of the points that moved it): a penetration
  // already there goes out over several windows.
  // c_p from the level's Courant estimate, omega_geometric = 2 c_p / h_min.
  const double recovery = kRecoverySpeed * 0.5 * L.omega_geometric * L.min_altitude * dt;  // m
  for (std::int32_t i : lc.held_vertices) {
    if (lc.held[std::size_t(i)] != kHeldRadial) continue;
    P3& push = lc.push[std::size_t(i)];
    const double len = std::sqrt(norm2(push));
    if (!(len > recovery)) continue;
    const auto n = std::size_t(lc.surface_nodes[std::size_t(i)]);
    // The vertex's approach to the tool in the window: the axis point's displacement against the
    // vertex's own (v dt), along the push.
    double s = 0, unused = 0;
    const P3 x = vertex(L, std::int32_t(n));
    closest_segment_segment(a1, b1, x, x, s, unused);
    const P3 axis_motion = sub(add(a1, mul(sub(b1, a1), s)), add(a0, mul(sub(b0, a0), s)));
    const P3 own_motion{double(L.v[0][n]) * dt, double(L.v[1][n]) * dt, double(L.v[2][n]) * dt};
    // Beyond its approach, a vertex comes out by the recovery but no further than the deepest
    // triangle point that moved it (the least-squares move carries a corner up to 1.37x its
    // point's push). With the recovery added to the approach, bodies driven into a resting tool
    // gained energy at every window: a corner went out by both, further than the point it carried
    // had come in (stress scenes, 1.5-2.3x their criterion: docs/tool.md).
    const double approach = std::max(0.0, dot(sub(axis_motion, own_motion), mul(push, 1 / len)));
    const double allowed = std::max(approach, std::min(recovery, lc.depth[std::size_t(i)]));
    if (len <= allowed) continue;
    const double back = 1 - allowed / len;
    for (int c = 0; c < 3; ++c) L.x[c][n] = T(double(L.x[c][n]) - back * push[std::size_t(c)]);
    push = mul(push, allowed / len);
  }

  // 5. Held vertices lose their velocity into the tool (relative to the tool's motion there),
  // and their forces are the reaction on the tool. The work of the tool (a rigid body moved
  // along its path whatever resists it): at each held node, its motion against the node's force,
  // -f . v_tool dt, and against the impulse it gave the node, m (v_new - v_old) . v_tool (of which
  // the node keeps (v_new - v_old) . (v_new + v_old) / 2; the rest is the inelastic contact's
  // loss). A tool at rest does no work, however it holds the body.
  Vec3d force{0, 0, 0};
  double work = 0;
  for (std::int32_t i : lc.held_vertices) {
    const auto n = std::size_t(lc.surface_nodes[std::size_t(i)]);
    const P3& push = lc.push[std::size_t(i)];
    const double len = std::sqrt(norm2(push));
    if (len > 0 && dt > 0) {
      const P3 dir = mul(push, 1 / len);
      // The tool's velocity at the node: that of the axis point nearest to it.
      double s = 0, unused = 0;
      const P3 x = vertex(L, std::int32_t(n));
      closest_segment_segment(a1, b1, x, x, s, unused);
      const P3 v_tool = mul(sub(add(a1, mul(sub(b1, a1), s)), add(a0, mul(sub(b0, a0), s))), 1 / dt);
      const P3 v{double(L.v[0][n]), double(L.v[1][n]), double(L.v[2][n])};
      work -= (double(L.f[0][n]) * v_tool[0] + double(L.f[1][n]) * v_tool[1] + double(L.f[2][n]) * v_tool[2]) * dt;
      const double vn = dot(sub(v, v_tool), dir);
      if (vn < 0) {
        for (int c = 0; c < 3; ++c) L.v[c][n] = T(v[std::size_t(c)] - vn * dir[std::size_t(c)]);
        double jv = 0;  // (v_new - v_old) . v_tool, m^2/s^2
        for (int c = 0; c < 3; ++c) jv += (double(L.v[c][n]) - v[std::size_t(c)]) * v_tool[std::size_t(c)];
        work += double(L.mass[n]) * jv;
      }
    }
    for (int c = 0; c < 3; ++c) force[std::size_t(c)] += double(L.f[c][n]);
  }

  // 6. What is left inside the tool.
  double worst = 0;
  for (std::uint32_t t : lc.hits) {
    const auto& tri = lc.triangles[t];
    const SegmentTriangle st = closest_segment_triangle(a1, b1, vertex(L, lc.surface_nodes[std::size_t(tri[0])]),
                                                        vertex(L, lc.surface_nodes[std::size_t(tri[1])]),
                                                        vertex(L, lc.surface_nodes[std::size_t(tri[2])]));
    worst = std::max(worst, r - std::sqrt(st.distance2));
  }
  lc.force = force;
  lc.work = work;
  lc.contacts = int(lc.hits.size());
  lc.max_penetration = worst;
  lc.from = to;
  return true;
}

template LevelContact<float> make_level_contact<float>(EmbreeDevice&, const Level<float>&, int, int, Executor&, const ToolPose&);
template LevelContact<double> make_level_contact<double>(EmbreeDevice&, const Level<double>&, int, int, Executor&, const ToolPose&);
template void note_simulated_surface<float>(LevelContact<float>&, const Level<float>&);
template void note_simulated_surface<double>(LevelContact<double>&, const Level<double>&);
template bool find_tool_contacts<float>(LevelContact<float>&, const Level<float>&, const ToolShapeDef&, const ToolPose&,
                                        const ToolPose&, const Vec3d&, Executor&, std::string&);
template bool find_tool_contacts<double>(LevelContact<double>&, const Level<double>&, const ToolShapeDef&, const ToolPose&,
                                         const ToolPose&, const Vec3d&, Executor&, std::string&);
template bool resolve_tool_contact<float>(LevelContact<float>&, Level<float>&, const ToolShapeDef&, const ToolPose&,
                                          const Vec3d&, double, Executor&, std::string&);
template bool resolve_tool_contact<double>(LevelContact<double>&, Level<double>&, const ToolShapeDef&, const ToolPose&,
                                           const Vec3d&, double, Executor&, std::string&);

}  // namespace pliant::detail
