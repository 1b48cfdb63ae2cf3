// The plan of a run (run_plan.hpp): what the scene and the built world say about sizes, the step
// and the number of steps, the warm-up estimate, and the unit-mistake warnings.
#include "pliant/run_plan.hpp"

#include <algorithm>
#include <cmath>
#include <fmt/format.h>

#include "pliant/error.hpp"
#include "pliant/meshing.hpp"
#include "step_clock.hpp"

namespace pliant {
namespace {

constexpr double kTetsPerCellVolume = 4.3;  // Mesh_3 gives about 4.3 V / s^3 (cgal_mesher.cpp)

double largest_side(const Vec3d& lo, const Vec3d& hi) {
  return std::max({hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]});
}

// A length with a unit a reader takes in at once: 12 um, 3.5 mm, 24 cm, 1.8 m, 250 m, 12 km.
std::string length_text(double m) {
  const double a = std::abs(m);
  if (a == 0) return "0 m";
  if (a < 1e-3) return fmt::format("{:.3g} um", m * 1e6);
  if (a < 1e-2) return fmt::format("{:.3g} mm", m * 1e3);
  if (a < 1) return fmt::format("{:.3g} cm", m * 1e2);
  if (a < 1e3) return fmt::format("{:.3g} m", m);
  return fmt::format("{:.3g} km", m * 1e-3);
}

std::string size_text(const Vec3d& lo, const Vec3d& hi) {
  return fmt::format("{} x {} x {}", length_text(hi[0] - lo[0]), length_text(hi[1] - lo[1]), length_text(hi[2] - lo[2]));
}

std::string scaled(const MeshSourceDef& m) {
  std::string s = m.path.filename().string();
  if (m.scale != 1) s += fmt::format(" x {:g}", m.scale);
  return s;
}

std::string describe_source(const MeshSourceDef& m) {
  switch (m.kind) {
    case MeshSourceDef::Kind::box:
      return fmt::format("box of {} x {} x {} cells, {} tets each", m.cells[0], m.cells[1], m.cells[2], m.tets_per_cell);
    case MeshSourceDef::Kind::file: return "file " + scaled(m);
    case MeshSourceDef::Kind::surface: return fmt::format("surface {}, cell_size {:g} m", scaled(m), m.cell_size);
    case MeshSourceDef::Kind::implicit:
      return fmt::format("implicit shape '{}'{}, cell_size {:g} m", m.shape, m.scale != 1 ? fmt::format(" x {:g}", m.scale) : "",
                         m.cell_size);
  }
  return "?";
}

void transform_bounds(const MeshSourceDef& m, Vec3d& lo, Vec3d& hi) {
  for (int k = 0; k < 3; ++k) {
    lo[k] = m.scale * lo[k] + m.translate[k];
    hi[k] = m.scale * hi[k] + m.translate[k];
  }
}

// Cell size (m) the user chose for a body: cell_size of a surface or implicit shape; 0 for
// boxes (cell counts are chosen, and slender bars rightly have cells under 1% of their length)
// and files.
double chosen_cell(const MeshSourceDef& m) {
  return m.kind == MeshSourceDef::Kind::surface || m.kind == MeshSourceDef::Kind::implicit ? m.cell_size : 0;
}

void size_warnings(const std::string& body, const MeshSourceDef& m, const Vec3d& lo, const Vec3d& hi,
                   std::vector<PlanWarning>& out) {
  const double side = largest_side(lo, hi);
  if (side < kSmallestBody)
    out.push_back({"size", body, fmt::format(
        "body '{}' is only {} across ({}): smaller than 1 mm. Lengths are in metres; mesh.scale multiplies the "
        "mesh's coordinates (a mesh in mm needs 0.001, in cm 0.01){}",
        body, length_text(side), size_text(lo, hi), m.scale != 1 ? fmt::format(" and is {:g} here", m.scale) : "")});
  if (side > kLargestBody)
    out.push_back({"size", body, fmt::format(
        "body '{}' is {} across ({}): larger than 100 m. Lengths are in metres: if the mesh is in mm, add "
        "\"scale\": 0.001 to its mesh (0.01 for cm)",
        body, length_text(side), size_text(lo, hi))});
  const double cell = chosen_cell(m);
  if (cell > 0 && side > 0 && cell < kSmallestCellFraction * side) {
    out.push_back({"cell_size", body, fmt::format(
        "body '{}': cell_size {} is {:.2g}% of its {} size: under 1% (about {:.3g} cells across). Is cell_size in "
        "metres, like the mesh after its scale?",
        body, length_text(cell), 100 * cell / side, length_text(side), side / cell)});
  }
}

bool already_warned(const std::vector<PlanWarning>& warnings, const PlanWarning& w) {
  for (const PlanWarning& x : warnings)
    if (x.kind == w.kind && x.body == w.body) return true;
  return false;
}

// Volume (m^3, before scale) and bounding box of a shipped implicit shape, from the cells of a
// 48^3 grid over its bounding cube that are inside (the box to half a cell).
double implicit_volume(const std::string& shape, Vec3d& lo, Vec3d& hi) {
  const double r = implicit_shape_bounding_radius(shape);
  constexpr int n = 48;
  const double h = 2 * r / n;
  std::size_t inside = 0;
  lo = {1e300, 1e300, 1e300};
  hi = {-1e300, -1e300, -1e300};
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j)
      for (int k = 0; k < n; ++k) {
        const Vec3d p{-r + (i + 0.5) * h, -r + (j + 0.5) * h, -r + (k + 0.5) * h};
        if (!(implicit_shape_value(shape, p) < 0)) continue;
        ++inside;
        for (int c = 0; c < 3; ++c) {
          lo[c] = std::min(lo[c], p[c] - 0.5 * h);
          hi[c] = std::max(hi[c], p[c] + 0.5 * h);
        }
      }
  if (inside == 0) lo = hi = {0, 0, 0};
  return double(inside) * h * h * h;
}

template <class T>
void fill_body(const World& world, BodyId b, BodyPlan& p) {
  const int fine = world.level_count(b) - 1;
  const Level<T>& L = world.level<T>(b, fine);
  p.levels = world.level_count(b);
  p.nodes = L.node_count;
  p.tets = L.tet_count;
  p.min = {1e300, 1e300, 1e300};
  p.max = {-1e300, -1e300, -1e300};
  for (std::size_t n = 0; n < L.node_count; ++n)
    for (int k = 0; k < 3; ++k) {
      p.min[k] = std::min(p.min[k], double(L.X[k][n]));
      p.max[k] = std::max(p.max[k], double(L.X[k][n]));
    }
  p.h_min = L.min_altitude;
  p.omega_geometric = L.omega_geometric;
  p.omega_measured = L.omega_measured;
  p.omega_max = L.omega_max;
  p.stable_dt = L.stable_dt;
  for (int l = 0; l < fine; ++l) p.stable_dt = std::min(p.stable_dt, world.level<T>(b, l).stable_dt);
}

std::string count_text(double n) {
  if (n < 1e4) return fmt::format("{:.0f}", n);
  if (n < 1e6) return fmt::format("{:.0f}k", n / 1e3);
  if (n < 1e9) return fmt::format("{:.3g} million", n / 1e6);
  return fmt::format("{:.2g}", n);
}

std::string seconds_text(double s) {
  if (s < 1e-3) return fmt::format("{:.3g} us", s * 1e6);
  if (s < 1) return fmt::format("{:.3g} ms", s * 1e3);
  if (s < 120) return fmt::format("{:.3g} s", s);
  if (s < 7200) return fmt::format("{:.3g} min", s / 60);
  return fmt::format("{:.3g} h", s / 3600);
}

}  // namespace

ScenePreview preview_scene(const SceneDef& scene) {
  ScenePreview out;
  for (const BodyDef& b : scene.bodies) {
    BodyPreview p;
    p.name = b.name;
    p.source = describe_source(b.mesh);
    const MeshSourceDef& m = b.mesh;
    double volume = 0;  // m^3 after scale, when known
    switch (m.kind) {
      case MeshSourceDef::Kind::box:
        p.bounds_known = true;
        p.min = m.min;
        p.max = m.max;
        break;
      case MeshSourceDef::Kind::file: break;
      case MeshSourceDef::Kind::implicit:
        p.needs_meshing = true;
        try {
          volume = implicit_volume(m.shape, p.min, p.max) * m.scale * m.scale * m.scale;
          p.bounds_known = true;
        } catch (const InputError&) {  // an unknown shape: the mesher says so
        }
        break;
      case MeshSourceDef::Kind::surface:
        p.needs_meshing = true;
        if (meshing_available()) {
          try {
            const SurfaceDiagnosis d = diagnose_surface(m.path);
            p.bounds_known = true;
            p.min = d.min;
            p.max = d.max;
            if (d.closed) volume = std::abs(d.volume) * m.scale * m.scale * m.scale;
          } catch (const InputError&) {  // unreadable: the mesher says why
          }
        }
        break;
    }
    if (p.bounds_known) {
      transform_bounds(m, p.min, p.max);
      size_warnings(b.name, m, p.min, p.max, out.warnings);
    }
    if (volume > 0 && m.cell_size > 0) p.estimated_tets = kTetsPerCellVolume * volume / std::pow(m.cell_size, 3);
    out.bodies.push_back(std::move(p));
  }
  return out;
}

std::string preview_line(const BodyPreview& p) {
  std::string s = fmt::format("body '{}': {}", p.name, p.source);
  if (p.bounds_known) s += fmt::format(", {}", size_text(p.min, p.max));
  if (p.estimated_tets > 0) s += fmt::format(", about {} tets", count_text(p.estimated_tets));
  return s;
}

RunPlan plan_run(const World& world, const SceneDef& scene, const RunOptions& options, const ScenePreview* preview) {
  RunPlan plan;
  plan.precision = to_string(world.precision());
  plan.threads = world.threads();
  plan.duration = options.duration.value_or(scene.duration);
  plan.dt = world.dt();
  plan.stable_dt = world.stable_dt();
  plan.courant = scene.world.time_step.courant;
  plan.dt_given = scene.world.time_step.dt.has_value();
  plan.substeps = world.substeps();
  plan.adapt = scene.world.time_step.adapt;
  plan.steps = steps_for(plan.duration, plan.dt);
  if (preview) plan.warnings = preview->warnings;
  std::vector<PlanWarning> found;
  for (std::size_t b = 0; b < world.body_count(); ++b) {
    BodyPlan p;
    const BodyDef& def = world.body_def(BodyId(b));
    p.name = def.name;
    p.source = describe_source(def.mesh);
    p.model = to_string(def.model);
    if (world.precision() == Precision::float32)
      fill_body<float>(world, BodyId(b), p);
    else
      fill_body<double>(world, BodyId(b), p);
    if (p.stable_dt <= plan.stable_dt * (1 + 1e-12) && plan.limiting_body.empty()) plan.limiting_body = p.name;
    size_warnings(p.name, def.mesh, p.min, p.max, found);
    plan.bodies.push_back(std::move(p));
  }
  if (double(plan.steps) > kMostSteps)
    found.push_back({"steps", "", fmt::format(
        "{} steps (dt = {:.3g} s for {:g} s): more than 10 million. Check the units: young in Pa, density in kg/m^3, "
        "lengths in m (a mesh too small or too stiff makes dt tiny); or shorten the duration",
        count_text(double(plan.steps)), plan.dt, plan.duration)});
  for (PlanWarning& w : found)
    if (!already_warned(plan.warnings, w)) plan.warnings.push_back(std::move(w));

  plan.outputs.push_back("summary.json");
  for (std::size_t b = 0; b < world.body_count(); ++b)
    if (!world.node_map(BodyId(b)).empty()) {
      plan.outputs.push_back("node_map.csv");
      break;
    }
  if (world.probe_count() > 0) plan.outputs.push_back("probes.csv");
  if (world.tool_count() > 0) plan.outputs.push_back("tools.csv");
  if (scene.output.vtu_every > 0) {
    const auto frames = std::int64_t(std::floor(plan.duration / scene.output.vtu_every + 1e-9)) + 1;
    plan.outputs.push_back(fmt::format("series.pvd + vtu/ ({} frames x {} bod{})", frames, world.body_count(),
                                       world.body_count() == 1 ? "y" : "ies"));
  }
  return plan;
}

void measure_warm_up(World& world, RunPlan& plan, double seconds) {
  detail::StepClock clock;
  clock.start();
  do {
    world.step();
    clock.stepped(world.substeps());
  } while (clock.steps() < plan.steps && (clock.steps() < 2 || clock.wall() < seconds));
  plan.warm_up_steps = clock.steps();
  plan.warm_up_wall_s = clock.wall();
  plan.seconds_per_substep = clock.seconds_per_substep();
  plan.estimated_wall_s = double(plan.steps) * world.substeps() * plan.seconds_per_substep;
}

std::string estimate_line(double estimated_wall_s, std::int64_t steps_timed, double seconds_per_substep) {
  return fmt::format("estimate: {} of stepping (timed over {} step{}: {} per sub-step); writing files not counted",
                     seconds_text(estimated_wall_s), steps_timed, steps_timed == 1 ? "" : "s",
                     seconds_text(seconds_per_substep));
}

std::vector<std::string> plan_lines(const RunPlan& plan) {
  std::vector<std::string> out;
  std::size_t nodes = 0, tets = 0;
  for (const BodyPlan& b : plan.bodies) {
    nodes += b.nodes;
    tets += b.tets;
  }
  out.push_back(fmt::format("plan: {} bod{}, {} nodes, {} tets, {} precision, {} thread{}", plan.bodies.size(),
                            plan.bodies.size() == 1 ? "y" : "ies", nodes, tets, plan.precision, plan.threads,
                            plan.threads == 1 ? "" : "s"));
  for (const BodyPlan& b : plan.bodies)
    out.push_back(fmt::format("  body '{}': {}; {} nodes, {} tets, {} level{}, {}; {}", b.name, b.source, b.nodes, b.tets,
                              b.levels, b.levels == 1 ? "" : "s", size_text(b.min, b.max), b.model));
  // The step and why.
  const BodyPlan* lim = nullptr;
  for (const BodyPlan& b : plan.bodies)
    if (b.name == plan.limiting_body) lim = &b;
  std::string why;
  if (lim) {
    const bool measured = lim->omega_measured / 0.98 >= lim->omega_geometric;
    const double undamped = plan.courant * 2 / lim->omega_max;
    why = fmt::format("Courant {:g} x 2/omega_max, omega_max = {:.4g} rad/s of body '{}' from {}", plan.courant,
                      lim->omega_max, lim->name,
                      measured ? fmt::format("its measured highest mode (the Courant estimate 2 c_p/h_min is {:.4g} rad/s, h_min {})",
                                             lim->omega_geometric, length_text(lim->h_min))
                               : fmt::format("the Courant estimate 2 c_p/h_min (h_min {}; the measured highest mode is {:.4g} rad/s)",
                                             length_text(lim->h_min), lim->omega_measured));
    if (lim->stable_dt < undamped * (1 - 5e-3))  // below half a percent it is not worth a word
      why += fmt::format(", shortened {:.2g}% by damping", 100 * (1 - lim->stable_dt / undamped));
  }
  if (!plan.dt_given)
    out.push_back(fmt::format("  dt {:.4g} s: the stable bound ({})", plan.dt, why));
  else if (plan.substeps == 1)
    out.push_back(fmt::format("  dt {:.4g} s as given, within the stable bound {:.4g} s ({})", plan.dt, plan.stable_dt, why));
  else
    out.push_back(fmt::format("  dt {:.4g} s as given, above the stable bound {:.4g} s ({}): each step split into {} sub-steps",
                              plan.dt, plan.stable_dt, why, plan.substeps));
  out.push_back(fmt::format("  {} step{} of {} sub-step{} to t = {:g} s{}", plan.steps, plan.steps == 1 ? "" : "s", plan.substeps,
                            plan.substeps == 1 ? "" : "s", plan.duration,
                            plan.adapt ? " (more sub-steps if the deformation stiffens the elements: time_step.adapt)" : ""));
  if (!plan.outputs.empty()) {
    std::string files;
    for (const std::string& f : plan.outputs) files += (files.empty() ? "" : ", ") + f;
    out.push_back("  writes: " + files);
  }
  if (plan.warm_up_steps > 0)
    out.push_back("  " + estimate_line(plan.estimated_wall_s, plan.warm_up_steps, plan.seconds_per_substep));
  for (const PlanWarning& w : plan.warnings) out.push_back("warning: " + w.text);
  return out;
}

}  // namespace pliant
