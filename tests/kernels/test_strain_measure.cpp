// The adaptive decision's strain measure in vector lanes (kernels/strain_measure.hpp) must give the
// bits of the one-tet-at-a-time code for every tet, whatever lane or batch it falls in (full and
// partial batches, any list order), and the deformation gradient of an affine motion must be the
// motion's matrix, with the strain |(F^T F - I) / 2|^2 computed here independently.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <numeric>
#include <random>
#include <vector>

#include "../support/random_rest_tet.hpp"
#include "pliant/kernels/element_forces.hpp"
#include "pliant/kernels/strain_measure.hpp"

namespace pliant {
namespace {

// nt tets of 4 shared-free nodes each (tet t: nodes 4t..4t+3), random rest shapes; current
// positions x = A X + b with A random near the identity for most tets, far from it for some.
template <class T>
struct MeasureTets {
  std::size_t nt;
  std::vector<std::int32_t> tet[4];
  std::vector<T> grad[9];
  std::vector<double> X[3], x[3];
  StrainMeasureContext<T> c;

  MeasureTets(std::size_t n, unsigned seed, const double* affine = nullptr) : nt(n) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u(-1, 1);
    for (int k = 0; k < 3; ++k) {
      X[k].resize(4 * nt);
      x[k].resize(4 * nt);
    }
    for (auto& g : grad) g.resize(nt);
    for (auto& a : tet) a.resize(nt);
    for (std::size_t t = 0; t < nt; ++t) {
      double p[4][3], vol, g[9];
      test::random_rest_tet(rng, p, vol, g);
      for (int q = 0; q < 9; ++q) grad[q][t] = T(g[q]);
      double A[9];
      const double spread = t % 5 == 4 ? 0.8 : 0.05;  // some tets far from rest
      for (int q = 0; q < 9; ++q) A[q] = affine ? affine[q] : (q % 4 == 0 ? 1.0 : 0.0) + spread * u(rng);
      for (int a = 0; a < 4; ++a) {
        const auto node = std::int32_t(4 * t + std::size_t(a));
        tet[a][t] = node;
        for (int k = 0; k < 3; ++k) X[k][std::size_t(node)] = p[a][k];
        for (int i = 0; i < 3; ++i) {
          double y = 0.01 * i;
          for (int j = 0; j < 3; ++j) y += A[3 * i + j] * p[a][j];
          x[i][std::size_t(node)] = y;
        }
      }
    }
    for (int a = 0; a < 4; ++a) c.tet[a] = tet[a].data();
    for (int q = 0; q < 9; ++q) c.grad[q] = grad[q].data();
    for (int k = 0; k < 3; ++k) c.x[k] = x[k].data();
  }
};

template <class T>
void lanes_give_the_scalar_bits() {
  MeasureTets<T> m(203, 11);
  std::vector<std::int32_t> ids(m.nt);
  std::iota(ids.begin(), ids.end(), 0);
  std::shuffle(ids.begin(), ids.end(), std::mt19937(5));
  ids.resize(190);  // a list of some tets, in no order
  for (std::size_t begin : {std::size_t(0), std::size_t(1), std::size_t(3)})
    for (std::size_t end : {std::size_t(190), std::size_t(189), std::size_t(186), begin + 2}) {
      const Range r{begin, end};
      std::vector<std::array<double, 9>> f_lanes(m.nt), f_scalar(m.nt);
      const double top_lanes = deformation_gradients_listed(m.c, ids.data(), r, f_lanes.data());
      const double top_scalar = deformation_gradients_listed_scalar(m.c, ids.data(), r, f_scalar.data());
      EXPECT_EQ(std::memcmp(&top_lanes, &top_scalar, sizeof(double)), 0) << begin << " " << end;
      EXPECT_GT(top_scalar, 0.0);
      std::size_t differ = 0;
      for (std::size_t i = r.begin; i < r.end; ++i) {
        const auto e = std::size_t(ids[i]);
        differ += std::memcmp(f_lanes[e].data(), f_scalar[e].data(), 9 * sizeof(double)) != 0;
      }
      EXPECT_EQ(differ, 0u) << begin << " " << end;
    }
}

TEST(StrainMeasure, LanesGiveTheBitsOfOneTetAtATimeFloat) { lanes_give_the_scalar_bits<float>(); }
TEST(StrainMeasure, LanesGiveTheBitsOfOneTetAtATimeDouble) { lanes_give_the_scalar_bits<double>(); }

TEST(StrainMeasure, AnAffineMotionGivesItsMatrixAndItsGreenLagrangeStrain) {
  const double A[9] = {1.1, 0.2, -0.05, 0.03, 0.9, 0.1, -0.02, 0.04, 1.3};
  MeasureTets<double> m(13, 3, A);
  std::vector<std::int32_t> ids(m.nt);
  std::iota(ids.begin(), ids.end(), 0);
  std::vector<std::array<double, 9>> f(m.nt);
  const double top = deformation_gradients_listed(m.c, ids.data(), Range{0, m.nt}, f.data());
  double e2 = 0;  // |(A^T A - I) / 2|^2
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b) {
      double q = -(a == b);
      for (int k = 0; k < 3; ++k) q += A[3 * k + a] * A[3 * k + b];
      e2 += q * q / 4;
    }
  // Rounding of the rest gradients and of positions ~0.1 m apart: measured up to 2.6e-15 on F
  // and 1.1e-14 relative on the peak strain (2026-11-28).
  for (std::size_t t = 0; t < m.nt; ++t)
    for (int q = 0; q < 9; ++q) EXPECT_NEAR(f[t][std::size_t(q)], A[q], 1e-14) << t << " " << q;
  EXPECT_NEAR(top, e2, 3e-14 * e2);
}

}  // namespace
}  // namespace pliant
