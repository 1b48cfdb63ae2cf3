// How much stiffer each element is now than at rest: the deformation monitor of the adaptive
// time step (World re-checks it every few steps and sub-steps when it has grown).
//
// Why: the stable step is measured at rest (engine/src/core/stable_step.cpp), but stvk stiffens
// without bound in stretch, and corotational's tangent grows without bound as an inverted
// element's two signed stretches cancel. A body that deforms far enough (a beam too soft to carry
// its own weight, docs/stability.md) then has modes several times faster than at rest and
// diverges at any step fixed at load.
//
// What: for an isotropic energy density psi of the signed principal stretches s1, s2, s3 (the
// singular values of F, the smallest negated when det F < 0), the Hessian of psi with respect to
// F has, in closed form (Smith, de Goes, Kim 2019, "Analytic eigensystems for isotropic distortion
// energies"), the eigenvalues
//   scaling: those of the 3x3 matrix d2psi / ds_i ds_j,
//   twist:   (psi_i + psi_j) / (s_i + s_j),   flip: (psi_i - psi_j) / (s_i - s_j),   i < j,
// with psi_i = dpsi / ds_i. The ratio written per tet is the largest of their magnitudes now over
// the largest at rest (3 lambda + 2 mu, the hydrostatic scaling mode): the factor by which the
// element's highest frequency squared has grown, at most. The scaling block is bounded by its
// Gershgorin row sums (exact at rest). Negative eigenvalues (softening, buckling) count by their
// magnitude: conservative.
//   stvk:          psi = mu |E|^2 + lambda/2 tr(E)^2, E_i = (s_i^2 - 1)/2, psi_i = s_i S_i with
//                  S_i = lambda tr E + 2 mu E_i; twist and flip are bounded by the stresses S_i
//                  plus 2 mu s^2 (no blow-up at small stretches: stvk softens there).
//   corotational:  psi = mu |S - I|^2 + lambda/2 tr(S - I)^2 with S = R^T F (R the element's rotation,
//                  the invertible one for inverted tets), psi_i = 2 mu (s_i - 1) + lambda (tr S - 3);
//                  scaling 2 mu + 3 lambda, flip 2 mu, twist unbounded as s_i + s_j -> 0. The
//                  denominator is floored at kMinStretchSum (so a tet flattened exactly gives a
//                  large finite ratio, not inf).
//   springs:       a spring of rest length L and length l has the tangent k along the edge and
//                  k (1 - L / l) across it: below k when stretched, but negative and without bound
//                  as the spring is squashed (l < L / 2: |1 - L / l| > 1). The ratio is the
//                  largest 1 + |1 - L / l| over the tet's six springs (L / l when squashed, below
//                  2 when stretched), l floored at kMinStretchSum L: the sum of the magnitudes of
//                  a spring's axial and transverse tangents over its rest k, an estimate that was
//                  above the element's Hessian growth (finite differences) in every state tested
//                  (tests/kernels/test_element_stiffness.cpp), not a proof. (Springs used to be
//                  taken as never stiffening: the stability matrix's collapsing springs
//                  cantilever, springs squashed to L / 9, gained 1.5x its energy at the default step.)
// linear keeps its rest stiffness (it is affine): its ratio is 1 and World does not call it.
//
// Scalar code in double, like the energy reports, except corotational's fast path (below).
// Corotational uses the rotation the last force pass stored (one step old) as it is: refining it
// would cost more than the rest of the pass, and a monitor needs no more. Read-only: monitoring
// never changes the trajectory.
//
// Corotational fast path in vector lanes: with eps = |R^T F - I|_F <= 1/2 the ratio is exactly 1
// (element_stiffness.cpp says why), which is every tet of a body that is not far from rest. The
// kernel tests that W tets at a time, one per lane (F, R and R^T F with the helpers of the force
// passes, the same bits as the scalar code; the sum of squares in double in the scalar order, or
// for float in float against 1/4 less a margin that covers the difference), and runs the scalar
// code on every lane that does not pass (tests/kernels/test_stiffness_lanes.cpp: the same ratios
// as the one-tet-at-a-time code). On the default scene this made the monitor
// cost about a third of a force pass instead of 1.5 (perf, 1 thread; docs/performance.md "Small
// bodies: the deformation monitor and chunk ownership").
#pragma once
#include <cstdint>

#include "pliant/kernels/element_context.hpp"
#include "pliant/kernels/range.hpp"

namespace pliant {

// Smallest |s_i + s_j| the corotational twist ratio divides by (dimensionless stretch).
inline constexpr double kMinStretchSum = 1e-3;

// ratio[t] = (largest |eigenvalue| of the Hessian of psi at the tet's current F) / (3 lambda + 2 mu),
// for t in the range; 1 at rest. Corotational reads c.rotation (the stored element rotations),
// and its lanes read the positions from c.xp when it is set (which must then hold x, packed).
template <class T> void element_stiffness_ratio_stvk(const ElementContext<T>& c, Range tets, double* ratio);
template <class T> void element_stiffness_ratio_corotational(const ElementContext<T>& c, Range tets, double* ratio);
// The largest ratio of the range and 1, without writing per-tet ratios (what World's monitor
// needs): max(1, ratio[t]...) with NaN ratios skipped, as a std::max(top, ratio[t]) loop over
// element_stiffness_ratio_corotational's output would give. The divergence check reports NaN.
template <class T> double element_stiffness_ratio_corotational_max(const ElementContext<T>& c, Range tets);
// The same over listed tets: tets[i] for i in r (a level stepped from a list, element_forces.hpp).
template <class T>
double element_stiffness_ratio_corotational_max_listed(const ElementContext<T>& c, const std::int32_t* tets, Range r);
// The same ratios as element_stiffness_ratio_corotational, one tet at a time in scalar code (no
// lanes): the reference of the tests.
template <class T>
void element_stiffness_ratio_corotational_scalar(const ElementContext<T>& c, Range tets, double* ratio);
// Springs: the largest 1 + |1 - L / l| over the tet's edges (reads x, X, tet; see above).
template <class T> void element_stiffness_ratio_springs(const ElementContext<T>& c, Range tets, double* ratio);

// Eigenvalues of the symmetric 3x3 matrix a (row-major, only the upper triangle read), ascending,
// by the trigonometric closed form. Exposed for the tests.
void symmetric_eigenvalues3(const double a[9], double eig[3]);

}  // namespace pliant
