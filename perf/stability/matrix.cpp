// The stability matrix (issue 3 §3): cells built in code, run for a bounded number of steps,
// classified as stable / clamped / refused / diverged, and the generated docs/stability.md.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <fmt/format.h>
#include <functional>
#include <map>
#include <optional>

#include "pliant/error.hpp"
#include "pliant/kernels/node_passes.hpp"
#include "pliant/perf/stability.hpp"

namespace pliant::stability {
namespace {

constexpr double kLength = 0.1, kWidth = 0.025;  // m, the beam of every scenario
constexpr double kDensity = 1000;                // kg/m^3

std::uint64_t splitmix(std::uint64_t& s) {
  std::uint64_t z = (s += 0x9E3779B97F4A7C15ull);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}
double uniform(std::uint64_t& s) { return double(splitmix(s) >> 11) * 0x1.0p-53; }  // [0, 1)

double p_wave_speed(double E, double nu) {
  const double lambda = E * nu / ((1 + nu) * (1 - 2 * nu)), mu = E / (2 * (1 + nu));
  return std::sqrt((lambda + 2 * mu) / kDensity);
}

// Writes initial positions/velocities of every node of a body: f(node, rest X, x&, v&), positions
// in the world frame (the level's arrays are relative to the body origin).
template <class F>
void set_state(World& w, BodyId b, F&& f) {
  const Vec3d o = w.body_origin(b);
  auto apply = [&](auto& L) {
    using T = std::remove_reference_t<decltype(L.x[0][0])>;
    for (std::size_t n = 0; n < L.node_count; ++n) {
      const Vec3d X{o[0] + double(L.X[0][n]), o[1] + double(L.X[1][n]), o[2] + double(L.X[2][n])};
      Vec3d x{o[0] + double(L.x[0][n]), o[1] + double(L.x[1][n]), o[2] + double(L.x[2][n])};
      Vec3d v{double(L.v[0][n]), double(L.v[1][n]), double(L.v[2][n])};
      if (!f(n, X, x, v, L.state[n] == kNodeFree)) continue;
      for (int k = 0; k < 3; ++k) {
        L.x[k][n] = T(x[k] - o[k]);
        L.v[k][n] = T(v[k]);
      }
    }
  };
  if (w.precision() == Precision::float32)
    apply(w.level<float>(b));
  else
    apply(w.level<double>(b));
}

struct Setup {
  TetMesh mesh;
  BodyDef body;
  Vec3d gravity{0, 0, -9.81};
  bool kick = true;          // random velocity of amplitude 1e-3 c_p on free nodes (excites every mode)
  std::function<void(World&, BodyId)> init;  // initial conditions after add_body
  std::string note;
};

RegionDef face_x(double x) {
  RegionDef r;
  r.min = {x, -1, -1};
  r.max = {x, 1, 1};
  return r;
}

TetMesh beam_mesh() { return make_box_mesh({0, 0, 0}, {kLength, kWidth, kWidth}, {6, 2, 2}, 6); }

// The setup of a cell; `dt` is the step the cell will use (0 for the probe world that measures
// the bound), needed by compress_90 to time its motion over the run.
Setup make_setup(const CellSpec& s, double dt) {
  Setup u;
  u.body.name = "body";
  u.body.model = s.model;
  u.body.material.young = s.young;
  u.body.material.poisson = s.poisson;
  u.body.material.density = kDensity;
  u.mesh = beam_mesh();
  const std::string& sc = s.scenario;
  if (sc == "cantilever" || sc == "inverted_input" || sc == "inverted_state" || sc == "rotated_rest" ||
      sc == "compress_90" || sc == "slivers")
    u.body.fixed.push_back(face_x(0));
  if (sc == "cantilever") {
  } else if (sc == "inverted_input") {
    std::size_t swapped = 0;
    for (std::size_t t = 0; t < u.mesh.tets.size(); t += 2, ++swapped) std::swap(u.mesh.tets[t][0], u.mesh.tets[t][1]);
    u.note = fmt::format("{} of {} tets given inverted", swapped, u.mesh.tets.size());
  } else if (sc == "inverted_state") {
    // Mirror the free half through the beam's mid-plane z = w/2: its tets start inside out.
    u.init = [](World& w, BodyId b) {
      set_state(w, b, [](std::size_t, const Vec3d& X, Vec3d& x, Vec3d&, bool free) {
        if (!free || X[0] < 0.5 * kLength) return false;
        x[2] = kWidth - X[2] + 0.2 * kWidth * (X[0] - 0.5 * kLength) / kLength;
        return true;
      });
    };
    u.note = "free half mirrored (inverted tets at start)";
  } else if (sc == "rotated_rest") {
    for (std::size_t i = 0; i < u.mesh.node_count(); ++i) {  // 180 deg about the x axis
      u.mesh.points[3 * i + 1] = -u.mesh.points[3 * i + 1];
      u.mesh.points[3 * i + 2] = -u.mesh.points[3 * i + 2];
    }
  } else if (sc == "rotated_state") {
    u.gravity = {0, 0, 0};
    u.init = [](World& w, BodyId b) {  // 180 deg about the vertical axis through the centre
      set_state(w, b, [](std::size_t, const Vec3d& X, Vec3d& x, Vec3d&, bool) {
        x[0] = kLength - X[0];
        x[1] = kWidth - X[1];
        return true;
      });
    };
  } else if (sc == "compress_90") {
    PrescribedMotionDef m;
    m.region = face_x(kLength);
    const double T = dt > 0 ? 0.6 * s.steps * dt : 1.0;  // compress over 60% of the run, then hold
    m.keyframes = {{0.0, {0, 0, 0}}, {T, {-0.9 * kLength, 0, 0}}};
    u.body.prescribed.push_back(m);
  } else if (sc == "spin_100") {
    u.gravity = {0, 0, 0};
    u.init = [](World& w, BodyId b) {
      set_state(w, b, [](std::size_t, const Vec3d& X, Vec3d&, Vec3d& v, bool) {
        const double omega = 100;  // rad/s about z through the centre
        v[0] += -omega * (X[1] - 0.5 * kWidth);
        v[1] += omega * (X[0] - 0.5 * kLength);
        return true;
      });
    };
    u.note = "rim speed 5 m/s";
  } else if (sc == "slivers") {
    // Squash every other inner x-layer towards the next one (to 10% of a cell) and the middle
    // z-layer towards the bottom face (to 8%), then jitter inner y: near-flat tets.
    const double dx = kLength / 6, dz = kWidth / 2, dy = kWidth / 2;
    std::uint64_t rng = 12345;
    for (std::size_t i = 0; i < u.mesh.node_count(); ++i) {
      double* p = &u.mesh.points[3 * i];
      const int layer = int(std::lround(p[0] / dx));
      if (layer % 2 == 1 && layer < 6) p[0] += 0.9 * dx;
      if (std::abs(p[2] - dz) < 1e-12) p[2] = 0.08 * dz;
      if (std::abs(p[1] - dy) < 1e-12) p[1] += 0.3 * dy * (uniform(rng) - 0.5);
    }
    double hmin = 1e300;
    for (const Tet& t : u.mesh.tets) {
      const Vec3d a = u.mesh.point(t[0]), b = u.mesh.point(t[1]), c = u.mesh.point(t[2]), d = u.mesh.point(t[3]);
      hmin = std::min(hmin, std::abs(signed_tet_volume(a, b, c, d)));
    }
    u.note = fmt::format("smallest tet volume {:.2g} m^3 (regular: {:.2g})", hmin,
                         kLength * kWidth * kWidth / u.mesh.tets.size());
  } else {
    throw InputError(fmt::format("unknown stability scenario '{}'", sc));
  }
  return u;
}

}  // namespace

const std::vector<std::string>& scenarios() {
  static const std::vector<std::string> names = {"cantilever",    "inverted_input", "inverted_state", "rotated_rest",
                                                 "rotated_state", "compress_90",    "spin_100",       "slivers"};
  return names;
}

std::string CellSpec::label() const {
  return fmt::format("{} {} {} E={:g} nu={:g} dt={:g}x{}", scenario, pliant::to_string(model),
                     pliant::to_string(precision), young, poisson, dt_factor,
                     dt_factor > 1 ? (substep ? " substep" : " no-substep") : "");
}

// Expected: refused exactly when dt is above the bound without sub-stepping, clamped when it is
// above the bound with sub-stepping (or the adaptive step sub-stepped); never diverged.
bool CellResult::acceptable() const {
  const bool above = spec.dt_factor > 1.0;
  if (outcome == Outcome::refused) return above && !spec.substep;
  if (outcome == Outcome::clamped) return (above && spec.substep) || adapted_steps > 0;
  if (outcome == Outcome::diverged) return false;
  return !above;
}

CellResult run_cell(const CellSpec& spec, int threads) {
  CellResult r;
  r.spec = spec;
  const auto t0 = std::chrono::steady_clock::now();
  auto finish = [&]() -> CellResult {
    r.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return r;
  };
  // 1. The bound, from a probe world on the same mesh and material.
  WorldDef wd;
  wd.precision = spec.precision;
  wd.threads = threads;
  {
    Setup probe = make_setup(spec, 0);
    wd.gravity = probe.gravity;
    World w(wd);
    w.add_body(probe.body, probe.mesh);
    r.bound = w.stable_dt();
  }
  // 2. The cell's world: an explicit dt = factor x bound. Above the bound World either refuses
  //    (InputError, before any step) or sub-steps.
  r.dt = spec.dt_factor * r.bound;
  Setup u = make_setup(spec, r.dt);
  r.message = u.note;
  wd.gravity = u.gravity;
  wd.time_step.dt = r.dt;
  wd.time_step.substep = spec.substep;
  wd.time_step.adapt = spec.adapt;
  std::optional<World> world;
  BodyId b = -1;
  try {
    world.emplace(wd);
    b = world->add_body(u.body, u.mesh);
  } catch (const InputError& e) {
    r.outcome = Outcome::refused;
    r.message = e.what();
    return finish();
  }
  World& w = *world;
  r.substeps = w.substeps();
  if (u.init) u.init(w, b);
  if (u.kick) {
    const double amp = 1e-3 * p_wave_speed(spec.young, spec.poisson);
    std::uint64_t rng = 0x5eed;
    set_state(w, b, [&](std::size_t, const Vec3d&, Vec3d&, Vec3d& v, bool free) {
      const double a = uniform(rng), c = uniform(rng), d = uniform(rng);
      if (!free) return false;
      v[0] += amp * (2 * a - 1);
      v[1] += amp * (2 * c - 1);
      v[2] += amp * (2 * d - 1);
      return true;
    });
  }
  EnergyMonitor mon;
  mon.start(w);
  const int sample_every = 10;
  bool bounded = true;
  try {
    for (int i = 1; i <= spec.steps && bounded; ++i) {
      w.step();
      mon.after_step(w);
      if (i % sample_every == 0 || i == spec.steps) bounded = mon.sample(w);
    }
    if (bounded) bounded = mon.finish();
  } catch (const DivergenceError& e) {
    r.steps_run = w.steps();
    r.max_substeps = w.max_substeps();
    r.adapted_steps = w.adapted_steps();
    r.max_stiffness_ratio = w.max_stiffness_ratio();
    r.outcome = Outcome::diverged;
    r.message = e.what();
    r.peak_ratio = mon.peak_ratio();
    return finish();
  }
  r.steps_run = w.steps();
  r.peak_ratio = mon.peak_ratio();
  r.growth = mon.growth();
  r.max_substeps = w.max_substeps();
  r.adapted_steps = w.adapted_steps();
  r.max_stiffness_ratio = w.max_stiffness_ratio();
  if (!bounded) {
    r.outcome = Outcome::diverged;
    r.message = fmt::format("step {}: {}", w.steps(), mon.why());
  } else {
    r.outcome = r.max_substeps > 1 ? Outcome::clamped : Outcome::stable;
    if (r.outcome == Outcome::clamped && r.adapted_steps == 0)
      r.message = fmt::format("{} sub-steps of {:.4g} s per step", r.substeps, r.dt / r.substeps);
    else if (r.outcome == Outcome::clamped)
      r.message = fmt::format(
          "the deformation stiffened the elements up to {:.3g}x (Hessian eigenvalue over rest): the adaptive step "
          "split {} of {} steps, into up to {} sub-steps (at load: {})",
          r.max_stiffness_ratio, r.adapted_steps, r.steps_run, r.max_substeps, r.substeps);
  }
  return finish();
}

const char* known_issue(const CellSpec& c) {
  (void)c;  // none open: see the findings of markdown_report for what was fixed
  return nullptr;
}

std::vector<CellSpec> matrix_cells(const MatrixOptions& o) {
  std::vector<CellSpec> out;
  const ForceModel models[] = {ForceModel::linear, ForceModel::stvk, ForceModel::corotational, ForceModel::springs};
  const Precision precisions[] = {Precision::float32, Precision::float64};
  struct Dt {
    double factor;
    bool substep;
  };
  const std::vector<Dt> dts_full = {{0.5, false}, {0.9, false}, {1.0, false}, {1.2, false}, {1.2, true}};
  const std::vector<Dt> dts_sub = {{0.9, false}, {1.0, false}, {1.2, false}, {1.2, true}};
  const std::vector<double> nus = o.full ? std::vector<double>{0, 0.3, 0.45, 0.49, 0.499} : std::vector<double>{0, 0.499};
  const std::vector<double> Es = o.full ? std::vector<double>{1e2, 1e4, 1e6, 1e9} : std::vector<double>{1e2, 1e9};
  const auto& dts = o.full ? dts_full : dts_sub;
  for (Precision p : precisions)
    for (ForceModel m : models)
      for (double E : Es)
        for (double nu : nus)
          for (const Dt& d : dts) {
            CellSpec c;
            c.scenario = "cantilever";
            c.model = m;
            c.precision = p;
            c.young = E;
            c.poisson = nu;
            c.dt_factor = d.factor;
            c.substep = d.substep;
            c.steps = o.steps;
            out.push_back(c);
          }
  // The extremes: every model and precision, two materials each side of rubber-like, at 0.9x
  // and 1.0x the bound (the full run adds 1.2x sub-stepped and a stiff material).
  const std::vector<std::pair<double, double>> mats =
      o.full ? std::vector<std::pair<double, double>>{{1e4, 0.3}, {1e6, 0.3}, {1e6, 0.49}, {1e9, 0.45}}
             : std::vector<std::pair<double, double>>{{1e6, 0.49}};
  const std::vector<Dt> xdts =
      o.full ? std::vector<Dt>{{0.9, false}, {1.0, false}, {1.2, true}} : std::vector<Dt>{{0.9, false}};
  for (std::size_t s = 1; s < scenarios().size(); ++s)
    for (Precision p : precisions)
      for (ForceModel m : models)
        for (const auto& [E, nu] : mats)
          for (const Dt& d : xdts) {
            CellSpec c;
            c.scenario = scenarios()[s];
            c.model = m;
            c.precision = p;
            c.young = E;
            c.poisson = nu;
            c.dt_factor = d.factor;
            c.substep = d.substep;
            c.steps = o.steps;
            out.push_back(c);
          }
  return out;
}

std::vector<CellResult> run_matrix(const MatrixOptions& o) {
  const auto cells = matrix_cells(o);
  std::vector<CellResult> out;
  out.reserve(cells.size());
  for (std::size_t i = 0; i < cells.size(); ++i) {
    out.push_back(run_cell(cells[i], o.threads));
    if (o.progress) o.progress(out.back(), i, cells.size());
  }
  return out;
}

std::string markdown_report(const std::vector<CellResult>& res, const MatrixOptions& o, double wall_s) {
  std::map<std::string, int> counts;
  int unacceptable = 0;
  for (const auto& r : res) {
    ++counts[to_string(r.outcome)];
    if (!r.acceptable()) ++unacceptable;
  }
  std::string s;
  s += "# Stability at the extremes\n\n";
  s += "Generated by `pliant stability --markdown docs/stability.md` (do not edit by hand); code in\n";
  s += "`perf/stability/`, ctest subset in `tests/stability/test_stability.cpp` (`Matrix.SubsetHasNoUnexpectedOutcome`).\n";
  s += fmt::format("Machine: {}.\n\n", o.machine.empty() ? std::string("not recorded") : o.machine);
  s += fmt::format("{} cells, {} steps each, {} thread(s), {:.0f} s wall: **{} stable, {} clamped, {} refused, {} "
                   "diverged**; {} cell(s) not as expected.\n\n",
                   res.size(), o.steps, o.threads, wall_s, counts["stable"], counts["clamped"], counts["refused"],
                   counts["diverged"], unacceptable);
  for (int part = 0; part < 2; ++part) {
    std::map<std::string, int> c;
    std::size_t n = 0;
    for (const auto& r : res)
      if ((r.spec.scenario == "cantilever") == (part == 0)) {
        ++n;
        ++c[to_string(r.outcome)];
        if (!r.acceptable()) ++c["bug"];
      }
    s += fmt::format("- {}: {} cells: {} stable, {} clamped, {} refused, {} diverged ({} not as expected).\n",
                     part == 0 ? "the matrix (cantilever, 4 models x 5 nu x 4 E x 5 dt x 2 precisions)"
                               : "the extremes (7 scenarios x 4 models x 2 precisions x 4 materials x 3 dt)",
                     n, c["stable"], c["clamped"], c["refused"], c["diverged"], c["bug"]);
  }
  // The cells a scene with nothing but defaults runs: "dt": "auto" at Courant number 0.5 is 1.0x.
  {
    std::vector<const CellResult*> at_default, bad_default;
    double worst = 0;
    for (const auto& r : res)
      if (r.spec.dt_factor == 1.0 && !r.spec.substep) {
        at_default.push_back(&r);
        worst = std::max(worst, r.peak_ratio);
        if (r.outcome == Outcome::diverged) bad_default.push_back(&r);
      }
    s += fmt::format("\n**Defaults-only scenes** (`\"dt\": \"auto\"`, Courant number 0.5: the 1.0x cells, {} of them): ",
                     at_default.size());
    if (bad_default.empty()) {
      s += fmt::format("none diverged; the largest energy over its budget was {:.2f}x (the bound is {}x).", worst,
                       kBoundFactor);
    } else {
      s += fmt::format("**{} are not stable**:", bad_default.size());
      for (const auto* r : bad_default) s += fmt::format(" `{}` ({});", r->spec.label(), r->message);
    }
    s += " A scene's own body can still fall outside what the matrix covers (other meshes, loads, contact).\n";
  }
  s += R"(
**Findings.** No cell diverges. The verdicts were tightened (issue 10 §2): a run counted as
stable with up to 10x the energy it was given, and a divergence at 1.0x the bound (the default
step) was tolerated, so that the E = 100 Pa cantilever of stvk (nu = 0, diverged at step 20) and of
springs (nu = 0 and 0.3, 1.5x their energy by step 550-1300) diverged with `"dt": "auto"` while the
summary said "0 diverged at <= 0.9x". Now a run is bounded only within 1.5x its budget (the swing
of the time-centred kinetic energy is at most a third at the default step) and no divergence is
acceptable. What that showed, and the fixes:

- *stvk, E = 100 Pa, 1.0x, step 20*: the beam, loaded by 10x its own weight, stiffens from the first
  step (stiffness ratio 1.16, 1.5, 2.2, 3.3 over steps 1-4), but the adaptive step measured it every
  16 steps, and the first check after load came too late. The check interval now starts at one step,
  doubles while the ratio stays far from the trigger (up to 16) and is cut when the ratio rises
  (engine/src/core/world.cpp, next_check).
- *springs, E = 100 Pa*: springs squashed to L / 20 have a transverse tangent k (1 - L / l), 19x
  their rest stiffness, and springs were taken as never stiffening. They now have a stiffness ratio
  (1 + |1 - L / l|, kernels/src/element_stiffness.cpp) and the adaptive step sub-steps them. That
  alone was not enough: each decrease of the sub-step count costs energy (symplectic Euler's velocity
  is half a step off, so the first kick after a change is (h_old - h_new) a / 2 off), and a body whose
  springs squash and re-expand changed it often. The count now comes down only after 256 checks in a
  row wanted fewer (was 32).
- *corotational, E = 100 Pa, nu = 0.499, 0.9x-1.0x*: 1.55x its budget near step 1800-2000 with 32;
  within the bound with 256.

Before (issue 3): the E = 100 Pa cantilever of stvk and corotational (a beam that cannot carry its
own weight, rho g L / E = 10, collapses through itself, stretching tets up to 8x and inverting half
of them, where stvk stiffens without bound in stretch and corotational's twist modes grow without
bound as an inverted tet's two signed stretches cancel) became *clamped*: the adaptive step
(`TimeStepDef::adapt`, on by default; World measures every element's stiffness ratio, the largest
Hessian eigenvalue of its energy density now over at rest) splits their steps into up to tens of
sub-steps while they are collapsed, and the message of each such cell says by how much: a target
Courant number of 0.35 on the estimated current frequency (0.7 left stvk cells diverging), and
hysteresis on the sub-step count; the corotational rotation iteration may take up to 64
iterations (was 16) for inverted tets. Fixed before that: the saddle of `extract_rotation` a half
turn from the warm start (`rotated_state`), the step built for the highest mode measured at load
(Lanczos on M^-1 K; Kuhn meshes exceed 2 c_p / h_min by up to 22%), a finite state beyond 1e15 m
or m/s reported as a divergence at once, and the time-centred kinetic energy of the criterion.

## What a cell is

Every cell is built in code: a beam 0.1 x 0.025 x 0.025 m (6 x 2 x 2 cells, 6 tets each: 144 tets,
63 nodes), density 1000 kg/m^3, no damping, Courant number 0.5. The bound is the engine's
`World::stable_dt()` (C x 2 / omega_max, omega_max the larger of 2 c_p / h_min and the highest mode
of M^-1 K measured at load, see engine/src/core/stable_step.cpp and docs/architecture.md), measured
on a probe world with the same mesh and material; the cell then sets `TimeStepDef::dt = factor x bound`.
Every free node gets a random initial velocity of amplitude 1e-3 c_p (c_p the P-wave speed) so that
every mode, the highest above all, is excited from the first step.

- **cantilever** (the matrix): fixed at x = 0, gravity -9.81 m/s^2 in z.
- **inverted_input**: every other tet of the mesh given with negative orientation (two corners
  swapped); `finalize_tet_mesh` re-orients them, then as cantilever.
- **inverted_state**: as cantilever, but the free half's initial positions are mirrored through the
  mid-plane: its tets start inside out.
- **rotated_rest**: the rest mesh rotated 180 deg about the beam axis before `add_body`.
- **rotated_state**: free body, no gravity; rest unchanged, initial positions rotated 180 deg about
  the vertical axis (for `linear` a huge spurious strain, for `corotational` a polar decomposition
  at 180 deg).
- **compress_90**: fixed at x = 0; the x = L face is pushed by a prescribed motion to x = 0.1 L over
  60% of the run, then held.
- **spin_100**: free body, no gravity, initial velocity of a rigid rotation at 100 rad/s about z.
- **slivers**: every other inner node layer squashed to 10% of a cell along x, the middle layer to
  8% along z, inner nodes jittered: near-flat (but valid) tets and a bound about 10x smaller.

## Outcomes

- **stable**: no non-finite value, energy bounded (below) over all steps, dt <= the bound.
- **clamped**: dt = 1.2x the bound with `substep: true`: World split every step into
  `substeps()` sub-steps (reported) and the run was then stable; or the deformation stiffened
  the elements and the adaptive step sub-stepped (the message gives the ratio and the counts).
- **refused**: dt = 1.2x the bound without sub-stepping: `add_body` threw InputError naming the
  bound, before any step.
- **diverged**: a DivergenceError (World checks every free node after each sub-step, for a value
  that is not finite or beyond 1e15 m or m/s, and reports body, level, step and node at once:
  `pliant run` exits 3, no NaN or runaway value reaches an output), or an
  unbounded energy, or a non-finite energy without DivergenceError. Every divergence is a bug (every
  cell that runs has a step at most the bound); `pliant stability` then exits 3.

**Energy bounded** (`EnergyMonitor`, sampled every 10 steps): with M = kinetic + elastic energy
(the kinetic energy time-centred: of the velocity at the time of the positions, see
`Energies` in pliant/world.hpp), P the potential of gravity and loads, L their work on the free
nodes from the velocities, W the accumulated |f . dx| of fixed and prescribed nodes plus the
kinetic energy they carry, and S(t) = M(0) + max(|P(t) - P(0)|, |L(t)|) + W(t) + a floor (1e-9 m g D
plus the energy 1/2 (lambda + 2 mu) e^2 V of a strain e = 1e-4 in float, 1e-7 in double: rounding noise):
(a) M(t) <= 1.5 S(t) at every sample, and (b) the largest kinetic energy over the second half of
the run is at most 100x the largest over the first half (+ S at the end: a driven body may
speed up, but not beyond all the energy it was given). `peak` in the tables is
max M/S (about 1 for a conservative run, at most 4/3 at the default step; an unstable step grows it
by orders of magnitude within tens of steps).

)";
  // Matrix tables: one per model x precision, rows E x nu, columns dt factor.
  auto cell_key = [](const CellSpec& c) {
    return fmt::format("{}|{:g}|{:g}|{:g}|{}", c.scenario, c.young, c.poisson, c.dt_factor, c.substep);
  };
  auto abbrev = [](const CellResult& r) -> std::string {
    switch (r.outcome) {
      case Outcome::stable: return fmt::format("stable ({:.2f})", r.peak_ratio);
      case Outcome::clamped: return fmt::format("clamped x{} ({:.2f})", r.substeps, r.peak_ratio);
      case Outcome::refused: return "refused";
      case Outcome::diverged: return fmt::format("**DIVERGED** @{}", r.steps_run);
    }
    return "?";
  };
  const ForceModel models[] = {ForceModel::linear, ForceModel::stvk, ForceModel::corotational, ForceModel::springs};
  const Precision precisions[] = {Precision::float32, Precision::float64};
  std::vector<std::pair<double, bool>> dts;
  std::vector<double> Es, nus;
  for (const auto& r : res) {
    if (r.spec.scenario != "cantilever") continue;
    auto d = std::make_pair(r.spec.dt_factor, r.spec.substep);
    if (std::find(dts.begin(), dts.end(), d) == dts.end()) dts.push_back(d);
    if (std::find(Es.begin(), Es.end(), r.spec.young) == Es.end()) Es.push_back(r.spec.young);
    if (std::find(nus.begin(), nus.end(), r.spec.poisson) == nus.end()) nus.push_back(r.spec.poisson);
  }
  s += "## The matrix (cantilever)\n\nEach entry: outcome (peak M/S); for a divergence, the step it was detected at.\n\n";
  for (Precision p : precisions)
    for (ForceModel m : models) {
      std::map<std::string, const CellResult*> by;
      for (const auto& r : res)
        if (r.spec.scenario == "cantilever" && r.spec.model == m && r.spec.precision == p) by[cell_key(r.spec)] = &r;
      if (by.empty()) continue;
      s += fmt::format("### {} / {}\n\n| E (Pa) | nu |", pliant::to_string(m), pliant::to_string(p));
      for (auto& d : dts) s += fmt::format(" {:g}x{} |", d.first, d.first > 1 ? (d.second ? " substep" : "") : "");
      s += "\n|---:|---:|";
      for (std::size_t i = 0; i < dts.size(); ++i) s += "---|";
      s += "\n";
      for (double E : Es)
        for (double nu : nus) {
          s += fmt::format("| {:g} | {:g} |", E, nu);
          for (auto& d : dts) {
            CellSpec c;
            c.scenario = "cantilever";
            c.young = E;
            c.poisson = nu;
            c.dt_factor = d.first;
            c.substep = d.second;
            auto it = by.find(cell_key(c));
            s += " " + (it == by.end() ? std::string("-") : abbrev(*it->second)) + " |";
          }
          s += "\n";
        }
      s += "\n";
    }
  s += "## The extremes\n\nOne row per scenario, material and time step; columns model / precision.\n\n";
  s += "| scenario | E (Pa) | nu | dt |";
  for (ForceModel m : models)
    for (Precision p : precisions) s += fmt::format(" {} {} |", pliant::to_string(m), pliant::to_string(p));
  s += "\n|---|---:|---:|---|";
  for (int i = 0; i < 8; ++i) s += "---|";
  s += "\n";
  std::vector<std::string> rows;
  std::map<std::string, std::map<std::string, const CellResult*>> table;
  std::map<std::string, std::string> notes;
  for (const auto& r : res) {
    if (r.spec.scenario == "cantilever") continue;
    const std::string row = fmt::format("| {} | {:g} | {:g} | {:g}x{} |", r.spec.scenario, r.spec.young, r.spec.poisson,
                                        r.spec.dt_factor, r.spec.substep ? " substep" : "");
    if (!table.count(row)) rows.push_back(row);
    table[row][fmt::format("{}{}", pliant::to_string(r.spec.model), pliant::to_string(r.spec.precision))] = &r;
    if (r.outcome != Outcome::refused && r.outcome != Outcome::diverged && !r.message.empty() &&
        r.outcome != Outcome::clamped)
      notes[r.spec.scenario] = r.message;
  }
  for (const auto& row : rows) {
    s += row;
    for (ForceModel m : models)
      for (Precision p : precisions) {
        auto& t = table[row];
        auto it = t.find(fmt::format("{}{}", pliant::to_string(m), pliant::to_string(p)));
        s += " " + (it == t.end() ? std::string("-") : abbrev(*it->second)) + " |";
      }
    s += "\n";
  }
  if (!notes.empty()) {
    s += "\nNotes:";
    for (const auto& [k, v] : notes) s += fmt::format(" {}: {}.", k, v);
    s += "\n";
  }
  std::vector<const CellResult*> bad;
  for (const auto& r : res)
    if (r.outcome == Outcome::diverged) bad.push_back(&r);
  s += "\n## Divergences\n\n";
  if (bad.empty()) s += "None.\n";
  for (const auto* r : bad) {
    const char* why = known_issue(r->spec);
    s += fmt::format("- `{}`{}: {}\n", r->spec.label(), r->acceptable() ? "" : " (**bug**)",
                     r->message);
    if (why && !r->acceptable()) s += fmt::format("  - cause: {}\n", why);
  }
  return s;
}

}  // namespace pliant::stability
