// Gather and integrate (see node_passes.hpp). Both are loops over SoA node arrays; the gather
// reads corner forces indirectly through the CSR incidence, and the fused pass integrates each
// node as soon as its force is summed.
#include "pliant/kernels/node_passes.hpp"

#include <cmath>
#include <cstddef>

namespace pliant {

template <class T>
bool integrate_symplectic_euler(const IntegrateContext<T>& c, Range r) {
  bool finite = true;  // accumulated without branches; see within_bounds
  const T dt = c.dt;
  for (std::size_t n = r.begin; n < r.end; ++n) {
    if (c.state[n] != kNodeFree) continue;
    for (int k = 0; k < 3; ++k) {
      const T a = c.f[k][n] * c.inv_mass[n] + c.gravity[k] - c.mass_damping * c.v[k][n];
      const T v = c.v[k][n] + dt * a;
      const T x = c.x[k][n] + dt * v;
      c.v[k][n] = v;
      c.x[k][n] = x;
      finite &= within_bounds(x, v);  // finite and below kDivergedMagnitude
    }
  }
  return finite;
}

namespace {

// Sum of a node's corner forces in incidence order (+ its external load). A chain of dependent
// adds per component: vectorising it (GCC does, with gathers, then adds the lanes one by one)
// only adds work, so it stays scalar and the out-of-order core overlaps consecutive nodes.
#if defined(__GNUC__) && !defined(__clang__)
#define PLIANT_SCALAR_LOOP __attribute__((optimize("no-tree-vectorize")))
#else
#define PLIANT_SCALAR_LOOP
#endif

// Where the corner-force arrays of every corner are the same distance apart (component 1 at
// +d1 from component 0, component 2 at +d2, as separately allocated equal arrays usually are),
// one base pointer per corner is enough: 5 loads per incidence entry instead of 7, and the loop
// is bound by loads. Otherwise each component's pointer is looked up. Both sum the same values
// in the same order.
template <class T>
struct CornerTable {
  const T* base[4];
  std::ptrdiff_t d1 = 0, d2 = 0;
  bool regular = false;
  explicit CornerTable(const GatherContext<T>& c) {
    const T* const* cf = c.corner_force;
    d1 = cf[1] - cf[0];
    d2 = cf[2] - cf[0];
    regular = true;
    for (int k = 0; k < 4; ++k) {
      base[k] = cf[3 * k];
      regular &= cf[3 * k + 1] - cf[3 * k] == d1 && cf[3 * k + 2] - cf[3 * k] == d2;
    }
  }
};

template <class T, bool External, bool Regular>
PLIANT_SCALAR_LOOP inline void node_force(const GatherContext<T>& c, const CornerTable<T>& table, std::size_t n,
                                          T f[3]) {
  T f0 = 0, f1 = 0, f2 = 0;
  const std::int32_t end = c.offsets[n + 1];
  for (std::int32_t e = c.offsets[n]; e < end; ++e) {
    const std::int32_t code = c.incidence[e];
    const std::int32_t t = code >> 2;
    if constexpr (Regular) {
      const T* p = table.base[code & 3] + t;
      f0 += p[0];
      f1 += p[table.d1];
      f2 += p[table.d2];
    } else {
      const T* const* p = c.corner_force + 3 * (code & 3);
      f0 += p[0][t];
      f1 += p[1][t];
      f2 += p[2][t];
    }
  }
  if constexpr (External) {
    f0 += c.external[0][n];
    f1 += c.external[1][n];
    f2 += c.external[2][n];
  }
  f[0] = f0;
  f[1] = f1;
  f[2] = f2;
}

template <class T, bool External, bool Regular>
PLIANT_SCALAR_LOOP bool gather_integrate(const GatherContext<T>& g, const CornerTable<T>& table,
                                         const IntegrateContext<T>& c, Range r) {
  bool finite = true;
  const T dt = c.dt;
  for (std::size_t n = r.begin; n < r.end; ++n) {
    T f[3];
    node_force<T, External, Regular>(g, table, n, f);
    g.f[0][n] = f[0];
    g.f[1][n] = f[1];
    g.f[2][n] = f[2];
    if (c.state[n] != kNodeFree) continue;
    for (int k = 0; k < 3; ++k) {
      const T a = f[k] * c.inv_mass[n] + c.gravity[k] - c.mass_damping * c.v[k][n];
      const T v = c.v[k][n] + dt * a;
      const T x = c.x[k][n] + dt * v;
      c.v[k][n] = v;
      c.x[k][n] = x;
      finite &= within_bounds(x, v);  // finite and below kDivergedMagnitude
    }
  }
  return finite;
}

template <class T, bool External, bool Regular>
PLIANT_SCALAR_LOOP void gather(const GatherContext<T>& c, const CornerTable<T>& table, Range r) {
  for (std::size_t n = r.begin; n < r.end; ++n) {
    T f[3];
    node_force<T, External, Regular>(c, table, n, f);
    c.f[0][n] = f[0];
    c.f[1][n] = f[1];
    c.f[2][n] = f[2];
  }
}

}  // namespace

template <class T>
void gather_forces(const GatherContext<T>& c, Range r) {
  const CornerTable<T> table(c);
  if (table.regular)
    c.external[0] ? gather<T, true, true>(c, table, r) : gather<T, false, true>(c, table, r);
  else
    c.external[0] ? gather<T, true, false>(c, table, r) : gather<T, false, false>(c, table, r);
}

template <class T>
bool gather_integrate_symplectic_euler(const GatherContext<T>& g, const IntegrateContext<T>& c, Range r) {
  const CornerTable<T> table(g);
  if (table.regular)
    return g.external[0] ? gather_integrate<T, true, true>(g, table, c, r) : gather_integrate<T, false, true>(g, table, c, r);
  return g.external[0] ? gather_integrate<T, true, false>(g, table, c, r) : gather_integrate<T, false, false>(g, table, c, r);
}

namespace {
// out[4 n + k] = in[k][n] for k < 3 and out[4 n + 3] = 0, on nodes [begin, end).
template <class T>
void interleave(const T* const in[3], T* __restrict out, Range r) {
  const T* __restrict a = in[0];
  const T* __restrict b = in[1];
  const T* __restrict c = in[2];
  for (std::size_t n = r.begin; n < r.end; ++n) {
    out[4 * n] = a[n];
    out[4 * n + 1] = b[n];
    out[4 * n + 2] = c[n];
    out[4 * n + 3] = T(0);
  }
}
}  // namespace

template <class T>
void pack_positions(const PackContext<T>& c, Range r) {
  interleave(c.x, c.xp, r);
  if (c.vp) interleave(c.v, c.vp, r);
}

template void pack_positions<float>(const PackContext<float>&, Range);
template void pack_positions<double>(const PackContext<double>&, Range);
template bool gather_integrate_symplectic_euler<float>(const GatherContext<float>&, const IntegrateContext<float>&,
                                                       Range);
template bool gather_integrate_symplectic_euler<double>(const GatherContext<double>&, const IntegrateContext<double>&,
                                                        Range);
template void gather_forces<float>(const GatherContext<float>&, Range);
template void gather_forces<double>(const GatherContext<double>&, Range);
template bool integrate_symplectic_euler<float>(const IntegrateContext<float>&, Range);
template bool integrate_symplectic_euler<double>(const IntegrateContext<double>&, Range);

}  // namespace pliant
