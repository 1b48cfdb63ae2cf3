// Headless stress runs (issue 3 §5): random valid scenes back to back, each checked for
// divergence, non-finite or unbounded energy; some re-run with another thread count and their
// state hashes compared; resident memory sampled after every scene.
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <fmt/format.h>
#include <fstream>
#include <optional>

#include "pliant/error.hpp"
#include "pliant/mesh_io.hpp"
#include "pliant/meshing.hpp"
#include "pliant/run.hpp"
#include "pliant/perf/stability.hpp"

namespace pliant::stability {
namespace {
namespace fs = std::filesystem;

std::uint64_t splitmix(std::uint64_t& s) {
  std::uint64_t z = (s += 0x9E3779B97F4A7C15ull);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

struct Rng {
  std::uint64_t s;
  double uniform() { return double(splitmix(s) >> 11) * 0x1.0p-53; }
  double uniform(double a, double b) { return a + (b - a) * uniform(); }
  double log_uniform(double a, double b) { return std::exp(uniform(std::log(a), std::log(b))); }
  int integer(int a, int b) { return a + int(splitmix(s) % std::uint64_t(b - a + 1)); }  // [a, b]
  bool chance(double p) { return uniform() < p; }
};

// Meshes of the shipped set and of implicit shapes, loaded once and normalised: centred on the
// origin, bounding-box diagonal 0.2 m.
struct MeshCache {
  std::vector<std::pair<std::string, TetMesh>> files;
  std::vector<std::pair<std::string, TetMesh>> implicit;
};

void normalise(TetMesh& m) {
  Vec3d lo{1e300, 1e300, 1e300}, hi{-1e300, -1e300, -1e300};
  for (std::size_t i = 0; i < m.node_count(); ++i)
    for (int k = 0; k < 3; ++k) {
      lo[k] = std::min(lo[k], m.points[3 * i + k]);
      hi[k] = std::max(hi[k], m.points[3 * i + k]);
    }
  const double d = std::sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) +
                             (hi[2] - lo[2]) * (hi[2] - lo[2]));
  const double s = 0.2 / d;
  for (std::size_t i = 0; i < m.node_count(); ++i)
    for (int k = 0; k < 3; ++k) m.points[3 * i + k] = s * (m.points[3 * i + k] - 0.5 * (lo[k] + hi[k]));
}

MeshCache& cache(const StressOptions& o) {
  static std::optional<MeshCache> c;
  if (c) return *c;
  c.emplace();
  for (const auto& dir : o.mesh_dirs) {
    std::error_code ec;
    if (!fs::is_directory(dir, ec)) continue;
    std::vector<fs::path> paths;
    for (const auto& e : fs::directory_iterator(dir, ec)) {
      const auto ext = e.path().extension().string();
      if (ext == ".msh" || ext == ".vtu" || ext == ".vtk") paths.push_back(e.path());
    }
    std::sort(paths.begin(), paths.end());
    for (const auto& p : paths) {
      try {
        TetMesh m = read_tet_mesh(p);
        if (m.tet_count() == 0 || m.tet_count() > 25000) continue;
        normalise(m);
        c->files.emplace_back(p.filename().string(), std::move(m));
      } catch (const std::exception&) {
        // not a volume mesh this build reads: skip it
      }
    }
  }
  if (o.use_implicit && meshing_available()) {
    for (const auto& name : implicit_shape_names()) {
      try {
        TetMesh m = mesh_implicit_shape(name, 0.012);
        c->implicit.emplace_back(name, std::move(m));
      } catch (const std::exception&) {
      }
    }
  }
  return *c;
}

struct Bounds {
  Vec3d lo{1e300, 1e300, 1e300}, hi{-1e300, -1e300, -1e300};
};
Bounds bounds(const TetMesh& m) {
  Bounds b;
  for (std::size_t i = 0; i < m.node_count(); ++i)
    for (int k = 0; k < 3; ++k) {
      b.lo[k] = std::min(b.lo[k], m.points[3 * i + k]);
      b.hi[k] = std::max(b.hi[k], m.points[3 * i + k]);
    }
  return b;
}

struct Scene {
  WorldDef world;
  BodyDef body;
  TetMesh mesh;
  std::string description, mesh_kind, dt_mode;
  double spin = 0;        // rad/s about z, initial velocity
  double dt_factor = 0;   // 0: auto
  bool substep = false;
  int steps = 0;
  // Adaptive multiresolution scenes (random_adaptive_scene): the body is def.mesh's box at
  // `levels` levels, `mesh` its finest level. Times of the prescribed motion's keyframes, of
  // min_dwell and of check_every are fractions of the run (steps x dt) until run_stress_scene,
  // which knows dt, turns them into seconds; cp is the P-wave speed (m/s) that caps the motion.
  bool adaptive = false;
  std::string adapt_kind;  // "nested" | "non-nested"
  double cp = 0;
  // A tool pressed into the body (random_adaptive_scene, one scene in three): keyframe times and
  // positions as for the pulse, fractions of the run until timeline_in_seconds.
  std::optional<ToolDef> tool;
};

// An adaptive body: a box of 2 or 3 levels, ratio 2, 6 tets per cell (fine cells a multiple of
// 2^(levels-1), so the levels nest), or, one time in six, fine cells one short of that multiple
// (the coarser boxes, ceil(cells / 2^k), then have nodes that are not fine nodes: non-nested).
// One end fixed, the other pushed sideways and released once or twice (a prescribed motion that
// returns to rest: strain comes and goes, so nodes split and then merge), random thresholds,
// dwell and decision interval, mostly mass-damped so the body calms after the release.
Scene random_adaptive_scene(std::uint64_t seed, const StressOptions& o) {
  Rng r{seed ^ 0x5eedada7ull};
  Scene s;
  s.adaptive = true;
  const int levels = r.chance(0.5) ? 2 : 3;
  const int f = levels == 2 ? 2 : 4;
  const bool nested = !r.chance(1.0 / 6.0);
  s.adapt_kind = nested ? "nested" : "non-nested";
  // Coarsest cells: 2-5 (2-4 at 3 levels) along x, 1-2 (1 at 3 levels) across: at most 960
  // (2 levels) or 1536 (3 levels) fine tets.
  const std::array<int, 3> coarse{r.integer(2, levels == 2 ? 5 : 4), levels == 2 ? r.integer(1, 2) : 1,
                                  levels == 2 ? r.integer(1, 2) : 1};
  std::array<int, 3> cells{f * coarse[0], f * coarse[1], f * coarse[2]};
  if (!nested) cells[0] -= 1;
  const double length = r.uniform(0.1, 0.3);
  const double a = length / coarse[0];  // coarsest cell (m)
  const Vec3d size{length, coarse[1] * a * r.uniform(0.6, 1.2), coarse[2] * a * r.uniform(0.6, 1.2)};
  BodyDef& b = s.body;
  b.name = "stress";
  b.mesh.kind = MeshSourceDef::Kind::box;
  b.mesh.min = {0, 0, 0};
  b.mesh.max = size;
  b.mesh.cells = cells;
  b.mesh.tets_per_cell = 6;
  b.multiresolution.levels = levels;
  b.multiresolution.ratio = 2;
  b.multiresolution.active.kind = ActiveDef::Kind::adaptive;
  AdaptDef& ad = b.multiresolution.active.adapt;
  // Relative thresholds (AdaptDef::Measure::relative, fractions of the body's peak strain): from
  // refining nearly everything (0.15) to refining only where the strain varies most (2).
  ad.refine_above = r.log_uniform(0.15, 2.0);
  ad.coarsen_below = ad.refine_above * r.uniform(0.05, 0.6);
  ad.min_dwell = r.uniform(0, 0.15);                          // fraction of the run, for now
  ad.check_every = r.chance(0.4) ? 0 : r.uniform(0.002, 0.05);  // fraction of the run, for now
  s.mesh = make_box_mesh(b.mesh.min, b.mesh.max, b.mesh.cells, 6);
  s.mesh_kind = "adaptive";
  const ForceModel models[] = {ForceModel::linear, ForceModel::stvk, ForceModel::corotational, ForceModel::springs};
  b.model = models[r.integer(0, 3)];
  s.world.precision = r.chance(0.5) ? Precision::float32 : Precision::float64;
  s.world.threads = r.integer(1, std::max(1, o.threads));
  s.world.gravity = r.chance(0.7) ? Vec3d{0, 0, -9.81} : Vec3d{0, 0, 0};
  s.world.time_step.courant = r.chance(0.7) ? 0.5 : r.uniform(0.2, 0.5);
  auto& mat = b.material;
  mat.young = r.log_uniform(3e4, 3e6);
  const double nus[] = {0.0, 0.25, 0.3, 0.4, 0.45};
  mat.poisson = nus[r.integer(0, 4)];
  mat.density = r.uniform(500, 2000);
  const int damping = r.integer(0, 4);  // 0: none, 1-3: mass, 4: Rayleigh
  if (damping >= 1 && damping <= 3) mat.damping.mass = r.uniform(5, 30);
  if (damping == 4) mat.damping.stiffness = r.log_uniform(1e-5, 1e-3);
  const bool stvk = b.model == ForceModel::stvk;
  {  // own weight strains it by at most 0.5 (0.1 for stvk), as in random_scene
    const double D = std::sqrt(size[0] * size[0] + size[1] * size[1] + size[2] * size[2]);
    const double min_young = (stvk ? 10.0 : 2.0) * mat.density * 9.81 * D;
    if (mat.young < min_young) mat.young = min_young * (1 + r.uniform());
  }
  const double nu = mat.poisson;
  s.cp = std::sqrt(mat.young * (1 - nu) / ((1 + nu) * (1 - 2 * nu)) / mat.density);
  RegionDef low, high;
  low.min = {-1, -1, -1};
  low.max = {1e-9 * length, size[1] + 1, size[2] + 1};
  high.min = {length * (1 - 1e-9), -1, -1};
  high.max = {length + 1, size[1] + 1, size[2] + 1};
  b.fixed.push_back(low);
  // The pulse: rest, push to A over a ramp, hold, back to rest (once or twice, the second time
  // perhaps the other way), all within the first half of the run, then rest.
  PrescribedMotionDef m;
  m.region = high;
  const double amp = (stvk ? 0.1 : 0.25) * r.uniform(0.3, 1.0) * length;
  const double dir = r.uniform(0, 2 * 3.14159265358979);
  const Vec3d A{r.uniform(-0.2, 0.2) * amp, std::cos(dir) * amp, std::sin(dir) * amp};
  const int pulses = r.integer(1, 2);
  double t = r.uniform(0, 0.1);
  m.keyframes.push_back({0, {0, 0, 0}});
  m.keyframes.push_back({t, {0, 0, 0}});
  for (int p = 0; p < pulses; ++p) {
    const double sign = p == 0 || r.chance(0.5) ? 1.0 : -1.0;
    const double ramp = r.uniform(0.05, 0.15) / pulses, hold = r.uniform(0, 0.1) / pulses;
    t += ramp;
    m.keyframes.push_back({t, {sign * A[0], sign * A[1], sign * A[2]}});
    t += hold;
    m.keyframes.push_back({t, {sign * A[0], sign * A[1], sign * A[2]}});
    t += ramp;
    m.keyframes.push_back({t, {0, 0, 0}});
  }
  b.prescribed.push_back(m);
  const double mode = r.uniform();
  if (mode < 0.4) {
    s.dt_mode = "auto";
  } else if (mode < 0.8) {
    const double fs[] = {0.5, 0.9, 1.0};
    s.dt_factor = fs[r.integer(0, 2)];
    s.dt_mode = fmt::format("{:g}x", s.dt_factor);
  } else {
    s.dt_factor = r.uniform(1.1, 3.0);
    s.substep = true;
    s.dt_mode = "substep";
  }
  s.steps = r.integer(1500, 3000);
  // With StressOptions::tools, one adaptive scene in three also has a tool (a sphere, or with
  // StressOptions::capsules half the time a capsule, below), from a stream of its own (the draws
  // above stay as they were): it comes down onto the top face at a random
  // point, presses 10-40% of the thickness in, slides along the bar and leaves. Its refine_near is
  // auto (the finest level around the tool), 0 (only the strain refines: coarser surfaces get made
  // active under the tool, the case that flung a corner 80 m on the organ, docs/tool.md) or up to
  // a coarsest cell. The monitor counts the tool's work (EnergyMonitor::add_work).
  Rng tr{seed ^ 0x70015ca1e5eedull};
  std::string tool_text;
  if (o.tools && tr.chance(1.0 / 3.0)) {
    ToolDef t;
    t.name = "stress_tool";
    t.shape.radius = tr.uniform(0.3, 1.0) * std::min(size[1], size[2]);
    const double depth = tr.uniform(0.1, 0.4) * size[2];
    const double x0 = tr.uniform(0.3, 0.9) * length;
    const double x1 = std::clamp(x0 + tr.uniform(-0.3, 0.3) * length, 0.2 * length, length);
    const double y = tr.uniform(0.2, 0.8) * size[1];
    const double t0 = tr.uniform(0, 0.3), t1 = t0 + tr.uniform(0.05, 0.15), t2 = t1 + tr.uniform(0, 0.2),
                 t3 = t2 + tr.uniform(0.05, 0.15);
    const double near = tr.uniform();
    ad.refine_near = near < 0.4 ? -1.0 : near < 0.8 ? 0.0 : tr.uniform(0, 1) * a;
    // With StressOptions::capsules, half the tools are capsules (a surgical instrument's shaft),
    // 1-3 radii between their caps' centres, leaning 0-80 degrees from vertical along the bar and
    // pressing with their lower cap: from a third stream, so the spheres' draws stay as they were.
    Rng cr{seed ^ 0xca95e1e5eedull};
    double lean = 0;  // rad, about y
    if (o.capsules && cr.chance(0.5)) {
      t.shape.kind = ToolShapeDef::Kind::capsule;
      t.shape.length = cr.uniform(1, 3) * t.shape.radius;
      lean = cr.uniform(0, 80) * std::acos(-1.0) / 180;
    }
    // Centre height at which the lowest point (the sphere's, or the capsule's lower cap's) touches the top.
    const double touch = size[2] + t.shape.radius + 0.5 * t.shape.length * std::cos(lean);
    const Quatd q{std::cos(0.5 * lean), 0, std::sin(0.5 * lean), 0};
    const double above = touch + 0.1 * t.shape.radius;
    t.keyframes = {{0, {x0, y, above}, q}, {t0, {x0, y, above}, q}, {t1, {x0, y, touch - depth}, q},
                   {t2, {x1, y, touch - depth}, q}, {t3, {x1, y, above}, q}};
    tool_text = fmt::format(", tool r {:.3f} m{} {:.0f}% deep, refine_near {}", t.shape.radius,
                            t.shape.kind == ToolShapeDef::Kind::capsule
                                ? fmt::format(" capsule length {:.3f} m leaning {:.0f} deg", t.shape.length, lean * 180 / std::acos(-1.0))
                                : std::string(),
                            100 * depth / size[2], ad.refine_near < 0 ? std::string("auto") : fmt::format("{:.3g}", ad.refine_near));
    s.tool = t;
  }
  s.description = fmt::format(
      "adaptive {} box {:.3f}x{:.3f}x{:.3f} {}x{}x{}x6, {} levels ({} fine tets), refine_above {:.3g} coarsen_below "
      "{:.3g}, {} {}, E={:.3g} nu={:g} rho={:.0f}{}, fixed end, {} pulse(s) of up to {:.3f} m, dt {}, {} thr",
      s.adapt_kind, size[0], size[1], size[2], cells[0], cells[1], cells[2], levels, s.mesh.tet_count(), ad.refine_above,
      ad.coarsen_below, to_string(b.model), to_string(s.world.precision), mat.young, mat.poisson, mat.density,
      damping == 0 ? "" : damping == 4 ? ", Rayleigh damping" : fmt::format(", mass damping {:.1f}/s", mat.damping.mass),
      pulses, amp, s.dt_mode, s.world.threads) + tool_text;
  return s;
}

Scene random_scene(std::uint64_t seed, const StressOptions& o) {
  if (adaptive_scene_seed(seed)) return random_adaptive_scene(seed, o);
  Rng r{seed};
  Scene s;
  const MeshCache& mc = cache(o);
  const double pick = r.uniform();
  if (pick < 0.3 && !mc.files.empty()) {
    const auto& f = mc.files[std::size_t(r.integer(0, int(mc.files.size()) - 1))];
    s.mesh = f.second;
    s.mesh_kind = "file";
    s.description = f.first;
  } else if (pick < 0.45 && !mc.implicit.empty()) {
    const auto& f = mc.implicit[std::size_t(r.integer(0, int(mc.implicit.size()) - 1))];
    s.mesh = f.second;
    s.mesh_kind = "implicit";
    s.description = "implicit " + f.first;
  } else {
    const Vec3d size{r.uniform(0.05, 0.3), r.uniform(0.02, 0.1), r.uniform(0.02, 0.1)};
    const std::array<int, 3> cells{r.integer(1, 10), r.integer(1, 4), r.integer(1, 4)};
    const int tpc = r.chance(0.5) ? 5 : 6;
    s.mesh = make_box_mesh({0, 0, 0}, size, cells, tpc);
    s.mesh_kind = "box";
    s.description = fmt::format("box {:.3f}x{:.3f}x{:.3f} {}x{}x{}x{}", size[0], size[1], size[2], cells[0], cells[1],
                                cells[2], tpc);
  }
  const ForceModel models[] = {ForceModel::linear, ForceModel::stvk, ForceModel::corotational, ForceModel::springs};
  s.body.name = "stress";
  s.body.model = models[r.integer(0, 3)];
  s.world.precision = r.chance(0.5) ? Precision::float32 : Precision::float64;
  s.world.threads = r.integer(1, std::max(1, o.threads));
  s.world.gravity = r.chance(0.7) ? Vec3d{0, 0, -9.81} : Vec3d{0, 0, 0};
  s.world.time_step.courant = r.chance(0.7) ? 0.5 : r.uniform(0.2, 0.5);
  auto& mat = s.body.material;
  mat.young = r.log_uniform(1e3, 1e7);
  const double nus[] = {0.0, 0.25, 0.3, 0.4, 0.45, 0.49};
  mat.poisson = nus[r.integer(0, 5)];
  mat.density = r.uniform(500, 2000);
  const int damping = r.integer(0, 3);
  if (damping == 1) mat.damping.mass = r.uniform(0, 5);
  if (damping == 2) mat.damping.stiffness = r.log_uniform(1e-6, 1e-3);
  if (damping == 3) {
    mat.damping.bulk_viscosity = r.log_uniform(1e-2, 10);
    mat.damping.shear_viscosity = r.log_uniform(1e-2, 10);
    if (s.body.model == ForceModel::springs) {  // springs refuse viscosities: the same shear damping as beta
      const double mu = mat.young / (2 * (1 + mat.poisson));
      mat.damping.stiffness = *mat.damping.shear_viscosity / mu;
      mat.damping.bulk_viscosity.reset();
      mat.damping.shear_viscosity.reset();
    }
  }
  const Bounds b = bounds(s.mesh);
  const double ext = b.hi[0] - b.lo[0];
  // Valid scenes stay in each model's range: the strain of the body's own weight, rho g D / E,
  // at most 0.5 (0.1 for stvk, whose energy collapses under large compression and stiffens
  // without bound in stretch, so that the rest-state Courant bound stops holding: see
  // docs/stability.md, the E = 100 Pa cantilever). The stability matrix covers the extremes.
  const bool stvk = s.body.model == ForceModel::stvk;
  {
    const double D = std::sqrt((b.hi[0] - b.lo[0]) * (b.hi[0] - b.lo[0]) + (b.hi[1] - b.lo[1]) * (b.hi[1] - b.lo[1]) +
                               (b.hi[2] - b.lo[2]) * (b.hi[2] - b.lo[2]));
    const double min_young = (stvk ? 10.0 : 2.0) * mat.density * 9.81 * D;
    if (mat.young < min_young) mat.young = min_young * (1 + r.uniform());
  }
  const double amp = stvk ? 0.1 : 0.3;  // prescribed offsets, fraction of the length
  RegionDef low, high;
  low.min = {b.lo[0] - 1, b.lo[1] - 1, b.lo[2] - 1};
  low.max = {b.lo[0] + 0.1 * ext, b.hi[1] + 1, b.hi[2] + 1};
  high.min = {b.hi[0] - 0.1 * ext, b.lo[1] - 1, b.lo[2] - 1};
  high.max = {b.hi[0] + 1, b.hi[1] + 1, b.hi[2] + 1};
  const bool fixed = r.chance(0.6);
  if (fixed) s.body.fixed.push_back(low);
  // A body fixed at one end is a cantilever: its weight bends it with a strain of about
  // 3 rho g L^2 / (E h) at the root (beam theory; L its length along x, h its thickness along
  // gravity), (L/h) (L/D) times the rho g D / E above. For stvk that is the strain to keep under
  // 0.1: scene 0xd327d1aa66ac608f of seed 19 (L/h 2.9, rho g D / E 0.06, bending 0.45) swung its
  // edges between 26 % and 135 % of their length, where stvk softens and the step gains energy
  // (docs/stress.md). The other models keep the looser bound: their large bending is wanted and
  // stays stable.
  const double width = b.hi[1] - b.lo[1], height = b.hi[2] - b.lo[2];  // m, ext the length along x
  if (stvk && fixed && s.world.gravity[2] != 0) {
    const double min_young = 3.0 * mat.density * 9.81 * ext * ext / (0.1 * height);
    // Raised by its own value (no draw: the scene's other choices stay those of its seed).
    if (mat.young < min_young) mat.young += min_young;
  }
  if (r.chance(0.35)) {
    PrescribedMotionDef m;
    m.region = high;
    double t = 0;
    m.keyframes.push_back({0, {0, 0, 0}});
    const int n = r.integer(1, 4);
    // Keyframes at most 5% of the P-wave speed apart: a prescribed motion, not an impact.
    const double nu = mat.poisson, E = mat.young;
    const double cp = std::sqrt(E * (1 - nu) / ((1 + nu) * (1 - 2 * nu)) / mat.density);
    Vec3d prev{0, 0, 0};
    for (int i = 0; i < n; ++i) {
      const Vec3d off{r.uniform(-amp, amp) * ext, r.uniform(-0.7, 0.7) * amp * ext, r.uniform(-0.7, 0.7) * amp * ext};
      const double dist = std::sqrt((off[0] - prev[0]) * (off[0] - prev[0]) + (off[1] - prev[1]) * (off[1] - prev[1]) +
                                    (off[2] - prev[2]) * (off[2] - prev[2]));
      t += std::max(r.uniform(0.02, 0.3), dist / (0.05 * cp));
      m.keyframes.push_back({t, off});
      prev = off;
    }
    s.body.prescribed.push_back(m);
  } else if (r.chance(0.4)) {
    NodalLoadDef l;
    l.region = high;
    const double scale = mat.young * 1e-3 * ext * ext;  // about 0.1% strain over the cross-section
    l.total_force = {r.uniform(-1, 1) * scale, r.uniform(-1, 1) * scale, r.uniform(-1, 1) * scale};
    if (stvk && fixed) {
      // The load at the free end of a cantilever: axial F_x / (w h), bending 6 F_y L / (h w^2)
      // and 6 F_z L / (w h^2) (w its width along y). For stvk at most 0.05 with the weight's 0.1.
      const Vec3d& F = l.total_force;
      const double strain = (std::abs(F[0]) / (width * height) + 6 * std::abs(F[1]) * ext / (height * width * width) +
                             6 * std::abs(F[2]) * ext / (width * height * height)) / mat.young;
      if (strain > 0.05)
        for (int k = 0; k < 3; ++k) l.total_force[k] *= 0.05 / strain;
    }
    s.body.loads.push_back(l);
  }
  if (!fixed && s.body.prescribed.empty() && r.chance(0.4)) {
    // Up to 100 rad/s, but with a centrifugal strain rho w^2 R^2 / E of at most 0.2 (0.05 for
    // stvk): a faster spin of a soft body tears it apart, outside every model's range.
    const double R = 0.5 * std::sqrt((b.hi[0] - b.lo[0]) * (b.hi[0] - b.lo[0]) + (b.hi[1] - b.lo[1]) * (b.hi[1] - b.lo[1]));
    const double w_max = std::min(100.0, std::sqrt((stvk ? 0.05 : 0.2) * mat.young / (mat.density * R * R)));
    s.spin = r.uniform(-w_max, w_max);
  }
  const double mode = r.uniform();
  if (mode < 0.4) {
    s.dt_mode = "auto";
  } else if (mode < 0.8) {
    const double f[] = {0.5, 0.9, 1.0};
    s.dt_factor = f[r.integer(0, 2)];
    s.dt_mode = fmt::format("{:g}x", s.dt_factor);
  } else {
    s.dt_factor = r.uniform(1.1, 3.0);
    s.substep = true;
    s.dt_mode = "substep";
  }
  const double tets = double(s.mesh.tet_count());
  s.steps = int(std::clamp(4e6 / tets, 200.0, 3000.0));
  s.description = fmt::format("{} ({} tets), {} {}, E={:.3g} nu={:g} rho={:.0f}{}{}{}{}{}, dt {}, {} thr",
                              s.description, s.mesh.tet_count(), to_string(s.body.model),
                              to_string(s.world.precision), mat.young, mat.poisson, mat.density,
                              damping == 1 ? ", mass damping" : damping == 2 ? ", Rayleigh damping" : damping == 3 ? ", viscosity" : "",
                              fixed ? ", fixed end" : "", s.body.prescribed.empty() ? "" : ", prescribed",
                              s.body.loads.empty() ? "" : ", load", s.spin != 0 ? fmt::format(", spin {:.0f} rad/s", s.spin) : "",
                              s.dt_mode, s.world.threads);
  return s;
}

// An adaptive scene's times were drawn as fractions of the run; `duration` (s) is steps x dt.
// The pulse is then slowed (its amplitude scaled down) where a ramp would move the end faster
// than 5% of the P-wave speed: a prescribed motion, not an impact (as random_scene's motions).
void timeline_in_seconds(Scene& sc, double duration) {
  PrescribedMotionDef& m = sc.body.prescribed.front();
  AdaptDef& ad = sc.body.multiresolution.active.adapt;
  double shrink = 1;
  for (std::size_t i = 1; i < m.keyframes.size(); ++i) {
    const Vec3d& p = m.keyframes[i - 1].offset;
    const Vec3d& q = m.keyframes[i].offset;
    const double dist = std::sqrt((q[0] - p[0]) * (q[0] - p[0]) + (q[1] - p[1]) * (q[1] - p[1]) + (q[2] - p[2]) * (q[2] - p[2]));
    const double dt = (m.keyframes[i].time - m.keyframes[i - 1].time) * duration;
    if (dist > 0) shrink = std::min(shrink, 0.05 * sc.cp * dt / dist);
  }
  for (auto& k : m.keyframes) {
    k.time *= duration;
    for (int c = 0; c < 3; ++c) k.offset[c] *= shrink;
  }
  ad.min_dwell *= duration;
  ad.check_every *= duration;
  if (sc.tool) {  // the same cap on the tool's speed, its path shrunk towards its first keyframe
    auto& keys = sc.tool->keyframes;
    double tool_shrink = 1;
    for (std::size_t i = 1; i < keys.size(); ++i) {
      const Vec3d& p = keys[i - 1].position;
      const Vec3d& q = keys[i].position;
      const double dist = std::sqrt((q[0] - p[0]) * (q[0] - p[0]) + (q[1] - p[1]) * (q[1] - p[1]) + (q[2] - p[2]) * (q[2] - p[2]));
      const double dt = (keys[i].time - keys[i - 1].time) * duration;
      if (dist > 0) tool_shrink = std::min(tool_shrink, 0.05 * sc.cp * dt / dist);
    }
    const Vec3d start = keys.front().position;
    for (auto& k : keys) {
      k.time *= duration;
      for (int c = 0; c < 3; ++c) k.position[c] = start[c] + tool_shrink * (k.position[c] - start[c]);
    }
  }
}

}  // namespace

// About one scene in five is an adaptive multiresolution body (issue 14 §3). Which ones is a
// function of the scene's seed alone (so `--scene 0x...` replays it), from its own stream, so the
// other scenes are drawn exactly as before (their seeds give the same scenes and hashes).
bool adaptive_scene_seed(std::uint64_t seed) {
  std::uint64_t s = seed ^ 0xada971e5ca1e5eefull;
  return splitmix(s) % 5 == 0;
}

std::string stress_scene_description(std::uint64_t seed, const StressOptions& o) { return random_scene(seed, o).description; }

std::size_t resident_bytes() {
  std::ifstream f("/proc/self/statm");
  std::size_t size = 0, resident = 0;
  if (!(f >> size >> resident)) return 0;
  return resident * std::size_t(sysconf(_SC_PAGESIZE));
}

StressScene run_stress_scene(std::uint64_t scene_seed, std::int64_t index, const StressOptions& o, int threads_override) {
  const auto t0 = std::chrono::steady_clock::now();
  Scene sc = random_scene(scene_seed, o);
  if (threads_override > 0) sc.world.threads = threads_override;
  StressScene out;
  out.index = index;
  out.seed = scene_seed;
  out.description = sc.description;
  out.threads = sc.world.threads;
  auto done = [&]() {
    out.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return out;
  };
  std::optional<World> world;
  try {
    if (sc.dt_factor > 0 || sc.adaptive) {
      WorldDef probe_def = sc.world;
      World probe(probe_def);
      probe.add_body(sc.body, sc.mesh);
      const double bound = probe.stable_dt();
      if (sc.dt_factor > 0) {
        sc.world.time_step.dt = sc.dt_factor * bound;
        sc.world.time_step.substep = sc.substep;
      }
      if (sc.adaptive) timeline_in_seconds(sc, sc.steps * (sc.dt_factor > 0 ? sc.dt_factor : 1.0) * bound);
    }
    world.emplace(sc.world);
    world->add_body(sc.body, sc.mesh);
    if (sc.tool) world->add_tool(*sc.tool);
  } catch (const InputError& e) {
    out.status = "refused";
    out.message = e.what();
    return done();
  }
  World& w = *world;
  if (sc.spin != 0) {
    auto apply = [&](auto& L) {
      using T = std::remove_reference_t<decltype(L.v[0][0])>;
      double c[3] = {0, 0, 0};
      for (std::size_t n = 0; n < L.node_count; ++n)
        for (int k = 0; k < 3; ++k) c[k] += double(L.X[k][n]) / double(L.node_count);
      for (std::size_t n = 0; n < L.node_count; ++n) {
        L.v[0][n] = T(-sc.spin * (double(L.X[1][n]) - c[1]));
        L.v[1][n] = T(sc.spin * (double(L.X[0][n]) - c[0]));
      }
    };
    if (w.precision() == Precision::float32)
      apply(w.level<float>(0));
    else
      apply(w.level<double>(0));
  }
  EnergyMonitor mon;
  mon.start(w);
  // An adaptive body must weigh rho x the volume of its finest mesh after every split and merge:
  // the masses of all its levels' nodes (ghosts and inactive nodes hold none) sum to it. Checked
  // at every energy sample, to rounding of the masses' precision.
  double expected_mass = 0;
  if (sc.adaptive) {
    for (const Tet& t : sc.mesh.tets)
      expected_mass += signed_tet_volume(sc.mesh.point(t[0]), sc.mesh.point(t[1]), sc.mesh.point(t[2]), sc.mesh.point(t[3]));
    expected_mass *= sc.body.material.density;
  }
  const double mass_tolerance = w.precision() == Precision::float32 ? kAdaptMassToleranceFloat : kAdaptMassToleranceDouble;
  auto check_mass = [&]() {
    if (!sc.adaptive) return true;
    const double total = body_mass(w, 0);
    const double err = std::abs(total - expected_mass) / expected_mass;
    out.mass_error = std::max(out.mass_error, err);
    return err <= mass_tolerance;
  };
  bool ok = check_mass();
  bool mass_ok = ok;
  auto adapt_stats = [&]() {
    if (!sc.adaptive) return;
    const World::AdaptStats a = w.adapt_stats(0);
    out.splits = a.splits;
    out.merges = a.merges;
    out.changes = a.changes;
    out.undone = a.undone;
  };
  out.adaptive = sc.adaptive;
  std::int64_t substeps_taken = 0;  // steps, or sub-steps when sub-stepping: the fine ticks so far
  // A level's windows are aligned on multiples of its period: a period may grow only at a tick that
  // is a multiple of the new one (Simulation::align_periods). Checked after every step of an
  // adaptive body, whose periods change with its resolution (Simulation::shorten_far_sources).
  std::vector<int> periods;
  for (int l = 0; sc.adaptive && l < w.level_count(0); ++l) periods.push_back(w.level_info(0, l).period);
  std::string misaligned;
  try {
    for (int i = 1; i <= sc.steps && ok; ++i) {
      const double tool_work = sc.tool ? w.tool_reading(ToolId(0)).work_total : 0.0;
      const std::int64_t ticks_before = substeps_taken;
      substeps_taken += w.substeps();  // the adaptive step may raise them as the body stiffens
      w.step();
      // The sub-steps this step took (World::step chooses them at its start): the fine ticks.
      substeps_taken = ticks_before + w.substeps();
      // A change comes at the end of one of the step's sub-steps: the period may have grown at any
      // of those ticks, and at least one of them must be a multiple of it.
      for (std::size_t l = 0; l < periods.size() && misaligned.empty(); ++l) {
        const int p = w.level_info(0, int(l)).period;
        bool aligned = p <= periods[l];
        for (std::int64_t t = ticks_before + 1; t <= substeps_taken && !aligned; ++t) aligned = t % p == 0;
        if (!aligned)
          misaligned = fmt::format("level {}'s period grew from {} to {} ticks within ticks {}-{}, none a multiple of it", l,
                                   periods[l], p, ticks_before + 1, substeps_taken);
        periods[l] = p;
      }
      if (!misaligned.empty()) ok = false;
      mon.after_step(w);
      // A kinematic tool drives the body: its work over the step and its sub-steps
      // (ToolReading::work_total), as the driven nodes' by its magnitude.
      if (sc.tool) {
        const ToolReading& reading = w.tool_reading(ToolId(0));
        mon.add_work(reading.work_total - tool_work);
        if (reading.contacts > 0) ++out.tool_steps;
      }
      if (i % 20 == 0 || i == sc.steps) {
        ok = mon.sample(w);
        if (ok) ok = mass_ok = check_mass();
      }
    }
    if (ok) ok = mon.finish();
  } catch (const DivergenceError& e) {
    out.status = "diverged";
    out.message = e.what();
    out.steps = substeps_taken;
    adapt_stats();
    return done();
  }
  out.steps = substeps_taken;
  out.hash = w.state_hash();
  out.energy_peak = mon.peak_ratio();
  adapt_stats();
  if (!misaligned.empty()) {
    out.status = "misaligned";
    out.message = misaligned;
  } else if (!mass_ok) {
    out.status = "mass";
    out.message = fmt::format("mass not conserved: relative error {:.3g} after {} splits and {} merges (tolerance {:g})",
                              out.mass_error, out.splits, out.merges, mass_tolerance);
  } else if (!ok) {
    out.status = mon.why().rfind("non-finite", 0) == 0 ? "nan" : "unbounded";
    out.message = mon.why();
  }
  return done();
}

StressReport run_stress(const StressOptions& o) {
  StressReport rep;
  auto log = [&](const std::string& s) {
    if (o.log) o.log(s);
  };
  rep.rss_start = resident_bytes();
  const MeshCache& mc = cache(o);  // loaded before the clock and the memory baseline start
  rep.mesh_files = mc.files.size();
  rep.implicit_shapes = mc.implicit.size();
  log(fmt::format("stress: seed {}, {} s, up to {} threads; {} shipped meshes, {} implicit shapes{}{}", o.seed,
                  o.seconds, o.threads, mc.files.size(), mc.implicit.size(),
                  meshing_available() ? "" : " (no meshing in this build)", o.tools ? (o.capsules ? "; tools on (--tools), half of them capsules" : "; tools on (--tools), spheres only") : ""));
  const auto t0 = std::chrono::steady_clock::now();
  auto elapsed = [&] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(); };
  std::vector<std::pair<double, double>> samples;  // (s, bytes)
  std::uint64_t seq = o.seed;
  std::uint64_t digest = 1469598103934665603ull;
  const std::int64_t digest_scenes = 10;
  double next_progress = 10;
  while ((o.max_scenes < 0 || rep.scenes < o.max_scenes) && (elapsed() < o.seconds || rep.scenes == 0)) {
    const std::uint64_t scene_seed = splitmix(seq);
    StressScene s = run_stress_scene(scene_seed, rep.scenes, o);
    ++rep.scenes;
    rep.steps += s.steps;
    {
      Scene sc = random_scene(scene_seed, o);
      ++rep.counts["model " + std::string(to_string(sc.body.model))];
      ++rep.counts["precision " + std::string(to_string(sc.world.precision))];
      ++rep.counts["mesh " + sc.mesh_kind];
      if (sc.adaptive) {
        ++rep.counts[fmt::format("adaptive {} levels", sc.body.multiresolution.levels)];
        ++rep.counts["adaptive " + sc.adapt_kind];
      }
      ++rep.counts["dt " + (sc.dt_mode.back() == 'x' ? std::string("explicit") : sc.dt_mode)];
      ++rep.counts[fmt::format("threads {}", s.threads)];
    }
    if (s.adaptive) {
      ++rep.adaptive_scenes;
      rep.splits += s.splits;
      rep.merges += s.merges;
      rep.undone += s.undone;
      if (s.splits > 0 && s.merges > 0) ++rep.adaptive_split_and_merged;
      rep.max_mass_error = std::max(rep.max_mass_error, s.mass_error);
    }
    if (s.status == "ok") {  // how close the passing scenes came to failing
      constexpr std::size_t kClosest = 3;
      auto at = std::find_if(rep.closest.begin(), rep.closest.end(),
                             [&](const StressScene& c) { return s.energy_peak > c.energy_peak; });
      if (std::size_t(at - rep.closest.begin()) < kClosest) {
        rep.closest.insert(at, s);
        if (rep.closest.size() > kClosest) rep.closest.pop_back();
      }
    }
    if (s.status != "ok") {
      ++rep.failures;
      rep.failed.push_back(s);
      log(fmt::format("FAIL scene {} (seed {:#x}): {}: {} [{}]", s.index, s.seed, s.status, s.message, s.description));
    } else if (o.repeat_every > 0 && s.index % o.repeat_every == 0) {
      // The same scene again with another thread count: the state hash must be identical.
      const StressScene again = run_stress_scene(scene_seed, s.index, o, s.threads == 1 ? std::max(2, o.threads) : 1);
      ++rep.repeats;
      if (again.hash != s.hash || again.status != s.status) {
        ++rep.repeat_mismatches;
        StressScene bad = s;
        bad.status = "irreproducible";
        bad.message = fmt::format("hash {} with {} threads, {} with {} threads", hash_hex(s.hash), s.threads,
                                  hash_hex(again.hash), again.threads);
        rep.failed.push_back(bad);
        log(fmt::format("FAIL scene {} (seed {:#x}): {} [{}]", s.index, s.seed, bad.message, s.description));
      }
    }
    if (rep.scenes <= digest_scenes) {
      for (int i = 0; i < 8; ++i) {
        digest ^= (s.hash >> (8 * i)) & 0xff;
        digest *= 1099511628211ull;
      }
      rep.digest = digest;
      rep.digest_scenes = rep.scenes;
    }
    if (rep.first.size() < 12) rep.first.push_back(s);
    const std::size_t rss = resident_bytes();
    rep.rss_peak = std::max(rep.rss_peak, rss);
    samples.emplace_back(elapsed(), double(rss));
    if (elapsed() >= next_progress) {
      next_progress = elapsed() + (o.seconds > 600 ? 60 : 10);
      log(fmt::format("stress: {:.0f} s, {} scenes ({} adaptive: {} splits, {} merges), {} steps, {} failures, RSS "
                      "{:.1f} MiB (peak {:.1f})",
                      elapsed(), rep.scenes, rep.adaptive_scenes, rep.splits, rep.merges, rep.steps,
                      rep.failures + rep.repeat_mismatches, rss / 1048576.0, rep.rss_peak / 1048576.0));
    }
  }
  rep.wall_s = elapsed();
  rep.rss_end = resident_bytes();
  // Memory: baseline = median over the samples of the first 10% of the run after a warm-up
  // (first 10% of the samples: allocator pools and thread arenas), end = median over the last 10%.
  auto median = [](std::vector<double> v) {
    if (v.empty()) return 0.0;
    std::nth_element(v.begin(), v.begin() + long(v.size() / 2), v.end());
    return v[v.size() / 2];
  };
  const std::size_t n = samples.size();
  const std::size_t warm = n / 10;
  const std::size_t win = std::max<std::size_t>(1, n / 10);
  std::vector<double> a, z;
  for (std::size_t i = warm; i < std::min(n, warm + win); ++i) a.push_back(samples[i].second);
  for (std::size_t i = n > win ? n - win : 0; i < n; ++i) z.push_back(samples[i].second);
  rep.rss_baseline = std::size_t(median(a));
  rep.rss_drift = median(z) - median(a);
  if (n - warm >= 3) {
    double st = 0, sy = 0, stt = 0, sty = 0;
    const double m = double(n - warm);
    for (std::size_t i = warm; i < n; ++i) {
      st += samples[i].first;
      sy += samples[i].second;
      stt += samples[i].first * samples[i].first;
      sty += samples[i].first * samples[i].second;
    }
    const double den = m * stt - st * st;
    rep.rss_slope_per_min = den > 0 ? 60 * (m * sty - st * sy) / den : 0;
  }
  // Flat: the end sits within max(16 MiB, 10% of the baseline) of the baseline.
  rep.memory_flat = rep.rss_drift <= std::max(16.0 * 1048576.0, 0.1 * double(rep.rss_baseline));
  return rep;
}

std::string stress_text(const StressReport& r, const StressOptions& o) {
  std::string s;
  s += fmt::format("seed {}, {:.0f} s wall, up to {} threads{}\n", o.seed, r.wall_s, o.threads,
                   o.tools ? (o.capsules ? ", tools in one adaptive scene in three, half of them capsules (--tools)" : ", sphere tools in one adaptive scene in three (--tools --no-capsules)") : "");
  s += fmt::format("scenes {}, steps {} ({:.0f} steps/s), failures {}, repeats {} (hash mismatches {})\n", r.scenes,
                   r.steps, r.wall_s > 0 ? double(r.steps) / r.wall_s : 0.0, r.failures, r.repeats,
                   r.repeat_mismatches);
  s += fmt::format("RSS start {:.1f} MiB, baseline {:.1f} MiB, peak {:.1f} MiB, end {:.1f} MiB, drift {:+.2f} MiB, "
                   "slope {:+.3f} MiB/min: {}\n",
                   r.rss_start / 1048576.0, r.rss_baseline / 1048576.0, r.rss_peak / 1048576.0,
                   r.rss_end / 1048576.0, r.rss_drift / 1048576.0, r.rss_slope_per_min / 1048576.0,
                   r.memory_flat ? "flat" : "GROWING");
  s += fmt::format("adaptive scenes {} ({} split and merged): splits {}, merges {}, changes undone {}; mass conserved to {:.2g} "
                   "(relative, worst)\n",
                   r.adaptive_scenes, r.adaptive_split_and_merged, r.splits, r.merges, r.undone, r.max_mass_error);
  s += fmt::format("digest of the first {} scene hashes: {}\n", r.digest_scenes, hash_hex(r.digest));
  s += "mix:";
  for (const auto& [k, v] : r.counts) s += fmt::format(" {}={}", k, v);
  s += "\n";
  for (const auto& c : r.closest)
    s += fmt::format("closest to the energy bound ({} x): scene {} (seed {:#x}) at {:.3f} x{} [{}]\n", kBoundFactor, c.index,
                     c.seed, c.energy_peak, c.tool_steps > 0 ? ", tool touching" : "", c.description);
  for (const auto& f : r.failed)
    s += fmt::format("failed scene {} (seed {:#x}): {}: {} [{}]\n", f.index, f.seed, f.status, f.message, f.description);
  s += r.ok() ? "result: OK\n" : "result: FAILED\n";
  return s;
}

}  // namespace pliant::stability
