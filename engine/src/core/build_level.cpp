// From a validated TetMesh and a BodyDef to a ready-to-step Level: SoA arrays, rest gradients,
// lumped masses, the node->tet incidence (CSR, sorted for a fixed gather order), boundary
// triangles, node states from fixed/prescribed regions, constant loads and the stable step
// (stable_step.cpp).
#include <algorithm>
#include <cmath>
#include <limits>
#include <fmt/format.h>

#include "pliant/error.hpp"
#include "pliant/kernels/element_forces.hpp"
#include "pliant/mesh_quality.hpp"
#include "simulation.hpp"

namespace pliant::detail {
namespace {

std::string describe(const RegionDef& r) {
  switch (r.kind) {
    case RegionDef::Kind::box:
      return fmt::format("box [{}, {}, {}]..[{}, {}, {}]", r.min[0], r.min[1], r.min[2], r.max[0], r.max[1], r.max[2]);
    case RegionDef::Kind::sphere:
      return fmt::format("sphere centre [{}, {}, {}] radius {}", r.center[0], r.center[1], r.center[2], r.radius);
    case RegionDef::Kind::nodes: return fmt::format("{} listed nodes", r.nodes.size());
  }
  return "region";
}

// Nodes of the mesh inside a region (rest positions), with a tolerance of 1e-9 of the mesh size
// so that a box face placed exactly on a mesh face selects it.
}  // namespace

std::vector<std::int32_t> select_nodes(const TetMesh& mesh, const RegionDef& r, const std::string& what,
                                       const std::string& body, bool may_be_empty) {
  std::vector<std::int32_t> out;
  const std::size_t n = mesh.node_count();
  if (r.kind == RegionDef::Kind::nodes) {
    for (auto i : r.nodes) {
      if (i < 0 || std::size_t(i) >= n)
        throw InputError(fmt::format("body '{}': {}: node {} does not exist (the mesh has {} nodes)", body, what, i, n));
      out.push_back(i);
    }
    std::sort(out.begin(), out.end());
    out.erase(std::unique(out.begin(), out.end()), out.end());
  } else {
    Vec3d lo{1e300, 1e300, 1e300}, hi{-1e300, -1e300, -1e300};
    for (std::size_t i = 0; i < n; ++i)
      for (int k = 0; k < 3; ++k) {
        lo[k] = std::min(lo[k], mesh.points[3 * i + k]);
        hi[k] = std::max(hi[k], mesh.points[3 * i + k]);
      }
    const double tol = 1e-9 * std::sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) +
                                        (hi[2] - lo[2]) * (hi[2] - lo[2]));
    for (std::size_t i = 0; i < n; ++i) {
      const Vec3d p = mesh.point(i);
      bool inside = true;
      if (r.kind == RegionDef::Kind::box) {
        for (int k = 0; k < 3; ++k) inside &= p[k] >= r.min[k] - tol && p[k] <= r.max[k] + tol;
      } else {
        const double dx = p[0] - r.center[0], dy = p[1] - r.center[1], dz = p[2] - r.center[2];
        inside = std::sqrt(dx * dx + dy * dy + dz * dz) <= r.radius + tol;
      }
      if (inside) out.push_back(std::int32_t(i));
    }
    if (out.empty() && !may_be_empty)
      throw InputError(fmt::format(
          "body '{}': {} ({}) selects no node; the body spans [{}, {}, {}]..[{}, {}, {}]", body, what, describe(r),
          lo[0], lo[1], lo[2], hi[0], hi[1], hi[2]));
  }
  return out;
}

namespace {

void check_material(const MaterialDef& m, const std::string& body) {
  auto bad = [&](const char* field, double value, const char* rule) {
    throw InputError(fmt::format("body '{}': material.{} must be {}, got {}", body, field, rule, value));
  };
  if (!(m.young > 0) || !std::isfinite(m.young)) bad("young", m.young, "a finite number > 0 (Pa)");
  if (!(m.poisson >= 0 && m.poisson < 0.5)) bad("poisson", m.poisson, "in [0, 0.5)");
  if (!(m.density > 0) || !std::isfinite(m.density)) bad("density", m.density, "a finite number > 0 (kg/m^3)");
  if (!(m.damping.mass >= 0) || !std::isfinite(m.damping.mass)) bad("damping.mass", m.damping.mass, ">= 0 (1/s)");
  if (!(m.damping.stiffness >= 0) || !std::isfinite(m.damping.stiffness))
    bad("damping.stiffness", m.damping.stiffness, ">= 0 (s)");
  if (m.damping.bulk_viscosity && (!(*m.damping.bulk_viscosity >= 0) || !std::isfinite(*m.damping.bulk_viscosity)))
    bad("damping.bulk_viscosity", *m.damping.bulk_viscosity, "a finite number >= 0 (Pa s)");
  if (m.damping.shear_viscosity && (!(*m.damping.shear_viscosity >= 0) || !std::isfinite(*m.damping.shear_viscosity)))
    bad("damping.shear_viscosity", *m.damping.shear_viscosity, "a finite number >= 0 (Pa s)");
}

// The springs model has no bulk or shear: its dashpots are beta (damping.stiffness) times each
// spring's stiffness. Viscosities given for it would be silently ignored, so they are refused.
void check_model_damping(const MaterialDef& m, ForceModel model, const std::string& body) {
  if (model != ForceModel::springs) return;
  for (const auto& [field, value] : {std::pair{"bulk_viscosity", m.damping.bulk_viscosity},
                                     std::pair{"shear_viscosity", m.damping.shear_viscosity}})
    if (value)
      throw InputError(fmt::format(
          "body '{}': material.damping.{} is not used by the springs model (a spring network has no bulk or "
          "shear viscosity: its dashpots are damping.stiffness times each spring's stiffness); remove it and use "
          "damping.stiffness, or choose another model",
          body, field));
}

// What a float world cannot hold: numbers valid in double whose float is infinite, zero or
// subnormal. They ran and "diverged" at step 0 (exit 3), for input that does not fit the chosen
// precision. Checked on the level as built (its own T values), so also right for double.
template <class T>
void check_precision_range(const Level<T>& L, const BodyDef& def, const std::vector<double>& mass) {
  const char* precision = sizeof(T) == 4 ? "float" : "double";
  constexpr double lo = double(std::numeric_limits<T>::min()), hi = double(std::numeric_limits<T>::max());
  auto refuse = [&](const std::string& what) {
    throw InputError(fmt::format("body '{}': {}, outside the range of {} precision ({:.2g} .. {:.2g}){}", def.name, what,
                                 precision, lo, hi, sizeof(T) == 4 ? ": use \"precision\": \"double\"" : ""));
  };
  const MaterialDef& m = def.material;
  const bool moduli = std::isfinite(double(L.lambda)) && std::isfinite(double(L.mu)) && double(L.mu) >= lo &&
                      std::isfinite(double(L.young)) && double(L.young) >= lo;
  if (!moduli) refuse(fmt::format("material.young = {:g} Pa gives Lame coefficients {:g} and {:g} Pa", m.young,
                                  m.young * m.poisson / ((1 + m.poisson) * (1 - 2 * m.poisson)), m.young / (2 * (1 + m.poisson))));
  if (!std::isfinite(double(L.bulk_viscosity)) || !std::isfinite(double(L.shear_viscosity)))
    refuse(fmt::format("material.damping viscosities {:g} and {:g} Pa s", double(L.bulk_viscosity), double(L.shear_viscosity)));
  for (std::size_t t = 0; t < L.tet_count; ++t) {
    if (!(double(L.volume[t]) >= lo))
      refuse(fmt::format("the rest volume of tet {} is {:g} m^3 (scale the mesh to metres?)", t, double(L.volume[t])));
    for (const auto& g : L.grad)
      if (!std::isfinite(double(g[t])))
        refuse(fmt::format("the rest shape gradients of tet {} are beyond {:g} 1/m (scale the mesh to metres?)", t, hi));
  }
  for (std::size_t n = 0; n < L.node_count; ++n)
    if (!(double(L.mass[n]) >= lo) || !std::isfinite(double(L.inv_mass[n])))
      refuse(fmt::format("material.density = {:g} kg/m^3 gives node {} a mass of {:g} kg", m.density, n, mass[n]));
}

struct Lame {
  double lambda, mu;
};
Lame lame(const MaterialDef& m) {
  return {m.young * m.poisson / ((1 + m.poisson) * (1 - 2 * m.poisson)), m.young / (2 * (1 + m.poisson))};
}

}  // namespace

Vec3d MotionState::offset_at(double time) const {
  if (host_driven) return host_offset;
  if (keyframes.empty()) return {0, 0, 0};
  if (time <= keyframes.front().time) return keyframes.front().offset;
  if (time >= keyframes.back().time) return keyframes.back().offset;
  auto it = std::upper_bound(keyframes.begin(), keyframes.end(), time,
                             [](double t, const KeyframeDef& k) { return t < k.time; });
  const KeyframeDef& b = *it;
  const KeyframeDef& a = *(it - 1);
  const double s = b.time > a.time ? (time - a.time) / (b.time - a.time) : 1.0;
  return {a.offset[0] + s * (b.offset[0] - a.offset[0]), a.offset[1] + s * (b.offset[1] - a.offset[1]),
          a.offset[2] + s * (b.offset[2] - a.offset[2])};
}

Vec3d body_frame_origin(const TetMesh& mesh) {
  const std::size_t nn = mesh.node_count();
  if (nn == 0) return {0, 0, 0};
  Vec3d lo{mesh.points[0], mesh.points[1], mesh.points[2]}, hi = lo;
  for (std::size_t i = 1; i < nn; ++i)
    for (int k = 0; k < 3; ++k) {
      lo[k] = std::min(lo[k], mesh.points[3 * i + k]);
      hi[k] = std::max(hi[k], mesh.points[3 * i + k]);
    }
  return {0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1]), 0.5 * (lo[2] + hi[2])};
}

template <class T>
Level<T> build_level(const TetMesh& mesh, const Vec3d& origin, const BodyDef& def, double courant,
                     std::vector<MotionState>& motions, Executor& exec, bool regions_may_be_empty) {
  const bool lax = regions_may_be_empty;
  check_material(def.material, def.name);
  check_model_damping(def.material, def.model, def.name);
  Level<T> L;
  const std::size_t nn = mesh.node_count(), nt = mesh.tet_count();
  L.node_count = nn;
  L.tet_count = nt;
  // Positions in the body frame (relative to `origin`, in double, then rounded to T): a float
  // body 1 km from the world origin keeps the resolution it has at the origin.
  std::vector<double> local(3 * nn);
  for (std::size_t i = 0; i < nn; ++i)
    for (int k = 0; k < 3; ++k) local[3 * i + k] = mesh.points[3 * i + k] - origin[k];
  // The divergence check counts a position beyond kDivergedMagnitude from the body frame's origin
  // as diverged: a mesh that large was accepted and stopped at its first step, at rest.
  for (std::size_t i = 0; i < 3 * nn; ++i)
    if (!(std::fabs(local[i]) < kDivergedMagnitude))
      throw InputError(fmt::format("body '{}': the mesh reaches {:g} m from its centre, beyond the {:g} m at which a "
                                   "position counts as diverged (check the mesh's scale: metres)",
                                   def.name, std::fabs(local[i]), kDivergedMagnitude));
  for (int k = 0; k < 3; ++k) {
    L.X[k].resize(nn);
    L.x[k].resize(nn);
    L.v[k].assign(nn, T(0));
    L.f[k].assign(nn, T(0));
    for (std::size_t i = 0; i < nn; ++i) L.X[k][i] = L.x[k][i] = T(local[3 * i + k]);
  }
  for (int a = 0; a < 4; ++a) L.tet[a].resize(nt);
  L.volume.resize(nt);
  for (auto& g : L.grad) g.resize(nt);
  L.corner_force.assign(nt, T(0));
  std::vector<double> mass(nn, 0.0);
  double h_min = 1e300;
  for (std::size_t t = 0; t < nt; ++t) {
    const Tet& tt = mesh.tets[t];
    double p[4][3];
    for (int a = 0; a < 4; ++a) {
      L.tet[a][t] = tt[a];
      for (int k = 0; k < 3; ++k) p[a][k] = local[3 * tt[a] + k];
    }
    double volume, grad[9];
    if (!tet_rest_geometry(p[0], p[1], p[2], p[3], &volume, grad))
      throw InputError(fmt::format("body '{}': tet {} is degenerate or inverted (volume {})", def.name, t, volume));
    L.volume[t] = T(volume);
    for (int q = 0; q < 9; ++q) L.grad[q][t] = T(grad[q]);
    for (int a = 0; a < 4; ++a) mass[tt[a]] += def.material.density * volume / 4;
    h_min = std::min(h_min, tet_min_altitude(p[0], p[1], p[2], p[3]));
  }
  if (def.model == ForceModel::corotational) {
    L.rotation[0].assign(nt, T(1));
    for (int k = 1; k < 4; ++k) L.rotation[k].assign(nt, T(0));
  }

  // Incidence: count, prefix sum, fill in tet order (so each node's list is sorted).
  L.incidence_offsets.assign(nn + 1, 0);
  for (std::size_t t = 0; t < nt; ++t)
    for (int a = 0; a < 4; ++a) ++L.incidence_offsets[mesh.tets[t][a] + 1];
  for (std::size_t i = 0; i < nn; ++i) L.incidence_offsets[i + 1] += L.incidence_offsets[i];
  L.incidence.resize(4 * nt);
  {
    std::vector<std::int32_t> cursor(L.incidence_offsets.begin(), L.incidence_offsets.end() - 1);
    for (std::size_t t = 0; t < nt; ++t)
      for (int a = 0; a < 4; ++a) L.incidence[cursor[mesh.tets[t][a]]++] = std::int32_t(4 * t + a);
  }
  L.corner_offset.resize(L.incidence.size());
  if (!encode_corner_offsets(L.incidence.data(), L.incidence.size(), L.corner_force.stride(), L.corner_offset.data()))
    L.corner_offset.clear();
  L.boundary = boundary_triangles(mesh.tets);

  // Node states: fixed regions, then prescribed motions (also fixed: the motion drives them).
  L.state.assign(nn, kNodeFree);
  for (std::size_t i = 0; i < def.fixed.size(); ++i)
    for (auto n : select_nodes(mesh, def.fixed[i], fmt::format("fixed[{}]", i), def.name, lax)) L.state[n] = kNodeFixed;
  motions.clear();
  for (std::size_t i = 0; i < def.prescribed.size(); ++i) {
    MotionState m;
    m.nodes.push_back(select_nodes(mesh, def.prescribed[i].region, fmt::format("prescribed[{}]", i), def.name, lax));
    m.host_from.resize(1);
    m.keyframes = def.prescribed[i].keyframes;
    // A host's BodyDef may hold what a scene file cannot (NaN, infinities): a NaN time broke the
    // search of offset_at, a non-finite offset looked like a divergence at the first step.
    for (std::size_t k = 0; k < m.keyframes.size(); ++k) {
      const KeyframeDef& kf = m.keyframes[k];
      if (!std::isfinite(kf.time))
        throw InputError(fmt::format("body '{}': prescribed[{}].keyframes[{}].time must be a finite number (s), got {}",
                                     def.name, i, k, kf.time));
      if (!std::isfinite(kf.offset[0]) || !std::isfinite(kf.offset[1]) || !std::isfinite(kf.offset[2]))
        throw InputError(fmt::format("body '{}': prescribed[{}].keyframes[{}].offset must be 3 finite numbers (m), got "
                                     "[{}, {}, {}]",
                                     def.name, i, k, kf.offset[0], kf.offset[1], kf.offset[2]));
    }
    for (std::size_t k = 1; k < m.keyframes.size(); ++k)
      if (m.keyframes[k].time < m.keyframes[k - 1].time)
        throw InputError(fmt::format("body '{}': prescribed[{}].keyframes must be sorted by time", def.name, i));
    for (auto n : m.nodes[0]) L.state[n] = kNodeFixed;
    const Vec3d o = m.offset_at(0.0);
    for (auto n : m.nodes[0])
      for (int k = 0; k < 3; ++k) L.x[k][n] = L.X[k][n] + T(o[k]);
    motions.push_back(std::move(m));
  }
  // A node in two motions followed the one listed last, without a word: refused where they move it
  // differently (the same keyframes twice say one thing).
  if (motions.size() > 1) {
    const auto same = [](const std::vector<KeyframeDef>& a, const std::vector<KeyframeDef>& b) {
      return std::equal(a.begin(), a.end(), b.begin(), b.end(),
                        [](const KeyframeDef& x, const KeyframeDef& y) { return x.time == y.time && x.offset == y.offset; });
    };
    std::vector<std::int32_t> mover(nn, -1);
    for (std::size_t i = 0; i < motions.size(); ++i)
      for (auto n : motions[i].nodes[0]) {
        const std::int32_t j = mover[std::size_t(n)];
        if (j >= 0 && !same(def.prescribed[std::size_t(j)].keyframes, def.prescribed[i].keyframes))
          throw InputError(fmt::format("body '{}': prescribed[{}] and prescribed[{}] both move node {} (at [{}, {}, {}] m), "
                                       "along different keyframes; a node can follow one motion only",
                                       def.name, j, i, n, mesh.points[3 * std::size_t(n)],
                                       mesh.points[3 * std::size_t(n) + 1], mesh.points[3 * std::size_t(n) + 2]));
        mover[std::size_t(n)] = std::int32_t(i);
      }
  }
  if (!def.loads.empty()) {
    for (auto& e : L.external) e.assign(nn, T(0));
    for (std::size_t i = 0; i < def.loads.size(); ++i) {
      const Vec3d& force = def.loads[i].total_force;
      if (!std::isfinite(force[0]) || !std::isfinite(force[1]) || !std::isfinite(force[2]))
        throw InputError(fmt::format("body '{}': loads[{}].force must be 3 finite numbers (N), got [{}, {}, {}]", def.name,
                                     i, force[0], force[1], force[2]));
      const auto nodes = select_nodes(mesh, def.loads[i].region, fmt::format("loads[{}]", i), def.name, lax);
      for (auto n : nodes)
        for (int k = 0; k < 3; ++k) L.external[k][n] += T(def.loads[i].total_force[k] / double(nodes.size()));
    }
  }
  L.mass.resize(nn);
  L.inv_mass.resize(nn);
  for (std::size_t i = 0; i < nn; ++i) {
    L.mass[i] = T(mass[i]);
    L.inv_mass[i] = L.state[i] == kNodeFree ? T(1.0 / mass[i]) : T(0);
  }

  const Lame l = lame(def.material);
  L.model = def.model;
  L.lambda = T(l.lambda);
  L.mu = T(l.mu);
  const auto& d = def.material.damping;
  L.bulk_viscosity = T(d.bulk_viscosity ? *d.bulk_viscosity : d.stiffness * l.lambda);
  L.shear_viscosity = T(d.shear_viscosity ? *d.shear_viscosity : d.stiffness * l.mu);
  L.mass_damping = T(d.mass);
  L.young = T(def.material.young);
  L.stiffness_damping = T(d.stiffness);
  check_precision_range(L, def, mass);
  L.min_altitude = h_min;
  // The step: for the higher of the geometric frequency 2 c_p / h_min and the measured one
  // (stable_step.cpp; a Ritz value approaches from below, hence the margin).
  L.omega_geometric = geometric_frequency(h_min, def.material);
  L.omega_measured = highest_frequency(exec, L, kFrequencyIterations);
  L.omega_max = std::max(L.omega_geometric, L.omega_measured / kFrequencyMargin);
  L.stable_dt = stable_step_for(L.omega_max, def.material, def.model, courant);
  // Numbers each finite can still leave no step: damping so strong that (2/omega)(sqrt(1+z^2) - z)
  // cancels to 0 (damping.mass 1e12 1/s) or overflows to NaN (viscosities of 1e300 Pa s), or a mesh
  // whose face areas overflow or underflow (coordinates of 1e100 m), giving an infinite frequency.
  // Accepted, such a body set the world's step to 0 s: step() did nothing, advance_to never ended.
  if (!(L.stable_dt > 0) || !std::isfinite(L.stable_dt))
    throw InputError(fmt::format(
        "body '{}': no stable time step: {:g} s from a highest frequency of {:g} rad/s (smallest tet altitude {:g} m) "
        "and material.damping mass {:g} 1/s, stiffness {:g} s, viscosities {:g} and {:g} Pa s; the explicit step "
        "cannot follow such damping or such a mesh (check the damping, and the mesh's scale: metres)",
        def.name, L.stable_dt, L.omega_max, h_min, d.mass, d.stiffness, double(L.bulk_viscosity),
        double(L.shear_viscosity)));
  L.stepped_runs = {Range{0, nt}};
  L.stepped_count = nt;
  return L;
}

template Level<float> build_level<float>(const TetMesh&, const Vec3d&, const BodyDef&, double,
                                         std::vector<MotionState>&, Executor&, bool);
template Level<double> build_level<double>(const TetMesh&, const Vec3d&, const BodyDef&, double,
                                           std::vector<MotionState>&, Executor&, bool);

}  // namespace pliant::detail
