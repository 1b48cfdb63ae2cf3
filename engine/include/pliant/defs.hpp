// Plain definitions a host fills in (or a scene file produces) to create worlds and bodies.
// Every field has a sane default; units are SI.
#pragma once
#include <array>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "pliant/tet_mesh.hpp"

namespace pliant {

enum class Precision { float32, float64 };
enum class ForceModel { linear, stvk, corotational, springs };

const char* to_string(Precision p);   // "float" | "double"
const char* to_string(ForceModel m);  // "linear" | "stvk" | "corotational" | "springs"

struct DampingDef {
  double mass = 0.0;        // alpha (1/s): force -alpha m v on every node
  double stiffness = 0.0;   // beta (s): Rayleigh stiffness factor, viscous stress with phi = beta*lambda, psi = beta*mu
  // Viscous stress coefficients of the thesis (ch.2 §4), Pa*s: phi tr(eps_dot) I + 2 psi eps_dot.
  // When set they replace beta*lambda and beta*mu.
  std::optional<double> bulk_viscosity;   // phi
  std::optional<double> shear_viscosity;  // psi
};

struct MaterialDef {
  double young = 1e6;     // E (Pa), > 0
  double poisson = 0.3;   // nu, in [0, 0.5)
  double density = 1000;  // rho (kg/m^3), > 0
  DampingDef damping;
};

// A region of a body's rest configuration: which nodes it selects.
struct RegionDef {
  enum class Kind { box, sphere, nodes } kind = Kind::box;
  Vec3d min{}, max{};                 // box (m), inclusive
  Vec3d center{}; double radius = 0;  // sphere (m), inclusive
  std::vector<std::int32_t> nodes;    // explicit node indices (0-based, after loading)
};

// A keyframed rigid translation of a region, relative to its rest position; linear interpolation
// between keyframes, held constant after the last one (and before the first).
struct KeyframeDef {
  double time = 0;      // s
  Vec3d offset{};       // m
};
struct PrescribedMotionDef {
  RegionDef region;
  std::vector<KeyframeDef> keyframes;  // sorted by time, at least one
};

// A constant external force spread equally over the nodes of a region.
struct NodalLoadDef {
  RegionDef region;
  Vec3d total_force{};  // N, sum over the region's nodes
};

// Where a body's mesh comes from.
struct MeshSourceDef {
  enum class Kind { box, file, surface, implicit } kind = Kind::box;
  // box
  Vec3d min{0, 0, 0}, max{1, 0.1, 0.1};
  std::array<int, 3> cells{10, 1, 1};
  // 5 or 6. A scene file's box without the key gets 5 (6 for a multiresolution body, whose box
  // levels nest exactly only with 6); a host filling this struct in code chooses (default 6).
  int tets_per_cell = 6;
  // file (volume mesh) or surface (closed triangle surface meshed by CGAL); absolute after loading
  std::filesystem::path path;
  // surface or implicit: target cell size (m) of the body as simulated, after scale (the mesher
  // gets cell_size / scale in the units of the surface or shape)
  double cell_size = 0;
  // implicit: name of a shipped shape ("organ", ...)
  std::string shape;
  // surface: a surface that does not bound a volume is repaired first (meshing.hpp, repair_surface)
  bool repair = false;
  // applied after loading, to any kind: x <- scale * x + translate
  double scale = 1.0;
  Vec3d translate{0, 0, 0};
};

// Which level simulates which part of a body (MultiresolutionDef::active). Outside every region
// the coarsest level is active.
struct ActiveRegionDef {
  int level = 0;       // 0 = coarsest .. levels - 1 = finest
  RegionDef region;    // box, sphere or nodes (nodes: of the finest level's mesh)
};
// Adaptivity (ActiveDef::Kind::adaptive, docs/multiresolution.md "Adaptivity"): the body starts at
// its coarsest level; at fixed points of the tick sequence (the ticks where every level's window
// ends) a node of level l < finest is split where the level represents the deformation badly (its
// children and their ring become active, initialised from the current field), and a split node
// whose children stay close to what the coarse level would give for `min_dwell` seconds is merged
// back (it takes their restricted state).
// The split measure of a node is the largest jump |F_t - F_u| (Frobenius) of the deformation
// gradient between face-neighbouring stepped tets around it (about h |grad F|: zero for any rigid
// motion or uniform strain). The merge measure is the largest distance of a child's displacement
// from the coarse field interpolated at its rest place, over the coarse level's mean edge. Both
// are strain-like (dimensionless). With Measure::relative (the default) both are divided by the
// body's peak Green-Lagrange strain |E| = |(F^T F - I) / 2| over its stepped tets (at least
// kStrainFloor), so the thresholds are fractions of how much the body deforms now: the same
// defaults suit a soft organ sagging 4% and a stiff bar bent 0.1%, and a body at rest merges.
// With Measure::absolute they are compared as they are.
struct AdaptDef {
  enum class Measure { relative, absolute } measure = Measure::relative;
  static constexpr double kStrainFloor = 1e-3;  // strains below 0.1% never ask for resolution
  // Defaults chosen on the organ of scenes/adaptive_organ.json (docs/adaptivity.md): its probes stay
  // within 6% of the all-fine run's motion (the fine level's own error against a mesh twice as fine
  // is 14%) for 2.1x fewer tet updates; 0.25 / 0.05 gives 1.0% for 1.2x, 1.0 / 0.1 gives 13% for 2.6x.
  double refine_above = 0.5;     // split where the strain jumps by more than this (relative: x the peak strain)
  double coarsen_below = 0.1;    // merge where children stay within this of the coarse field (< refine_above)
  double min_dwell = 0.05;       // s a split node's children stay calm before merging
  double check_every = 0.002;    // s between decisions (500 Hz, the thesis's force loop: a body's motion
                                 //   changes over its lowest period, tens of ms; 0: every aligned tick)
  double refine_near = -1;       // m: nodes within this distance of a tool touching the body, of a
                                 //   prescribed motion's nodes, or of a probe with `refine`, are split
                                 //   and not merged while it is near; -1 (default, "auto"): one mean
                                 //   edge of the node's own level; 0: nothing refines by distance
                                 //   (but nodes inside a touching tool, or within a quarter edge of
                                 //   it, do not merge: docs/multiresolution.md)
};
struct ActiveDef {
  enum class Kind { finest, coarsest, level, regions, adaptive } kind = Kind::finest;
  int level = 0;                         // Kind::level
  std::vector<ActiveRegionDef> regions;  // Kind::regions
  AdaptDef adapt;                        // Kind::adaptive
};

// Several resolutions of one body simulated at once (thesis ch. 5; docs/multiresolution.md).
// Level levels - 1 is the body's mesh as given; each coarser level is an independent tet mesh of
// the same object: a box at cells / ratio^k, a surface (or the boundary of an implicit shape or of
// a volume file) simplified to about 1/ratio^2 of the faces per level and meshed at
// cell_size * ratio^k; or the meshes listed in `coarser` (coarse to fine).
struct MultiresolutionDef {
  int levels = 1;      // N >= 1; 1 = a single-resolution body
  double ratio = 2;    // r > 1: resolution ratio between neighbouring levels
  std::vector<MeshSourceDef> coarser;  // explicit coarser levels, coarse to fine (N = size + 1)
  // Triangles of each coarser level's simplified surface, coarse to fine (N - 1 counts; empty: the
  // finer level's / ratio^2). Each is then meshed at the cell size that gives about as many facets.
  std::vector<std::size_t> faces;
  // Scale each coarser level's elastic moduli so that the lowest mode its weight excites has the
  // finest level's frequency (linear tets lock in bending, the more so the coarser they are): the
  // levels then agree on the body's first modes (docs/multiresolution.md). Needs fixed nodes. Off
  // by default: a coarse level then no longer has the material's stress under a uniform strain
  // (the patch test across an interface fails by the factor), and a split's error near a load grew.
  bool calibrate = false;
  ActiveDef active;
};

// A rigid tool that touches bodies (thesis ch. 6; docs/tool.md): a sphere, or a capsule whose
// axis is the tool's local z (the segment from -length/2 to +length/2, rounded by `radius`).
// Its pose follows keyframes (position linear, orientation slerp; held after the last and before
// the first) until a host sets it (World::set_tool_pose). Free nodes of the bodies it touches are
// kept out of it; the force the bodies exert on it is read back (World::tool_reading, HapticLink).
struct ToolShapeDef {
  enum class Kind { sphere, capsule } kind = Kind::sphere;
  double radius = 0.005;  // m, > 0
  double length = 0;      // m, capsule only: distance between the centres of its two caps, > 0
};
using Quatd = std::array<double, 4>;  // unit quaternion (w, x, y, z): body of the tool -> world
struct ToolKeyframeDef {
  double time = 0;                 // s
  Vec3d position{};                // m, world frame: the centre of the sphere / of the capsule's axis
  Quatd orientation{1, 0, 0, 0};   // normalised when the tool is added
};
struct ToolDef {
  std::string name = "tool";
  ToolShapeDef shape;
  std::vector<ToolKeyframeDef> keyframes;  // sorted by time, at least one (a scene's "csv" path is read into these)
  std::vector<std::string> bodies;         // names of the bodies it touches; empty: every body
};

struct BodyDef {
  std::string name = "body";
  MeshSourceDef mesh;
  MultiresolutionDef multiresolution;
  MaterialDef material;
  ForceModel model = ForceModel::corotational;
  std::vector<RegionDef> fixed;                 // nodes held at their rest position
  std::vector<PrescribedMotionDef> prescribed;  // nodes moved along keyframes
  std::vector<NodalLoadDef> loads;
  // A render surface bound to the mesh (pliant/skin.hpp): an OBJ file in the units and frame of
  // the mesh's source (mesh.scale and mesh.translate apply to it too). Empty: none.
  std::filesystem::path skin;
};

struct TimeStepDef {
  std::optional<double> dt;   // s; empty = "auto" (the stable step)
  double courant = 0.5;       // C in dt <= C h_min sqrt(rho / (lambda + 2 mu)), in (0, 1]
  bool substep = false;       // an explicit dt above the bound is split into stable sub-steps instead of refused
  // Follow the deformation: every few steps, measure how much stiffer the elements are than at
  // rest (stvk and corotational stiffen under large stretch and inversion, springs when squashed) and split the step
  // into more sub-steps when the rest-state step would no longer be stable. Reported in
  // World::substeps() / max_substeps(). Off: the step stays as chosen at load, whatever happens.
  bool adapt = true;
};

// How the levels of multiresolution bodies are spread over the fine ticks (docs/multiresolution.md).
// staggered: a level of period 2^k computes its element pass in 2^k slices, one per tick, from the
// state at the start of its window, so that every tick costs about the same; naive: the whole pass
// on the last tick of the window (every coarse level on the same tick). Both give the same bits.
enum class Schedule { staggered, naive };
const char* to_string(Schedule s);  // "staggered" | "naive"
// Whether the element passes read a tet's corners from a copy of the positions (and, where the
// pass is damped, velocities) interleaved per node, written right before them, instead of
// gathering x[3][n] (Level::x_packed). The same values either way, so the same bits: only speed
// differs. automatic: the kernels' measured choice for this ISA and precision (packed with AVX2;
// gathered with AVX-512 and SSE; docs/performance.md); on / off: always / never, for a host whose
// machine measures otherwise, and for tests.
enum class PackedCorners { automatic, on, off };  // scene key packed_corners: "auto" | "on" | "off"
// A static obstacle: the solid half-space below a plane, which free nodes of every body may not
// enter (a floor, a table, a wall). After each (sub-)step a node found inside is put back onto
// the plane and loses its velocity into it (inelastic), and with friction some of its sliding
// velocity (Coulomb). Not a contact between bodies.
struct ObstacleDef {
  Vec3d point{0, 0, 0};   // m, a point of the plane
  Vec3d normal{0, 0, 1};  // out of the solid, into the free side; any length > 0 (normalised)
  double friction = 0;    // Coulomb coefficient mu >= 0 (0: frictionless)
};

struct WorldDef {
  Vec3d gravity{0, 0, -9.81};   // m/s^2
  Precision precision = Precision::float64;
  int threads = 0;              // 0: all cores the process may use; more than those is clamped to them
                                //   (World::threads() reports the number used)
  TimeStepDef time_step;
  Schedule schedule = Schedule::staggered;
  PackedCorners packed_corners = PackedCorners::automatic;
  std::vector<ObstacleDef> obstacles;  // static half-spaces (none by default)
};

struct ProbeDef {
  std::string name;
  std::string body;   // body name
  Vec3d point{};      // rest position (m); the probe follows this material point
  bool refine = false;  // an adaptive body keeps its finest level within AdaptDef::refine_near of it
};

struct OutputDef {
  double vtu_every = 0;   // s between VTU frames; 0 = no VTU output
  double probe_every = 0; // s between probe rows; 0 = every step
  bool sheet = false;     // `pliant run` also writes a contact sheet (sheet.png), as with --sheet
};

// Where pictures are taken from (`pliant run --png-every/--sheet`, `pliant render`).
struct CameraDef {
  Vec3d position{};     // m, the eye
  Vec3d target{};       // m, the point at the centre of the picture
  Vec3d up{0, 0, 1};    // the direction shown upwards (not along target - position)
  double fov_deg = 40;  // vertical field of view (degrees), in (0, 180)
};

// A whole scene: what `pliant run` executes.
struct SceneDef {
  double duration = 1.0;  // s
  WorldDef world;
  std::vector<BodyDef> bodies;
  std::vector<ProbeDef> probes;
  std::vector<ToolDef> tools;
  OutputDef output;
  std::optional<CameraDef> camera;  // none: pictures frame the bodies automatically
  bool realtime = false;  // `pliant run` paces the steps so that simulated time follows the wall clock (RunOptions::realtime)
  // s: the frame of a real-time run (the host's tick: 1 ms for a 1 kHz haptic loop). Each frame of
  // simulated time must be computed by the wall-clock time of its end (its deadline); the steps
  // inside a frame run back to back. 0: every step is its own frame.
  double realtime_frame = 0.001;
  std::filesystem::path source;  // the scene file, for messages ("" when built in code)
};

}  // namespace pliant
