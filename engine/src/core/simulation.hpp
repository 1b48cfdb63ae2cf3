// The precision-specific state behind World: bodies made of levels, prescribed motions, probes,
// and the step. World holds one Simulation<float> or Simulation<double>.
#pragma once
#include <algorithm>
#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "pliant/defs.hpp"
#include "pliant/hierarchy.hpp"
#include "pliant/level.hpp"
#include "pliant/level_passes.hpp"
#include "pliant/kernels/multilevel_passes.hpp"
#include "pliant/scheduler/executor.hpp"
#include "pliant/scheduler/level_schedule.hpp"
#include "pliant/tool.hpp"
#include "../collision/skin_binding.hpp"
#include "../multires/adaptivity.hpp"
#include "../collision/tool_contact.hpp"

namespace pliant::detail {

struct MotionState {
  std::vector<std::vector<std::int32_t>> nodes;  // per level: node indices of the region (active nodes)
  std::vector<KeyframeDef> keyframes;
  bool host_driven = false;               // set_motion_offset() took over
  Vec3d host_offset{};                    // m
  std::vector<Vec3d> host_from;           // m, per level: host offset at the start of its next step
  Vec3d offset_at(double time) const;     // m
};

template <class T>
struct SimBody {
  BodyDef def;
  // The body frame: every level stores positions relative to this point (the centre of the rest
  // bounding box of the body's mesh, m, world frame, kept in double: body_frame_origin), so that
  // float accuracy is the same wherever the body is. World converts at its edge (node_position,
  // probes, snapshot, ...).
  Vec3d origin{0, 0, 0};
  std::vector<Level<T>> levels;   // 0 (coarsest) .. L (finest); one level until multiresolution lands
  std::vector<MotionState> motions;
  // Per level: the factor its elastic moduli were scaled by (multiresolution calibration; 1 = none).
  std::vector<double> stiffness_factors;
  std::shared_ptr<const SkinState> skin;  // BodyDef::skin bound to every level; null without one
  std::shared_ptr<AdaptiveState> adapt;   // ActiveDef::Kind::adaptive; null otherwise
};

// A tool as the step sees it: its pose source and its contact with every level of every body it
// touches (collision/tool_contact.hpp).
template <class T>
struct ToolState {
  ToolDef def;
  bool host_driven = false;   // World::set_tool_pose took over from the keyframes
  ToolPose host_pose;
  std::vector<LevelContact<T>> levels;
  ToolReading reading;        // sums over its levels, from their last windows
  double work_total = 0;      // J, ToolReading::work summed over every step so far
  ToolPose pose_at(double t) const { return host_driven ? host_pose : tool_pose_at(def.keyframes, t); }
};

// The tets of every level around a probe's material point, which relocating the probe after a
// change of resolution reads instead of every stepped tet of the body (probe_placement.hpp).
struct ProbeCandidates {
  std::array<double, 3> X{};  // m, body frame at rest: the point the lists were made for
  double reach = -1;          // m: they hold for points within this of X (< 0: not made)
  std::vector<std::vector<std::int32_t>> tets;  // per level, ascending
};

struct ProbeState {
  std::string name;
  int body = 0, level = 0;
  std::int32_t tet = 0;
  std::array<double, 4> weights{};  // barycentric weights of the tet's corners
  bool refine = false;              // ProbeDef::refine: an adaptive body stays fine around it
  ProbeCandidates candidates;       // made for probes of adaptive bodies (World::add_probe)
};

// The origin of a body frame for a mesh (world frame, m): the centre of its rest bounding box.
// Every body-frame coordinate is then at most half the body's extent (the best float resolution),
// and the origin does not depend on the node order (a mean would, by rounding, and the bits of
// the body-frame rest positions seed the stable-step measurement: a renumbered mesh must get the
// same step).
Vec3d body_frame_origin(const TetMesh& mesh);

// Builds a level from a validated mesh (world frame): SoA arrays relative to `origin` (the body
// frame, SimBody::origin), rest geometry, masses, incidence, boundary, node states from the body's
// regions (given in the world frame), stable step (measured with exec's threads; the result does
// not depend on their number). Throws InputError on bad regions or material.
// regions_may_be_empty: a region that selects no node of this mesh is not an error (the coarser
// levels of a multiresolution body; the body checks that some level has the nodes).
template <class T>
Level<T> build_level(const TetMesh& mesh, const Vec3d& origin, const BodyDef& def, double courant,
                     std::vector<MotionState>& motions, Executor& exec, bool regions_may_be_empty = false);

// The nodes of `mesh` in region r (rest positions, tolerance 1e-9 of the mesh size; node lists
// checked against the mesh). Throws InputError naming `what` if none is selected, unless may_be_empty.
std::vector<std::int32_t> select_nodes(const TetMesh& mesh, const RegionDef& r, const std::string& what,
                                       const std::string& body, bool may_be_empty = false);

// A body of several levels (docs/multiresolution.md) from its hierarchy (world frame; every level
// in the body frame of the finest mesh): each level built as a whole (its stable step measured as
// for a single level), then who is active where applied (activation.hpp): stepped tets, node roles,
// ghosts and their sources, receivers, masses from the stepped tets with each ghost's mass moved to
// its sources, regions on active nodes.
template <class T>
SimBody<T> build_multilevel_body(const Hierarchy& h, const BodyDef& def, double courant, Executor& exec);

// Sizes the level's obstacle impulse record and refuses (InputError naming the node) a body
// whose free nodes start inside one of the (unit-normal) obstacles (obstacles.cpp).
template <class T>
void prepare_obstacles(Level<T>& level, const std::vector<ObstacleDef>& obstacles, const std::string& body,
                       const Vec3d& origin);

// ---- the stable step (stable_step.cpp) ----
// 2 c_p / h_min (rad/s): the highest frequency of a mesh of smallest altitude h_min (m) as the
// classic Courant estimate has it (not a bound: Kuhn meshes go 22% above it).
double geometric_frequency(double h_min, const MaterialDef& material);
// Highest angular frequency (rad/s) of the level's linearised undamped dynamics at rest, over
// its free nodes: sqrt of the largest Ritz value of `iterations` Lanczos steps on M^-1 K, with
// K from the level's model (linear elasticity for linear/stvk/corotational, the springs' own).
// From below: a lower bound of the true value, within 4e-4 at 30 iterations on the meshes
// measured (tests/core/test_physics_validation.cpp). Deterministic (fixed start, fixed-order
// sums). Uses the level's corner-force arrays as scratch (zeroed on return). 0 without free nodes.
template <class T>
double highest_frequency(Executor& exec, Level<T>& level, int iterations);
inline constexpr int kFrequencyIterations = 30;
inline constexpr double kFrequencyMargin = 0.98;  // the step is built for measured / margin
// Stable step (s) of the explicit integrator for highest frequency omega_max (rad/s), times the
// Courant number, tightened by damping: courant (2 / omega) (sqrt(1 + zeta^2) - zeta).
double stable_step_for(double omega_max, const MaterialDef& material, ForceModel model, double courant);
// stable_step_for(geometric_frequency(h_min)): the classic Courant bound, tightened by damping.
double courant_time_step(double h_min, const MaterialDef& material, ForceModel model, double courant);

// What one level needs to run its passes on a tick: kernel contexts pointing into the level and
// its body's other levels (built by Simulation::prepare, so that a tick allocates nothing).
template <class T>
struct LevelJobState {
  int body = 0, level = 0;
  ElementContext<T> ec;
  ElementPass<T> pass = nullptr;
  std::vector<std::size_t> run_start;  // stepped-tet index at which each run begins (+ the total)
  // A level whose stepped tets lie in short runs (a multiresolution level stepping a region of its
  // mesh) steps them from a list instead, in full vector lanes: stepped[i] is its i-th stepped tet
  // (Simulation::prepare decides; empty: by runs). Made in ascending order; a change of resolution
  // then edits it in place (Simulation::edit_list): a tet no longer stepped gives its position to
  // the list's last tet, a newly stepped one is appended. list_position[t] is tet t's position
  // (-1: not listed); listed_runs are the level's stepped runs the list holds (Level::stepped_runs
  // when it was made or last edited); listed_level the level's identity (its Level::tet[0] data).
  ListedElementPass<T> listed_pass = nullptr;
  std::vector<std::int32_t> stepped;
  AlignedVector<std::int32_t> list_position;
  std::vector<Range> listed_runs;
  const void* listed_level = nullptr;
  PackContext<T> pack;  // positions into x_packed, before the element pass (ec.xp set each tick)
  // Whether the element passes of the level's current window read the packed copy: decided at the
  // window's first slice, which packs it (Simulation::step). Every slice of a window reads the same
  // positions and velocities (the level moves at the window's end, its ghosts at its start), so one
  // pack serves the whole window: a level stepped every p ticks packs once per p ticks, not never
  // (a tick's slice alone, a p-th of its tets, never paid for a pack of the level).
  enum class WindowPack : std::uint8_t { undecided, packed, gathered };
  WindowPack window_pack = WindowPack::undecided;
  GatherContext<T> gc;
  IntegrateContext<T> ic;
  GhostContext<T> gh;
  ReceiveContext<T> rc;
  // The node passes' pieces (indices into Simulation's node pieces): the level's nodes that are not
  // inactive, as runs. A multiresolution level simulates part of its nodes; its gathers,
  // integration and obstacles cost what it simulates, not the whole level (a 49k-tet finest level
  // stepping 86 tets near a tool gathered all its 10k nodes every tick: as much time as its tets).
  std::size_t first_node_piece = 0, end_node_piece = 0;
  // A listed level's gather reads its own incidence: per node, the entries of Level::incidence
  // whose tet is stepped, in the same order, coded by list position (listed_corner_force). They fill
  // the front of the node's range of Level::incidence (gc.offsets is Level::incidence_offsets,
  // gc.ends = gather_end: the room after them takes the entries a change of resolution adds, so
  // that it edits the ranges of the nodes it reaches, not the level's). The entries it drops are
  // tets that are not stepped, whose corner forces are zero (apply_changes.cpp): a sum that starts
  // at +0 is not changed by adding a zero, so the forces are the same bits, and the gather reads a
  // stepped region's entries, not every tet around its nodes (a middle level stepping 342 of its
  // 5 906 tets read about 4x as many).
  AlignedVector<std::int32_t> gather_end, gather_incidence;
  AlignedVector<std::int32_t> gather_corner_offset;  // gather_incidence as offsets (encode_corner_offsets)
  // A listed level's rest data in list order (ElementContext::listed_tet, listed_grad,
  // listed_volume: ec points at them): its element passes and monitor load them instead of
  // gathering them from tets scattered over its mesh. Made by prepare() from `stepped`.
  AlignedVector<std::int32_t> listed_tet[4];
  AlignedVector<T> listed_grad[9], listed_volume;
  // A corotational listed level's warm-start rotations in list order (ElementContext::
  // listed_rotation): its force passes read and write them here instead of gathering and
  // scattering Level::rotation (on the 50k organ's coarser levels, a sixth of the listed pass in
  // perf samples). They are the level's current rotations: Simulation::write_back_rotations copies
  // them to Level::rotation before anything reads those by tet (a new list, the energy of a change).
  AlignedVector<T> listed_rotation[4];
  // A listed level's corner forces in list order (ElementContext::listed_corner_forces; ec and gc
  // point at them, and gather_incidence codes list positions, 4 x position + corner): a batch
  // stores them with one vector store per array, where scattering them to tets spread over the
  // level's mesh cost a quarter to a third of the listed pass (perf/layout_ab listed). The
  // level's own Level::corner_force is then not written for its stepped tets.
  CornerForceArrays<T> listed_corner_force;
  // The static obstacles against this level, one context each, refreshed on every tick whose
  // window ends for it: its node passes resolve them over each range right after integrating it
  // (run_gather_integrate, run_integrate), so they cost no phase or region of their own.
  std::vector<HalfSpaceContext<T>> obstacles;
};

// The phases of a tick, in the order they run (Simulation::step): A ghost refresh, the positions
// packed per node for the element passes that read them (after the ghosts: they pack ghosts too), B element
// passes, C gathers (+ integration of uncoupled levels), D impulses to coarser levels,
// E integration of coupled levels.
enum TickPhase : std::size_t { kPhaseGhosts, kPhasePack, kPhaseElements, kPhaseNodes, kPhaseReceive, kPhaseIntegrate, kTickPhases };

// A piece of one level's element work on a tick: a stretch of consecutive stepped tets, or of a
// listed level's list (LevelJobState::stepped).
template <class T>
struct ElementPiece {
  const LevelJobState<T>* job = nullptr;
  std::size_t first_tet = 0;  // its first tet (by runs) or its first position in the list (listed)
};

// A piece of one level's node work: a run of nodes [first, first + count) that holds every node
// of the run that is not inactive (short gaps of inactive nodes are kept inside a run: a gather or
// integration of an inactive node changes nothing that is read, and fewer pieces cost less).
template <class T>
struct NodePiece {
  const LevelJobState<T>* job = nullptr;
  std::size_t first = 0, count = 0;
};

// A level's positions and velocities with its ghosts where their sources are now (a level's own
// ghost entries are refreshed only at the start of its windows, so between windows they lag).
// Copies, for reports and outputs: energies, snapshots, probes. Without ghosts: a plain copy.
template <class T>
struct CurrentState {
  AlignedVector<T> x[3], v[3];
};
template <class T>
void current_state(const SimBody<T>& body, const Level<T>& L, CurrentState<T>& out);
// Where ghost g of level L (its index in L.ghosts) is now, and how fast it moves: its sources'
// positions and velocities weighted, summed in double in the order of its entries (current_state
// rounds these to T; the adaptive decisions take them the same way).
template <class T>
void ghost_now(const SimBody<T>& body, const Level<T>& L, std::size_t g, double x[3], double v[3]) {
  for (int k = 0; k < 3; ++k) x[k] = v[k] = 0;
  for (auto e = L.ghost_offsets[g]; e < L.ghost_offsets[g + 1]; ++e) {
    const Level<T>& S = body.levels[std::size_t(L.ghost_source_level[std::size_t(e)])];
    const auto n = std::size_t(L.ghost_source_node[std::size_t(e)]);
    const double w = L.ghost_weight[std::size_t(e)];
    for (int k = 0; k < 3; ++k) {
      x[k] += w * double(S.x[k][n]);
      v[k] += w * double(S.v[k][n]);
    }
  }
}
// One node's current position (m): its own, or for a ghost where its sources are now.
template <class T>
Vec3d node_now(const SimBody<T>& body, const Level<T>& L, std::size_t node) {
  Vec3d x{double(L.x[0][node]), double(L.x[1][node]), double(L.x[2][node])};
  if (L.state[node] != kNodeGhost) return x;
  const auto it = std::lower_bound(L.ghosts.begin(), L.ghosts.end(), std::int32_t(node));
  const std::size_t i = std::size_t(it - L.ghosts.begin());
  x = {0, 0, 0};
  for (auto e = L.ghost_offsets[i]; e < L.ghost_offsets[i + 1]; ++e) {
    const Level<T>& S = body.levels[std::size_t(L.ghost_source_level[std::size_t(e)])];
    const auto n = std::size_t(L.ghost_source_node[std::size_t(e)]);
    for (int k = 0; k < 3; ++k) x[std::size_t(k)] += L.ghost_weight[std::size_t(e)] * double(S.x[k][n]);
  }
  return x;
}

template <class T>
class Simulation {
 public:
  std::vector<SimBody<T>> bodies;
  std::vector<ProbeState> probes;
  T gravity[3] = {0, 0, 0};
  ScheduleKind schedule = ScheduleKind::staggered;
  PackedCorners packed_corners = PackedCorners::automatic;  // WorldDef::packed_corners
  std::vector<ObstacleDef> obstacles;  // static half-spaces, unit normals (World checks them)
  std::unique_ptr<EmbreeDevice> embree;  // made with the first tool; before `tools`: outlives their BVHs
  std::vector<ToolState<T>> tools;

  // Builds the jobs (one per level of every body), their periods for fine ticks of `tick_dt` (s)
  // (levels of a multiresolution body: level_period of their stable step; single-level bodies: 1)
  // and every kernel context. Call after bodies or the step change, with the tick of the step as
  // chosen (World: dt / its base sub-steps): when the deformation monitor sub-steps, the ticks
  // shrink and every level's step with them.
  void prepare(double tick_dt);
  // Sizes exec's region scratch for the largest tick the prepared jobs can make (an upper bound
  // of the chunks of every pass of every level at once), so that no tick allocates; step() calls
  // it at its first tick after a prepare (the tick of a change: its own step, which allocates).
  void size_region(Executor& exec);
  // prepare(): the periods of the levels whose nodes source ghosts two or more levels finer (their
  // receivers are stiffer than their own stable step was measured for), shortened.
  void shorten_far_sources(SimBody<T>& body);
  // prepare(): a period that grew kept to one whose windows start at this tick (before: the periods
  // before the prepare), and none below a finer level's.
  void align_periods(SimBody<T>& body, const std::vector<int>& before);
  double period_tick() const { return period_tick_; }  // s: the tick the periods were made for

  // One fine tick of size h (s) from time t for every body and level: ghost refresh (levels whose
  // window starts), element passes (every level's due slice), gathers, impulses to the coarser
  // levels, integration (levels whose window ends): one parallel region with a barrier between
  // phases; then obstacles, tools and prescribed motion. Returns false (and fills `where`) if a free node's state diverged.
  bool step(Executor& exec, double t, double h, std::string& where, std::int64_t step_index);
  std::int64_t ticks() const { return tick_; }
  std::size_t last_tick_tets() const { return last_tick_tets_; }  // tets computed by the last tick
  // The period (ticks) of the finest level that steps a tet, 1 if none does: the stepped tets'
  // corners move only at their level's window boundaries (integration, obstacles, tools and
  // prescribed motion at its end; ghosts refreshed at its start), so no stepped tet's deformation
  // changes more often than this (World's deformation monitor checks no more often).
  int finest_stepped_period() const {
    int p = 0;
    for (const LevelJob& j : jobs_)
      if (j.items > 0 && (p == 0 || j.period < p)) p = j.period;
    return p > 0 ? p : 1;
  }
  std::size_t pass_nodes(int body, int level) const;  // nodes the level's node passes run over
  bool steps_listed(int body, int level) const;        // its element pass runs from a list
  std::size_t gather_entries(int body, int level) const;  // corner forces its gather sums per step
  // What the level's last element pass put on tet's corners (N), [corner][component]: from
  // Level::corner_force, or from the step's list-ordered copy of a listed level; zero for a tet
  // the pass did not step. tet < the level's tet count.
  std::array<std::array<double, 3>, 4> corner_forces(int body, int level, std::size_t tet) const;

  void elastic_energies(Executor& exec, double& elastic) const;
  double body_energy(Executor* exec, const SimBody<T>& body) const;  // kinetic + elastic of one body (J); exec may be null
  void add_elastic_energy(Executor* exec, const SimBody<T>& body, const Level<T>& L, double& sum) const;
  // The free nodes' mass (kg), momentum (kg m/s) and kinetic energy about their mean velocity (J):
  // what take_energy can take at most, without changing the momentum.
  struct BodyMotion {
    double mass = 0, momentum[3] = {0, 0, 0}, relative = 0;
  };
  BodyMotion body_motion(const SimBody<T>& body) const;
  // Takes `excess` J from the body's motion about its mean velocity (all of it at most); `motion`
  // is body_motion(body) as the body is now (measured once for the decision and the taking).
  void take_energy(SimBody<T>& body, double excess, const BodyMotion& motion);
  // What a change of resolution adds to a body's kinetic + elastic energy (J), measured where the
  // change acts, not over the body: save_change_energy just before the change keeps, per level
  // that steps a tet, its nodes' states, its simulated nodes' masses and current positions and
  // velocities (ghosts where their sources are) and its stepped runs; change_energy_added after it
  // (reading the state after in place, ghosts placed) finds the nodes whose
  // state, mass, position or velocity differ (the changed region, the ghosts whose sources moved,
  // every node when a renormalisation rescaled the masses) and sums, before and after, the elastic
  // energy of the stepped tets around them or whose stepping changed and the kinetic energy of
  // those nodes. Every other term of the body's energy is the same bits before and after (a tet
  // with the same corners, rest data and warm start gives the same energy), so the difference is
  // that of two whole-body sums up to their rounding. On the 50k-tet organ held at its middle
  // level the two whole-body sums cost about 50 us each, this about a fifth of that.
  // Tests: ApplyChanges.TheEnergyAChangeAddsIsTheDifferenceOfTheBodysEnergies.
  struct ChangeEnergy {
    double added = 0;        // J: E_after - E_before
    double before_here = 0;  // J: the part of E_before where the change acted (<= E_before)
  };
  void place_ghosts(SimBody<T>& body);  // every ghost where its sources are now (after a change)
  void save_change_energy(const SimBody<T>& body);
  ChangeEnergy change_energy_added(SimBody<T>& body);  // places every ghost (place_ghosts) first
  // A change of an adaptive body that merged is undone (undo_change: applied again without its
  // merges) when the energy it adds, less what take_energy can take, is more than this share of the
  // body's energy before it. The merges that made random adaptive scenes unbounded added 39% to
  // 141% of it at once (docs/stress.md, seed 7); a few % is what the coarser tets lock of a sagging
  // body's strain, and such merges go ahead: a body at rest under a load must still coarsen.
  static constexpr double kUnpaidShare = 0.05;
  // Kinetic energy (J) at the time of the positions: 1/2 sum m |v_c|^2 with, on free nodes,
  // v_c = v + (h/2) a(x, v), the mean of the stored velocity (v_{n+1/2}: the one that moved x_n to
  // x_{n+1}) and the one the next sub-step of size h will give (v_{n+3/2}); a is the force of the
  // current state (element pass on scratch copies, so measuring never changes the trajectory)
  // over the mass, plus gravity, minus mass damping. Non-free nodes: their stored velocity.
  // `stored` receives 1/2 sum m |v|^2 of the stored velocities.
  double centred_kinetic(Executor& exec, double h, double& stored) const;
  // Largest element stiffness ratio over every stvk, corotational and springs level (1 if none): how far
  // the current deformation has raised the highest frequency squared above the rest state's
  // (kernels element_stiffness.hpp). Deterministic (a max), whatever the thread split.
  // Allocation-free once `scratch` and `chunk_max` have been sized (add_body does).
  double stiffness_ratio(Executor& exec) const;
  // True if some level's model can stiffen beyond its rest state (stvk, corotational, springs).
  bool can_stiffen() const;
  mutable std::vector<double> scratch;  // per-tet energies/stresses for reports (not the hot path)
  double period_tick_ = 0;              // s: prepare()'s tick_dt (a change of resolution prepares again with it)
  mutable std::vector<std::int32_t> energy_ids;  // add_elastic_energy: a listed level's stepped tets (grows, stays)
  mutable AlignedVector<T> energy_rotation[4];    // energies over lists of tets: their rotations in the lists' order
  mutable AlignedVector<T> level_rotation[4];     // add_elastic_energy by runs of a listed level: its rotations by tet
  // The warm-start rotations of level L's tets ids[0, n), in that order, into out: a listed level's
  // current ones from its job's list (LevelJobState::list_position), the others' from
  // Level::rotation, where a tet leaves its rotation when it leaves a list (edit_list). False, and
  // out untouched, when the level's job is not listed: Level::rotation holds them all.
  bool listed_rotations(const SimBody<T>& body, const Level<T>& L, const std::int32_t* ids, std::size_t n,
                        AlignedVector<T> (&out)[4]) const;
  // save_change_energy's record of the state before a change, and change_energy_added's scratch.
  struct ChangeEnergyLevel {
    bool saved = false;                // the level stepped a tet (else all its nodes were inactive)
    std::vector<std::uint8_t> state;   // per node
    std::vector<Range> stepped_runs;   // Level::stepped_runs
    AlignedVector<T> mass;             // per node (kg); simulated nodes' only (save_change_energy)
    CurrentState<T> now;               // positions (m), velocities (m/s), ghosts where their sources were; as mass
  };
  struct ChangeEnergyScratch {
    std::vector<ChangeEnergyLevel> before;
    std::vector<std::uint8_t> tet_mark;
    std::vector<std::int32_t> dirty, tets, phase_tets;
    std::vector<double> energy;  // per tet of a level, written for the listed tets only
  };
  ChangeEnergyScratch change_energy_;
  // Sizes scratch for n tets. Never shrinks: the levels of a body take it in turn, and resizing
  // from a coarse level's size back to the finest's zeroed 0.4 MB at every deformation check of the
  // 50k-tet organ (only the entries of stepped tets, written first, are read).
  void grow_scratch(std::size_t n) const {
    if (scratch.size() < n) scratch.resize(n);
  }
  mutable std::vector<double> chunk_max;  // stiffness_ratio: the largest ratio of each chunk of tets
  std::vector<NearShape> near_scratch_;  // step(): what refines by distance at a decision point (reused)

  void relocate_probes(int body);

  // The host took a level to write (World::level): the windows open now pack their positions again
  // at their next slice (LevelJobState::window_pack), so that what it wrote between two steps is
  // read by the slices after them, as without the pack; and every level refreshes its ghosts (they, or their sources, may have been written).
  void levels_given_to_host() { packs_stale_ = ghosts_stale_ = true; }
  // The listed levels' rotations (LevelJobState::listed_rotation) copied to Level::rotation, so that
  // whatever reads them by tet reads the current ones. O(listed tets); nothing when no tick ran
  // since the last one. The step does not need it (energies read a listed level's rotations from
  // its list: listed_rotations, current_rotations; a tet leaving a list leaves its rotation in
  // Level::rotation): 110-150 us a change on a level listing 14 000 tets.
  void write_back_rotations();
  // Level::rotation with a listed level's current rotations (its job's list copy) laid over, into
  // out: what a report reading the rotations by tet starts from (the energy, the stresses).
  void current_rotations(const SimBody<T>& body, const Level<T>& L, AlignedVector<T> (&out)[4]) const;
  // The job state of a level of one of `bodies` (null before the first prepare()).
  const LevelJobState<T>* job_of(const SimBody<T>& body, const Level<T>& L) const {
    const auto b = std::size_t(&body - bodies.data()), l = std::size_t(&L - body.levels.data());
    return b < job_of_body_.size() ? &job_state_[job_of_body_[b] + l] : nullptr;
  }

 private:
  bool packs_stale_ = false;
  bool region_sized_ = false;  // size_region done since the last prepare
  bool ghosts_stale_ = true;   // every level's ghosts refresh at their next window (step(), phase A)
  std::int64_t tick_ = 0;
  std::int64_t rotations_written_tick_ = -1;  // tick_ at the last write_back_rotations (its passes ran before it)
  std::size_t last_tick_tets_ = 0;
  std::vector<LevelJob> jobs_;
  std::vector<LevelDue> due_;
  std::vector<LevelJobState<T>> job_state_;
  std::vector<ElementPiece<T>> pieces_;
  std::vector<NodePiece<T>> node_pieces_;  // made by prepare(), fixed until the next one
  static void make_list(const Level<T>& L, LevelJobState<T>& js);
  static void edit_list(Level<T>& L, LevelJobState<T>& js, std::vector<Range> (&scratch)[2]);
  static void bind_list(const Level<T>& L, LevelJobState<T>& js);
  std::vector<Range> list_edit_scratch_[2];  // edit_list's: the runs a change turns off and on
  // Per phase of a tick (TickPhase): its plain and its predicate segments (lists that grow to the
  // largest tick, then stay).
  std::array<std::vector<Executor::Segment>, kTickPhases> tick_segments_;
  std::array<std::vector<Executor::PredicateSegment>, kTickPhases> tick_predicates_;
  std::vector<std::size_t> job_of_body_;  // first job of each body (its levels follow)
};

}  // namespace pliant::detail
