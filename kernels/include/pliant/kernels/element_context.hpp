// What an element kernel reads and writes: plain pointers into a level's SoA arrays. No
// ownership, no containers, so a kernel can be called serially in a test or by the scheduler.
#pragma once
#include <cstdint>

namespace pliant {

template <class T>
struct ElementContext {
  // Nodes (SoA, one array per component).
  const T* X[3] = {};  // rest positions (m) — springs need rest lengths
  const T* x[3] = {};  // current positions (m)
  // Optional: the same positions interleaved per node, xp[4 n + k] = x[k][n] (k < 3; the fourth
  // value is padding), 16-byte (float) or 32-byte (double) aligned. When set, the force passes
  // read a tet's corners from it (one load per corner instead of three gathered elements); the
  // caller keeps it equal to x (pack_positions, node_passes.hpp). Null: read x.
  const T* xp = nullptr;
  const T* v[3] = {};  // velocities (m/s)
  // Optional: the velocities interleaved per node as xp (vp[4 n + k] = v[k][n]), read instead of
  // v by the damped passes when set; the caller keeps it equal to v (pack_positions). Null: read v.
  const T* vp = nullptr;
  // Tetrahedra.
  const std::int32_t* tet[4] = {};  // corner node indices, positively oriented at rest
  const T* volume = nullptr;        // rest volume V (m^3)
  // Rest shape-function gradients of corners 1..3 (1/m): grad[3*(c-1) + k] is d(phi_c)/dX_k.
  // Corner 0's gradient is minus their sum. Together they are the rows of Dm^-1.
  const T* grad[9] = {};
  // Corotational warm start: the element rotation as a unit quaternion (w, x, y, z), updated
  // in place by the element pass. Null for the other models.
  T* rotation[4] = {};
  // Material (one per level): Lamé coefficients (Pa) and viscous coefficients (Pa*s).
  T lambda = 0, mu = 0;
  T bulk_viscosity = 0, shear_viscosity = 0;  // phi, psi: phi tr(eps_dot) I + 2 psi eps_dot
  // Rayleigh stiffness damping: beta (s) when phi = beta lambda and psi = beta mu
  // (rayleigh_factor, element_forces.hpp), else 0. Non-zero, the continuum passes take the stress
  // as one Hooke law of eps + beta eps_dot instead of two added (the same value, fewer flops).
  T rayleigh = 0;
  // Springs: Young's modulus (Pa) and the Rayleigh factor beta (s) for the edge dashpots.
  T young = 0, spring_damping = 0;
  // Output: the force on each corner, corner_force[3*c + k][tet] (N).
  T* corner_force[12] = {};
  // Optional, for the passes over a list of tets (the *_listed kernels): the same rest data of
  // the list's tets in list order, listed_tet[a][i] = tet[a][tets[i]], listed_grad[q][i] =
  // grad[q][tets[i]], listed_volume[i] = volume[tets[i]], for the list the kernels are given
  // (a multiresolution level's stepped tets: Simulation::prepare copies them once per change).
  // A batch then loads them instead of gathering them from tets scattered over the mesh. Null:
  // gathered.
  const std::int32_t* listed_tet[4] = {};
  const T* listed_grad[9] = {};
  const T* listed_volume = nullptr;
  // Optional, for the corotational *_listed passes: the warm-start rotations in list order,
  // listed_rotation[k][i] for the list's i-th tet, read (and written back by the force pass) in
  // place of rotation[k][tets[i]]: one vector load and store per component instead of a gather
  // and a scatter. The caller keeps them and writes them back to `rotation` when the list changes
  // or another pass reads the rotations by tet (Simulation::write_back_rotations). Null: per tet.
  T* listed_rotation[4] = {};
  // Optional, for the *_listed force passes: true when corner_force is in list order,
  // corner_force[3*c + k][i] for the list's i-th tet (arrays as long as the list), so that a
  // batch stores its forces in one vector store per array instead of scattering them over the
  // mesh's tets (a listed level's gather reads them by list position: Simulation::prepare).
  // False: corner_force[3*c + k][tet], as the range passes write it.
  bool listed_corner_forces = false;
};

}  // namespace pliant
