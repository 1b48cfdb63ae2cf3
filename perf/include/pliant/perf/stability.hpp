// Stability at the extremes (issue 3 §3) and headless stress runs (§5): the code behind
// `pliant stability` and `pliant stress`, and their ctest subsets, so that both call the same code.
//
// A *cell* is one small simulation built in code (no scene file): a scenario (a cantilever under
// gravity with a random velocity kick, or one of the extreme cases), a force model, a precision,
// a material and a time step given as a factor of the Courant bound. It ends as one of:
//   stable   - every step finite and the energy bounded (see EnergyMonitor) at dt <= the bound;
//   clamped  - dt above the bound with sub-stepping on: World split each step into substeps()
//              stable sub-steps (reported), and the run was then stable;
//   refused  - World refused the set-up (InputError) before any step, with its message;
//   diverged - a DivergenceError (non-finite state, reported by World at the step it happened),
//              or finite but unbounded energy, or a non-finite energy without DivergenceError.
#pragma once
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "pliant/defs.hpp"
#include "pliant/world.hpp"

namespace pliant::stability {

enum class Outcome { stable, clamped, refused, diverged };
const char* to_string(Outcome o);

// Energy boundedness, the criterion both harnesses use. Samples are taken every few steps:
//   M(t) = K(t) + U(t)              kinetic + elastic energy (J)
//   S(t) = K(0) + U(0) + max(|P(t) - P(0)|, |L(t)|) + W(t) + Eg
// where K is World::energies().kinetic, the kinetic energy of the velocity at the time of the
// positions (time-centred: the stored velocity is half a step off, and paired with the
// positions it swings by (omega dt / 2) of each mode's energy, which made bodies released from
// rest fail at the turning points of their motion; see pliant/world.hpp, Energies), P the
// potential of gravity and constant loads (World::energies().potential), L their work on the
// free nodes from the velocities (sum over steps of dt f . v: equal to -(P(t) - P(0)) except
// where float positions stagnate, see energy_monitor.cpp), W the
// accumulated |work| of the prescribed and fixed nodes on the body (sum over steps of
// |f_n . dx_n| on non-free nodes, an upper bound of the energy they inject) plus the kinetic
// energy they carry, and Eg a floor so that a body starting at rest with no load has a non-zero
// scale: 1e-9 m g_ref D (m body mass, g_ref = 9.81 m/s^2, D bbox diagonal) plus the energy
// 1/2 (lambda + 2 mu) e^2 V of a uniform strain e at rounding-noise level (e = 1e-4 in float,
// 1e-7 in double; 3E instead of lambda + 2 mu for springs).
// The run is *bounded* when, at every sample,
//   (a) M(t) <= kBoundFactor * S(t)                 (no energy appears from nowhere), and
//   (b) max K over the second half <= kGrowthFactor * max K over the first half + S_end
//       (kinetic energy does not grow exponentially, even while still below (a)).
// A symplectic Euler run at a stable step conserves a modified energy, so M stays within a few
// per cent of K(0)+U(0)+work (for a linear system M - (K(0)+U(0)+work) is (dt^2/8)(|a(t)|^2 -
// |a(0)|^2)_M, at most a third of M at Courant number 0.5); an unstable step grows M by orders of
// magnitude within tens of steps. Hence kBoundFactor = 1.5: the third of that swing plus a margin,
// and no more. (It was 10: a run that made ten times the energy it was given counted as stable,
// and the matrix's springs cantilever at E = 100 Pa, 4.5x its budget at 0.9x the bound, did.)
inline constexpr double kBoundFactor = 1.5;
inline constexpr double kGrowthFactor = 100.0;

// Relative error allowed on an adaptive body's mass (sum of its levels' node masses against rho x
// the finest mesh's volume): the engine rescales the masses (in double) to that total at every
// change, so what is left is rounding. Float: each stored mass is within 6e-8 of its double, so
// the sum is too (measured up to 3.9e-8); double: the order of the sum (measured up to 5.3e-15).
inline constexpr double kAdaptMassToleranceFloat = 2e-7;
inline constexpr double kAdaptMassToleranceDouble = 5e-14;
// The mass of a body as the step sees it (kg): the sum of every level's node masses (the ghosts
// and inactive nodes of a multiresolution body hold none).
double body_mass(const World& world, BodyId body);

class EnergyMonitor {
 public:
  // Records the initial state of `world` (call before the first step).
  void start(const World& world);
  // Call after every step: accumulates the work of the non-free nodes and of gravity and loads
  // on the free ones (cheap, O(nodes)).
  void after_step(const World& world);
  // Work given to the bodies by what after_step does not see (a tool: its force times its
  // displacement over the step), J; counted by its magnitude, as the driven nodes' work.
  void add_work(double joules) { work_ += std::abs(joules); }
  // Call every few steps (and at the end): samples K, U, P and checks (a). Returns false (with
  // why()) on a non-finite or unbounded energy.
  bool sample(const World& world);
  // Checks (b) over all samples; call at the end.
  bool finish();
  const std::string& why() const { return why_; }
  double peak_ratio() const { return peak_ratio_; }   // max M/S over the samples
  double scale() const { return last_scale_; }        // S at the last sample (J)
  double growth() const { return growth_; }           // (b)'s ratio, 0 if K stayed ~0
  double initial_total() const { return m0_; }
  double work() const { return work_; }

 private:
  std::vector<std::vector<double>> last_x_;  // per level of every body: previous positions of every node (3 per node)
  std::vector<std::vector<double>> last_m_;  // per level of every body: each node's mass while driven, else 0 (kg)
  double m0_ = 0, p0_ = 0, floor_ = 0, work_ = 0, load_work_ = 0, peak_ratio_ = 0, growth_ = 0, last_scale_ = 0;
  std::vector<double> kinetic_;
  std::string why_;
};

// ---- the matrix ---------------------------------------------------------------------------

struct CellSpec {
  std::string scenario = "cantilever";  // see scenarios()
  ForceModel model = ForceModel::corotational;
  Precision precision = Precision::float64;
  double young = 1e6, poisson = 0.3;    // Pa, -
  double dt_factor = 1.0;               // dt = factor x Courant bound
  bool substep = false;                 // for factors above 1: sub-step instead of being refused
  int steps = 1000;
  bool adapt = true;                    // TimeStepDef::adapt (the adaptive step)
  double refine_above = 0;              // adaptive_push: multiresolution.adapt.refine_above (0: its default)
  std::string label() const;            // "cantilever corotational double E=1e+06 nu=0.3 dt=1.0x"
};

struct CellResult {
  CellSpec spec;
  Outcome outcome = Outcome::stable;
  std::string message;       // refusal / divergence text, or a note (reoriented tets...)
  double bound = 0, dt = 0;  // s
  int substeps = 1;              // per step as chosen at load
  int max_substeps = 1;          // most per step (the adaptive step may raise it)
  std::int64_t adapted_steps = 0;  // steps the adaptive step sub-stepped (World::adapted_steps)
  double max_stiffness_ratio = 1;
  std::int64_t steps_run = 0;
  double peak_ratio = 0, growth = 0;
  double wall_s = 0;
  // Adaptive cells (scenario adaptive_push): node splits and merges, the most finest-level tets
  // stepped at a sample, and the worst relative error of the body's mass (body_mass against rho
  // x the finest mesh's volume) over the samples; a mass off by more than rounding is not
  // acceptable, whatever the energy did.
  std::int64_t splits = 0, merges = 0;
  std::size_t max_fine_tets = 0;
  double mass_error = 0;
  bool acceptable_mass() const;
  // Refused only above the bound without sub-stepping; clamped only with it or when the
  // deformation made the adaptive step sub-step; never diverged. Every cell that runs has a step
  // at most the bound: 1.0x is the default step ("dt": "auto" at Courant number 0.5), and 1.2x
  // runs only sub-stepped, below the bound. (A divergence at 1.0x used to be tolerated, so that
  // scenes with the default step could diverge while the summary said "0 diverged at <= 0.9x".)
  bool acceptable() const;
};

// Scenarios: "cantilever" (the matrix's), and the extremes "inverted_input" (mesh given with
// every other tet negatively oriented; finalize re-orients them), "inverted_state" (initial
// positions with the free end mirrored, so tets start inverted), "rotated_rest" (the rest mesh
// rotated 180 deg about x before add_body, cantilever under gravity), "rotated_state" (rest
// unchanged, initial positions rotated 180 deg about the body's axis), "compress_90" (one end
// fixed, the other pushed by a prescribed motion to 10% of the length, then held), "spin_100"
// (free body, no gravity, initial velocity of a rigid rotation at 100 rad/s), "slivers" (a box
// mesh whose inner node layers are squashed towards their neighbours and jittered, giving
// near-flat tets), "adaptive_push" (the cantilever as an adaptive body of 3 nested levels, 18 to
// 1152 tets, its free end pushed 2 cm sideways and brought back: splits, then merges; the cell's
// refine_above sets the threshold, coarsen_below is a quarter of it).
const std::vector<std::string>& scenarios();

CellResult run_cell(const CellSpec& spec, int threads = 1);

// Cells that diverge at dt <= 0.9x the bound because of engine bugs outside the time step
// (reported, see docs/stability.md "Divergences"): the explanation, or nullptr. They still count
// as unexpected (the command exits 3); the ctest checks that nothing else diverges.
const char* known_issue(const CellSpec& spec);

struct MatrixOptions {
  bool full = true;       // false: the ctest subset (extreme corners of the matrix)
  int steps = 2000;       // per cell
  int threads = 1;
  std::string machine;    // the CPU the report names (pliant stability fills it from /proc/cpuinfo)
  std::string filter;     // run only the cells whose label() contains this (empty: all)
  std::function<void(const CellResult&, std::size_t index, std::size_t count)> progress;
};

std::vector<CellSpec> matrix_cells(const MatrixOptions& options);
std::vector<CellResult> run_matrix(const MatrixOptions& options);

// docs/stability.md: the criteria, the counts and the tables.
std::string markdown_report(const std::vector<CellResult>& results, const MatrixOptions& options, double wall_s);

// ---- stress -------------------------------------------------------------------------------

struct StressOptions {
  double seconds = 10;          // wall-clock budget
  int threads = 2;              // largest thread count a scene may use
  std::uint64_t seed = 1;
  std::int64_t max_scenes = -1; // stop after this many scenes (-1: no limit)
  int repeat_every = 5;         // every Nth scene is run again (other thread count) and hashes compared
  std::vector<std::filesystem::path> mesh_dirs;  // shipped meshes (*.msh, *.vtu, *.vtk), if present
  bool use_implicit = true;     // implicit shapes when meshing_available()
  // One adaptive scene in three also gets a sphere tool (random_adaptive_scene). Off by default:
  // the scenes, hashes and digests without it stay those of docs/stress.md.
  bool tools = false;
  // With tools: half of them capsules (random length and lean), from a stream of their own. On by
  // default; off, every tool is the sphere it was before (the scenes the ctests name).
  bool capsules = true;
  std::function<void(const std::string&)> log;   // progress lines
};

struct StressScene {
  std::int64_t index = 0;
  std::uint64_t seed = 0;
  std::string description;
  std::string status = "ok";  // ok | diverged | unbounded | nan | irreproducible | refused | mass
  std::string message;
  std::int64_t steps = 0;
  // Adaptive multiresolution scenes: node splits and merges (World::adapt_stats), decisions that
  // changed what is stepped, changes undone (their added energy more than the motion could give
  // back: World::AdaptStats::undone), and the worst relative error of the body's mass over the run.
  bool adaptive = false;
  std::int64_t splits = 0, merges = 0, changes = 0, undone = 0;
  double mass_error = 0;
  int tool_steps = 0;  // steps in which the scene's tool touched the body (ToolReading::contacts > 0)
  double energy_peak = 0;  // the energy criterion's largest M/S over the run (fails above kBoundFactor)
  int threads = 1;
  std::uint64_t hash = 0;
  double wall_s = 0;
};

struct StressReport {
  double wall_s = 0;
  std::int64_t scenes = 0, steps = 0, failures = 0, repeats = 0, repeat_mismatches = 0;
  std::int64_t adaptive_scenes = 0, adaptive_split_and_merged = 0, splits = 0, merges = 0, undone = 0;
  double max_mass_error = 0;  // relative, over the adaptive scenes
  std::size_t rss_start = 0, rss_baseline = 0, rss_peak = 0, rss_end = 0;  // bytes
  double rss_drift = 0;           // bytes, end (median of last samples) - baseline (after warm-up)
  double rss_slope_per_min = 0;   // bytes/min, least squares over samples after warm-up
  bool memory_flat = true;
  std::uint64_t digest = 0;       // FNV-1a over the hashes of the first `digest_scenes` scenes
  std::int64_t digest_scenes = 0;
  std::vector<StressScene> failed;     // every failing scene
  std::vector<StressScene> first;      // the first few scenes, for the report
  std::vector<StressScene> closest;    // the passing scenes nearest the energy bound, nearest first
  std::map<std::string, int> counts;   // scenes per model / precision / mesh kind / dt mode
  std::size_t mesh_files = 0, implicit_shapes = 0;  // what the scenes were drawn from
  bool ok() const { return failures == 0 && repeat_mismatches == 0 && memory_flat; }
};

std::size_t resident_bytes();  // from /proc/self/statm
// Whether the scene of this seed is an adaptive multiresolution body (about one in five; see
// docs/stress.md): a function of the seed alone, drawn apart from the other scenes' choices.
bool adaptive_scene_seed(std::uint64_t scene_seed);
// The description of the scene of this seed (as a run prints it), without running it.
std::string stress_scene_description(std::uint64_t scene_seed, const StressOptions& options);
StressScene run_stress_scene(std::uint64_t scene_seed, std::int64_t index, const StressOptions& options,
                             int threads_override = -1);
StressReport run_stress(const StressOptions& options);
std::string stress_text(const StressReport& report, const StressOptions& options);

}  // namespace pliant::stability
