// A tool against one level of one body (thesis ch. 6 §2; docs/tool.md): find the surface
// triangles it touches or swept through over the level's window (Embree BVH + exact tests), move
// their free vertices onto the tool's surface with the smallest barycentric displacement, remove
// their velocity into the tool, and read the reaction. Runs after the level's integration, on
// the calling thread except for the BVH refit (our executor's threads). Allocation-free after
// make_level_contact: every scratch array is sized there.
#pragma once
#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "pliant/level.hpp"
#include "pliant/tool.hpp"
#include "surface_bvh.hpp"

namespace pliant::detail {

template <class T>
struct LevelContact {
  int body = 0, level = 0;
  std::unique_ptr<SurfaceBvh> bvh;
  std::vector<std::int32_t> surface_nodes;               // level node of each surface vertex
  std::vector<std::array<std::int32_t, 3>> triangles;    // surface vertex indices (L.boundary, renumbered)
  std::vector<std::uint32_t> candidates, hits;           // scratch: triangles near the tool, touched
  std::vector<std::uint8_t> held;                        // per surface vertex: moved in this window
                                                         //   (kHeldRadial, kHeldDeep), else 0
  std::vector<std::array<double, 3>> push;               // per surface vertex: sum of its displacements
  std::vector<double> depth;                             // per surface vertex: the deepest triangle point that
                                                         //   moved it in this window, m (inside the tool)
  std::vector<std::int32_t> held_vertices;               // surface vertices moved in the last window
  ToolPose from;                                         // the tool's pose at the start of the window
  // Lazy refit: the BVH holds the positions of its last refit, and queries are widened by
  // `margin`; it is refit only once some surface vertex has moved more than `margin` from there
  // (checking that costs a read of the vertices, a refit ~14 ns per triangle: docs/tool.md).
  double margin = 0;          // m: a quarter of the mean boundary edge
  std::int64_t refits = 0, queries = 0;
  // The surface vertices whose node is simulated (not inactive), when some are not: the only ones
  // the margin check reads (note_simulated_surface; empty: all of them). A triangle with an
  // inactive corner is never a hit, so where such a node stands does not matter to the hits.
  std::vector<std::int32_t> simulated;
  // Results of the level's last window.
  Vec3d force{};          // N, world frame
  double work = 0;        // J, the energy the tool gave up to the level (ToolReading::work)
  int contacts = 0;
  double max_penetration = 0;  // m
  // Body frame, m: the points of the touched triangles the response left alone in the last window
  // (their point on held corners: kMaxCornerPush). An adaptive body refines around them whatever
  // its refine_near (Simulation::step), so that a finer surface, free there, takes the contact.
  std::vector<std::array<double, 3>> unresolved;
};

// Sets up the contact of a tool with level L of a body (its boundary triangles; Embree BVH built).
template <class T>
LevelContact<T> make_level_contact(EmbreeDevice& device, const Level<T>& L, int body, int level, Executor& exec,
                                   const ToolPose& pose);

// Lists lc.simulated from L's node states. Called when the contact is made and whenever the node
// states change (Simulation::prepare, after a change of resolution): on the 50k-tet organ the margin
// check read every surface vertex of a level stepping a region of it, at every tick.
template <class T>
void note_simulated_surface(LevelContact<T>& lc, const Level<T>& L);

// Detection only: refits the BVH to L's positions and fills lc.hits with the surface triangles
// (with at least one free vertex) that the tool, moving from `from` to `to`, reaches within its
// radius (sorted). Returns false with a message if Embree failed.
template <class T>
bool find_tool_contacts(LevelContact<T>& lc, const Level<T>& L, const ToolShapeDef& shape, const ToolPose& from,
                        const ToolPose& to, const Vec3d& origin, Executor& exec, std::string& error);

// The contact pass at the end of a window: the tool moved from `lc.from` to `to` (world frame;
// `origin` is the body frame's origin). Updates L.x, L.v of free surface nodes and lc's results;
// lc.from becomes `to`. dt: the window's length (s). Returns false with a message if Embree failed.
template <class T>
bool resolve_tool_contact(LevelContact<T>& lc, Level<T>& L, const ToolShapeDef& shape, const ToolPose& to,
                          const Vec3d& origin, double dt, Executor& exec, std::string& error);

// Iterations of the projection over the touched triangles (Gauss-Seidel, in triangle order):
// neighbouring triangles share vertices, and moving one moves its neighbours' points.
inline constexpr int kContactIterations = 4;

// The most a free corner may move, per triangle and pass, over the push d of the triangle's
// point: the least-squares move b_k d / sum_j b_j^2 (over the free corners j) reaches at most
// (1 + sqrt 3) / 2 = 1.366 |d| when every corner is free (at b = (1/sqrt 3, ...)). When the point
// lies near a fixed or ghost corner the free weights are smaller and the move grows as d / b_k (a
// ghost corner on the adaptive organ flung a vertex 80 m). Such a triangle is left to its
// neighbours: the tool stays inside next to the held corner (max_penetration reports it).
// Capping the move instead ratcheted (the point never came out, so the corner was pushed again
// every pass). With 2 instead of the all-free bound, corners pushed up to twice the point's push
// overshot the tool's surface at every step, and bodies driven into a resting tool gained energy
// (three stress scenes, 1.7-1.9x their budget: docs/stress.md). 2.5 (with kRecoverySpeed) let a
// coarse triangle whose held corner had weight 0.4 push back a tool that otherwise sinks through
// it, but a body driven into a resting tool then gained energy from the lever: each step the point
// comes back while the corner nearest it goes out further than it came in (five stress scenes of
// seed 3, 1.05-1.32x their criterion, that pass at 1.37: docs/stress.md).
inline constexpr double kMaxCornerPush = 1.37;

// How fast a penetration the window's motion does not explain is pushed out. A vertex the
// radial push moved comes out, over a window, by at most what the window's motion brought it in
// (the tool's displacement against the vertex's own v dt, along the push) or, if more,
// kRecoverySpeed c_p dt (no more than the depth of the triangle points that moved it), c_p the
// level's P-wave speed: a surface moved at speed v sends a strain of about v / c_p into the
// body, so the push-out of a penetration found already there (the finer surface of a level a
// split made active under the tool, where the coarser one could not follow it: docs/tool.md)
// strains the body no more than a tool moving at 5% of c_p (the fastest path of `pliant stress
// --tools`). At the level's stable step c_p dt is about h_min / 2, so that is about h_min / 40 a
// window. Pushed out at once, a 6.8 mm penetration put 0.7 J into a 1.3 kg bar in one step (a
// stress scene: 1.04 J against its criterion's 0.96 J, docs/stress.md). A vertex a deep push
// moved (the tool went through its triangle in this window) is not limited. (Until 2026-11-28
// the allowance was added to the approach: a corner that the least-squares move carries up to
// 1.37x its point's push went out by both at every window, further than its point had come in,
// and bodies driven into a resting tool gained energy: stress scenes at 1.5-2.3x their
// criterion, docs/tool.md.)
inline constexpr double kRecoverySpeed = 0.05;
inline constexpr std::uint8_t kHeldRadial = 1, kHeldDeep = 2;  // LevelContact::held

}  // namespace pliant::detail
