// One step of every level (element pass -> gather + integrate -> prescribed motion), in the
// order DESIGN.md §4 gives. Allocation-free: contexts are stack structs of pointers. Two
// parallel loops per level: the element pass over tets, then the fused gather + integrate over
// nodes (see docs/performance.md for why and for the grain sizes).
#include "simulation.hpp"

#include <algorithm>
#include <cmath>
#include <fmt/format.h>

#include "pliant/kernels/element_stiffness.hpp"
#include "pliant/level_passes.hpp"

namespace pliant::detail {
namespace {

template <class T>
using EnergyPass = void (*)(const ElementContext<T>&, Range, double*);

template <class T>
EnergyPass<T> energy_kernel(ForceModel m) {
  switch (m) {
    case ForceModel::linear: return &element_energy_linear<T>;
    case ForceModel::stvk: return &element_energy_stvk<T>;
    case ForceModel::corotational: return &element_energy_corotational<T>;
    case ForceModel::springs: return &element_energy_springs<T>;
  }
  return &element_energy_linear<T>;
}

}  // namespace

template <class T>
bool Simulation<T>::step(Executor& exec, double t, double dt, std::string& where, std::int64_t step_index) {
  for (std::size_t b = 0; b < bodies.size(); ++b) {
    SimBody<T>& body = bodies[b];
    for (std::size_t l = 0; l < body.levels.size(); ++l) {
      Level<T>& L = body.levels[l];
      const ElementContext<T> ec = element_context(L);
      const ElementPass<T> pass = force_kernel<T>(L.model);
      exec.parallel_for(L.tet_count, pass_grain(L.tet_count, kTetGrain), [&](Range r) { pass(ec, r); });

      const GatherContext<T> gc = gather_context(L);
      const IntegrateContext<T> ic = integrate_context(L, gravity, dt);
      // Gather and integrate fused: each node's force is used while in registers (the same
      // bits as the two passes). Nodes only read corner forces, which the element pass has
      // finished writing, so node ranges are independent.
      const bool finite = exec.parallel_all(L.node_count, pass_grain(L.node_count, kNodeGrain),
                                            [&](Range r) { return gather_integrate_symplectic_euler(gc, ic, r); });
      if (!finite) {
        std::size_t bad = 0;
        for (std::size_t n = 0; n < L.node_count; ++n) {
          bool ok = true;
          if (L.state[n] != kNodeFree) continue;
          for (int k = 0; k < 3; ++k) ok &= within_bounds(L.x[k][n], L.v[k][n]);
          if (!ok) {
            bad = n;
            break;
          }
        }
        where = fmt::format(
            "body '{}', level {}, step {} (t = {:.6g} s): node {} has a non-finite position or velocity, or one beyond "
            "{:g} (m, m/s)",
            body.def.name, l, step_index, t + dt, bad, kDivergedMagnitude);
        return false;
      }

      // Static obstacles: nodes that entered one go back onto its surface (kernels/obstacle_passes.hpp).
      for (const ObstacleDef& o : obstacles) {
        const HalfSpaceContext<T> hc = half_space_context(L, o);
        exec.parallel_for(L.node_count, pass_grain(L.node_count, kNodeGrain), [&](Range r) { resolve_half_space(hc, r); });
      }

      // Prescribed motion: nodes at rest + offset(t + dt), velocity = offset rate over the step.
      for (MotionState& m : body.motions) {
        const Vec3d o1 = m.offset_at(t + dt);
        const Vec3d o0 = m.host_driven ? m.host_from : m.offset_at(t);
        m.host_from = o1;
        for (std::int32_t n : m.nodes)
          for (int k = 0; k < 3; ++k) {
            L.x[k][n] = L.X[k][n] + T(o1[k]);
            L.v[k][n] = T((o1[k] - o0[k]) / dt);
          }
      }
    }
  }
  return true;
}

template <class T>
void Simulation<T>::elastic_energies(Executor& exec, double& elastic) const {
  elastic = 0;
  for (const SimBody<T>& body : bodies)
    for (const Level<T>& L : body.levels) {
      scratch.resize(L.tet_count);
      const ElementContext<T> ec = element_context(L);
      const EnergyPass<T> pass = energy_kernel<T>(L.model);
      double* out = scratch.data();
      exec.parallel_for(L.tet_count, kTetGrain, [&](Range r) { pass(ec, r, out); });
      for (std::size_t t = 0; t < L.tet_count; ++t) elastic += scratch[t];  // fixed order
    }
}

template <class T>
double Simulation<T>::centred_kinetic(Executor& exec, double h, double& stored) const {
  double kinetic = 0;
  stored = 0;
  for (const SimBody<T>& body : bodies)
    for (const Level<T>& L : body.levels) {
      // Forces of the current state, as the next step's element pass and gather will compute
      // them, into scratch arrays (allocated here: a report, not the hot path).
      ElementContext<T> ec = element_context(L);
      AlignedVector<T> corner[12], rotation[4], f[3];
      for (int q = 0; q < 12; ++q) {
        corner[q].assign(L.tet_count, T(0));
        ec.corner_force[q] = corner[q].data();
      }
      if (!L.rotation[0].empty())
        for (int k = 0; k < 4; ++k) {
          rotation[k].assign(L.rotation[k].begin(), L.rotation[k].end());
          ec.rotation[k] = rotation[k].data();
        }
      const ElementPass<T> pass = force_kernel<T>(L.model);
      exec.parallel_for(L.tet_count, pass_grain(L.tet_count, kTetGrain), [&](Range r) { pass(ec, r); });
      GatherContext<T> gc;
      gc.offsets = L.incidence_offsets.data();
      gc.incidence = L.incidence.data();
      for (int q = 0; q < 12; ++q) gc.corner_force[q] = corner[q].data();
      for (int k = 0; k < 3; ++k) {
        f[k].assign(L.node_count, T(0));
        gc.external[k] = L.external[k].empty() ? nullptr : L.external[k].data();
        gc.f[k] = f[k].data();
      }
      exec.parallel_for(L.node_count, pass_grain(L.node_count, kNodeGrain), [&](Range r) { gather_forces(gc, r); });
      for (std::size_t n = 0; n < L.node_count; ++n) {  // fixed order
        const double m = double(L.mass[n]);
        const bool free = L.state[n] == kNodeFree;
        double vc2 = 0, v2 = 0;
        for (int k = 0; k < 3; ++k) {
          const double v = double(L.v[k][n]);
          const double a = double(f[k][n]) * double(L.inv_mass[n]) + double(gravity[k]) - double(L.mass_damping) * v;
          const double vc = free ? v + 0.5 * h * a : v;
          vc2 += vc * vc;
          v2 += v * v;
        }
        kinetic += 0.5 * m * vc2;
        stored += 0.5 * m * v2;
      }
    }
  return kinetic;
}

template <class T>
double Simulation<T>::stiffness_ratio(Executor& exec) const {
  double ratio = 1;
  for (const SimBody<T>& body : bodies)
    for (const Level<T>& L : body.levels) {
      if (L.model != ForceModel::stvk && L.model != ForceModel::corotational) continue;
      scratch.resize(L.tet_count);
      const ElementContext<T> ec = element_context(L);
      double* out = scratch.data();
      if (L.model == ForceModel::stvk)
        exec.parallel_for(L.tet_count, pass_grain(L.tet_count, kTetGrain),
                          [&](Range r) { element_stiffness_ratio_stvk(ec, r, out); });
      else
        exec.parallel_for(L.tet_count, pass_grain(L.tet_count, kTetGrain),
                          [&](Range r) { element_stiffness_ratio_corotational(ec, r, out); });
      for (std::size_t t = 0; t < L.tet_count; ++t) ratio = std::max(ratio, scratch[t]);
    }
  return ratio;
}

template <class T>
bool Simulation<T>::can_stiffen() const {
  for (const SimBody<T>& body : bodies)
    for (const Level<T>& L : body.levels)
      if (L.model == ForceModel::stvk || L.model == ForceModel::corotational) return true;
  return false;
}

template class Simulation<float>;
template class Simulation<double>;

// Used by World::snapshot.
template <class T>
void cauchy_stress(Executor& exec, const Level<T>& L, std::vector<double>& sigma9) {
  sigma9.resize(9 * L.tet_count);
  const ElementContext<T> ec = element_context(L);
  const int measure = L.model == ForceModel::stvk ? 1 : L.model == ForceModel::corotational ? 2 : 0;
  double* out = sigma9.data();
  exec.parallel_for(L.tet_count, kTetGrain, [&](Range r) { element_cauchy_stress(ec, r, measure, out); });
}
template void cauchy_stress<float>(Executor&, const Level<float>&, std::vector<double>&);
template void cauchy_stress<double>(Executor&, const Level<double>&, std::vector<double>&);

}  // namespace pliant::detail
