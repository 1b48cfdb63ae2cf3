// The node passes that couple the levels of a multiresolution body (docs/multiresolution.md):
// ghosts take their position and velocity from the active nodes of other levels by fixed weights
// (barycentric in the coarser tet that covers them), and the forces the element passes put on the
// ghosts go back to those nodes by the transpose of the same weights, as impulses (N s) that each
// receiving node accumulates until its own level integrates. Free functions over ranges, no
// allocation, a fixed summation order (bitwise the same for any thread split).
#pragma once
#include <cstdint>

#include "pliant/kernels/node_passes.hpp"
#include "pliant/kernels/range.hpp"

namespace pliant {

inline constexpr int kMaxLevels = 8;  // levels of one body

template <class T>
struct GhostContext {
  // Over the ghost list: ghost node indices, and for ghost i its sources (level, node, weight) in
  // entries offsets[i] .. offsets[i+1].
  const std::int32_t* ghosts = nullptr;
  const std::int32_t* offsets = nullptr;
  const std::int32_t* source_level = nullptr;
  const std::int32_t* source_node = nullptr;
  const double* weight = nullptr;
  const T* source_x[kMaxLevels][3] = {};  // m, per level of the body
  const T* source_v[kMaxLevels][3] = {};  // m/s
  T* x[3] = {};  // output: this level's positions (ghost entries)
  T* v[3] = {};  // and velocities
};

// x_g = sum_k w_k x_k, v_g = sum_k w_k v_k for the ghosts in range (an index range of the list),
// summed in double in the order of the entries.
template <class T>
void refresh_ghosts(const GhostContext<T>& c, Range ghosts);

template <class T>
struct ReceiveContext {
  // Over the receiver list: node indices of this level that are sources of ghosts, and for
  // receiver i the ghosts it feeds (level, node, weight) in entries offsets[i] .. offsets[i+1],
  // sorted by (level, node).
  const std::int32_t* receivers = nullptr;
  const std::int32_t* offsets = nullptr;
  const std::int32_t* ghost_level = nullptr;
  const std::int32_t* ghost_node = nullptr;
  const double* weight = nullptr;
  const T* ghost_f[kMaxLevels][3] = {};  // N, the gathered force on each level's nodes
  T ghost_dt[kMaxLevels] = {};           // s, the step of each ghost level whose window ended now; 0 = not now
  T* impulse[3] = {};                    // N s, this level's accumulated impulses (output)
};

// impulse_n += sum over the ghosts of levels due now of w dt_g f_g, for the receivers in range.
template <class T>
void receive_ghost_impulses(const ReceiveContext<T>& c, Range receivers);

// integrate_symplectic_euler for a level that receives impulses: on free nodes first
// v += impulse / m (and the impulse is cleared), then v += dt (f/m + g - alpha v), x += dt v.
// Returns false if a free node's new state diverged (within_bounds).
template <class T>
bool integrate_symplectic_euler_impulse(const IntegrateContext<T>& c, T* const impulse[3], Range nodes);

}  // namespace pliant
