// One step of every level (element pass -> gather + integrate -> prescribed motion), in the
// order DESIGN.md §4 gives. Allocation-free: contexts are stack structs of pointers. Two
// parallel loops per level: the element pass over tets, then the fused gather + integrate over
// nodes (see docs/performance.md for why and for the grain sizes).
#include "simulation.hpp"

#include <cmath>
#include <fmt/format.h>

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
          for (int k = 0; k < 3; ++k) ok &= std::isfinite(L.x[k][n]) && std::isfinite(L.v[k][n]);
          if (!ok) {
            bad = n;
            break;
          }
        }
        where = fmt::format("body '{}', level {}, step {} (t = {:.6g} s): node {} has a non-finite position or velocity",
                            body.def.name, l, step_index, t + dt, bad);
        return false;
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
