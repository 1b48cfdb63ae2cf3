// World: the public facade over Simulation<float|double>. Chooses the step (auto = the stable
// bound; an explicit dt above it is refused or sub-stepped), reports divergence at once, and
// offers the zero-copy and measuring accessors hosts and the runner use.
#include "pliant/world.hpp"

#include <cmath>
#include <cstring>
#include <limits>
#include <fmt/format.h>
#include <variant>

#include "pliant/mesh_io.hpp"
#include "pliant/meshing.hpp"
#include "simulation.hpp"

namespace pliant {

namespace detail {
template <class T>
void cauchy_stress(Executor& exec, const Level<T>& L, std::vector<double>& sigma9);
}

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
  double max_stiffness_ratio = 1;


  explicit Impl(const WorldDef& d) : def(d), exec(d.threads) {
    if (d.precision == Precision::float32)
      sim.emplace<detail::Simulation<float>>();
    else
      sim.emplace<detail::Simulation<double>>();
    std::visit([&](auto& s) {
      for (int k = 0; k < 3; ++k) s.gravity[k] = static_cast<std::remove_reference_t<decltype(s.gravity[0])>>(d.gravity[k]);
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
      dt = stable_dt;
      return;
    }
    if (*ts.dt <= stable_dt) {
      dt = *ts.dt;
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
  }

  // The adaptive step (TimeStepDef::adapt). Every 16 steps (every 8 once r > 1.5, every step
  // once the body is stiffened past the trigger or sub-stepped), the elements' stiffness ratio r (how far the current deformation has raised
  // the largest Hessian eigenvalue of an element's energy over its rest value, at most;
  // kernels/element_stiffness.hpp) estimates the current highest frequency as omega_rest sqrt(r).
  // Below kAdaptTrigger nothing changes: ordinary deformations run at the step chosen at load and
  // cost one monitor pass per 16 steps (for corotational at strains below 50%, a norm per tet). Above it, the step is split so that each sub-step has
  // omega_rest sqrt(r) h / 2 <= kAdaptCourant. The estimate scales the mesh's rest frequency by the
  // worst element's ratio, which is not a bound (the stiffened elements need not be the ones that set
  // omega_rest), hence the low target: with 0.7, stvk cells of the stability matrix (a beam
  // collapsing under 10x its own weight, r up to 50) still diverged at 0.5x the bound; with 0.35
  // they are all stable (docs/stability.md).
  // The count goes up at once but comes down only after kAdaptRelax checks in a row have wanted
  // fewer: symplectic Euler stores the velocity half a step off, and a step size that toggles
  // from one step to the next (a ratio hovering at the trigger) pumps energy into the body (the
  // stability matrix's inverted stvk cells diverged that way without this hysteresis).
  static constexpr int kAdaptInterval = 8;         // steps between checks near the trigger (r > 1.5)
  static constexpr int kAdaptIntervalFar = 16;     // and far below it: the monitor costs ~1/8 of a step
  static constexpr double kAdaptTrigger = 2.0;
  static constexpr double kAdaptCourant = 0.35;
  static constexpr int kAdaptRelax = 32;
  static constexpr int kMaxAdaptiveSubsteps = 256;
  int checks_wanting_fewer = 0;
  std::vector<MeshLoadReport> load_reports;  // per body: what loading fixed in its mesh
  void adapt_substeps() {
    stiffness_ratio = visit([&](auto& s) { return s.stiffness_ratio(exec); });
    max_stiffness_ratio = std::max(max_stiffness_ratio, stiffness_ratio);
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
    if (!std::isfinite(def.gravity[k])) throw InputError("gravity must be 3 finite numbers");
  if (def.threads < 0) throw InputError(fmt::format("threads must be >= 0 (0 = all cores), got {}", def.threads));
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
      mesh = meshed([&](double h) { return mesh_surface_file(src.path, h); });
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

// RegionDef::nodes count in the mesh as loaded (the file's numbering): map them to the
// renumbered mesh. Indices out of range stay as given, so that the error names them.
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
  std::vector<std::int32_t> old_to_new;
  MeshLoadReport read;  // what the reader skipped or fixed
  TetMesh mesh = build_mesh_mapped(def.mesh, &read, &old_to_new);
  const bool mapped = !old_to_new.empty() && has_node_regions(def);
  const BodyId id = mapped ? add_body(with_mapped_node_regions(def, old_to_new), std::move(mesh))
                           : add_body(def, std::move(mesh));
  if (mapped) impl_->visit([&](auto& s) { s.bodies[std::size_t(id)].def = def; });  // keep the definition as given
  MeshLoadReport& r = impl_->load_reports[std::size_t(id)];
  r.skipped_cells += read.skipped_cells;
  r.reoriented_tets += read.reoriented_tets;
  r.dropped_vertices += read.dropped_vertices;
  return id;
}

const MeshLoadReport& World::mesh_load_report(BodyId body) const {
  if (body < 0 || std::size_t(body) >= impl_->load_reports.size())
    throw InputError(fmt::format("no body with id {}", body));
  return impl_->load_reports[std::size_t(body)];
}

BodyId World::add_body(const BodyDef& def, TetMesh mesh) {
  if (find_body(def.name) >= 0) throw InputError(fmt::format("a body named '{}' exists already", def.name));
  MeshLoadReport report;
  finalize_tet_mesh(mesh, fmt::format("body '{}'", def.name), report);
  if (mesh.tet_count() == 0) throw InputError(fmt::format("body '{}': the mesh has no tetrahedra", def.name));
  const BodyId id = impl_->visit([&](auto& s) {
    using T = std::remove_reference_t<decltype(s.gravity[0])>;
    detail::SimBody<T> b;
    b.def = def;
    b.origin = detail::body_frame_origin(mesh);
    b.levels.push_back(
        detail::build_level<T>(mesh, b.origin, def, impl_->def.time_step.courant, b.motions, impl_->exec));
    s.bodies.push_back(std::move(b));
    s.scratch.reserve(std::max(s.scratch.capacity(), mesh.tet_count()));  // reports and the monitor
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
  return id;
}

int World::add_probe(const ProbeDef& def) {
  const BodyId b = find_body(def.body);
  if (b < 0) throw InputError(fmt::format("probe '{}': no body named '{}'", def.name, def.body));
  return impl_->visit([&](auto& s) {
    const auto& L = s.bodies[std::size_t(b)].levels.back();  // the finest level
    const Vec3d& o = s.bodies[std::size_t(b)].origin;
    // The tet whose smallest barycentric weight is largest contains the point (or is nearest).
    double best = -1e300;
    detail::ProbeState p;
    p.name = def.name;
    p.body = b;
    p.level = int(s.bodies[std::size_t(b)].levels.size()) - 1;
    for (std::size_t t = 0; t < L.tet_count; ++t) {
      double c[4][3];
      for (int a = 0; a < 4; ++a)
        for (int k = 0; k < 3; ++k) c[a][k] = double(L.X[k][L.tet[a][t]]);
      // The point in the body frame, relative to corner 0.
      const double d[3] = {def.point[0] - o[0] - c[0][0], def.point[1] - o[1] - c[0][1], def.point[2] - o[2] - c[0][2]};
      double w[4];
      w[0] = 1;
      for (int a = 0; a < 3; ++a) {
        const double g0 = double(L.grad[3 * a][t]), g1 = double(L.grad[3 * a + 1][t]), g2 = double(L.grad[3 * a + 2][t]);
        w[a + 1] = g0 * d[0] + g1 * d[1] + g2 * d[2];
        w[0] -= w[a + 1];
      }
      const double m = std::min(std::min(w[0], w[1]), std::min(w[2], w[3]));
      if (m > best) {
        best = m;
        p.tet = std::int32_t(t);
        for (int a = 0; a < 4; ++a) p.weights[a] = w[a];
      }
    }
    if (best < -1e-6)
      throw InputError(fmt::format("probe '{}': point [{}, {}, {}] is not inside body '{}'", def.name, def.point[0],
                                   def.point[1], def.point[2], def.body));
    s.probes.push_back(p);
    return int(s.probes.size()) - 1;
  });
}

void World::step() {
  Impl& w = *impl_;
  if (w.def.time_step.adapt && (w.stiffness_ratio > Impl::kAdaptTrigger || w.substeps > w.base_substeps ||
                                 w.steps % (w.stiffness_ratio > 1.5 ? Impl::kAdaptInterval : Impl::kAdaptIntervalFar) == 0) &&
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
    const bool ok = w.visit([&](auto& s) { return s.step(w.exec, t, h, where, w.steps); });
    if (!ok) throw DivergenceError("diverged: " + where);
  }
  ++w.steps;
  w.time = w.time + w.dt;
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
Vec3d World::gravity() const { return impl_->def.gravity; }
Precision World::precision() const { return impl_->def.precision; }
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
int World::level_count(BodyId b) const {
  return impl_->visit([&](auto& s) { return int(impl_->body(s, b).levels.size()); });
}
std::size_t World::node_count(BodyId b, int l) const {
  return impl_->visit([&](auto& s) { return impl_->level(s, b, l).node_count; });
}
std::size_t World::tet_count(BodyId b, int l) const {
  return impl_->visit([&](auto& s) { return impl_->level(s, b, l).tet_count; });
}

template <class T>
Level<T>& World::level(BodyId b, int l) {
  auto* s = std::get_if<detail::Simulation<T>>(&impl_->sim);
  if (!s)
    throw InputError(fmt::format("level<{}>() on a world of precision {}", sizeof(T) == 4 ? "float" : "double",
                                 to_string(impl_->def.precision)));
  return impl_->level(*s, b, l);
}
template <class T>
const Level<T>& World::level(BodyId b, int l) const {
  return const_cast<World*>(this)->level<T>(b, l);
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
    if (n >= L.node_count) throw InputError(fmt::format("node {} out of range ({} nodes)", n, L.node_count));
    const Vec3d& o = impl_->body(s, b).origin;
    return Vec3d{o[0] + double(L.x[0][n]), o[1] + double(L.x[1][n]), o[2] + double(L.x[2][n])};
  });
}
Vec3d World::node_rest_position(BodyId b, std::size_t n, int l) const {
  return impl_->visit([&](auto& s) {
    const auto& L = impl_->level(s, b, l);
    if (n >= L.node_count) throw InputError(fmt::format("node {} out of range ({} nodes)", n, L.node_count));
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
      if (!std::isfinite(offset[k])) throw InputError("set_motion_offset: offset must be finite");
    auto& m = body.motions[std::size_t(motion)];
    // Keep the velocity consistent: the current offset becomes the start of the next step.
    if (!m.host_driven) m.host_from = m.offset_at(impl_->time);
    m.host_driven = true;
    m.host_offset = offset;
  });
}

std::size_t World::probe_count() const {
  return impl_->visit([](auto& s) { return s.probes.size(); });
}
const std::string& World::probe_name(int p) const {
  return impl_->visit([&](auto& s) -> const std::string& { return s.probes.at(std::size_t(p)).name; });
}
Vec3d World::probe_position(int p) const {
  return impl_->visit([&](auto& s) {
    const auto& pr = s.probes.at(std::size_t(p));
    const auto& body = s.bodies[std::size_t(pr.body)];
    const auto& L = body.levels[std::size_t(pr.level)];
    Vec3d local{0, 0, 0};
    for (int a = 0; a < 4; ++a) {
      const auto n = L.tet[a][std::size_t(pr.tet)];
      for (int k = 0; k < 3; ++k) local[k] += pr.weights[a] * double(L.x[k][n]);
    }
    return Vec3d{body.origin[0] + local[0], body.origin[1] + local[1], body.origin[2] + local[2]};
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
          m = std::max(m, std::sqrt(u2));
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
    const auto& L = impl_->level(s, b, l);
    const Vec3d& o = impl_->body(s, b).origin;
    out.points.resize(3 * L.node_count);
    out.displacement.resize(3 * L.node_count);
    for (std::size_t n = 0; n < L.node_count; ++n)
      for (int k = 0; k < 3; ++k) {
        out.points[3 * n + k] = o[k] + double(L.x[k][n]);  // world frame
        out.displacement[3 * n + k] = double(L.x[k][n]) - double(L.X[k][n]);
      }
    out.tets.resize(L.tet_count);
    for (std::size_t t = 0; t < L.tet_count; ++t)
      out.tets[t] = {L.tet[0][t], L.tet[1][t], L.tet[2][t], L.tet[3][t]};
    detail::cauchy_stress(impl_->exec, L, out.stress);
    out.von_mises.resize(L.tet_count);
    for (std::size_t t = 0; t < L.tet_count; ++t) {
      const double* q = &out.stress[9 * t];
      const double a = q[0] - q[4], bb = q[4] - q[8], c = q[8] - q[0];
      out.von_mises[t] = std::sqrt(0.5 * (a * a + bb * bb + c * c) + 3 * (q[1] * q[1] + q[5] * q[5] + q[2] * q[2]));
    }
  });
  return out;
}

}  // namespace pliant
