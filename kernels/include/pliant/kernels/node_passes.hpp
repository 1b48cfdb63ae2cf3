// Node passes: the deterministic gather of corner forces into node forces, and the symplectic
// Euler integrator. Free functions over node ranges, instantiated for float and double.
#pragma once
#include <cstddef>
#include <cstdint>

#include "pliant/kernels/range.hpp"

namespace pliant {

// Divergence: a free node whose position (m) or velocity (m/s) component is not finite, or
// larger in magnitude than this, has diverged. No run in range gets near it (a body in free
// fall for a century reaches 3e10 m/s, and light does 3e8), while an unstable mode grows by a
// constant factor per step, so it passes 1e15 within a few hundred steps of leaving physical
// magnitudes: the run is stopped then (DivergenceError, exit code 3) instead of going on with
// garbage until inf/NaN (float overflows at 3e38, double at 1e308; a state at 1e160 m/s is
// finite). In float, 1e15 m is still 10 orders of magnitude below overflow of the squared
// values the energies and strains use.
inline constexpr double kDivergedMagnitude = 1e15;

// True when a free node's new position or velocity component counts as diverged (see above).
// Written as one comparison each, so that NaN (which fails every comparison) counts too and
// the hot loops only accumulate the flag (no branch).
template <class T>
inline bool within_bounds(T x, T v) {
  const T b = T(kDivergedMagnitude);
  return (x <= b) & (x >= -b) & (v <= b) & (v >= -b);
}

// Node states (Level::state). Only free nodes are integrated.
enum NodeStateCode : std::uint8_t { kNodeFree = 0, kNodeFixed = 1, kNodeGhost = 2, kNodeInactive = 3 };

template <class T>
struct GatherContext {
  // Node -> (tet, corner) incidence in CSR form: entries incidence[offsets[n] .. offsets[n+1])
  // hold 4 * tet + corner, sorted, so the sum order never depends on threads.
  const std::int32_t* offsets = nullptr;
  const std::int32_t* incidence = nullptr;
  // Optional: node n's entries end at ends[n] instead of offsets[n + 1], so that each node's range
  // may have room left after its entries (a listed level's gather edits its entries in place at a
  // change of resolution: their ranges are the level's whole incidence, filled from the front).
  // Null: ends = offsets + 1 (CSR).
  const std::int32_t* ends = nullptr;
  const T* corner_force[12] = {};
  const T* external[3] = {};  // constant nodal loads (N), or null
  T* f[3] = {};               // output: total force on each node (N)
  // Optional, the entries of `incidence` as element offsets from corner_force[0], for corner
  // forces in one block whose array q starts at q x corner_stride (encode_corner_offsets): the
  // gather then loads an entry's three components straight from three base pointers, with no
  // table lookup per entry. Used only when the corner_force pointers are that block (checked
  // per call); otherwise, or when null, incidence is read as above. Same sums either way.
  const std::int32_t* corner_offset = nullptr;
  std::size_t corner_stride = 0;  // elements from one corner-force array to the next
};

// out[e] = 3 x stride x (corner) + tet for each incidence code 4 x tet + corner in [0, entries):
// the offset of the entry's x force from the first array of a corner-force block of that stride
// (GatherContext::corner_offset). False, and out untouched, when an offset would not fit in 32
// bits (more than about 178 million tets).
bool encode_corner_offsets(const std::int32_t* incidence, std::size_t entries, std::size_t stride,
                           std::int32_t* out);

template <class T>
void gather_forces(const GatherContext<T>& c, Range nodes);

template <class T>
struct IntegrateContext {
  T* x[3] = {};
  T* v[3] = {};
  const T* f[3] = {};
  const T* inv_mass = nullptr;        // 1/kg
  const std::uint8_t* state = nullptr;
  T dt = 0;                           // s
  T gravity[3] = {0, 0, 0};           // m/s^2
  T mass_damping = 0;                 // alpha (1/s)
};

// v <- v + dt (f/m + g - alpha v); x <- x + dt v, on free nodes (a vector register of nodes at a
// time, each lane the scalar operations in order: the same bits). Returns false if any free
// node's new position or velocity is not finite or beyond kDivergedMagnitude (within_bounds;
// the caller then locates it).
template <class T>
bool integrate_symplectic_euler(const IntegrateContext<T>& c, Range nodes);

// gather_forces and then integrate_symplectic_euler in one sweep over the nodes: each node's
// force is summed and stored in g.f, and integrated at once (or, with offset entries, its block of
// 64 nodes in vector lanes while their forces are in L1), so f is not read back from memory. The
// same results, bit for bit, as the two passes one after the other (i.f must be g.f).
template <class T>
bool gather_integrate_symplectic_euler(const GatherContext<T>& g, const IntegrateContext<T>& i, Range nodes);

// The positions interleaved per node for the element passes (ElementContext::xp): xp[4 n + k] =
// x[k][n] for k < 3 and xp[4 n + 3] = 0, on nodes [begin, end). A copy, so whoever writes x
// (integrator, ghosts, prescribed motion, obstacles, tools, adaptivity) needs not know of it: the
// step packs right before its element passes. (Packing the velocities too, for the damped
// passes, did not pay: docs/performance.md.)
// With vp set, the velocities too (vp[4 n + k] = v[k][n]: ElementContext::vp, for the damped
// passes), in the same sweep.
template <class T>
struct PackContext {
  const T* x[3] = {};
  T* xp = nullptr;  // 4 per node
  const T* v[3] = {};
  T* vp = nullptr;  // 4 per node, or null: velocities not packed
};

template <class T>
void pack_positions(const PackContext<T>& c, Range nodes);

}  // namespace pliant
