// The strain part of an adaptive body's decision (engine/src/multires/adaptivity.cpp, adapt_body):
// per stepped tet, its deformation gradient F = sum_c (x_c - x_0) (x) g_c (the rest gradients g of
// its corners 1-3, the current positions x in double), kept for the jumps between neighbours, and
// the body's largest squared Green-Lagrange strain |(F^T F - I) / 2|^2 (Frobenius), its peak.
//
// Why lanes: a decision measures every stepped tet every check_every (2 ms by default); on the
// 50k-tet organ held at its middle level (about 1 500 tets stepped) that was 45 us of scalar double
// arithmetic per decision point, half of a decision that changes nothing. The lanes run W tets per
// instruction with exactly the scalar code's operations in its order (kernels/src/simd.hpp: no
// fused multiply-add, the build keeps -ffp-contract=off), so F, the peak and every decision taken
// from them are the same bits (tests/kernels/test_strain_measure.cpp).
#pragma once
#include <array>
#include <cstdint>

#include "pliant/kernels/range.hpp"

namespace pliant {

template <class T>
struct StrainMeasureContext {
  const std::int32_t* tet[4] = {};  // corner node indices, per tet
  const T* grad[9] = {};            // rest gradients of corners 1-3, [3 c + axis], per tet (1/m)
  const double* x[3] = {};          // current node positions (m), x, y, z arrays
};

// For i in r: F[ids[i]] = the deformation gradient of tet ids[i] (row-major, F[3 i + j] =
// dx_i / dX_j); returns max(top, e2) over the tets in list order, e2 their squared strain, as
// the loop `top = std::max(top, e2)` from top = 0 gives it (a NaN strain is skipped). The listed
// tets must be distinct.
template <class T>
double deformation_gradients_listed(const StrainMeasureContext<T>& c, const std::int32_t* ids, Range r,
                                    std::array<double, 9>* F);
// The same, one tet at a time in scalar code: the reference of the tests.
template <class T>
double deformation_gradients_listed_scalar(const StrainMeasureContext<T>& c, const std::int32_t* ids, Range r,
                                           std::array<double, 9>* F);

}  // namespace pliant
