// The corotational deformation monitor tests its fast path (|R^T F - I|_F^2 <= 1/4: ratio exactly
// 1) W tets at a time in vector lanes and runs the scalar code on the lanes that fail it
// (kernels/element_stiffness.hpp). Neither that, nor folding the max into the kernel, nor reading
// corners from the interleaved copy of x may change a result: every ratio must be the bits of the
// one-tet-at-a-time scalar code, for any range split (full and partial batches), on tets near
// rest, stretched, inverted, flattened and non-finite, with stored rotations near and far from
// the tets' own. (What is compared is the ratios: the fast-path test is conservative, so a lane
// mask that differed from the scalar test only just above e2 = 1/4 would still give ratio 1.)
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <random>
#include <vector>

#include "../support/element_arrays.hpp"
#include "../support/random_rest_tet.hpp"
#include "../support/same_bits.hpp"
#include "pliant/kernels/element_forces.hpp"
#include "pliant/kernels/element_stiffness.hpp"
#include "pliant/kernels/node_passes.hpp"

namespace pliant {
namespace {

// n tets with 4 nodes each; tet t's current corners are a rotation Q times a stretch S (by kind,
// t % 8) of its random rest shape, plus a translation. Its stored rotation is Q's quaternion,
// perturbed (a step-old rotation), or random for every fifth tet.
template <class T>
struct Tets : test::ElementArrays<T> {
  using test::ElementArrays<T>::X, test::ElementArrays<T>::x, test::ElementArrays<T>::v, test::ElementArrays<T>::volume,
      test::ElementArrays<T>::grad, test::ElementArrays<T>::rot, test::ElementArrays<T>::cf, test::ElementArrays<T>::tet,
      test::ElementArrays<T>::c;
  std::size_t nt;

  explicit Tets(std::size_t n, unsigned seed) : nt(n) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u(-1, 1);
    const std::size_t nn = 4 * nt;
    for (int k = 0; k < 3; ++k) {
      X[k].resize(nn);
      x[k].resize(nn);
      v[k].assign(nn, T(0));
    }
    this->size_tets(nt);
    for (std::size_t t = 0; t < nt; ++t) {
      double p[4][3], vol, g[9];
      test::random_rest_tet(rng, p, vol, g);
      volume[t] = T(vol);
      for (int q = 0; q < 9; ++q) grad[q][t] = T(g[q]);
      // Stretch S by kind.
      double S[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
      const int kind = int(t % 8);
      const double noise = kind <= 2 ? 0.05 : kind == 3 ? 0.12 : 0.02;
      if (kind == 4) S[2][2] = -0.5;                 // inverted
      if (kind == 5) S[1][1] = 0.5, S[2][2] = -0.5;  // flattened: two stretches cancel
      if (kind == 6) S[0][0] = 2;                    // stretched
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) S[i][j] += kind == 7 ? 1.5 * u(rng) : noise * u(rng);
      // Q from a random unit quaternion.
      double q[4], nq = 0;
      for (double& e : q) {
        e = u(rng);
        nq += e * e;
      }
      for (double& e : q) e /= std::sqrt(nq);
      const double w = q[0], a = q[1], b = q[2], d = q[3];
      const double Q[3][3] = {{1 - 2 * (b * b + d * d), 2 * (a * b - w * d), 2 * (a * d + w * b)},
                              {2 * (a * b + w * d), 1 - 2 * (a * a + d * d), 2 * (b * d - w * a)},
                              {2 * (a * d - w * b), 2 * (b * d + w * a), 1 - 2 * (a * a + b * b)}};
      double F[3][3];
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) F[i][j] = Q[i][0] * S[0][j] + Q[i][1] * S[1][j] + Q[i][2] * S[2][j];
      double shift[3];
      for (double& s : shift) s = 0.05 * u(rng);
      for (int c4 = 0; c4 < 4; ++c4) {
        const std::size_t node = 4 * t + std::size_t(c4);
        tet[c4][t] = std::int32_t(node);
        for (int k = 0; k < 3; ++k) {
          X[k][node] = T(p[c4][k]);
          double y = p[0][k] + shift[k];
          for (int j = 0; j < 3; ++j) y += F[k][j] * (p[c4][j] - p[0][j]);
          x[k][node] = T(y);
        }
      }
      // The stored rotation: Q perturbed by up to 0.02 per component, or random.
      double r[4], nr = 0;
      for (int k = 0; k < 4; ++k) {
        r[k] = t % 5 == 4 ? u(rng) : q[k] + 0.02 * u(rng);
        nr += r[k] * r[k];
      }
      for (int k = 0; k < 4; ++k) rot[k][t] = T(r[k] / std::sqrt(nr));
    }
    this->wire();
  }
};

using test::same_bits;

// max(1, r...) skipping NaN, the fold World's monitor did over the per-tet ratios.
double fold_max(const std::vector<double>& r, Range range) {
  double top = 1;
  for (std::size_t t = range.begin; t < range.end; ++t) top = std::max(top, r[t]);
  return top;
}

template <class T>
void check_lanes(std::size_t n, unsigned seed, bool poison) {
  Tets<T> m(n, seed);
  if (poison) {  // one corner at NaN (a diverged state) and one at +inf
    m.x[1][4 * 37 + 2] = std::numeric_limits<T>::quiet_NaN();
    m.x[0][4 * 90 + 1] = std::numeric_limits<T>::infinity();
  }
  const double unset = -12345;
  std::vector<double> scalar(n, unset), lanes(n, unset);
  element_stiffness_ratio_corotational_scalar(m.c, Range{0, n}, scalar.data());
  // Coverage: the cases must reach both paths, or the test says nothing.
  std::size_t ones = 0, above = 0, nonfinite = 0;
  for (double r : scalar) {
    ones += r == 1.0;
    above += r > 1.0;
    nonfinite += !std::isfinite(r);
  }
  EXPECT_GT(ones, n / 4);   // measured 577 of 1000 (kinds 0-2, part of 3, some stored rotations far off)
  EXPECT_GT(above, n / 4);  // measured 423 of 1000 (inverted, flattened, stretched, random)
  // A non-finite F takes the scalar path (e2 is NaN) and gives a finite ratio there (its NaN
  // twist ratios are skipped by std::max): the divergence check, not the monitor, reports it.
  EXPECT_EQ(nonfinite, 0u);
  std::printf("%zu tets: %zu at ratio 1, %zu above\n", n, ones, above);
  // Whole range, then pieces of odd sizes starting at every offset within a batch.
  element_stiffness_ratio_corotational(m.c, Range{0, n}, lanes.data());
  EXPECT_TRUE(same_bits(scalar, lanes));
  const std::size_t sizes[] = {1, 3, 7, 16, 17, 5, 33, 2, 9, 64, 15};
  std::fill(lanes.begin(), lanes.end(), unset);
  std::size_t t = 0;
  for (std::size_t i = 0; t < n; ++i) {
    const Range r{t, std::min(n, t + sizes[i % std::size(sizes)])};
    element_stiffness_ratio_corotational(m.c, r, lanes.data());
    // The max variant: the same value as the fold over the scalar ratios of the piece (a max:
    // exact, so compared with ==; NaN ratios skipped by both).
    EXPECT_EQ(element_stiffness_ratio_corotational_max(m.c, r), fold_max(scalar, r)) << r.begin << ".." << r.end;
    t = r.end;
  }
  EXPECT_TRUE(same_bits(scalar, lanes));
  EXPECT_EQ(element_stiffness_ratio_corotational_max(m.c, Range{0, n}), fold_max(scalar, Range{0, n}));
  // Over listed tets (a level stepped from a list): every other run of 1-4 tets, shuffled, in
  // pieces of odd sizes: each piece's max is the fold over the scalar ratios of its tets.
  std::vector<std::int32_t> ids;
  for (std::size_t i = 0; i < n; i += 2 + i % 5)
    for (std::size_t j = i; j < std::min(n, i + 1 + i % 4); ++j) ids.push_back(std::int32_t(j));
  std::shuffle(ids.begin(), ids.end(), std::mt19937(seed));
  std::size_t pieces_above = 0;
  for (std::size_t i = 0, p = 0; i < ids.size(); ++p) {
    const Range r{i, std::min(ids.size(), i + sizes[p % std::size(sizes)])};
    double expect = 1;
    for (std::size_t k = r.begin; k < r.end; ++k) expect = std::max(expect, scalar[std::size_t(ids[k])]);
    EXPECT_EQ(element_stiffness_ratio_corotational_max_listed(m.c, ids.data(), r), expect) << r.begin << ".." << r.end;
    // The same with the rest data copied in list order (a listed level's, ElementContext::listed_tet ...).
    m.list_rest(ids);
    EXPECT_EQ(element_stiffness_ratio_corotational_max_listed(m.c, ids.data(), r), expect) << r.begin << ".." << r.end;
    // And the rotations in list order (ElementContext::listed_rotation), the lanes' and the scalar
    // fallback's: the same ratios.
    m.list_rotations(ids);
    EXPECT_EQ(element_stiffness_ratio_corotational_max_listed(m.c, ids.data(), r), expect) << r.begin << ".." << r.end;
    m.list_rotations({});
    m.list_rest({});
    pieces_above += expect > 1;
    i = r.end;
  }
  EXPECT_GT(pieces_above, 10u);
  // Corners from the interleaved copy of x (ElementContext::xp, packed as the step packs it), as
  // the monitor reads them where packed corners pay: the same ratios.
  std::vector<T> xp(4 * 4 * n, T(-7));
  PackContext<T> pc;
  for (int k = 0; k < 3; ++k) pc.x[k] = m.x[k].data();
  pc.xp = xp.data();
  pack_positions(pc, Range{0, 4 * n});
  m.c.xp = xp.data();
  std::fill(lanes.begin(), lanes.end(), unset);
  element_stiffness_ratio_corotational(m.c, Range{0, n}, lanes.data());
  EXPECT_TRUE(same_bits(scalar, lanes));
  EXPECT_EQ(element_stiffness_ratio_corotational_max(m.c, Range{3, n - 5}), fold_max(scalar, Range{3, n - 5}));
  m.c.xp = nullptr;
  // The monitor reads and never writes: stored rotations and corner forces untouched.
  Tets<T> fresh(n, seed);
  for (int k = 0; k < 4; ++k) EXPECT_TRUE(fresh.rot[k] == m.rot[k]);
  for (int q = 0; q < 12; ++q) EXPECT_TRUE(fresh.cf[q] == m.cf[q]);
}

TEST(StiffnessLanes, CorotationalLanesGiveTheScalarRatiosFloat) { check_lanes<float>(1000, 7, false); }
TEST(StiffnessLanes, CorotationalLanesGiveTheScalarRatiosDouble) { check_lanes<double>(1000, 7, false); }
TEST(StiffnessLanes, CorotationalLanesGiveTheScalarRatiosOnNonFiniteTetsFloat) { check_lanes<float>(1000, 11, true); }
TEST(StiffnessLanes, CorotationalLanesGiveTheScalarRatiosOnNonFiniteTetsDouble) { check_lanes<double>(1000, 11, true); }

// A body at rest or rigidly turned: every lane takes the fast path and the max is exactly 1.
TEST(StiffnessLanes, MaxIsExactlyOneNearRest) {
  Tets<float> m(203, 3);
  // Every tet at rest, with the identity stored.
  for (std::size_t t = 0; t < m.nt; ++t)
    for (int c4 = 0; c4 < 4; ++c4)
      for (int k = 0; k < 3; ++k) m.x[k][4 * t + std::size_t(c4)] = m.X[k][4 * t + std::size_t(c4)];
  for (std::size_t t = 0; t < m.nt; ++t) {
    m.rot[0][t] = 1;
    for (int k = 1; k < 4; ++k) m.rot[k][t] = 0;
  }
  EXPECT_EQ(element_stiffness_ratio_corotational_max(m.c, Range{0, m.nt}), 1.0);
  std::vector<double> r(m.nt, -1);
  element_stiffness_ratio_corotational(m.c, Range{0, m.nt}, r.data());
  for (double v : r) EXPECT_EQ(v, 1.0);
}

}  // namespace
}  // namespace pliant
