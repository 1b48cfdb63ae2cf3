// Gather and integrate (see node_passes.hpp). Both are loops over SoA node arrays; the gather
// reads corner forces indirectly through the CSR incidence, and the fused pass integrates each
// node as soon as its force is summed (with offset entries, each block of 64 nodes).
#include "pliant/kernels/node_passes.hpp"

#include "simd.hpp"

#include <algorithm>
#include <climits>
#include <cmath>
#include <cstddef>
#include <cstring>
#include <type_traits>

namespace pliant {

namespace {

// One node's symplectic Euler update with force f (N), if it is free; false if it diverged.
// always_inline: its callers are compiled with different optimisation attributes
// (PLIANT_SCALAR_LOOP), which would otherwise keep GCC from inlining it.
template <class T>
__attribute__((always_inline)) inline bool integrate_node(const IntegrateContext<T>& c, std::size_t n, const T f[3]) {
  if (c.state[n] != kNodeFree) return true;
  bool finite = true;  // accumulated without branches; see within_bounds
  const T dt = c.dt;
  for (int k = 0; k < 3; ++k) {
    const T a = f[k] * c.inv_mass[n] + c.gravity[k] - c.mass_damping * c.v[k][n];
    const T v = c.v[k][n] + dt * a;
    const T x = c.x[k][n] + dt * v;
    c.v[k][n] = v;
    c.x[k][n] = x;
    finite &= within_bounds(x, v);  // finite and below kDivergedMagnitude
  }
  return finite;
}

// The symplectic Euler update of free nodes [b, e) with forces f, a vector register of nodes at a
// time (simd::Pack<T>::V, every lane the scalar code's operations in its order: ((f m⁻¹ + g) - α v),
// then v + dt a, then x + dt v, no fused multiply-add, so the same bits) and the last few alone.
// A lane whose node is not free stores back the values it loaded (the node's range belongs to the
// calling thread: nothing else reads or writes it during the pass). True if every free node's new
// position and velocity are within_bounds.
template <class T>
inline bool integrate_nodes(const IntegrateContext<T>& c, const T* const f[3], std::size_t b, std::size_t e) {
  using V = typename simd::Pack<T>::V;
  using M = typename simd::Pack<T>::M;
  constexpr int W = simd::Pack<T>::W;
  const T dt = c.dt;
  const T alpha = c.mass_damping;
  const T bound = T(kDivergedMagnitude);
  M diverged = M{};
  std::size_t n = b;
  for (; n + W <= e; n += W) {
    M free_lane;
    for (int l = 0; l < W; ++l) free_lane[l] = c.state[n + std::size_t(l)] == kNodeFree ? -1 : 0;
    V inv_mass;
    std::memcpy(&inv_mass, c.inv_mass + n, sizeof(V));
    for (int k = 0; k < 3; ++k) {
      V fk, vk, xk;
      std::memcpy(&fk, f[k] + n, sizeof(V));
      std::memcpy(&vk, c.v[k] + n, sizeof(V));
      std::memcpy(&xk, c.x[k] + n, sizeof(V));
      const V a = fk * inv_mass + c.gravity[k] - alpha * vk;
      const V v = vk + dt * a;
      const V x = xk + dt * v;
      const M ok = (x <= bound) & (x >= -bound) & (v <= bound) & (v >= -bound);
      diverged |= free_lane & ~ok;
      const V v_out = free_lane ? v : vk;
      const V x_out = free_lane ? x : xk;
      std::memcpy(c.v[k] + n, &v_out, sizeof(V));
      std::memcpy(c.x[k] + n, &x_out, sizeof(V));
    }
  }
  bool finite = true;
  for (int l = 0; l < W; ++l) finite &= diverged[l] == 0;
  for (; n < e; ++n) {
    const T fn[3] = {f[0][n], f[1][n], f[2][n]};
    finite &= integrate_node(c, n, fn);
  }
  return finite;
}

}  // namespace

template <class T>
bool integrate_symplectic_euler(const IntegrateContext<T>& c, Range r) {
  return integrate_nodes(c, c.f, r.begin, r.end);
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

// How an incidence entry finds its corner forces, fastest first (the same values summed in the
// same order in all three):
// - kOffset: the entries pre-encoded as offsets from the block's first array
//   (GatherContext::corner_offset, checked against the pointers here): one load of the offset and
//   three loads from fixed base pointers per entry, and two nodes summed side by side
//   (node_force_pair). Measured on an AMD EPYC Zen 3 guest, 1 thread, 1k and 10k boxes, the two
//   together took the gather from 4.1 to 2.85 ns per tet (docs/performance.md, "The gather's
//   entries as offsets"): the loop is a chain of dependent adds per component, and fewer
//   instructions per entry and two independent chains let the out-of-order core overlap them.
//   (Four nodes side by side were slower: 3.3-5.1 ns per tet, their tails longer.)
// - kRegular: the corner-force arrays of every corner the same distance apart (component 1 at
//   +d1 from component 0, component 2 at +d2): one base pointer per corner, looked up per entry.
// - kIrregular: each component's pointer looked up per entry.
enum class Entries { kOffset, kRegular, kIrregular };

template <class T>
struct CornerTable {
  const T* base[4];
  std::ptrdiff_t d1 = 0, d2 = 0;
  Entries entries = Entries::kIrregular;
  explicit CornerTable(const GatherContext<T>& c) {
    const T* const* cf = c.corner_force;
    d1 = cf[1] - cf[0];
    d2 = cf[2] - cf[0];
    bool regular = true;
    for (int k = 0; k < 4; ++k) {
      base[k] = cf[3 * k];
      regular &= cf[3 * k + 1] - cf[3 * k] == d1 && cf[3 * k + 2] - cf[3 * k] == d2;
    }
    bool block = c.corner_offset != nullptr && c.corner_stride > 0;
    for (int q = 1; q < 12 && block; ++q) block = cf[q] == cf[0] + std::ptrdiff_t(q) * std::ptrdiff_t(c.corner_stride);
    entries = block ? Entries::kOffset : regular ? Entries::kRegular : Entries::kIrregular;
  }
};

template <class T, bool External, Entries How>
PLIANT_SCALAR_LOOP inline void node_force(const GatherContext<T>& c, const CornerTable<T>& table, std::size_t n,
                                          T f[3]) {
  T f0 = 0, f1 = 0, f2 = 0;
  const std::int32_t end = c.ends[n];
  if constexpr (How == Entries::kOffset) {
    const T* b0 = c.corner_force[0];
    const T* b1 = c.corner_force[1];
    const T* b2 = c.corner_force[2];
    for (std::int32_t e = c.offsets[n]; e < end; ++e) {
      const std::int32_t o = c.corner_offset[e];
      f0 += b0[o];
      f1 += b1[o];
      f2 += b2[o];
    }
  } else {
    for (std::int32_t e = c.offsets[n]; e < end; ++e) {
      const std::int32_t code = c.incidence[e];
      const std::int32_t t = code >> 2;
      if constexpr (How == Entries::kRegular) {
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

// Nodes n and n + 1 at once, with offset entries: two nodes' chains side by side, each summed in
// its own entry order (the same values as node_force twice). Their common length runs as one
// loop, so each step of it has two independent adds per component to issue where one node alone
// would wait on its previous add; the longer node's tail runs alone after it.
template <class T, bool External>
PLIANT_SCALAR_LOOP inline void node_force_pair(const GatherContext<T>& c, std::size_t n, T f[6]) {
  const T* b0 = c.corner_force[0];
  const T* b1 = c.corner_force[1];
  const T* b2 = c.corner_force[2];
  const std::int32_t* off = c.corner_offset;
  T a0 = 0, a1 = 0, a2 = 0, c0 = 0, c1 = 0, c2 = 0;
  std::int32_t e = c.offsets[n], g = c.offsets[n + 1];
  const std::int32_t e_end = c.ends[n], g_end = c.ends[n + 1];
  const std::int32_t common = std::min(e_end - e, g_end - g);
  for (std::int32_t i = 0; i < common; ++i) {
    const std::int32_t o = off[e + i], p = off[g + i];
    a0 += b0[o];
    c0 += b0[p];
    a1 += b1[o];
    c1 += b1[p];
    a2 += b2[o];
    c2 += b2[p];
  }
  for (e += common; e < e_end; ++e) {
    const std::int32_t o = off[e];
    a0 += b0[o];
    a1 += b1[o];
    a2 += b2[o];
  }
  for (g += common; g < g_end; ++g) {
    const std::int32_t p = off[g];
    c0 += b0[p];
    c1 += b1[p];
    c2 += b2[p];
  }
  if constexpr (External) {
    a0 += c.external[0][n];
    a1 += c.external[1][n];
    a2 += c.external[2][n];
    c0 += c.external[0][n + 1];
    c1 += c.external[1][n + 1];
    c2 += c.external[2][n + 1];
  }
  f[0] = a0;
  f[1] = a1;
  f[2] = a2;
  f[3] = c0;
  f[4] = c1;
  f[5] = c2;
}

// Stores node n's force f and integrates it if it is free; false if it diverged.
template <class T>
PLIANT_SCALAR_LOOP inline bool store_and_integrate(const GatherContext<T>& g, const IntegrateContext<T>& c,
                                                   std::size_t n, const T f[3]) {
  g.f[0][n] = f[0];
  g.f[1][n] = f[1];
  g.f[2][n] = f[2];
  return integrate_node(c, n, f);
}

template <class T, bool External, Entries How>
PLIANT_SCALAR_LOOP bool gather_integrate(const GatherContext<T>& g, const CornerTable<T>& table,
                                         const IntegrateContext<T>& c, Range r) {
  bool finite = true;
  std::size_t n = r.begin;
  if constexpr (How == Entries::kOffset) {
    // Blocks of kIntegrateBlock nodes: their forces summed two nodes at a time into g.f, then the
    // block integrated in vector lanes (integrate_nodes) while its forces are in L1.
    constexpr std::size_t kIntegrateBlock = 64;
    while (n + 1 < r.end) {
      const std::size_t end = std::min(r.end, n + kIntegrateBlock);
      const std::size_t b = n;
      for (; n + 1 < end; n += 2) {
        T f[6];
        node_force_pair<T, External>(g, n, f);
        for (int k = 0; k < 3; ++k) {
          g.f[k][n] = f[k];
          g.f[k][n + 1] = f[3 + k];
        }
      }
      if (n < end) {  // an odd block's last node
        T f[3];
        node_force<T, External, How>(g, table, n, f);
        for (int k = 0; k < 3; ++k) g.f[k][n] = f[k];
        ++n;
      }
      finite &= integrate_nodes(c, g.f, b, end);
    }
  }
  for (; n < r.end; ++n) {
    T f[3];
    node_force<T, External, How>(g, table, n, f);
    finite &= store_and_integrate(g, c, n, f);
  }
  return finite;
}

template <class T, bool External, Entries How>
PLIANT_SCALAR_LOOP void gather(const GatherContext<T>& c, const CornerTable<T>& table, Range r) {
  std::size_t n = r.begin;
  if constexpr (How == Entries::kOffset) {
    for (; n + 1 < r.end; n += 2) {
      T f[6];
      node_force_pair<T, External>(c, n, f);
      for (int k = 0; k < 3; ++k) {
        c.f[k][n] = f[k];
        c.f[k][n + 1] = f[3 + k];
      }
    }
  }
  for (; n < r.end; ++n) {
    T f[3];
    node_force<T, External, How>(c, table, n, f);
    c.f[0][n] = f[0];
    c.f[1][n] = f[1];
    c.f[2][n] = f[2];
  }
}

// Calls f with the node pass instantiated for the context's external loads and entries.
template <class T, class F>
auto dispatch(const GatherContext<T>& g, const CornerTable<T>& table, F&& f) {
  const bool ext = g.external[0] != nullptr;
  switch (table.entries) {
    case Entries::kOffset:
      return ext ? f(std::true_type{}, std::integral_constant<Entries, Entries::kOffset>{})
                 : f(std::false_type{}, std::integral_constant<Entries, Entries::kOffset>{});
    case Entries::kRegular:
      return ext ? f(std::true_type{}, std::integral_constant<Entries, Entries::kRegular>{})
                 : f(std::false_type{}, std::integral_constant<Entries, Entries::kRegular>{});
    default:
      return ext ? f(std::true_type{}, std::integral_constant<Entries, Entries::kIrregular>{})
                 : f(std::false_type{}, std::integral_constant<Entries, Entries::kIrregular>{});
  }
}

}  // namespace

bool encode_corner_offsets(const std::int32_t* incidence, std::size_t entries, std::size_t stride,
                           std::int32_t* out) {
  std::int64_t largest = 0;  // the largest code's tet bounds every offset's tet part
  for (std::size_t e = 0; e < entries; ++e) largest = std::max<std::int64_t>(largest, incidence[e] >> 2);
  if (9 * std::int64_t(stride) + largest > std::int64_t(INT32_MAX)) return false;
  for (std::size_t e = 0; e < entries; ++e)
    out[e] = std::int32_t(3 * std::int64_t(stride) * (incidence[e] & 3) + (incidence[e] >> 2));
  return true;
}

// The context with its entries' ends set (GatherContext::ends; CSR when null).
template <class T>
GatherContext<T> with_ends(const GatherContext<T>& c) {
  GatherContext<T> out = c;
  if (!out.ends) out.ends = out.offsets + 1;
  return out;
}

template <class T>
void gather_forces(const GatherContext<T>& context, Range r) {
  const GatherContext<T> c = with_ends(context);
  const CornerTable<T> table(c);
  dispatch(c, table, [&](auto ext, auto how) { gather<T, decltype(ext)::value, decltype(how)::value>(c, table, r); });
}

template <class T>
bool gather_integrate_symplectic_euler(const GatherContext<T>& context, const IntegrateContext<T>& c, Range r) {
  const GatherContext<T> g = with_ends(context);
  const CornerTable<T> table(g);
  return dispatch(g, table, [&](auto ext, auto how) {
    return gather_integrate<T, decltype(ext)::value, decltype(how)::value>(g, table, c, r);
  });
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
