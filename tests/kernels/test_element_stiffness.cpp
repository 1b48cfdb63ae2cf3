// The deformation monitor of the adaptive step (kernels/element_stiffness.hpp): the closed-form
// eigenvalues, a ratio of exactly 1 at rest and under rigid rotation, and the hand-derived ratios
// of a stretched stvk tet and an inverted corotational tet.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "pliant/kernels/element_stiffness.hpp"

namespace pliant {
namespace {

// One tet with rest corners 0, e1, e2, e3 (Dm = I: the gradients of phi_1..3 are e1..e3), so that
// corner c sits at F e_c and the deformation gradient is F exactly.
struct UnitTet {
  double X[3][4] = {{0, 1, 0, 0}, {0, 0, 1, 0}, {0, 0, 0, 1}};
  double x[3][4] = {};
  double v[3][4] = {};
  std::int32_t idx[4][1] = {{0}, {1}, {2}, {3}};
  double volume[1] = {1.0 / 6};
  double grad[9][1] = {{1}, {0}, {0}, {0}, {1}, {0}, {0}, {0}, {1}};
  double rot[4][1] = {{1}, {0}, {0}, {0}};
  ElementContext<double> c;
  UnitTet(const double F[3][3], double lambda, double mu) {
    for (int k = 0; k < 3; ++k)
      for (int a = 1; a < 4; ++a) x[k][a] = F[k][a - 1];
    for (int k = 0; k < 3; ++k) {
      c.X[k] = X[k];
      c.x[k] = x[k];
      c.v[k] = v[k];
    }
    for (int a = 0; a < 4; ++a) c.tet[a] = idx[a];
    c.volume = volume;
    for (int q = 0; q < 9; ++q) c.grad[q] = grad[q];
    for (int q = 0; q < 4; ++q) c.rotation[q] = rot[q];
    c.lambda = lambda;
    c.mu = mu;
  }
  double stvk() {
    double r = 0;
    element_stiffness_ratio_stvk(c, Range{0, 1}, &r);
    return r;
  }
  double corotational() {
    double r = 0;
    element_stiffness_ratio_corotational(c, Range{0, 1}, &r);
    return r;
  }
};

constexpr double kLambda = 1.7e6, kMu = 0.6e6;  // Pa

TEST(SymmetricEigenvalues, DiagonalRotatedAndRepeated) {
  double e[3];
  const double d[9] = {3, 0, 0, 0, -1, 0, 0, 0, 2};
  symmetric_eigenvalues3(d, e);
  EXPECT_NEAR(e[0], -1, 1e-14);
  EXPECT_NEAR(e[1], 2, 1e-14);
  EXPECT_NEAR(e[2], 3, 1e-14);
  // Q diag(1, 4, 9) Q^T with Q a rotation of 0.7 rad about z.
  const double c = std::cos(0.7), s = std::sin(0.7);
  const double a[9] = {c * c * 1 + s * s * 4, c * s * (1 - 4), 0, c * s * (1 - 4), s * s * 1 + c * c * 4, 0, 0, 0, 9};
  symmetric_eigenvalues3(a, e);
  EXPECT_NEAR(e[0], 1, 1e-13);
  EXPECT_NEAR(e[1], 4, 1e-13);
  EXPECT_NEAR(e[2], 9, 1e-13);
  const double id[9] = {2, 0, 0, 0, 2, 0, 0, 0, 2};
  symmetric_eigenvalues3(id, e);
  for (double x : e) EXPECT_EQ(x, 2.0);
}

TEST(ElementStiffness, RatioIsOneAtRestAndUnderRigidRotation) {
  const double I[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  UnitTet rest(I, kLambda, kMu);
  EXPECT_NEAR(rest.stvk(), 1.0, 1e-14);
  EXPECT_NEAR(rest.corotational(), 1.0, 1e-14);
  const double c = std::cos(0.5), s = std::sin(0.5);  // 0.5 rad about x
  const double R[3][3] = {{1, 0, 0}, {0, c, -s}, {0, s, c}};
  UnitTet turned(R, kLambda, kMu);
  EXPECT_NEAR(turned.stvk(), 1.0, 1e-12);
  EXPECT_NEAR(turned.corotational(), 1.0, 1e-9);
}

TEST(ElementStiffness, StvkUniaxialStretchMatchesTheClosedForm) {
  // F = diag(1, 1, 2): E = diag(0, 0, 3/2), S = (3/2 lambda, 3/2 lambda, 3/2 lambda + 3 mu). The
  // largest Gershgorin row of the scaling block is that of s = 2:
  // S_3 + 4 (lambda + 2 mu) + 2 lambda (1 + 1) = 9.5 lambda + 11 mu.
  const double F[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 2}};
  UnitTet t(F, kLambda, kMu);
  EXPECT_NEAR(t.stvk(), (9.5 * kLambda + 11 * kMu) / (3 * kLambda + 2 * kMu), 1e-12);
  // s = 8 (the collapsing cantilever's largest stretch): E_3 = 31.5, S_3 = 31.5 lambda + 63 mu,
  // row 3: S_3 + 64 (lambda + 2 mu) + 2 x 8 lambda = 111.5 lambda + 191 mu (48x at nu = 0.37).
  const double G[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 8}};
  UnitTet u(G, kLambda, kMu);
  EXPECT_NEAR(u.stvk(), (111.5 * kLambda + 191 * kMu) / (3 * kLambda + 2 * kMu), 1e-12);
  // Compression softens stvk: the ratio stays at most 1.
  const double H[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 0.5}};
  UnitTet w(H, kLambda, kMu);
  EXPECT_LE(w.stvk(), 1.0);
}

TEST(ElementStiffness, CorotationalInvertedTetMatchesTheTwistModes) {
  // F = diag(1, 1, -0.5): R = I (the invertible-FEM rotation), signed stretches (1, 1, -0.5),
  // tr S - 3 = -1.5, principal stresses psi = (-1.5 lambda, -1.5 lambda, -3 mu - 1.5 lambda). The
  // twist modes of pairs (1,3) and (2,3): |psi_i + psi_3| / |1 - 0.5| = 6 lambda + 6 mu, above the
  // scaling mode 3 lambda + 2 mu.
  const double F[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, -0.5}};
  UnitTet t(F, kLambda, kMu);
  EXPECT_NEAR(t.corotational(), (6 * kLambda + 6 * kMu) / (3 * kLambda + 2 * kMu), 1e-9);
  EXPECT_DOUBLE_EQ(t.rot[0][0], 1.0);  // the stored warm start was not touched
  // Two signed stretches cancelling (1, 0.5, -0.5): the twist mode is unbounded, floored at
  // kMinStretchSum: a large, finite ratio.
  const double G[3][3] = {{1, 0, 0}, {0, 0.5, 0}, {0, 0, -0.5}};
  UnitTet u(G, kLambda, kMu);
  const double r = u.corotational();
  EXPECT_TRUE(std::isfinite(r));
  EXPECT_GT(r, 100.0);
}

}  // namespace
}  // namespace pliant
