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

double mesh_volume(const TetMesh& m) {  // m^3
  double v = 0;
  for (const Tet& t : m.tets) v += signed_tet_volume(m.point(t[0]), m.point(t[1]), m.point(t[2]), m.point(t[3]));
  return v;
}

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
      sc == "compress_90" || sc == "slivers" || sc == "adaptive_push")
    u.body.fixed.push_back(face_x(0));
  if (sc == "cantilever") {
  } else if (sc == "adaptive_push") {
    // The beam as an adaptive body of 3 nested levels (ratio 2, 6 tets per cell): 3 x 1 x 1 cells
    // (18 tets, where it starts), 6 x 2 x 2 (the other cells' beam) and 12 x 4 x 4 (1152 tets).
    // Its free end is pushed 2 cm sideways over 15% of the run, held for 10%, brought back over
    // 15%, then left to ring for the last 55%: strain comes (splits) and goes (merges).
    MeshSourceDef& m = u.body.mesh;
    m.kind = MeshSourceDef::Kind::box;
    m.min = {0, 0, 0};
    m.max = {kLength, kWidth, kWidth};
    m.cells = {12, 4, 4};
    m.tets_per_cell = 6;
    u.mesh = make_box_mesh(m.min, m.max, m.cells, 6);
    u.body.multiresolution.levels = 3;
    u.body.multiresolution.ratio = 2;
    u.body.multiresolution.active.kind = ActiveDef::Kind::adaptive;
    AdaptDef& ad = u.body.multiresolution.active.adapt;
    ad.refine_above = s.refine_above > 0 ? s.refine_above : ad.refine_above;
    ad.coarsen_below = ad.refine_above / 4;
    const double run = dt > 0 ? s.steps * dt : 1.0;  // s
    ad.min_dwell = 0.05 * run;
    ad.check_every = 0;
    PrescribedMotionDef push;
    push.region = face_x(kLength);
    const Vec3d side{0, 0.2 * kLength, 0};
    push.keyframes = {{0.0, {0, 0, 0}}, {0.05 * run, {0, 0, 0}}, {0.2 * run, side}, {0.3 * run, side}, {0.45 * run, {0, 0, 0}}};
    u.body.prescribed.push_back(push);
    // Critically damped first bending mode (omega_1 = 1.875^2 / L^2 sqrt(E I / (rho A)), I / A =
    // w^2 / 12): the run is only a fraction of its period (the step resolves the finest tets), so
    // without damping the beam would still swing at the end and never calm enough to merge.
    const double omega1 = 1.875 * 1.875 / (kLength * kLength) * std::sqrt(s.young * kWidth * kWidth / (12 * kDensity));
    u.body.material.damping.mass = 2 * omega1;
    u.note = fmt::format("3 levels: 18 / 144 / 1152 tets; refine_above {:g}, coarsen_below {:g}, min_dwell 5% of the run, "
                         "mass damping {:.0f}/s",
                         ad.refine_above, ad.coarsen_below, u.body.material.damping.mass);
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
                                                 "rotated_state", "compress_90",    "spin_100",       "slivers",
                                                 "adaptive_push"};
  return names;
}

std::string CellSpec::label() const {
  return fmt::format("{} {} {} E={:g} nu={:g} dt={:g}x{}{}", scenario, pliant::to_string(model),
                     pliant::to_string(precision), young, poisson, dt_factor,
                     dt_factor > 1 ? (substep ? " substep" : " no-substep") : "",
                     scenario == "adaptive_push" ? fmt::format(" refine_above={:g}", refine_above) : "");
}

bool CellResult::acceptable_mass() const {
  return mass_error <= (spec.precision == Precision::float32 ? kAdaptMassToleranceFloat : kAdaptMassToleranceDouble);
}

// Expected: refused exactly when dt is above the bound without sub-stepping, clamped when it is
// above the bound with sub-stepping (or the adaptive step sub-stepped); never diverged.
bool CellResult::acceptable() const {
  const bool above = spec.dt_factor > 1.0;
  if (!acceptable_mass()) return false;
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
  // An adaptive body weighs rho x the finest mesh's volume after every split and merge.
  const bool adaptive = u.body.multiresolution.active.kind == ActiveDef::Kind::adaptive;
  const double expected_mass = adaptive ? kDensity * mesh_volume(u.mesh) : 0;
  auto adapt_record = [&]() {
    if (!adaptive) return;
    r.mass_error = std::max(r.mass_error, std::abs(body_mass(w, b) - expected_mass) / expected_mass);
    const World::AdaptStats a = w.adapt_stats(b);
    r.splits = a.splits;
    r.merges = a.merges;
    r.max_fine_tets = std::max(r.max_fine_tets, w.level_info(b, w.level_count(b) - 1).stepped_tets);
  };
  adapt_record();
  try {
    for (int i = 1; i <= spec.steps && bounded; ++i) {
      w.step();
      mon.after_step(w);
      if (i % sample_every == 0 || i == spec.steps) {
        bounded = mon.sample(w);
        adapt_record();
      }
    }
    if (bounded) bounded = mon.finish();
  } catch (const DivergenceError& e) {
    adapt_record();
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
  } else if (!r.acceptable_mass()) {
    r.outcome = r.max_substeps > 1 ? Outcome::clamped : Outcome::stable;
    r.message = fmt::format("mass not conserved: relative error {:.3g} after {} splits and {} merges", r.mass_error,
                            r.splits, r.merges);
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

// A cell whose unexpected outcome has a known cause in the engine, named in the report (none open
// today: the adaptive rows' three causes are fixed; markdown_report's findings say how).
const char* known_issue(const CellSpec& /*c*/) { return nullptr; }

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
  for (std::size_t s = 1; s < scenarios().size(); ++s) {
    if (scenarios()[s] == "adaptive_push") continue;  // its own rows, below
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
  }
  // The adaptive rows: model x time step x threshold on the 3-level beam pushed and released,
  // both precisions. The thresholds (relative to the beam's peak strain, AdaptDef::Measure::relative):
  // 0.25 (splits nearly everywhere while pushed), 0.5 (the default) and 1.0 (only where the strain
  // varies fastest). The ctest subset keeps the default at 1.0x (the default step).
  const std::vector<double> thresholds = o.full ? std::vector<double>{0.25, 0.5, 1.0} : std::vector<double>{0.5};
  const std::vector<Dt> adts = o.full ? dts_full : std::vector<Dt>{{1.0, false}};
  for (Precision p : precisions)
    for (ForceModel m : models)
      for (double th : thresholds)
        for (const Dt& d : adts) {
          CellSpec c;
          c.scenario = "adaptive_push";
          c.model = m;
          c.precision = p;
          c.dt_factor = d.factor;
          c.substep = d.substep;
          c.refine_above = th;
          c.steps = o.steps;
          out.push_back(c);
        }
  return out;
}

std::vector<CellResult> run_matrix(const MatrixOptions& o) {
  auto cells = matrix_cells(o);
  if (!o.filter.empty())
    std::erase_if(cells, [&](const CellSpec& c) { return c.label().find(o.filter) == std::string::npos; });
  std::vector<CellResult> out;
  out.reserve(cells.size());
  for (std::size_t i = 0; i < cells.size(); ++i) {
    out.push_back(run_cell(cells[i], o.threads));
    if (o.progress) o.progress(out.back(), i, cells.size());
  }
  return out;
}


namespace {

// The adaptive rows of docs/stability.md: what the cells do, a summary drawn from the results
// (so it says what this run showed, whatever that is) and the table.
template <class Abbrev>
std::string adaptive_section(const std::vector<CellResult>& res, Abbrev&& abbrev) {
  std::vector<const CellResult*> cells;
  for (const auto& r : res)
    if (r.spec.scenario == "adaptive_push") cells.push_back(&r);
  if (cells.empty()) return {};
  std::string s = R"(
## The adaptive rows

The cantilever beam again (0.1 x 0.025 x 0.025 m, E = 1 MPa, nu = 0.3, fixed at x = 0, gravity,
the same random kick), as an adaptive multiresolution body (`multiresolution.active = "adaptive"`,
docs/multiresolution.md "Adaptivity") of 3 nested levels, ratio 2, 6 tets per cell: 3 x 1 x 1
cells (18 tets, where it starts), 6 x 2 x 2 (144) and 12 x 4 x 4 (1152). Its free end is pushed
2 cm sideways over 15% of the run (after 5% at rest), held for 10%, brought back over 15% and
left to ring for the last 55%: the strain comes (nodes split) and goes (the children merge back
once calm for `min_dwell` = 5% of the run). Rows: the threshold `refine_above` (coarsen_below a
quarter of it, decisions at every aligned tick) and the time step as a factor of the bound (the
finest level's, the tick); columns: model and precision. The verdicts are the matrix's (energy
within 1.5x its budget, no divergence at any step that runs, refused exactly above the bound
without sub-stepping), plus the body's mass: rho x the finest mesh's volume after every split and
merge, to 1e-12 (double) or 1e-6 (float) relative, or the cell is not as expected. Each entry:
outcome (peak M/S), then splits / merges over the run. The beam is critically damped in its
first bending mode (mass damping 2 omega_1 = 160/s): a run of 1000-2000 ticks is a fraction of that
mode's period, and undamped it would still swing at the end, never calm enough to merge.

What adding these rows showed, first about the criterion: every adaptive cell failed it at its
first split (kinetic + elastic 1.7x the budget at step 60), and so did 3 of the first 30 adaptive
stress scenes. Not an energy gain of the engine: a split near the pushed face moves most of the
face nodes' lumped mass (0.155 kg to 0.050 kg in stress scene 44) into the free fine nodes next to
it, which take the face's velocity; that kinetic energy was in the budget only as "kinetic energy
the driven nodes carry", an instantaneous term, and left it with the mass. The budget now adds the
kinetic energy that leaves the driven nodes when their masses change (zero for every body that is
not adaptive, whose verdicts and hashes are unchanged), and the work of driven nodes counts only
fixed and prescribed ones. Then two stress scenes (seed 7, indices 30 and 37) were still
"unbounded" at 1.5x while the same bodies all fine or all coarse passed: a driven coarse node that
feeds fine ghosts takes their forces as part of its reaction without having them in its f (the
impulse-taking integrator drops them for non-free nodes), so the monitor missed the push's work
through the ghosts (0.070 J counted of 0.127 J). It now counts each ghost's share that goes to
driven sources, w f_g . dx_s (the share handed to free nodes is internal). With the engine's split
and merge as they are, the cells below are then judged like any other.

**Two bugs these rows found, fixed** (engine/src/multires/adaptivity.cpp, 2026-11-25). (1) A merge
put the coarse node at the mass-weighted average of the finer displacements around it, which is the
field at the weighted centroid of the node's hat function, about h/4 inside the body at its surface:
a pushed beam's elastic energy jumped from 0.024 J to 0.130 J in the tick of its first merge. A
merge now interpolates the finer field at the node's rest place (exact for any affine field; test
`Adaptivity.AMergeCarriesATurnedBodyOverWithoutStrainingIt`: a quarter-turned block split and
merged lands within 1.4e-17 m with no strain, 12 mm off and 1.5 J before). (2) `adapt_body` kept the
free nodes' linear momentum by adding one uniform velocity to all of them, also when a change moved
mass onto or off fixed and prescribed nodes, whose supports take momentum legitimately: at the first
split of stress scene 44 the free nodes next to the clamp came out at 0.55 m/s (0.0008 m/s without
the correction). The correction now applies only to bodies nothing holds.

**A third fix: changes give back the energy they add.** With the two fixes above, 6 cells at the
loosest threshold (refine_above 1, coarsen_below 0.25 of the peak strain) still exceeded their
budget after their first merges while the beam was held pushed (kinetic + elastic 0.70-1.1 J against
about 0.5 J). Two stricter merge rules made it worse (14 and 12 cells), so the cause is not one rule:
a change of level is simply not energy-neutral for a bent body (the coarser tets lock in bending; a
merged region snaps to the coarse field). The simulation now measures the body's kinetic + elastic
energy around each decision and takes what a change added back from the body's motion about its
mean velocity (momentum kept; src/core/simulation.cpp). All 120 adaptive cells are then as expected
(test `Cells.AdaptiveChangesGiveBackTheEnergyTheyAdd`: 1.09x the budget at most).

)";
  int split_and_merged = 0, diverged = 0, bad = 0, ran = 0;
  double worst_peak = 0, worst_mass = 0;
  std::int64_t splits = 0, merges = 0;
  std::size_t most_fine = 0;
  for (const auto* r : cells) {
    if (r->outcome == Outcome::refused) continue;
    ++ran;
    if (r->splits > 0 && r->merges > 0) ++split_and_merged;
    if (r->outcome == Outcome::diverged) ++diverged;
    if (!r->acceptable()) ++bad;
    worst_peak = std::max(worst_peak, r->peak_ratio);
    worst_mass = std::max(worst_mass, r->mass_error);
    splits += r->splits;
    merges += r->merges;
    most_fine = std::max(most_fine, r->max_fine_tets);
  }
  s += fmt::format(
      "**This run**: {} adaptive cells ran (the others were refused, as expected, above the bound without "
      "sub-stepping); {} of them both split and merged ({} splits, {} merges in all; at most {} of the 1152 finest "
      "tets stepped at a sample); {} diverged; the largest energy over its budget was {:.2f}x (the bound is {}x); "
      "the worst relative mass error was {:.2g}; {} cell(s) not as expected.\n\n",
      ran, split_and_merged, splits, merges, most_fine, diverged, worst_peak, kBoundFactor, worst_mass, bad);
  const ForceModel models[] = {ForceModel::linear, ForceModel::stvk, ForceModel::corotational, ForceModel::springs};
  const Precision precisions[] = {Precision::float32, Precision::float64};
  s += "| refine_above | dt |";
  for (ForceModel m : models)
    for (Precision p : precisions) s += fmt::format(" {} {} |", pliant::to_string(m), pliant::to_string(p));
  s += "\n|---:|---|";
  for (int i = 0; i < 8; ++i) s += "---|";
  s += "\n";
  std::vector<std::string> rows;
  std::map<std::string, std::map<std::string, const CellResult*>> table;
  for (const auto* r : cells) {
    const std::string row = fmt::format("| {:g} | {:g}x{} |", r->spec.refine_above, r->spec.dt_factor,
                                        r->spec.dt_factor > 1 ? (r->spec.substep ? " substep" : "") : "");
    if (!table.count(row)) rows.push_back(row);
    table[row][fmt::format("{}{}", pliant::to_string(r->spec.model), pliant::to_string(r->spec.precision))] = r;
  }
  for (const auto& row : rows) {
    s += row;
    for (ForceModel m : models)
      for (Precision p : precisions) {
        auto& t = table[row];
        auto it = t.find(fmt::format("{}{}", pliant::to_string(m), pliant::to_string(p)));
        if (it == t.end()) {
          s += " - |";
          continue;
        }
        const CellResult& r = *it->second;
        s += " " + abbrev(r);
        if (r.outcome != Outcome::refused) s += fmt::format(" {}/{}", r.splits, r.merges);
        s += " |";
      }
    s += "\n";
  }
  return s;
}

}  // namespace

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
  auto part_of = [](const CellSpec& c) { return c.scenario == "cantilever" ? 0 : c.scenario == "adaptive_push" ? 2 : 1; };
  for (int part = 0; part < 3; ++part) {
    std::map<std::string, int> c;
    std::size_t n = 0;
    for (const auto& r : res)
      if (part_of(r.spec) == part) {
        ++n;
        ++c[to_string(r.outcome)];
        if (!r.acceptable()) ++c["bug"];
      }
    const char* what[] = {"the matrix (cantilever, 4 models x 5 nu x 4 E x 5 dt x 2 precisions)",
                          "the extremes (7 scenarios x 4 models x 2 precisions x 4 materials x 3 dt)",
                          "the adaptive rows (3-level beam pushed and released, 4 models x 3 thresholds x 5 dt x 2 "
                          "precisions)"};
    s += fmt::format("- {}: {} cells: {} stable, {} clamped, {} refused, {} diverged ({} not as expected).\n", what[part],
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
  s += counts["diverged"] == 0 ? "\n**Findings.** No cell diverges." : fmt::format("\n**Findings.** **{} cell(s) diverge** (listed under \"Divergences\" at the end).", counts["diverged"]);
  s += R"( The verdicts were tightened (issue 10 §2): a run counted as
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
    if (r.spec.scenario == "cantilever" || r.spec.scenario == "adaptive_push") continue;
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
  s += adaptive_section(res, abbrev);
  std::vector<const CellResult*> bad;
  for (const auto& r : res)
    if (r.outcome == Outcome::diverged || !r.acceptable_mass()) bad.push_back(&r);
  s += "\n## Divergences (and adaptive cells whose mass drifted)\n\n";
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
