// World: the public facade over Simulation<float|double>. Chooses the step (auto = the stable
// bound; an explicit dt above it is refused or sub-stepped), reports divergence at once, and
// offers the zero-copy and measuring accessors hosts and the runner use.
#include "pliant/world.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>
#include <fmt/format.h>
#include <variant>

#include "pliant/hierarchy.hpp"
#include "pliant/mesh_io.hpp"
#include "pliant/meshing.hpp"
#include "pliant/skin.hpp"
#include "level_arrays.hpp"
#include "../multires/adapt_arrays.hpp"
#include "simulation.hpp"
#include "probe_placement.hpp"

namespace pliant {

namespace detail {
template <class T>
void cauchy_stress(Executor& exec, const Simulation<T>& sim, const SimBody<T>& body, const Level<T>& L,
                   std::vector<double>& sigma9);
}

namespace {

// A normal's components over its largest magnitude: the same direction, with a squared length in
// [1, 3] whatever the components' size (1e200 squared is infinite, 1e-200 squared is 0). Only where
// the plain squared length leaves the normal range of doubles: elsewhere the normal is divided by
// its length as it always was (the same bits).
Vec3d rescaled_normal(const Vec3d& n) {
  const double n2 = n[0] * n[0] + n[1] * n[1] + n[2] * n[2];
  if (n2 >= 1e-290 && n2 <= 1e290) return n;
  const double m = std::max({std::fabs(n[0]), std::fabs(n[1]), std::fabs(n[2])});
  return m > 0 ? Vec3d{n[0] / m, n[1] / m, n[2] / m} : n;
}

// The obstacles with unit normals (World's constructor has checked them).
std::vector<ObstacleDef> unit_obstacles(std::vector<ObstacleDef> obstacles) {
  for (ObstacleDef& o : obstacles) {
    o.normal = rescaled_normal(o.normal);
    const double n = std::sqrt(o.normal[0] * o.normal[0] + o.normal[1] * o.normal[1] + o.normal[2] * o.normal[2]);
    for (double& c : o.normal) c /= n;
  }
  return obstacles;
}

void check_obstacles(const std::vector<ObstacleDef>& obstacles) {
  for (std::size_t i = 0; i < obstacles.size(); ++i) {
    const ObstacleDef& o = obstacles[i];
    bool finite = std::isfinite(o.friction);
    for (int k = 0; k < 3; ++k) finite = finite && std::isfinite(o.point[k]) && std::isfinite(o.normal[k]);
    if (!finite) throw InputError(fmt::format("obstacles[{}]: point, normal and friction must be finite", i));
    const Vec3d n = rescaled_normal(o.normal);
    if (!(n[0] != 0 || n[1] != 0 || n[2] != 0))
      throw InputError(fmt::format("obstacles[{}]: the plane's normal must not be [0, 0, 0]", i));
    if (!(o.friction >= 0)) throw InputError(fmt::format("obstacles[{}]: friction must be >= 0, got {}", i, o.friction));
  }
}

// An enum's value among its enumerators, 0 .. `last` (each enum of defs.hpp counts from 0 without
// gaps): a host that casts a number into one (a scene file cannot) gets an error naming the field,
// not a switch that matches no case. The call names the last enumerator rather than a count, so
// that it says which list it means.
template <class E>
void check_enum(E value, E last, const std::string& field) {
  const auto v = static_cast<long long>(value), n = static_cast<long long>(last) + 1;
  if (v < 0 || v >= n) throw InputError(fmt::format("{}: {} is not one of its {} values", field, v, n));
}

// What add_body can check of a BodyDef before any mesh is built: the fields a scene file could not
// hold (enum values outside their lists) and the choices whose limits the scene reader enforces
// (docs/scene-format.md): 1..kMaxLevels levels (INT_MAX levels tried to allocate as many meshes),
// a fixed active level that exists, adaptivity on 2 levels or more, at least one keyframe per
// prescribed motion, and nodes to calibrate against.
void check_body_def(const BodyDef& def) {
  const auto field = [&](const std::string& f) { return fmt::format("body '{}': {}", def.name, f); };
  check_enum(def.model, ForceModel::springs, field("model"));
  check_enum(def.mesh.kind, MeshSourceDef::Kind::implicit, field("mesh.kind"));
  // (An empty node list selected nothing without a word, where an empty box is an error.)
  const auto region = [&](const RegionDef& r, const std::string& where) {
    check_enum(r.kind, RegionDef::Kind::nodes, field(where + ".kind"));
    if (r.kind == RegionDef::Kind::nodes && r.nodes.empty())
      throw InputError(field(where + " lists no node (a nodes region must list at least one)"));
  };
  for (std::size_t i = 0; i < def.fixed.size(); ++i) region(def.fixed[i], fmt::format("fixed[{}]", i));
  for (std::size_t i = 0; i < def.prescribed.size(); ++i) {
    region(def.prescribed[i].region, fmt::format("prescribed[{}].region", i));
    if (def.prescribed[i].keyframes.empty())
      throw InputError(field(fmt::format("prescribed[{}].keyframes must list at least one keyframe", i)));
  }
  for (std::size_t i = 0; i < def.loads.size(); ++i) region(def.loads[i].region, fmt::format("loads[{}].region", i));
  const MultiresolutionDef& mr = def.multiresolution;
  if (mr.levels < 1 || mr.levels > kMaxLevels)
    throw InputError(field(fmt::format("multiresolution.levels must be in 1 .. {}, got {}", kMaxLevels, mr.levels)));
  const ActiveDef& a = mr.active;
  check_enum(a.kind, ActiveDef::Kind::adaptive, field("multiresolution.active.kind"));
  if (a.kind == ActiveDef::Kind::level && (a.level < 0 || a.level >= mr.levels))
    throw InputError(field(fmt::format("multiresolution.active.level must be in 0 (coarsest) .. {} (finest), got {}",
                                       mr.levels - 1, a.level)));
  if (a.kind == ActiveDef::Kind::regions)
    for (std::size_t i = 0; i < a.regions.size(); ++i)
      region(a.regions[i].region, fmt::format("multiresolution.active.regions[{}]", i));
  if (a.kind == ActiveDef::Kind::adaptive) {
    if (mr.levels < 2)
      throw InputError(field(fmt::format("multiresolution.active \"adaptive\" needs at least 2 levels, got {}", mr.levels)));
    check_enum(a.adapt.measure, AdaptDef::Measure::absolute, field("multiresolution.adapt.measure"));
  }
  // (A box's coarser levels are boxes of cells / ratio^k: face counts were ignored without a word.)
  if (!mr.faces.empty() && def.mesh.kind == MeshSourceDef::Kind::box)
    throw InputError(field("multiresolution.faces is for surfaces and meshes; a box's coarser levels are boxes of "
                           "cells / ratio per level (leave faces out)"));
  if (mr.calibrate && mr.levels > 1 && def.fixed.empty() && def.prescribed.empty())
    throw InputError(field("multiresolution.calibrate needs fixed nodes (it matches each level's deflection under its own "
                           "weight against them), and the body has no fixed or prescribed region"));
}

}  // namespace

struct World::Impl {
  WorldDef def;
  Executor exec;
  std::variant<detail::Simulation<float>, detail::Simulation<double>> sim;
  double time = 0;
  std::int64_t steps = 0;
  double dt = 0, stable_dt = 0;
  int substeps = 1;            // sub-steps of the next step()
  int base_substeps = 1;       // as chosen at load (rest state)
  int max_substeps = 1;        // most sub-steps any step() took
  std::int64_t adapted_steps = 0;  // step() calls that took more sub-steps than base_substeps
  double stiffness_ratio = 1;  // last measured (adapt_substeps)
  TickStats ticks;
  double max_stiffness_ratio = 1;
  std::vector<std::unique_ptr<HapticLink>> haptic;  // one per tool (stable addresses for host threads)


  explicit Impl(const WorldDef& d) : def(d), exec(d.threads) {
    if (d.precision == Precision::float32)
      sim.emplace<detail::Simulation<float>>();
    else
      sim.emplace<detail::Simulation<double>>();
    std::visit([&](auto& s) {
      for (int k = 0; k < 3; ++k) s.gravity[k] = static_cast<std::remove_reference_t<decltype(s.gravity[0])>>(d.gravity[k]);
      s.obstacles = unit_obstacles(d.obstacles);
    }, sim);
  }

  template <class F>
  decltype(auto) visit(F&& f) { return std::visit(std::forward<F>(f), sim); }
  template <class F>
  decltype(auto) visit(F&& f) const { return std::visit(std::forward<F>(f), sim); }

  // Recomputes the step from every level's bound and the world's time-step settings.
  void choose_step() {
    stable_dt = visit([](auto& s) {
      double m = 1e300;
      for (auto& b : s.bodies)
        for (auto& L : b.levels) m = std::min(m, L.stable_dt);
      return m;
    });
    const TimeStepDef& ts = def.time_step;
    base_substeps = substeps = 1;
    if (stable_dt == 1e300) {  // no body (the first one was refused): as a new world
      stable_dt = dt = 0;
      return;
    }
    if (!ts.dt) {
      dt = aligned_tick();
      prepare();
      return;
    }
    if (*ts.dt <= stable_dt) {
      dt = *ts.dt;
      prepare();
      return;
    }
    if (!ts.substep)
      throw InputError(fmt::format(
          "time_step.dt = {:.6g} s is above the stable bound {:.6g} s (Courant number {}); use \"auto\", a dt at or "
          "below the bound, or \"substep\": true to split each step into stable sub-steps",
          *ts.dt, stable_dt, ts.courant));
    // Sub-steps per step are an int: a count beyond it overflowed to a negative one, and every
    // step then advanced the time without simulating anything.
    const double need = std::ceil(*ts.dt / stable_dt);
    if (!(need <= double(std::numeric_limits<int>::max())))
      throw InputError(fmt::format(
          "time_step.dt = {:.6g} s would take {:.3g} sub-steps of the stable bound {:.6g} s (Courant number {}); at "
          "most {} per step: use a smaller dt",
          *ts.dt, need, stable_dt, ts.courant, std::numeric_limits<int>::max()));
    base_substeps = substeps = int(need);
    dt = *ts.dt;
    prepare();
  }

  // The automatic step: the smallest stable bound, shortened (by less than kPeriodSlack) where that
  // lets a coarser level of a multiresolution body take a period twice as long. The bounds of
  // levels a ratio 2 apart are about 2x apart, but rarely exactly (the measured frequency of a
  // coarser mesh converges from a different side): a coarse bound of 1.98x the fine one would
  // otherwise give the coarse level period 1 and halve its saving.
  static constexpr double kPeriodSlack = 1.25;
  double aligned_tick() const {
    return visit([&](auto& s) {
      double tick = stable_dt;
      for (auto& b : s.bodies) {
        if (b.levels.size() < 2) continue;
        for (auto& L : b.levels) {
          double q = 1;
          while (2 * q <= kPeriodSlack * L.stable_dt / stable_dt && q < double(1 << 20)) q *= 2;
          tick = std::min(tick, L.stable_dt / q);
        }
      }
      return tick;
    });
  }

  // Jobs, periods and kernel contexts of every level for ticks of the step dt.
  void prepare() {
    visit([&](auto& s) {
      s.schedule = def.schedule == Schedule::naive ? ScheduleKind::naive : ScheduleKind::staggered;
      s.packed_corners = def.packed_corners;
      s.prepare(dt / base_substeps);  // the step's own tick: sub-steps shrink every level's step (Simulation::prepare)
      // The monitors' per-tet scratch at its largest now, not at the first step (a real-time run's
      // first frame paid its page faults: 0.4 MB on the 50k-tet organ).
      std::size_t tets = 0;
      for (const auto& body : s.bodies)
        for (const auto& L : body.levels) tets = std::max(tets, L.tet_count);
      s.grow_scratch(tets);
    });
  }

  // The adaptive step (TimeStepDef::adapt). Every few steps (see next_check below; every step
  // once the body is stiffened past the trigger or sub-stepped), the elements' stiffness ratio r (how far the current deformation has raised
  // the largest Hessian eigenvalue of an element's energy over its rest value, at most;
  // kernels/element_stiffness.hpp) estimates the current highest frequency as omega_rest sqrt(r).
  // Below kAdaptTrigger nothing changes: ordinary deformations run at the step chosen at load and
  // cost one monitor pass per 16 steps (for corotational at strains below 50%, a norm per tet; the
  // first few steps after load check more often, see next_check). Above it, the step is split so that each sub-step has
  // omega_rest sqrt(r) h / 2 <= kAdaptCourant. The estimate scales the mesh's rest frequency by the
  // worst element's ratio, which is not a bound (the stiffened elements need not be the ones that set
  // omega_rest), hence the low target: with 0.7, stvk cells of the stability matrix (a beam
  // collapsing under 10x its own weight, r up to 50) still diverged at 0.5x the bound; with 0.35
  // they are all stable (docs/stability.md).
  // The count goes up at once but comes down only after kAdaptRelax checks in a row have wanted
  // fewer: symplectic Euler stores the velocity half a step off, and a step size that toggles
  // from one step to the next (a ratio hovering at the trigger) pumps energy into the body (the
  // stability matrix's inverted stvk cells diverged that way without this hysteresis). Every
  // decrease still costs a little energy (the first kick after it is (h_old - h_new) a / 2 off),
  // so it waits for 256 checks: with 32, the springs cantilever at E = 100 Pa (squashed springs
  // re-expanding and squashing again) gained 1.5x its energy over 1500 steps at the default step;
  // with 256 the whole matrix stays within 1.15x, never relaxing within 1.07x but 25% slower.
  // When the next check comes: the interval starts at 1 step, doubles after every check that
  // finds r still far from the trigger, up to kAdaptIntervalMax (the monitor costs ~1/8 of a
  // step), and is cut so that, at the rate r rose since the last check, it would cover at most
  // half of the way left to the trigger. (It was a fixed 16 steps, 8 above r = 1.5: the
  // stability matrix's stvk cantilever at E = 100 Pa, loaded by 10x its own weight, went from
  // r = 1 to 3.3 in 4 steps and diverged at step 20 of the default step, before its first check.)
  // Steps are counted in the moves of the finest level that steps a tet (moving_steps): a
  // multiresolution body stepping only its coarser levels moves every 8 or 16 fine steps, and
  // measuring it every 16 fine steps cost 12% of the 50k-tet organ's stepping on its two coarser
  // levels (perf, 1 thread, 2026-11-28), for positions that had not moved since the last check.
  static constexpr int kAdaptIntervalMax = 16;
  // Fine steps between two moves of the finest stepped level (1 for a single-level body, or
  // whenever a multiresolution body steps tets of its finest level).
  int moving_steps() {
    const int ticks = visit([](const auto& s) { return s.finest_stepped_period(); });
    return std::max(1, ticks / std::max(1, base_substeps));
  }
  std::int64_t next_check = 0;   // step count at which step() measures r next
  int check_interval = 1;        // steps
  double last_checked_ratio = 1;
  std::int64_t last_check_step = 0;
  static constexpr double kAdaptTrigger = 2.0;
  static constexpr double kAdaptCourant = 0.35;
  static constexpr int kAdaptRelax = 256;
  static constexpr int kMaxAdaptiveSubsteps = 256;
  int checks_wanting_fewer = 0;
  std::vector<MeshLoadReport> load_reports;  // per body: what loading fixed in its mesh
  std::vector<std::vector<std::int32_t>> node_maps;  // per body: file vertex -> node (World::node_map)
  std::int64_t stiffness_checks = 0;
  std::size_t touch_cursor = 0;  // touch_pages: bytes into the bodies' level arrays, end to end
  void adapt_substeps() {
    ++stiffness_checks;
    stiffness_ratio = visit([&](auto& s) { return s.stiffness_ratio(exec); });
    max_stiffness_ratio = std::max(max_stiffness_ratio, stiffness_ratio);
    // The next check (used while r is below the trigger and nothing is sub-stepped).
    const double rise_per_step = (stiffness_ratio - last_checked_ratio) / double(std::max<std::int64_t>(1, steps - last_check_step));
    const int most = kAdaptIntervalMax * moving_steps();
    int interval = std::min(2 * check_interval, most);
    if (rise_per_step > 0) {
      const double steps_to_half = 0.5 * (kAdaptTrigger - stiffness_ratio) / rise_per_step;
      interval = std::min(interval, std::max(1, int(std::min(steps_to_half, double(most)))));
    }
    check_interval = interval;
    last_checked_ratio = stiffness_ratio;
    last_check_step = steps;
    next_check = steps + interval;
    int want = base_substeps;
    if (stiffness_ratio > kAdaptTrigger) {  // (NaN: the divergence check reports it)
      // stable_dt = courant x 2 / omega_rest (undamped), so the sub-step's Courant number is
      // courant (h / stable_dt) sqrt(r).
      const double need = def.time_step.courant * (dt / stable_dt) * std::sqrt(stiffness_ratio) / kAdaptCourant;
      want = std::max(base_substeps, need < kMaxAdaptiveSubsteps ? int(std::ceil(need)) : kMaxAdaptiveSubsteps);
    }
    if (want >= substeps) {
      substeps = want;
      checks_wanting_fewer = 0;
    } else if (++checks_wanting_fewer >= kAdaptRelax) {
      substeps = want;
      checks_wanting_fewer = 0;
    }
  }

  template <class S>
  auto& body(S& s, BodyId id) const {
    if (id < 0 || std::size_t(id) >= s.bodies.size()) throw InputError(fmt::format("no body with id {}", id));
    return s.bodies[std::size_t(id)];
  }
  template <class S>
  auto& level(S& s, BodyId id, int l) const {
    auto& b = body(s, id);
    if (l < 0 || std::size_t(l) >= b.levels.size())
      throw InputError(fmt::format("body '{}' has no level {} (it has {})", b.def.name, l, b.levels.size()));
    return b.levels[std::size_t(l)];
  }
};

World::World(const WorldDef& def) {
  if (!(def.time_step.courant > 0 && def.time_step.courant <= 1))
    throw InputError(fmt::format("time_step.courant must be in (0, 1], got {}", def.time_step.courant));
  if (def.time_step.dt && !(*def.time_step.dt > 0 && std::isfinite(*def.time_step.dt)))
    throw InputError(fmt::format("time_step.dt must be \"auto\" or a finite number > 0, got {}", *def.time_step.dt));
  for (int k = 0; k < 3; ++k)
    if (!std::isfinite(def.gravity[k]))
      throw InputError(fmt::format("gravity must be 3 finite numbers (m/s^2), got [{}, {}, {}]", def.gravity[0],
                                   def.gravity[1], def.gravity[2]));
  check_enum(def.precision, Precision::float64, "precision");
  check_enum(def.schedule, Schedule::naive, "schedule");
  check_enum(def.packed_corners, PackedCorners::off, "packed_corners");
  if (def.threads < 0) throw InputError(fmt::format("threads must be >= 0 (0 = all cores), got {}", def.threads));
  check_obstacles(def.obstacles);
  impl_ = std::make_unique<Impl>(def);
}
World::~World() = default;
World::World(World&&) noexcept = default;
World& World::operator=(World&&) noexcept = default;

namespace {

// build_mesh, also giving the node map of the locality renumbering (empty for boxes, which are
// in grid order already).
TetMesh build_mesh_mapped(const MeshSourceDef& src, MeshLoadReport* report, std::vector<std::int32_t>* old_to_new) {
  MeshLoadReport local;
  MeshLoadReport& rep = report ? *report : local;
  if (!(src.scale > 0 && std::isfinite(src.scale)))
    throw InputError(fmt::format("mesh.scale must be a finite number > 0, got {}", src.scale));
  // cell_size is a length of the body as simulated (m, after scale: docs/scene-format.md); the
  // mesher works in the units of the surface or shape, before scale. It was passed as is: a
  // surface in mm with scale 0.001 and cell_size 0.004 got 4 um cells.
  auto meshed = [&](auto&& mesher) {
    try {
      return mesher(src.cell_size / src.scale);
    } catch (const InputError& e) {
      if (src.scale == 1.0) throw;
      throw InputError(fmt::format("mesh.cell_size {} m with scale {} is {} in the units of the {}: {}", src.cell_size,
                                   src.scale, src.cell_size / src.scale,
                                   src.kind == MeshSourceDef::Kind::surface ? "surface file" : "shape", e.what()));
    }
  };
  TetMesh mesh;
  switch (src.kind) {
    case MeshSourceDef::Kind::box: mesh = make_box_mesh(src.min, src.max, src.cells, src.tets_per_cell); break;
    case MeshSourceDef::Kind::file: mesh = read_tet_mesh(src.path, &rep); break;
    case MeshSourceDef::Kind::surface:
      mesh = meshed([&](double h) { return mesh_surface_file(src.path, h, src.repair); });
      break;
    case MeshSourceDef::Kind::implicit:
      mesh = meshed([&](double h) { return mesh_implicit_shape(src.shape, h); });
      break;
  }
  if (src.scale != 1.0 || src.translate != Vec3d{0, 0, 0}) transform_mesh(mesh, src.scale, src.translate);
  // Files and meshers come in no useful order; the kernels stream only if neighbours in space
  // are neighbours in memory (docs/performance.md). Readers and the mesher return finalized
  // meshes, so every index is valid here.
  std::vector<std::int32_t> map;
  if (src.kind != MeshSourceDef::Kind::box) map = renumber_for_locality(mesh);
  if (old_to_new) *old_to_new = std::move(map);
  return mesh;
}

// RegionDef::nodes count in the file's numbering (for file meshes; else the mesher's): map them
// to the engine's. Indices out of range stay as given, so that the error names them.
BodyDef with_mapped_node_regions(const BodyDef& def, const std::vector<std::int32_t>& old_to_new) {
  BodyDef out = def;
  auto map = [&](RegionDef& r) {
    if (r.kind != RegionDef::Kind::nodes) return;
    for (auto& n : r.nodes)
      if (n >= 0 && std::size_t(n) < old_to_new.size()) n = old_to_new[std::size_t(n)];
  };
  for (auto& r : out.fixed) map(r);
  for (auto& p : out.prescribed) map(p.region);
  for (auto& l : out.loads) map(l.region);
  return out;
}

// A "nodes" region that lists a node of the file which no tet uses (and so was not loaded).
void check_region_nodes_used(const BodyDef& def, const std::vector<std::int32_t>& file_map) {
  auto check = [&](const RegionDef& r, const std::string& what) {
    if (r.kind != RegionDef::Kind::nodes) return;
    for (auto n : r.nodes)
      if (n >= 0 && std::size_t(n) < file_map.size() && file_map[std::size_t(n)] < 0)
        throw InputError(fmt::format("body '{}': {}: node {} of the file is used by no tetrahedron (it was not loaded)",
                                     def.name, what, n));
  };
  for (std::size_t i = 0; i < def.fixed.size(); ++i) check(def.fixed[i], fmt::format("fixed[{}]", i));
  for (std::size_t i = 0; i < def.prescribed.size(); ++i) check(def.prescribed[i].region, fmt::format("prescribed[{}]", i));
  for (std::size_t i = 0; i < def.loads.size(); ++i) check(def.loads[i].region, fmt::format("loads[{}]", i));
}

bool has_node_regions(const BodyDef& def) {
  for (const auto& r : def.fixed)
    if (r.kind == RegionDef::Kind::nodes) return true;
  for (const auto& p : def.prescribed)
    if (p.region.kind == RegionDef::Kind::nodes) return true;
  for (const auto& l : def.loads)
    if (l.region.kind == RegionDef::Kind::nodes) return true;
  return false;
}

}  // namespace

TetMesh build_mesh(const MeshSourceDef& src, MeshLoadReport* report) { return build_mesh_mapped(src, report, nullptr); }

BodyId World::add_body(const BodyDef& def) {
  check_body_def(def);  // before the mesh is built or read
  std::vector<std::int32_t> old_to_new;
  MeshLoadReport read;  // what the reader skipped or fixed
  TetMesh mesh;
  try {
    mesh = build_mesh_mapped(def.mesh, &read, &old_to_new);
  } catch (const InputError& e) {
    // Which body: a box's or a shape's error (and mesh.scale's, mesh.translate's) names no file.
    // A reader's names its file, and a mesher's its surface: those are left as they are.
    const std::string what = e.what();
    const bool names_file = def.mesh.kind == MeshSourceDef::Kind::file || def.mesh.kind == MeshSourceDef::Kind::surface;
    if (what.rfind("body '", 0) == 0 || (names_file && what.rfind("mesh", 0) != 0)) throw;
    throw InputError(fmt::format("body '{}': {}", def.name, what));
  }
  // A file's numbering -> the engine's: the reader dropped unused vertices (read.vertex_map),
  // then the mesh was renumbered for locality (old_to_new). "nodes" regions count in the file's.
  std::vector<std::int32_t> file_map;
  if (def.mesh.kind == MeshSourceDef::Kind::file) {
    file_map.resize(read.vertex_map.empty() ? mesh.node_count() : read.vertex_map.size());
    for (std::size_t i = 0; i < file_map.size(); ++i) {
      const std::int32_t j = read.vertex_map.empty() ? std::int32_t(i) : read.vertex_map[i];
      file_map[i] = j < 0 ? -1 : old_to_new.empty() ? j : old_to_new[std::size_t(j)];
    }
    check_region_nodes_used(def, file_map);
  }
  const std::vector<std::int32_t>& region_map = file_map.empty() ? old_to_new : file_map;
  const bool mapped = !region_map.empty() && has_node_regions(def);
  const BodyId id = mapped ? add_body(with_mapped_node_regions(def, region_map), std::move(mesh))
                           : add_body(def, std::move(mesh));
  if (mapped) impl_->visit([&](auto& s) { s.bodies[std::size_t(id)].def = def; });  // keep the definition as given
  impl_->node_maps[std::size_t(id)] = std::move(file_map);
  MeshLoadReport& r = impl_->load_reports[std::size_t(id)];
  r.skipped_cells += read.skipped_cells;
  r.reoriented_tets += read.reoriented_tets;
  r.dropped_vertices += read.dropped_vertices;
  return id;
}

const std::vector<std::int32_t>& World::node_map(BodyId body) const {
  if (body < 0 || std::size_t(body) >= impl_->node_maps.size()) throw InputError(fmt::format("no body with id {}", body));
  return impl_->node_maps[std::size_t(body)];
}

const MeshLoadReport& World::mesh_load_report(BodyId body) const {
  if (body < 0 || std::size_t(body) >= impl_->load_reports.size())
    throw InputError(fmt::format("no body with id {}", body));
  return impl_->load_reports[std::size_t(body)];
}

BodyId World::add_body(const BodyDef& def, TetMesh mesh) {
  check_body_def(def);
  if (find_body(def.name) >= 0) throw InputError(fmt::format("a body named '{}' exists already", def.name));
  MeshLoadReport report;
  finalize_tet_mesh(mesh, fmt::format("body '{}'", def.name), report);
  if (mesh.tet_count() == 0) throw InputError(fmt::format("body '{}': the mesh has no tetrahedra", def.name));
  std::size_t tets = 0;
  const BodyId id = impl_->visit([&](auto& s) {
    using T = std::remove_reference_t<decltype(s.gravity[0])>;
    detail::SimBody<T> b;
    if (def.multiresolution.levels > 1) {
      std::shared_ptr<const Hierarchy> h;
      try {
        h = std::make_shared<const Hierarchy>(link_levels(build_level_meshes(def, std::move(mesh))));
        b = detail::build_multilevel_body<T>(*h, def, impl_->def.time_step.courant, impl_->exec);
      } catch (const InputError& e) {
        // The hierarchy's and the activation's errors ("level 2 of the hierarchy has no tets",
        // "multiresolution.active: node 99999 does not exist") name no body.
        if (std::string_view(e.what()).rfind("body '", 0) == 0) throw;
        throw InputError(fmt::format("body '{}': {}", def.name, e.what()));
      }
      if (def.multiresolution.active.kind == ActiveDef::Kind::adaptive) {
        const AdaptDef& ad = def.multiresolution.active.adapt;
        if (!(std::isfinite(ad.refine_above) && ad.refine_above > 0))
          throw InputError(fmt::format("body '{}': multiresolution.adapt.refine_above must be a positive strain, got {}", def.name, ad.refine_above));
        if (!(std::isfinite(ad.coarsen_below) && ad.coarsen_below >= 0 && ad.coarsen_below < ad.refine_above))
          throw InputError(fmt::format("body '{}': multiresolution.adapt.coarsen_below must be in [0, refine_above = {}), got {}",
                                       def.name, ad.refine_above, ad.coarsen_below));
        if (!(std::isfinite(ad.min_dwell) && ad.min_dwell >= 0) || !(std::isfinite(ad.check_every) && ad.check_every >= 0))
          throw InputError(fmt::format("body '{}': multiresolution.adapt.min_dwell and check_every must be finite and >= 0 (s)", def.name));
        if (!(std::isfinite(ad.refine_near) && (ad.refine_near >= 0 || ad.refine_near == -1)))
          throw InputError(fmt::format("body '{}': multiresolution.adapt.refine_near must be a finite distance >= 0 (m), "
                                       "or -1 (\"auto\": one mean edge of each level), got {}", def.name, ad.refine_near));
        b.adapt = detail::make_adaptive_state(h, def.multiresolution.active, b);
      }
    } else {
      b.def = def;
      b.origin = detail::body_frame_origin(mesh);
      b.levels.push_back(
          detail::build_level<T>(mesh, b.origin, def, impl_->def.time_step.courant, b.motions, impl_->exec));
    }
    for (auto& L : b.levels) {
      tets += L.tet_count;
      detail::prepare_obstacles(L, s.obstacles, def.name, b.origin);
    }
    if (!def.skin.empty()) {
      // The skin in the mesh source's frame -> world (the mesh's scale and translate) -> body frame.
      const SkinSurface surface = read_obj_surface(def.skin);
      auto skin = std::make_shared<detail::SkinState>();
      skin->triangles = surface.triangles;
      skin->rest.resize(surface.points.size());
      std::vector<double> body_frame(surface.points.size());
      for (std::size_t i = 0; i < surface.points.size(); ++i) {
        const std::size_t k = i % 3;
        skin->rest[i] = def.mesh.scale * surface.points[i] + def.mesh.translate[k];
        body_frame[i] = skin->rest[i] - b.origin[k];
      }
      for (const auto& L : b.levels) skin->levels.push_back(detail::bind_skin(body_frame, L, impl_->exec));
      b.skin = std::move(skin);
    }
    s.bodies.push_back(std::move(b));
    s.scratch.reserve(std::max(s.scratch.capacity(), tets));  // reports and the monitor
    s.chunk_max.reserve(std::max(s.chunk_max.capacity(), tets / kTetGrain + 1));  // the monitor's chunks
    return BodyId(s.bodies.size() - 1);
  });
  try {
    impl_->choose_step();
  } catch (...) {
    // Refused for its step: the world goes back to the step of the bodies it had (choose_step
    // succeeded for them, so it does again; without it the bound and sub-steps stayed the
    // refused body's).
    impl_->visit([](auto& s) { s.bodies.pop_back(); });
    impl_->choose_step();
    throw;
  }
  impl_->load_reports.push_back(report);
  impl_->node_maps.emplace_back();
  return id;
}

namespace {

bool finite3(const Vec3d& v) { return std::isfinite(v[0]) && std::isfinite(v[1]) && std::isfinite(v[2]); }

// Checks a pose (finite position, finite non-zero quaternion) and returns it with a unit quaternion.
ToolPose checked_pose(const ToolPose& p, const std::string& what) {
  const Quatd& q = p.orientation;
  const double n = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
  if (!finite3(p.position)) throw InputError(fmt::format("{}: position must be finite", what));
  if (!std::isfinite(n) || !(n > 1e-12))
    throw InputError(fmt::format("{}: orientation must be a non-zero quaternion [w, x, y, z] of finite numbers", what));
  return {p.position, {q[0] / n, q[1] / n, q[2] / n, q[3] / n}};
}

}  // namespace

ToolId World::add_tool(const ToolDef& in) {
  ToolDef def = in;
  const std::string who = fmt::format("tool '{}'", def.name);
  const ToolShapeDef& sh = def.shape;
  check_enum(sh.kind, ToolShapeDef::Kind::capsule, who + ": shape.kind");
  if (!std::isfinite(sh.radius) || !(sh.radius > 0))
    throw InputError(fmt::format("{}: shape radius must be a positive length (m), got {}", who, sh.radius));
  if (sh.kind == ToolShapeDef::Kind::capsule && (!std::isfinite(sh.length) || !(sh.length > 0)))
    throw InputError(fmt::format("{}: a capsule's length must be positive (m), got {}", who, sh.length));
  if (def.keyframes.empty()) throw InputError(fmt::format("{}: needs at least one keyframe (time, position)", who));
  for (std::size_t i = 0; i < def.keyframes.size(); ++i) {
    ToolKeyframeDef& k = def.keyframes[i];
    const std::string at = fmt::format("{}: keyframes[{}]", who, i);
    if (!std::isfinite(k.time)) throw InputError(fmt::format("{}: time must be finite", at));
    if (i > 0 && !(k.time > def.keyframes[i - 1].time))
      throw InputError(fmt::format("{}: times must increase (got {} after {})", at, k.time, def.keyframes[i - 1].time));
    const ToolPose p = checked_pose({k.position, k.orientation}, at);
    k.orientation = p.orientation;
  }
  std::vector<BodyId> touched;
  if (def.bodies.empty()) {
    for (std::size_t b = 0; b < body_count(); ++b) touched.push_back(BodyId(b));
  } else {
    for (const std::string& name : def.bodies) {
      const BodyId b = find_body(name);
      if (b < 0) throw InputError(fmt::format("{}: bodies names '{}', which is not a body of the world (add tools after their bodies)", who, name));
      if (std::find(touched.begin(), touched.end(), b) == touched.end()) touched.push_back(b);
    }
  }
  Impl& w = *impl_;
  return w.visit([&](auto& s) {
    using T = typename std::remove_reference_t<decltype(s.bodies[0].levels[0].x[0][0])>;
    if (!s.embree) s.embree = std::make_unique<detail::EmbreeDevice>();
    detail::ToolState<T> tool;
    tool.def = def;
    const ToolPose now = tool.pose_at(w.time);
    for (BodyId b : touched) {
      auto& body = s.bodies[std::size_t(b)];
      for (std::size_t l = 0; l < body.levels.size(); ++l)
        tool.levels.push_back(detail::make_level_contact(*s.embree, body.levels[l], int(b), int(l), w.exec, now));
    }
    s.tools.push_back(std::move(tool));
    w.haptic.push_back(std::make_unique<HapticLink>());
    return ToolId(s.tools.size() - 1);
  });
}

World::AdaptStats World::adapt_stats(BodyId b) const {
  return impl_->visit([&](auto& s) {
    AdaptStats a;
    const auto& body = impl_->body(s, b);
    if (body.adapt)
      a = {body.adapt->splits,        body.adapt->merges,        body.adapt->checks, body.adapt->changes,
           body.adapt->apply_seconds, body.adapt->check_seconds, body.adapt->check_max_seconds, body.adapt->touched_nodes, body.adapt->touched_tets,
           body.adapt->keeping_splits, body.adapt->undone, body.adapt->deferred_merges};
    return a;
  });
}
void World::force_level(BodyId b, int level) {
  impl_->visit([&](auto& s) {
    auto& body = impl_->body(s, b);
    if (!body.adapt) throw InputError(fmt::format("force_level: body '{}' is not adaptive (multiresolution.active)", body.def.name));
    if (level < 0 || level >= int(body.levels.size()))
      throw InputError(fmt::format("force_level: level {} does not exist (0 .. {})", level, body.levels.size() - 1));
    body.adapt->forced_target = level;
    body.adapt->next_check = 0;
  });
}

void World::set_adapt_scale(BodyId b, double scale) {
  if (!(std::isfinite(scale) && scale >= 1)) throw InputError(fmt::format("set_adapt_scale: the scale must be >= 1, got {}", scale));
  impl_->visit([&](auto& s) {
    auto& body = impl_->body(s, b);
    if (!body.adapt) throw InputError(fmt::format("set_adapt_scale: body '{}' is not adaptive (multiresolution.active)", body.def.name));
    body.adapt->scale = scale;
  });
}
void World::set_adapt_split_budget(BodyId b, int splits) {
  if (splits < 1) throw InputError(fmt::format("set_adapt_split_budget: the budget must be >= 1 split per decision, got {}", splits));
  impl_->visit([&](auto& s) {
    auto& body = impl_->body(s, b);
    if (!body.adapt)
      throw InputError(fmt::format("set_adapt_split_budget: body '{}' is not adaptive (multiresolution.active)", body.def.name));
    body.adapt->split_budget = splits;
  });
}
int World::adapt_split_budget(BodyId b) const {
  return impl_->visit([&](auto& s) {
    const auto& body = impl_->body(s, b);
    return body.adapt ? body.adapt->split_budget : std::numeric_limits<int>::max();
  });
}
void World::set_adapt_change_interval(BodyId b, double seconds) {
  if (!(seconds >= 0 && std::isfinite(seconds)))
    throw InputError(fmt::format("set_adapt_change_interval: the interval must be a finite number of seconds >= 0, got {}", seconds));
  impl_->visit([&](auto& s) {
    auto& body = impl_->body(s, b);
    if (!body.adapt)
      throw InputError(fmt::format("set_adapt_change_interval: body '{}' is not adaptive (multiresolution.active)", body.def.name));
    body.adapt->change_interval = seconds;
  });
}
double World::adapt_change_interval(BodyId b) const {
  return impl_->visit([&](auto& s) {
    const auto& body = impl_->body(s, b);
    return body.adapt ? body.adapt->change_interval : 0.0;
  });
}
double World::adapt_next_decision(BodyId b) const {
  return impl_->visit([&](auto& s) {
    const auto& body = impl_->body(s, b);
    return body.adapt ? body.adapt->next_decision() : std::numeric_limits<double>::infinity();
  });
}
void World::set_adapt_cap(BodyId b, int level) {
  impl_->visit([&](auto& s) {
    auto& body = impl_->body(s, b);
    if (!body.adapt) throw InputError(fmt::format("set_adapt_cap: body '{}' is not adaptive (multiresolution.active)", body.def.name));
    if (level < 0 || level >= int(body.levels.size()))
      throw InputError(fmt::format("set_adapt_cap: level {} does not exist (0 .. {})", level, body.levels.size() - 1));
    // Lowered: decide at the next point where every level's window ends rather than at the next
    // check_every (the real-time controller lowers it when frames run out of time).
    if (level < body.adapt->cap) body.adapt->next_check = 0;
    body.adapt->cap = level;
  });
}
int World::adapt_cap(BodyId b) const {
  return impl_->visit([&](auto& s) {
    const auto& body = impl_->body(s, b);
    return body.adapt ? std::min(body.adapt->cap, int(body.levels.size()) - 1) : int(body.levels.size()) - 1;
  });
}
double World::adapt_scale(BodyId b) const {
  return impl_->visit([&](auto& s) {
    const auto& body = impl_->body(s, b);
    return body.adapt ? body.adapt->scale : 1.0;
  });
}

bool World::has_skin(BodyId b) const {
  return impl_->visit([&](auto& s) { return impl_->body(s, b).skin != nullptr; });
}
const std::vector<std::array<std::int32_t, 3>>& World::skin_triangles(BodyId b) const {
  static const std::vector<std::array<std::int32_t, 3>> none;
  return impl_->visit([&](auto& s) -> const std::vector<std::array<std::int32_t, 3>>& {
    const auto& skin = impl_->body(s, b).skin;
    return skin ? skin->triangles : none;
  });
}
const std::vector<double>& World::skin_rest_positions(BodyId b) const {
  static const std::vector<double> none;
  return impl_->visit([&](auto& s) -> const std::vector<double>& {
    const auto& skin = impl_->body(s, b).skin;
    return skin ? skin->rest : none;
  });
}
double World::skin_max_distance(BodyId b, int l) const {
  return impl_->visit([&](auto& s) {
    const auto& body = impl_->body(s, b);
    (void)impl_->level(s, b, l);
    return body.skin ? body.skin->levels[std::size_t(l)].max_distance : 0.0;
  });
}
void World::skin_positions(BodyId b, std::vector<double>& out) const {
  impl_->visit([&](auto& s) {
    const auto& body = impl_->body(s, b);
    out.clear();
    if (!body.skin) return;
    const detail::SkinState& skin = *body.skin;
    const std::size_t count = skin.rest.size() / 3;
    out.resize(3 * count);
    for (std::size_t i = 0; i < count; ++i) {
      // The finest level whose triangle has no inactive corner (a single level: always it).
      std::size_t l = body.levels.size() - 1;
      for (;; --l) {
        const auto& L = body.levels[l];
        const auto& t = skin.levels[l].nodes[i];
        bool active = true;
        for (std::int32_t n : t) active &= L.state[std::size_t(n)] != kNodeInactive;
        if (active || l == 0) break;
      }
      const auto& L = body.levels[l];
      const auto p = detail::skin_vertex(skin.levels[l], i, [&](std::int32_t n) { return detail::node_now(body, L, std::size_t(n)); });
      for (int k = 0; k < 3; ++k) out[3 * i + std::size_t(k)] = body.origin[std::size_t(k)] + p[std::size_t(k)];
    }
  });
}

std::size_t World::tool_count() const {
  return impl_->visit([](auto& s) { return s.tools.size(); });
}
namespace {
template <class S>
auto& tool_of(S& s, ToolId id) {
  if (id < 0 || std::size_t(id) >= s.tools.size())
    throw InputError(fmt::format("no tool {} (the world has {})", id, s.tools.size()));
  return s.tools[std::size_t(id)];
}
}  // namespace
const ToolDef& World::tool_def(ToolId id) const {
  return impl_->visit([&](auto& s) -> const ToolDef& { return tool_of(s, id).def; });
}
void World::set_tool_pose(ToolId id, const ToolPose& pose) {
  const ToolPose p = checked_pose(pose, fmt::format("set_tool_pose of tool {}", id));
  impl_->visit([&](auto& s) {
    auto& t = tool_of(s, id);
    t.host_driven = true;
    t.host_pose = p;
  });
}
ToolPose World::tool_pose(ToolId id) const {
  return impl_->visit([&](auto& s) { return tool_of(s, id).pose_at(impl_->time); });
}
ToolReading World::tool_reading(ToolId id) const {
  return impl_->visit([&](auto& s) { return tool_of(s, id).reading; });
}
const HapticLink& World::haptic_link(ToolId id) const {
  impl_->visit([&](auto& s) { (void)tool_of(s, id); });
  return *impl_->haptic[std::size_t(id)];
}

int World::add_probe(const ProbeDef& def) {
  const BodyId b = find_body(def.body);
  if (b < 0) throw InputError(fmt::format("probe '{}': no body named '{}'", def.name, def.body));
  // (An infinite point was "inside" nowhere but said to lie 1e150 m from the body; a point of
  // finite but huge numbers still gets that report.)
  if (!std::isfinite(def.point[0]) || !std::isfinite(def.point[1]) || !std::isfinite(def.point[2]))
    throw InputError(fmt::format("probe '{}': point must be 3 finite numbers (m), got [{}, {}, {}]", def.name, def.point[0],
                                 def.point[1], def.point[2]));
  return impl_->visit([&](auto& s) {
    const auto& body = s.bodies[std::size_t(b)];
    // The point in the body frame.
    const Vec3d point{def.point[0] - body.origin[0], def.point[1] - body.origin[1], def.point[2] - body.origin[2]};
    const double X[3] = {point[0], point[1], point[2]};
    constexpr double kInside = detail::kProbeInside;
    // The point must lie in the body's mesh as given (the finest level, all of it).
    const auto& fine = body.levels.back();
    double inside = -1e300;
    double w[4];
    for (std::size_t t = 0; t < fine.tet_count && inside < kInside; ++t) inside = std::max(inside, detail::probe_weights(fine, t, X, w));
    if (inside < kInside) {
      // Say where the body is: its nearest node (and that node's number in the file) and extent,
      // in the world frame.
      const auto& L = fine;
      const Vec3d& o = body.origin;
      double d2 = 1e300, lo[3] = {1e300, 1e300, 1e300}, hi[3] = {-1e300, -1e300, -1e300};
      std::size_t near = 0;
      for (std::size_t n = 0; n < L.node_count; ++n) {
        double e = 0;
        for (int k = 0; k < 3; ++k) {
          const double x = o[k] + double(L.X[k][n]), d = x - def.point[k];
          e += d * d;
          lo[k] = std::min(lo[k], x);
          hi[k] = std::max(hi[k], x);
        }
        if (e < d2) {
          d2 = e;
          near = n;
        }
      }
      std::string file_node;
      const auto& map = impl_->node_maps[std::size_t(b)];
      for (std::size_t i = 0; i < map.size(); ++i)
        if (map[i] == std::int32_t(near)) file_node = fmt::format(" (the file's node {}, counted from 0)", i);
      throw InputError(fmt::format(
          "probe '{}': point [{}, {}, {}] is not inside body '{}'; its nearest node is node {}{} at [{:.6g}, {:.6g}, "
          "{:.6g}], {:.4g} m away (the body spans [{:.6g}, {:.6g}, {:.6g}]..[{:.6g}, {:.6g}, {:.6g}] m)",
          def.name, def.point[0], def.point[1], def.point[2], def.body, near, file_node, o[0] + double(L.X[0][near]),
          o[1] + double(L.X[1][near]), o[2] + double(L.X[2][near]), std::sqrt(d2), lo[0], lo[1], lo[2], hi[0], hi[1],
          hi[2]));
    }
    // The finest level that steps a tet containing the point reads it (a single-level body: its
    // only level); where the levels' meshes differ at the surface and none does, the stepped tet
    // nearest to containing it, with its weights clamped to the tet.
    detail::ProbeState p;
    p.name = def.name;
    p.body = b;
    p.refine = def.refine;
    detail::place_probe_by_scan(body, X, p);
    // A probe of an adaptive body is placed again at every change of resolution: its candidates
    // now, so that no change reads the whole body for it (probe_placement.hpp).
    if (body.adapt) {
      double X[3];
      detail::probe_rest_point(body, p, X);
      detail::make_probe_candidates(body, X, p.candidates);
    }
    s.probes.push_back(p);
    return int(s.probes.size()) - 1;
  });
}

void World::step() {
  Impl& w = *impl_;
  // Due: at next_check, or within kAdaptIntervalMax moves of the finest stepped level when a
  // finer level began to step since (an adaptive body refined: its checks come 16x as often).
  if (w.def.time_step.adapt && (w.stiffness_ratio > Impl::kAdaptTrigger || w.substeps > w.base_substeps ||
                                 w.steps >= w.next_check ||
                                 (w.steps - w.last_check_step >= Impl::kAdaptIntervalMax &&  // cheap test first
                                  w.steps - w.last_check_step >= std::int64_t(Impl::kAdaptIntervalMax) * w.moving_steps())) &&
      w.visit([](const auto& s) { return s.can_stiffen(); })) {
    w.adapt_substeps();
  }
  const int n = w.substeps;
  w.max_substeps = std::max(w.max_substeps, n);
  if (n > w.base_substeps) ++w.adapted_steps;
  const double h = w.dt / n;
  for (int i = 0; i < n; ++i) {
    std::string where;
    const double t = w.time + h * i;
    const auto start = std::chrono::steady_clock::now();
    std::size_t tets = 0;
    const bool ok = w.visit([&](auto& s) {
      const bool r = s.step(w.exec, t, h, where, w.steps);
      tets = s.last_tick_tets();
      return r;
    });
    w.ticks.add(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), tets);
    if (!ok) throw DivergenceError("diverged: " + where);
  }
  ++w.steps;
  w.time = w.time + w.dt;
  if (!w.haptic.empty())
    w.visit([&](auto& s) {
      for (std::size_t i = 0; i < s.tools.size(); ++i) w.haptic[i]->publish(w.time, s.tools[i].reading.force);
    });
}

std::int64_t World::advance_to(double t) {
  if (!std::isfinite(t)) throw InputError(fmt::format("advance_to: the time must be finite, got {}", t));
  // Without a body there is no step (0 s): the loop below would never reach t.
  if (!(impl_->dt > 0))
    throw InputError(fmt::format("advance_to({}): the world has no body, so no time step to advance by", t));
  std::int64_t n = 0;
  while (impl_->time + 0.5 * impl_->dt <= t) {
    step();
    ++n;
  }
  return n;
}

double World::time() const { return impl_->time; }
std::int64_t World::steps() const { return impl_->steps; }
double World::dt() const { return impl_->dt; }
double World::stable_dt() const { return impl_->stable_dt; }
int World::substeps() const { return impl_->substeps; }
int World::max_substeps() const { return impl_->max_substeps; }
std::int64_t World::adapted_steps() const { return impl_->adapted_steps; }
double World::stiffness_ratio() const { return impl_->stiffness_ratio; }
double World::max_stiffness_ratio() const { return impl_->max_stiffness_ratio; }
std::int64_t World::stiffness_checks() const { return impl_->stiffness_checks; }

std::size_t World::touch_pages(std::size_t pages) {
  constexpr std::size_t kPage = 4096;
  Impl& w = *impl_;
  // The arrays end to end; the cursor is a byte offset into that sequence. One call reads from the
  // cursor to the end, then from the start up to where it began: each page once at most.
  const std::size_t from = w.touch_cursor;
  std::size_t touched = 0, total = 0;
  unsigned sum = 0;
  const auto read = [&](std::size_t lo, std::size_t hi) {  // the pages starting in [lo, hi) of the sequence
    std::size_t seen = 0;
    const auto array = [&](const void* data, std::size_t bytes) {
      const std::size_t start = seen;
      seen += bytes;
      if (touched >= pages || seen <= lo || start >= hi) return;
      const auto* p = static_cast<const volatile unsigned char*>(data);
      std::size_t at = lo > start ? lo - start : 0;
      at = (at + kPage - 1) / kPage * kPage;  // pages from the array's start
      for (; at < bytes && start + at < hi && touched < pages; at += kPage) {
        sum += p[at];
        ++touched;
        w.touch_cursor = start + at + kPage;
      }
    };
    w.visit([&](const auto& sim) {
      for (const auto& body : sim.bodies) {
        for (const auto& L : body.levels) detail::for_each_level_array(L, array);
        // An adaptive body's activation, hierarchy and decision arrays: the first change after
        // seconds at the coarsest level read them cold (update() of the 50k-tet organ 1.8 ms, 0.5
        // warm).
        if (body.adapt) detail::for_each_adapt_array(*body.adapt, array);
      }
    });
    return seen;
  };
  total = read(from, ~std::size_t(0));
  if (touched < pages) {
    w.touch_cursor = 0;
    read(0, std::min(from, total));
  }
  if (w.touch_cursor >= total) w.touch_cursor = 0;
  (void)sum;
  return touched;
}
Vec3d World::gravity() const { return impl_->def.gravity; }
const std::vector<ObstacleDef>& World::obstacles() const {
  return impl_->visit([](auto& s) -> const std::vector<ObstacleDef>& { return s.obstacles; });
}
Precision World::precision() const { return impl_->def.precision; }
Schedule World::schedule() const { return impl_->def.schedule; }
int World::threads() const { return impl_->exec.threads(); }

std::size_t World::body_count() const {
  return impl_->visit([](auto& s) { return s.bodies.size(); });
}
BodyId World::find_body(std::string_view name) const {
  return impl_->visit([&](auto& s) {
    for (std::size_t i = 0; i < s.bodies.size(); ++i)
      if (s.bodies[i].def.name == name) return BodyId(i);
    return BodyId(-1);
  });
}
const BodyDef& World::body_def(BodyId b) const {
  return impl_->visit([&](auto& s) -> const BodyDef& { return impl_->body(s, b).def; });
}
LevelInfo World::level_info(BodyId b, int l) const {
  return impl_->visit([&](auto& s) {
    const auto& L = impl_->level(s, b, l);
    LevelInfo i;
    i.level = l;
    i.nodes = L.node_count;
    i.tets = L.tet_count;
    i.stepped_tets = L.stepped_count;
    i.ghost_nodes = L.ghosts.size();
    for (auto st : L.state) i.active_nodes += st == kNodeFree || st == kNodeFixed;
    i.pass_nodes = s.pass_nodes(b, l);
    i.listed = s.steps_listed(b, l);
    i.gather_entries = s.gather_entries(b, l);
    i.period = L.period;
    i.dt = L.period * impl_->dt / impl_->substeps;
    i.stable_dt = L.stable_dt;
    const auto& body = impl_->body(s, b);
    i.stiffness_factor = std::size_t(l) < body.stiffness_factors.size() ? body.stiffness_factors[std::size_t(l)] : 1.0;
    return i;
  });
}
const TickStats& World::tick_stats() const { return impl_->ticks; }

int World::level_count(BodyId b) const {
  return impl_->visit([&](auto& s) { return int(impl_->body(s, b).levels.size()); });
}
std::size_t World::node_count(BodyId b, int l) const {
  return impl_->visit([&](auto& s) { return impl_->level(s, b, l).node_count; });
}
std::size_t World::tet_count(BodyId b, int l) const {
  return impl_->visit([&](auto& s) { return impl_->level(s, b, l).tet_count; });
}
std::array<Vec3d, 4> World::corner_forces(BodyId b, int l, std::size_t tet) const {
  return impl_->visit([&](auto& s) {
    const std::size_t n = impl_->level(s, b, l).tet_count;
    if (tet >= n)
      throw InputError(fmt::format("corner_forces: tet {} of level {} of body '{}', which has {} tets", tet, l,
                                   impl_->body(s, b).def.name, n));
    return s.corner_forces(b, l, tet);
  });
}

namespace {
// The world's simulation in precision T, for level<T>() (InputError if the world's is the other).
template <class T, class Sim>
auto& simulation_in(Sim& sim, Precision precision) {
  auto* s = std::get_if<detail::Simulation<T>>(&sim);
  if (!s)
    throw InputError(fmt::format("level<{}>() on a world of precision {}", sizeof(T) == 4 ? "float" : "double",
                                 to_string(precision)));
  return *s;
}
}  // namespace

template <class T>
Level<T>& World::level(BodyId b, int l) {
  auto& s = simulation_in<T>(impl_->sim, impl_->def.precision);
  s.levels_given_to_host();  // it may write positions and velocities between steps
  return impl_->level(s, b, l);
}
template <class T>
const Level<T>& World::level(BodyId b, int l) const {
  return impl_->level(simulation_in<T>(impl_->sim, impl_->def.precision), b, l);
}
template Level<float>& World::level<float>(BodyId, int);
template Level<double>& World::level<double>(BodyId, int);
template const Level<float>& World::level<float>(BodyId, int) const;
template const Level<double>& World::level<double>(BodyId, int) const;

namespace {
template <class T, class A>
std::array<std::span<const T>, 3> spans(const A (&arrays)[3]) {
  return {std::span<const T>(arrays[0]), std::span<const T>(arrays[1]), std::span<const T>(arrays[2])};
}
}  // namespace

template <class T>
std::array<std::span<const T>, 3> World::positions(BodyId b, int l) const {
  return spans<T>(level<T>(b, l).x);
}
template <class T>
std::array<std::span<const T>, 3> World::velocities(BodyId b, int l) const {
  return spans<T>(level<T>(b, l).v);
}
template <class T>
std::array<std::span<const T>, 3> World::rest_positions(BodyId b, int l) const {
  return spans<T>(level<T>(b, l).X);
}
template std::array<std::span<const float>, 3> World::positions<float>(BodyId, int) const;
template std::array<std::span<const double>, 3> World::positions<double>(BodyId, int) const;
template std::array<std::span<const float>, 3> World::velocities<float>(BodyId, int) const;
template std::array<std::span<const double>, 3> World::velocities<double>(BodyId, int) const;
template std::array<std::span<const float>, 3> World::rest_positions<float>(BodyId, int) const;
template std::array<std::span<const double>, 3> World::rest_positions<double>(BodyId, int) const;

Vec3d World::body_origin(BodyId b) const {
  return impl_->visit([&](auto& s) { return impl_->body(s, b).origin; });
}

Vec3d World::node_position(BodyId b, std::size_t n, int l) const {
  return impl_->visit([&](auto& s) {
    const auto& L = impl_->level(s, b, l);
    if (n >= L.node_count)
      throw InputError(fmt::format("body '{}', level {}: no node {} (it has {})", impl_->body(s, b).def.name, l, n,
                                   L.node_count));
    const Vec3d& o = impl_->body(s, b).origin;
    return Vec3d{o[0] + double(L.x[0][n]), o[1] + double(L.x[1][n]), o[2] + double(L.x[2][n])};
  });
}
Vec3d World::node_rest_position(BodyId b, std::size_t n, int l) const {
  return impl_->visit([&](auto& s) {
    const auto& L = impl_->level(s, b, l);
    if (n >= L.node_count)
      throw InputError(fmt::format("body '{}', level {}: no node {} (it has {})", impl_->body(s, b).def.name, l, n,
                                   L.node_count));
    const Vec3d& o = impl_->body(s, b).origin;
    return Vec3d{o[0] + double(L.X[0][n]), o[1] + double(L.X[1][n]), o[2] + double(L.X[2][n])};
  });
}

void World::set_motion_offset(BodyId b, int motion, const Vec3d& offset) {
  impl_->visit([&](auto& s) {
    auto& body = impl_->body(s, b);
    if (motion < 0 || std::size_t(motion) >= body.motions.size())
      throw InputError(fmt::format("body '{}' has no prescribed motion {} (it has {})", body.def.name, motion,
                                   body.motions.size()));
    for (int k = 0; k < 3; ++k)
      if (!std::isfinite(offset[k]))
        throw InputError(fmt::format("set_motion_offset: body '{}', motion {}: the offset must be 3 finite numbers (m), "
                                     "got [{}, {}, {}]", body.def.name, motion, offset[0], offset[1], offset[2]));
    auto& m = body.motions[std::size_t(motion)];
    // Keep the velocity consistent: the offset at the start of each level's current window (now,
    // for a level between windows) becomes the start of its next step.
    if (!m.host_driven)
      for (std::size_t l = 0; l < m.host_from.size(); ++l) {
        const auto& L = body.levels[l];
        m.host_from[l] = m.offset_at(L.window_dt > 0 ? L.window_start : impl_->time);
      }
    m.host_driven = true;
    m.host_offset = offset;
  });
}

std::size_t World::probe_count() const {
  return impl_->visit([](auto& s) { return s.probes.size(); });
}
namespace {
// s.probes[p], or an InputError naming the probe number and how many there are.
template <class S>
const auto& probe_of(const S& s, int p) {
  if (p < 0 || std::size_t(p) >= s.probes.size())
    throw InputError(fmt::format("no probe {} (the world has {})", p, s.probes.size()));
  return s.probes[std::size_t(p)];
}
}  // namespace

const std::string& World::probe_name(int p) const {
  return impl_->visit([&](auto& s) -> const std::string& { return probe_of(s, p).name; });
}
Vec3d World::probe_position(int p) const {
  return impl_->visit([&](auto& s) {
    const auto& pr = probe_of(s, p);
    const auto& body = s.bodies[std::size_t(pr.body)];
    const auto& L = body.levels[std::size_t(pr.level)];
    Vec3d local{0, 0, 0};
    for (int a = 0; a < 4; ++a) {
      const auto n = L.tet[a][std::size_t(pr.tet)];
      const Vec3d x = detail::node_now(body, L, std::size_t(n));
      for (int k = 0; k < 3; ++k) local[k] += pr.weights[a] * x[k];
    }
    return Vec3d{body.origin[0] + local[0], body.origin[1] + local[1], body.origin[2] + local[2]};
  });
}

Vec3d World::obstacle_impulse(BodyId b, int l) const {
  return impl_->visit([&](auto& s) {
    const auto& L = impl_->level(s, b, l);
    Vec3d J{0, 0, 0};
    if (!L.obstacle_impulse[0].empty())
      for (std::size_t n = 0; n < L.node_count; ++n)  // fixed order
        for (int k = 0; k < 3; ++k) J[k] += L.obstacle_impulse[k][n];
    return J;
  });
}

Energies World::energies() const {
  Energies e;
  const double h = impl_->dt / impl_->substeps;  // the (sub-)step the integrator takes
  impl_->visit([&](auto& s) {
    s.elastic_energies(impl_->exec, e.elastic);
    e.kinetic = s.centred_kinetic(impl_->exec, h, e.kinetic_stored);
    for (const auto& b : s.bodies)
      for (const auto& L : b.levels)
        for (std::size_t n = 0; n < L.node_count; ++n) {
          const double m = double(L.mass[n]);
          for (int k = 0; k < 3; ++k) {
            const double u = double(L.x[k][n]) - double(L.X[k][n]);
            e.potential -= m * double(s.gravity[k]) * u;
            if (!L.external[k].empty()) e.potential -= double(L.external[k][n]) * u;
          }
        }
  });
  return e;
}

double World::max_displacement() const {
  return impl_->visit([](auto& s) {
    double m = 0;
    for (const auto& b : s.bodies)
      for (const auto& L : b.levels)
        for (std::size_t n = 0; n < L.node_count; ++n) {
          double u2 = 0;
          for (int k = 0; k < 3; ++k) {
            const double u = double(L.x[k][n]) - double(L.X[k][n]);
            u2 += u * u;
          }
          // (Not std::max, which drops a NaN: a host's NaN position read as no displacement.)
          const double u = std::sqrt(u2);
          if (!(u <= m)) m = u;
        }
    return m;
  });
}

std::uint64_t World::state_hash() const {
  std::uint64_t h = 1469598103934665603ull;  // FNV-1a offset basis
  auto mix = [&](const void* data, std::size_t bytes) {
    const auto* p = static_cast<const unsigned char*>(data);
    for (std::size_t i = 0; i < bytes; ++i) {
      h ^= p[i];
      h *= 1099511628211ull;
    }
  };
  impl_->visit([&](auto& s) {
    for (const auto& b : s.bodies)
      for (const auto& L : b.levels)
        for (int k = 0; k < 3; ++k) {
          mix(L.x[k].data(), L.x[k].size() * sizeof(L.x[k][0]));
          mix(L.v[k].data(), L.v[k].size() * sizeof(L.v[k][0]));
        }
  });
  return h;
}

World::Snapshot World::snapshot(BodyId b, int l) const {
  Snapshot out;
  impl_->visit([&](auto& s) {
    const auto& body = impl_->body(s, b);
    const auto& L = impl_->level(s, b, l);
    const Vec3d& o = body.origin;
    using T = std::remove_cvref_t<decltype(L.x[0][0])>;
    detail::CurrentState<T> now;  // ghosts where their sources are now
    detail::current_state(body, L, now);
    out.points.resize(3 * L.node_count);
    out.displacement.resize(3 * L.node_count);
    for (std::size_t n = 0; n < L.node_count; ++n)
      for (int k = 0; k < 3; ++k) {
        out.points[3 * n + k] = o[k] + double(now.x[k][n]);  // world frame
        out.displacement[3 * n + k] = double(now.x[k][n]) - double(L.X[k][n]);
      }
    std::vector<double> sigma;
    detail::cauchy_stress(impl_->exec, s, body, L, sigma);
    // The tets the level steps (all of them for a single-level body).
    out.tets.reserve(L.stepped_count);
    out.stress.reserve(9 * L.stepped_count);
    out.von_mises.reserve(L.stepped_count);
    for (const Range& run : L.stepped_runs)
      for (std::size_t t = run.begin; t < run.end; ++t) {
        out.tets.push_back({L.tet[0][t], L.tet[1][t], L.tet[2][t], L.tet[3][t]});
        const double* q = &sigma[9 * t];
        out.stress.insert(out.stress.end(), q, q + 9);
        const double a = q[0] - q[4], bb = q[4] - q[8], c = q[8] - q[0];
        out.von_mises.push_back(std::sqrt(0.5 * (a * a + bb * bb + c * c) + 3 * (q[1] * q[1] + q[5] * q[5] + q[2] * q[2])));
      }
  });
  return out;
}

}  // namespace pliant
