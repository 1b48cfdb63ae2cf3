// Level: one resolution of one body, the unit the scheduler steps. Structure of arrays, one
// contiguous 64-byte-aligned array per component. A body with one level is simply L = 0.
#pragma once
#include <algorithm>
#include <array>
#include <cstdint>
#include <iterator>
#include <vector>

#include "pliant/aligned.hpp"
#include "pliant/corner_forces.hpp"
#include "pliant/defs.hpp"
#include "pliant/kernels/node_passes.hpp"
#include "pliant/kernels/range.hpp"

namespace pliant {

template <class T>
struct Level {
  // ---- nodes ----
  std::size_t node_count = 0;
  AlignedVector<T> X[3];        // rest positions (m), body frame: relative to the body origin (World::body_origin)
  AlignedVector<T> x[3];        // positions (m), body frame
  AlignedVector<T> v[3];        // velocities (m/s)
  AlignedVector<T> f[3];        // total internal + external force of the last step (N); on fixed nodes, the reaction
  AlignedVector<T> inv_mass;    // 1/kg, 0 on fixed nodes
  AlignedVector<T> mass;        // lumped mass rho V / 4 per incident tet (kg)
  AlignedVector<std::uint8_t> state;  // NodeStateCode
  AlignedVector<T> external[3];     // constant nodal loads (N); empty when the body has none
  AlignedVector<double> obstacle_impulse[3];  // impulse the obstacles gave each node so far (N s); empty without obstacles
  // Private to the step: x interleaved per node (x y z 0, 4 per node) for the element passes'
  // corner loads, rewritten from x right before them (pack_positions, level_passes.hpp); not
  // part of the state. Empty where packed corners do not pay (packed_corners_pay).
  AlignedVector<T> x_packed;
  // The same for the velocities, read by the damped passes (ElementContext::vp), packed with the
  // positions; empty where it does not pay (packed_velocities_pay) or the level is undamped.
  AlignedVector<T> v_packed;

  // ---- tetrahedra ----
  std::size_t tet_count = 0;
  AlignedVector<std::int32_t> tet[4];  // corner node indices, positive orientation at rest
  AlignedVector<T> volume;           // rest volume (m^3)
  AlignedVector<T> grad[9];          // rest gradients of phi_1..3 (1/m), rows of Dm^-1
  // corotational: element rotation quaternion (w,x,y,z), the force pass's warm start; empty
  // otherwise. A level stepped from a list (LevelInfo::listed) keeps its stepped tets' in list order
  // in the step, written back here at each change of resolution (and whenever the step is
  // prepared again): between those, its entries may be older than the step's.
  AlignedVector<T> rotation[4];
  // Per-tet corner forces of the element pass (N), [3c + k][tet], one block. A level whose step
  // lists its stepped tets (LevelInfo::listed) keeps theirs in the step's own arrays, in list
  // order, and does not write them here; zero for the tets a level does not step.
  CornerForceArrays<T> corner_force;

  // ---- incidence and surface ----
  AlignedVector<std::int32_t> incidence_offsets;  // node_count + 1
  AlignedVector<std::int32_t> incidence;          // 4 * tet + corner, sorted per node
  // The same entries as offsets into corner_force's block (encode_corner_offsets: the gather's
  // fast path, GatherContext::corner_offset); empty if they would not fit in 32 bits.
  AlignedVector<std::int32_t> corner_offset;
  std::vector<std::array<std::int32_t, 3>> boundary;  // outward boundary triangles

  // ---- material and time ----
  ForceModel model = ForceModel::corotational;
  T lambda = 0, mu = 0;                       // Pa
  T bulk_viscosity = 0, shear_viscosity = 0;  // Pa*s
  T mass_damping = 0;                         // 1/s
  T young = 0, stiffness_damping = 0;         // Pa, s (springs)
  double min_altitude = 0;                    // m, smallest tet altitude at rest
  double omega_geometric = 0;                 // rad/s, 2 c_p / h_min (the classic Courant estimate)
  double omega_measured = 0;                  // rad/s, highest frequency of M^-1 K at rest (Lanczos, from below)
  double omega_max = 0;                       // rad/s, the frequency stable_dt is built for:
                                              //   max(omega_geometric, omega_measured / 0.98)
  double stable_dt = 0;                       // s, stable step of this level: courant x (2 / omega_max),
                                              //   tightened by damping (docs/architecture.md)
  int period = 1;                             // fine ticks per step of this level (multiresolution; 1 otherwise)

  // ---- multiresolution (docs/multiresolution.md); a single-level body steps every tet, no ghosts ----
  std::vector<Range> stepped_runs;   // the tets this level steps, as sorted runs of tet indices
  std::size_t stepped_count = 0;     // tets in stepped_runs
  // Ghost nodes: corners of stepped tets whose position and velocity come from active nodes of
  // coarser levels; ghost i reads entries ghost_offsets[i] .. ghost_offsets[i+1].
  AlignedVector<std::int32_t> ghosts, ghost_offsets, ghost_source_level, ghost_source_node;
  AlignedVector<double> ghost_weight;
  // Receivers: this level's active nodes that feed ghosts of finer levels; the forces on those
  // ghosts come back to them as impulses (entries receive_offsets[i] .. [i+1], sorted).
  AlignedVector<std::int32_t> receivers, receive_offsets, receive_ghost_level, receive_ghost_node;
  AlignedVector<double> receive_weight;
  AlignedVector<T> impulse[3];       // N s received since this level last integrated; empty without receivers
  double window_dt = 0;              // s elapsed in this level's current window
  double window_start = 0;           // s, the time at which the current window began (of the positions)
  bool coupled() const { return !ghosts.empty() || !receivers.empty(); }
  // Whether tet t is stepped: inside one of stepped_runs (sorted, disjoint; a binary search).
  bool steps(std::size_t t) const {
    const auto next = std::upper_bound(stepped_runs.begin(), stepped_runs.end(), t,
                                       [](std::size_t x, const Range& r) { return x < r.begin; });
    return next != stepped_runs.begin() && std::prev(next)->end > t;
  }
};

}  // namespace pliant
