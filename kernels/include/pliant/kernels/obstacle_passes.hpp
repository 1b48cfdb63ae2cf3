// Static obstacles: a node pass that keeps free nodes out of a solid half-space (a floor, a
// table, a wall). It runs after the integrator, on the new positions and velocities: a node that
// ended the step inside the solid is put back onto its surface and loses its velocity into the
// solid (a perfectly inelastic contact), and optionally some of its tangential velocity (Coulomb
// friction). There is no contact between bodies here: this is the smallest honest support a
// body can rest on. A free function over a node range like the other node passes; each node is
// handled on its own, so the result does not depend on how ranges are split.
#pragma once
#include <cstdint>

#include "pliant/kernels/range.hpp"

namespace pliant {

template <class T>
struct HalfSpaceContext {
  T* x[3] = {};                        // positions (m), updated
  T* v[3] = {};                        // velocities (m/s), updated
  const T* mass = nullptr;             // lumped node masses (kg)
  const std::uint8_t* state = nullptr; // NodeStateCode: only free nodes are touched
  // Accumulated impulse the obstacle gave each node (N s): += m (v_after - v_before). Kept in
  // double so that a long run of float steps still sums it to the accuracy of a double. May be
  // null (no record).
  double* impulse[3] = {};
  T point[3] = {0, 0, 0};   // m, a point of the obstacle's surface (in the level's coordinates)
  T normal[3] = {0, 0, 1};  // unit normal of the surface, pointing out of the solid (into the free side)
  T friction = 0;           // Coulomb coefficient mu >= 0: |tangential velocity change| <= mu |normal velocity change|
};

// For each free node with d = normal . (x - point) < 0 (inside the solid):
//   x <- x - d normal                                  (back onto the surface)
//   if v_n = normal . v < 0: v <- v - v_n normal       (the velocity into the solid is removed)
//     and, with friction, the tangential velocity v_t is shortened by mu |v_n| (to zero at most).
// Nodes on the free side (d >= 0) and non-free nodes are left as they are. Scalar code: the
// same bits whatever the range split (each node is independent) and the thread count.
template <class T>
void resolve_half_space(const HalfSpaceContext<T>& c, Range nodes);

}  // namespace pliant
