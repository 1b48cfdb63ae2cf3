// World: the object a host application creates, fills with bodies, and steps from its own loop.
// Precision (float or double) is chosen at creation; the arrays of every level are reachable
// without copies through level<T>(). Errors come back as InputError / DivergenceError here, at
// the API edge; nothing below this header throws during a step.
//
// Two frames. Everything a host gives (meshes, regions, probe points, prescribed offsets) and
// everything the accessors below return in Vec3d (node_position, node_rest_position,
// probe_position, snapshot) is in the WORLD frame. The arrays of a level (level<T>(), positions(),
// rest_positions()) are in the BODY frame: relative to body_origin(body), the centre of the
// body's rest bounding box, kept in double. That way a float body placed 1 km from the world origin keeps the
// resolution it has at the origin (absolute float coordinates there would be only 6e-5 m apart).
// World position of node n = body_origin(body) + (x[0][n], x[1][n], x[2][n]). Velocities, forces,
// displacements (x - X) and offsets are the same in both frames.
#pragma once
#include <cstdint>
#include <array>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "pliant/defs.hpp"
#include "pliant/error.hpp"
#include "pliant/haptic_link.hpp"
#include "pliant/level.hpp"
#include "pliant/tet_mesh.hpp"
#include "pliant/tick_stats.hpp"
#include "pliant/tool.hpp"

namespace pliant {

// One level of a body as the step uses it (a single-level body has one, all of it stepped).
struct LevelInfo {
  int level = 0;                 // 0 = coarsest
  std::size_t nodes = 0, tets = 0;
  std::size_t stepped_tets = 0;  // tets this level steps (its active part)
  std::size_t active_nodes = 0;  // nodes it integrates (free or fixed)
  std::size_t ghost_nodes = 0;   // nodes that follow coarser levels
  std::size_t pass_nodes = 0;    // nodes its node passes (gather, integration, obstacles) run over:
                                 // those not inactive, and short gaps between them
  bool listed = false;           // its element pass reads its stepped tets from a list: they lie in
                                 // short runs (a region of its mesh), and a list fills the vector lanes
  std::size_t gather_entries = 0;  // corner forces its gather sums per step: over its pass nodes, every
                                   // tet around them, or (listed) its stepped tets' corners only
  int period = 1;                // fine ticks per step of the level
  double dt = 0;                 // s, its step: period x the tick
  double stable_dt = 0;          // s, its stable bound
  double stiffness_factor = 1;   // its moduli over the material's (multiresolution calibration)
};

using BodyId = int;
using ToolId = int;

// Energies of the current state, all at the time of the positions x.
// The integrator (symplectic Euler: v += h a(x, v), then x += h v) is the leapfrog scheme: the
// stored velocity is v_{n+1/2}, the one that moved x_n to x_{n+1}, half a step off x_{n+1}.
// Paired with U(x_{n+1}) as it is, the total oscillates by about (omega h / 2) of the energy of
// each mode, and near the stability limit (omega h -> 2) by a factor up to 1/(1 - omega h/2)
// (10x at omega h = 1.8), so a sampled energy says little about stability. `kinetic` therefore
// uses the velocity at the time of the positions, v_c = v_{n+1/2} + (h/2) a(x_{n+1}, v_{n+1/2}), the
// mean of v_{n+1/2} and the v_{n+3/2} the next (sub-)step will give: for a linear system,
// kinetic + elastic is then the scheme's invariant (1/2 v_{n+1/2} M v_{n+3/2} + U(x_{n+1}),
// exactly conserved) plus (h^2/8) |a|_M^2 >= 0, at most 1/(1 - (omega h/2)^2) times it (4/3 at
// omega h = 1, i.e. Courant number 0.5), and still grows without bound at an unstable step.
// Costs one force evaluation (on scratch copies: measuring never changes the trajectory).
struct Energies {
  double kinetic = 0;         // J, 1/2 sum m |v_c|^2, time-centred (above); fixed/prescribed nodes: stored v
  double kinetic_stored = 0;  // J, 1/2 sum m |v|^2 of the stored velocities v_{n+1/2}
  double elastic = 0;         // J, sum of element energies of the body's model at x
  double potential = 0;       // J, of gravity and constant nodal loads at x, relative to the rest state
  double total() const { return kinetic + elastic + potential; }
};

class World {
 public:
  explicit World(const WorldDef& def = {});
  ~World();
  World(World&&) noexcept;
  World& operator=(World&&) noexcept;

  // Adds a body whose mesh is built from def.mesh (box, file, surface or implicit shape).
  BodyId add_body(const BodyDef& def);
  // Adds a body on a mesh the host made (def.mesh is ignored). The mesh is validated.
  BodyId add_body(const BodyDef& def, TetMesh mesh);
  // Attaches a probe to the material point at rest position def.point of body def.body.
  int add_probe(const ProbeDef& def);

  // Advances every body by dt() (in substeps() equal sub-steps when sub-stepping).
  // Throws DivergenceError naming body, level, step and node if the state stops being finite.
  void step();

  // Steps until the simulated time reaches t (s) to within half a step, and returns the steps
  // taken (0 if it is there already): a host keeps simulated time on its own clock by calling it
  // each frame with the clock's time since the world started (real time; RunOptions::realtime
  // does the same for `pliant run`). The steps are the same as step()'s.
  std::int64_t advance_to(double t);

  double time() const;             // s
  std::int64_t steps() const;      // calls of step() so far
  double dt() const;               // s, the step of step()
  double stable_dt() const;        // s, smallest Courant bound over all levels
  int substeps() const;            // sub-steps the next step() takes (the adaptive step may raise it)
  // The adaptive step (TimeStepDef::adapt): the most sub-steps any step() took, how many step()
  // calls took more sub-steps than chosen at load, and the elements' stiffness
  // ratio (current largest Hessian eigenvalue over the rest one: 1 at rest; last and largest measured).
  int max_substeps() const;
  std::int64_t adapted_steps() const;
  double stiffness_ratio() const;
  double max_stiffness_ratio() const;
  // How many times the ratio was measured (every 1 to 16 moves of the finest level that steps a
  // tet; every step while it is high or sub-stepped).
  std::int64_t stiffness_checks() const;
  Vec3d gravity() const;           // m/s^2
  const std::vector<ObstacleDef>& obstacles() const;  // WorldDef::obstacles, normals of unit length
  Precision precision() const;
  Schedule schedule() const;
  int threads() const;  // used: WorldDef::threads, clamped to the cores the process may use (0: all of them)

  std::size_t body_count() const;
  BodyId find_body(std::string_view name) const;  // -1 if there is none
  const BodyDef& body_def(BodyId body) const;
  int level_count(BodyId body) const;
  LevelInfo level_info(BodyId body, int level) const;
  // Work and wall time per fine tick (every sub-step of step() is a tick), since the world began.
  const TickStats& tick_stats() const;
  std::size_t node_count(BodyId body, int level = 0) const;
  std::size_t tet_count(BodyId body, int level = 0) const;
  // The forces (N) the level's last element pass put on the four corners of `tet`, [corner][x y z];
  // zero for a tet the level does not step. Level::corner_force holds the same for a level stepped
  // by runs; a listed level (LevelInfo::listed) keeps its own in list order, and this reads them.
  // InputError for a tet out of range.
  std::array<Vec3d, 4> corner_forces(BodyId body, int level, std::size_t tet) const;
  // What loading did to the body's mesh: non-tetrahedral cells skipped, inverted tets re-oriented,
  // unused vertices dropped (all zero for a clean mesh).
  const MeshLoadReport& mesh_load_report(BodyId body) const;
  // For a body read from a volume mesh file: node_map(body)[i] is the engine's node index (the
  // index into positions(), level 0) of the file's i-th node, counted from 0 in the order the
  // file lists them (a Gmsh file's n-th node, whatever its id), or -1 when no tet uses it (not
  // loaded). The engine renumbers nodes for memory locality, so file index i is rarely node i.
  // Empty for other bodies (boxes, meshed surfaces and shapes, meshes given in code).
  const std::vector<std::int32_t>& node_map(BodyId body) const;

  // The world position (m) of the body frame's origin: the centre of the rest bounding box of the
  // body's mesh, in double. Positions in the level arrays are relative to it (see the top of this
  // file). It does not change while the body moves.
  Vec3d body_origin(BodyId body) const;

  // Zero-copy access to a level's arrays, in the BODY frame (positions relative to
  // body_origin(body)). T must match the world's precision (else InputError). Positions and
  // velocities may be written between steps (initial conditions, body frame); sizes must not change,
  // nor the rest data (tet, grad, volume: the step keeps copies of a listed level's, made at load).
  // A level stepped every p > 1 ticks (a multiresolution body's coarser levels) reads a copy of its
  // positions and velocities taken at the first tick of its window: this call marks those copies
  // stale, so write through a reference obtained after the last step (call level() again) for the
  // next tick to read what was written; writes through an older reference are read from the
  // level's next window.
  template <class T>
  Level<T>& level(BodyId body, int level = 0);
  template <class T>
  const Level<T>& level(BodyId body, int level = 0) const;

  // Reads one byte of each page (4 KiB) of the bodies' level arrays, `pages` pages a call, from
  // where the last call stopped (round and round); returns how many it read. Changes nothing. For
  // hosts stepping in real time, in the idle time between frames (`pliant run --realtime` calls
  // it there): on a virtual machine whose host reclaims guest memory left untouched, the arrays of
  // a level idle for seconds took 100-400 us per 36 KB to read again (docs/adaptivity.md), which
  // the frame that starts using them pays.
  std::size_t touch_pages(std::size_t pages);

  // The same, read-only, as spans over the SoA arrays (no copy; valid until the body is destroyed):
  // positions<float>(body)[2][n] is node n's z (m) in the BODY frame, i.e. its world z is
  // body_origin(body)[2] + positions<float>(body)[2][n]. T must match the world's precision.
  template <class T>
  std::array<std::span<const T>, 3> positions(BodyId body, int level = 0) const;   // m, body frame
  template <class T>
  std::array<std::span<const T>, 3> velocities(BodyId body, int level = 0) const;  // m/s
  template <class T>
  std::array<std::span<const T>, 3> rest_positions(BodyId body, int level = 0) const;  // m, body frame

  // World frame (body_origin + the level's arrays, in double).
  Vec3d node_position(BodyId body, std::size_t node, int level = 0) const;   // m
  Vec3d node_rest_position(BodyId body, std::size_t node, int level = 0) const;

  // The host takes over prescribed motion `motion` of a body: from the next step on, its nodes
  // sit at rest position + offset (m), and their velocity is the offset's rate of change.
  void set_motion_offset(BodyId body, int motion, const Vec3d& offset);

  // ---- adaptivity (multiresolution.active = adaptive; docs/multiresolution.md "Adaptivity") ----
  struct AdaptStats {
    std::int64_t splits = 0, merges = 0;  // node decisions so far
    std::int64_t checks = 0;              // decision points so far (ticks where every level's window ended)
    std::int64_t changes = 0;             // decisions that changed what is stepped
    double apply_seconds = 0;             // s of wall time spent applying the changes
    double check_seconds = 0;             // s of wall time of the decision points, applies included
    double check_max_seconds = 0;         // s, the longest of them
    std::int64_t touched_nodes = 0, touched_tets = 0;  // nodes and tets the applies read or wrote (their work)
    // Of `splits`, those of nodes inside a region already refined by their neighbours: they keep
    // that refinement (no merge drops detail nobody measured) rather than add to it, and the split
    // budget does not limit them.
    std::int64_t keeping_splits = 0;
    // Changes undone because they added more energy than the body's motion could give back
    // (docs/multiresolution.md "Energy at a change"), and the merges they dropped (applied again
    // without them; those nodes wait min_dwell again). Not in `merges`.
    std::int64_t undone = 0, deferred_merges = 0;
  };
  AdaptStats adapt_stats(BodyId body) const;  // zeros for a body that is not adaptive
  // At its next decision, an adaptive body activates every node up to `level` (0: the coarsest
  // everywhere), whatever the measure says; afterwards the measure decides again.
  void force_level(BodyId body, int level);
  // Multiplies an adaptive body's thresholds (refine_above, coarsen_below) by `scale` >= 1 from its
  // next decision on: above 1 it splits less and merges more (coarser, cheaper). The real-time
  // controller of `pliant run --realtime` sets it; 1 is the scene's own thresholds.
  void set_adapt_scale(BodyId body, double scale);
  double adapt_scale(BodyId body) const;
  // The finest level an adaptive body may split to (nodes split beyond it merge at the next tick
  // where every level's window ends, without waiting for check_every); level_count - 1 lifts the cap. The real-time controller lowers it when raising the
  // thresholds is not enough.
  void set_adapt_cap(BodyId body, int level);
  int adapt_cap(BodyId body) const;
  // At most `splits` nodes split at each decision of an adaptive body (>= 1; the first ones in the
  // decision's fixed order, coarse to fine; the others wait for the next decision); merges and
  // force_level are not limited. Bounds what one change costs (a split applies in ~0.2 ms on the
  // 50k-tet organ): the real-time controller sets 2, so that refining grows a region over
  // successive decisions and a frame never has to absorb a whole region's split at once.
  // Unlimited by default (std::numeric_limits<int>::max()).
  void set_adapt_split_budget(BodyId body, int splits);
  int adapt_split_budget(BodyId body) const;
  // After a change of resolution of an adaptive body, no decision for `seconds` of simulated time
  // (>= 0; 0 by default). Then decisions come at its check_every again, a tool pressing a triangle
  // it cannot push decides at once again, and a lowered cap merges. force_level is never held back.
  // The real-time controller sets one frame: a change costs 0.45-0.9 ms on the 50k-tet organ, its
  // decision points come every 0.22 ms, and right after its first change its tool pressed the new
  // finer surface's ghost corners, which decided at every point: three changes in one 1 ms frame
  // (2.3 ms of stepping). Decisions stay at fixed points of the tick sequence (any thread count).
  void set_adapt_change_interval(BodyId body, double seconds);
  double adapt_change_interval(BodyId body) const;
  // The earliest simulated time (s) at which an adaptive body's next decision may come: the later
  // of its next check_every and the end of its change interval; the decision comes at the first
  // tick from then on where every level's window ends (-infinity: forced, at the next such tick;
  // +infinity for a body that is not adaptive). A tool pressing a triangle it cannot push may bring
  // one sooner. `pliant run --realtime` starts a frame that holds one early, in the slack of the
  // frame before (docs/multiresolution.md).
  double adapt_next_decision(BodyId body) const;

  // ---- skins (pliant/skin.hpp, BodyDef::skin) ----
  bool has_skin(BodyId body) const;
  const std::vector<std::array<std::int32_t, 3>>& skin_triangles(BodyId body) const;  // empty without a skin
  const std::vector<double>& skin_rest_positions(BodyId body) const;  // m, world frame, 3 per vertex
  // Where the skin's vertices are now (m, world frame, 3 per vertex, into `out`): each follows its
  // triangle on the finest level that is active there (ghost nodes where their sources are now).
  void skin_positions(BodyId body, std::vector<double>& out) const;
  // The farthest any skin vertex is from the level's surface at rest (m): how well it fits the mesh.
  double skin_max_distance(BodyId body, int level) const;

  // ---- tools (docs/tool.md) ----
  // Adds a rigid tool touching the bodies named in def.bodies (all bodies if empty), which must
  // already be in the world: every level of each gets a collision surface (an Embree BVH over its
  // boundary triangles). Throws InputError naming the field for bad shapes, keyframes or names.
  ToolId add_tool(const ToolDef& def);
  std::size_t tool_count() const;
  const ToolDef& tool_def(ToolId tool) const;
  // The host takes over the tool's pose (world frame) from the next step on; the tool moves from
  // where it was to there over that step (contact sees the sweep: nothing tunnels through).
  void set_tool_pose(ToolId tool, const ToolPose& pose);
  ToolPose tool_pose(ToolId tool) const;  // at time()
  // What the bodies did to the tool in the last step: force, contacts, held nodes, penetration.
  ToolReading tool_reading(ToolId tool) const;
  // The lock-free exchange a haptic thread reads the tool's force from (see haptic_link.hpp);
  // step() publishes every reading into it. Valid as long as the world.
  const HapticLink& haptic_link(ToolId tool) const;

  std::size_t probe_count() const;
  const std::string& probe_name(int probe) const;
  Vec3d probe_position(int probe) const;  // m, world frame, interpolated in the probe's tet

  // Total impulse (N s) the static obstacles (WorldDef::obstacles) have given the nodes of a
  // body's level since the start: the sum of m (v_after - v_before) over every contact, so that
  // the body's momentum change is the impulse of gravity, loads and fixed nodes plus this one.
  Vec3d obstacle_impulse(BodyId body, int level = 0) const;

  Energies energies() const;  // see Energies: kinetic is time-centred
  double max_displacement() const;  // m, largest |x - X| over all nodes
  // 64-bit FNV-1a hash of the bits of every position (body frame) and velocity, in body and level order.
  std::uint64_t state_hash() const;

  // For result files: current positions (interleaved, world frame), tets, displacement and per-tet
  // Cauchy stress (9 components, Pa) and von Mises stress (Pa) of one body's level.
  struct Snapshot {
    std::vector<double> points, displacement, stress, von_mises;
    std::vector<Tet> tets;
  };
  Snapshot snapshot(BodyId body, int level = 0) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Builds the tet mesh a MeshSourceDef describes (box, file, surface, implicit), then applies its
// scale and translation.
TetMesh build_mesh(const MeshSourceDef& source, MeshLoadReport* report = nullptr);

}  // namespace pliant
