// Element passes: per tetrahedron, read its 4 nodes and write its 4 corner forces. Each model
// has a force kernel and an energy kernel (elastic energy per tet, J). All are free functions
// over a range of tets; instantiated for float and double.
//
//   linear        Cauchy strain eps = sym(F) - I, sigma = lambda tr(eps) I + 2 mu eps, P = sigma
//   stvk          Green–Lagrange E = (F^T F - I)/2, S = lambda tr(E) I + 2 mu E, P = F S
//   corotational  F = R S (polar), eps = S - I, P = R (lambda tr(eps) I + 2 mu eps)
//   springs       the 6 edges of every tet as springs k = E V / L^2 (van Gelder-style), summed
//                 over the tets sharing an edge; dashpots beta k along each edge
// and f_c = -V P grad(phi_c). Viscous stress (thesis ch.2 §4) is added to sigma (or S) with the
// strain rate of the same measure (with Rayleigh viscosities, as one Hooke law of eps + beta eps_dot).
#pragma once
#include <cstdint>

#include "pliant/kernels/element_context.hpp"
#include "pliant/kernels/range.hpp"

namespace pliant {

// Whether the force passes are faster reading corners from packed positions (ElementContext::xp)
// than gathering them, with the pack counted: true with AVX2 (8 float or 4 double loads and a
// transpose per corner: 0.75-0.85x the time in float, 0.87-0.94x in double on an AMD EPYC Zen 3,
// whose gathers are slow); false with AVX-512 (float 1.06-1.27x on a Xeon, 2026-11-29, probably
// because the transpose's 19 inserts and unpacks per corner need the same two 512-bit ports as the
// arithmetic, while gathers mostly wait on loads; double 0.93-1.07x, no gain for the pack's time
// and memory) and for SSE builds (not measured). docs/performance.md.
template <class T> bool packed_corners_pay();
// Whether the damped passes are faster reading corner velocities from a packed copy
// (ElementContext::vp) too, its pack counted: true with AVX2 (0.85-0.94x the damped pass with
// positions packed only, Zen 3); false with AVX-512 (float 0.93-1.02x on a Xeon, 2026-11-25,
// before the copy fix) and SSE builds. docs/performance.md.
template <class T> bool packed_velocities_pay();

// The Rayleigh factor beta (s) of viscosities phi = beta lambda, psi = beta mu (Pa s; Lamé moduli in
// Pa): psi / mu when phi equals beta lambda to 8 units in the last place of T, else 0 (not
// proportional, or psi = 0). For ElementContext::rayleigh: the engine's Rayleigh stiffness damping
// (damping.stiffness) gives such viscosities, and so do explicit ones in that proportion (the same
// values, so the same path and bits).
template <class T> T rayleigh_factor(T lambda, T mu, T phi, T psi);

template <class T> void element_forces_linear(const ElementContext<T>& c, Range tets);
template <class T> void element_forces_stvk(const ElementContext<T>& c, Range tets);
template <class T> void element_forces_corotational(const ElementContext<T>& c, Range tets);
template <class T> void element_forces_springs(const ElementContext<T>& c, Range tets);

// The same passes over listed tets: tets[i] for i in r (sorted or not, no tet twice). For a level
// that steps part of its mesh (multiresolution), whose stepped tets lie in short runs: a batch of
// W lanes is full however the runs are cut (gathers and per-lane stores instead of contiguous
// loads). The same bits per tet as the range passes. Corner forces go to corner_force[q][tet], or
// to corner_force[q][i] (the list position) when c.listed_corner_forces is set.
template <class T> void element_forces_linear_listed(const ElementContext<T>& c, const std::int32_t* tets, Range r);
template <class T> void element_forces_stvk_listed(const ElementContext<T>& c, const std::int32_t* tets, Range r);
template <class T> void element_forces_corotational_listed(const ElementContext<T>& c, const std::int32_t* tets, Range r);
template <class T> void element_forces_springs_listed(const ElementContext<T>& c, const std::int32_t* tets, Range r);

// Elastic energy of each tet into energy[tet] (J). The corotational energy uses (and may
// refine) the stored rotations, so it is consistent with the last force pass.
template <class T> void element_energy_linear(const ElementContext<T>& c, Range tets, double* energy);
template <class T> void element_energy_stvk(const ElementContext<T>& c, Range tets, double* energy);
template <class T> void element_energy_corotational(const ElementContext<T>& c, Range tets, double* energy);
template <class T> void element_energy_springs(const ElementContext<T>& c, Range tets, double* energy);
// Corotational runs W tets at a time (the rotation refinement in vector lanes, as the force pass),
// with the bits of this one-tet-at-a-time loop, kept as the tests' reference; and over listed tets
// (energy[tets[i]] for i in r).
template <class T> void element_energy_corotational_scalar(const ElementContext<T>& c, Range tets, double* energy);
template <class T>
void element_energy_corotational_listed(const ElementContext<T>& c, const std::int32_t* tets, Range r, double* energy);

// Cauchy (true) stress of each tet (Pa), 9 components row-major into sigma9[9 t + 3 i + j].
// measure: 0 small strain (linear; also used to report springs), 1 Green–Lagrange
// (sigma = F S F^T / det F), 2 corotational (sigma = R sigma_rot R^T).
template <class T> void element_cauchy_stress(const ElementContext<T>& c, Range tets, int measure, double* sigma9);

// Rest geometry of one tet from its corners (double, done once at load): volume (m^3) and the
// gradients of phi_1..3 as rows of Dm^-1. Returns false if the tet is degenerate.
bool tet_rest_geometry(const double a[3], const double b[3], const double c[3], const double d[3],
                       double* volume, double grad[9]);

// Smallest altitude of a tet (m): 3 V / (largest face area). The Courant length of the element.
double tet_min_altitude(const double a[3], const double b[3], const double c[3], const double d[3]);

}  // namespace pliant
