// The deformation monitor of the adaptive step (kernels/element_stiffness.hpp): the closed-form
// eigenvalues, a ratio of exactly 1 at rest and under rigid rotation, the hand-derived ratio of an
// inverted corotational tet, and the ratio against the Hessian's eigenvalues computed by finite
// differences of the force kernels and a dense solver.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <vector>

#include <Eigen/Dense>

#include "pliant/kernels/element_forces.hpp"
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
  double cf[12][1] = {};
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
    for (int q = 0; q < 12; ++q) c.corner_force[q] = cf[q];
    c.lambda = lambda;
    c.mu = mu;
  }
  void set_F(const double F[3][3]) {
    for (int k = 0; k < 3; ++k)
      for (int a = 1; a < 4; ++a) x[k][a] = F[k][a - 1];
  }
  // The first Piola stress P (Pa) from the kernel's corner forces: with Dm = I and V = 1/6,
  // corner c = 1..3 gets f_c = -V P e_c, so column c - 1 of P is -f_c / V.
  void piola(bool corotational, double P[3][3]) {
    corotational ? element_forces_corotational(c, Range{0, 1}) : element_forces_stvk(c, Range{0, 1});
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) P[i][j] = -cf[3 * (j + 1) + i][0] / volume[0];
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

// The largest |eigenvalue| of the Hessian d2 psi / dF2 (9 x 9, Pa) at F, computed without the
// closed form: dP/dF by central differences of the force kernel's stress (P from its corner
// forces), symmetrised, and Eigen's dense symmetric eigensolver. Step 1e-5 in F: the truncation
// error is O(h^2) ~ 1e-10 of the stiffness, the round-off ~ 1e-16 |P| / h.
double hessian_largest_eigenvalue(const double F[3][3], bool corotational) {
  const double h = 1e-5;
  Eigen::Matrix<double, 9, 9> H;
  for (int k = 0; k < 3; ++k)
    for (int l = 0; l < 3; ++l) {
      double Fp[3][3], Fm[3][3], Pp[3][3], Pm[3][3];
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) Fp[i][j] = Fm[i][j] = F[i][j];
      Fp[k][l] += h;
      Fm[k][l] -= h;
      UnitTet tp(Fp, kLambda, kMu), tm(Fm, kLambda, kMu);
      if (corotational) {  // warm start from the rotation of F itself, as the step would have it
        UnitTet t0(F, kLambda, kMu);
        double P0[3][3];
        t0.piola(true, P0);
        for (int q = 0; q < 4; ++q) tp.rot[q][0] = tm.rot[q][0] = t0.rot[q][0];
      }
      tp.piola(corotational, Pp);
      tm.piola(corotational, Pm);
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) H(3 * i + j, 3 * k + l) = (Pp[i][j] - Pm[i][j]) / (2 * h);
    }
  const Eigen::Matrix<double, 9, 9> S = 0.5 * (H + H.transpose());
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 9, 9>> eig(S, Eigen::EigenvaluesOnly);
  return eig.eigenvalues().cwiseAbs().maxCoeff();
}

TEST(SymmetricEigenvalues, DiagonalRotatedAndRepeated) {
  double e[3];
  const double d[9] = {3, 0, 0, 0, -1, 0, 0, 0, 2};
  symmetric_eigenvalues3(d, e);
  // Rounding: measured 2.2e-16 (1 ulp) for e[0], exact for the others.
  EXPECT_NEAR(e[0], -1, 1e-15);
  EXPECT_NEAR(e[1], 2, 1e-15);
  EXPECT_NEAR(e[2], 3, 1e-15);
  // Q diag(1, 4, 9) Q^T with Q a rotation of 0.7 rad about z.
  const double c = std::cos(0.7), s = std::sin(0.7);
  const double a[9] = {c * c * 1 + s * s * 4, c * s * (1 - 4), 0, c * s * (1 - 4), s * s * 1 + c * c * 4, 0, 0, 0, 9};
  symmetric_eigenvalues3(a, e);
  // Rounding: measured 8.9e-16 for e[0] and e[1], exact for e[2].
  EXPECT_NEAR(e[0], 1, 4e-15);
  EXPECT_NEAR(e[1], 4, 4e-15);
  EXPECT_NEAR(e[2], 9, 4e-15);
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

// The monitor's ratio against the Hessian's eigenvalues computed independently (above). It must
// be at least the true ratio everywhere (the adaptive step relies on it being a bound), equal to
// it where the closed form is exact (rest, rotation, and every corotational case: its scaling
// block is 2 mu I + lambda 1 1^T, whose largest eigenvalue is 3 lambda + 2 mu, and its twist and
// flip modes are exact), and not far above it for stvk, whose scaling block is bounded by its
// largest Gershgorin row. Measured ratio / truth - 1 (lambda = 1.7e6, mu = 0.6e6 Pa): exact cases
// within 2.4e-10 (the finite differences); stvk stretched 2x +0.259, 8x +0.092, compressed to
// 0.5 +0.126, generic F +0.211.
struct HessianCase {
  const char* what;
  double F[3][3];
  bool corotational;
  double max_over;  // ratio / truth - 1 allowed above (0: exact)
};

TEST(ElementStiffness, RatioBoundsTheLargestHessianEigenvalueFromFiniteDifferences) {
  const double c = std::cos(0.5), s = std::sin(0.5);
  const HessianCase cases[] = {
      {"stvk rest", {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}, false, 0},
      {"stvk rotated", {{1, 0, 0}, {0, c, -s}, {0, s, c}}, false, 0},
      {"stvk stretch 2", {{1, 0, 0}, {0, 1, 0}, {0, 0, 2}}, false, 0.3},
      {"stvk stretch 8", {{1, 0, 0}, {0, 1, 0}, {0, 0, 8}}, false, 0.3},  // the collapsing cantilever's
      {"stvk compressed 0.5", {{1, 0, 0}, {0, 1, 0}, {0, 0, 0.5}}, false, 0.3},
      {"stvk generic", {{1.3, 0.2, -0.1}, {0.05, 0.8, 0.3}, {-0.2, 0.1, 1.6}}, false, 0.3},
      {"corotational rest", {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}, true, 0},
      {"corotational rotated", {{1, 0, 0}, {0, c, -s}, {0, s, c}}, true, 0},
      {"corotational inverted", {{1, 0, 0}, {0, 1, 0}, {0, 0, -0.5}}, true, 0},
      {"corotational generic", {{1.3, 0.2, -0.1}, {0.05, 0.8, 0.3}, {-0.2, 0.1, 1.6}}, true, 0},
      {"corotational squashed", {{1, 0, 0}, {0, 0.3, 0}, {0, 0, 0.1}}, true, 0},
  };
  const double fd = 2e-9;  // finite-difference error allowed (10x the largest measured)
  for (const HessianCase& k : cases) {
    const double truth = hessian_largest_eigenvalue(k.F, k.corotational) / (3 * kLambda + 2 * kMu);
    UnitTet t(k.F, kLambda, kMu);
    if (k.corotational) {
      double P[3][3];
      t.piola(true, P);  // the monitor reads the rotation the force pass stored
    }
    const double ratio = k.corotational ? t.corotational() : t.stvk();
    std::printf("%-24s monitor %.9g, finite-difference Hessian %.9g (ratio / truth - 1 = %.2e)\n", k.what, ratio, truth,
                ratio / truth - 1);
    EXPECT_GE(ratio / truth - 1, -fd) << k.what;
    EXPECT_LE(ratio / truth - 1, k.max_over + fd) << k.what;
  }
}

// Springs: the largest |eigenvalue| of the element's 12 x 12 Hessian (N/m, by central differences
// of element_forces_springs over the corner positions, Eigen's dense solver) now over at rest. The
// monitor's per-spring ratio must be at least that.
double springs_hessian_ratio(const double F[3][3]) {
  auto largest = [](const double G[3][3]) {
    const double h = 1e-7;  // m, on a tet of unit edges
    Eigen::Matrix<double, 12, 12> H;
    for (int b = 0; b < 4; ++b)
      for (int l = 0; l < 3; ++l) {
        UnitTet tp(G, kLambda, kMu), tm(G, kLambda, kMu);
        tp.c.young = tm.c.young = 1e6;
        tp.x[l][b] += h;
        tm.x[l][b] -= h;
        element_forces_springs(tp.c, Range{0, 1});
        element_forces_springs(tm.c, Range{0, 1});
        for (int q = 0; q < 12; ++q) H(q, 3 * b + l) = -(tp.cf[q][0] - tm.cf[q][0]) / (2 * h);
      }
    const Eigen::Matrix<double, 12, 12> S = 0.5 * (H + H.transpose());
    return Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 12, 12>>(S, Eigen::EigenvaluesOnly)
        .eigenvalues()
        .cwiseAbs()
        .maxCoeff();
  };
  const double I[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  return largest(F) / largest(I);
}

TEST(ElementStiffness, SpringsRatioBoundsTheHessianGrowthOfSquashedSprings) {
  // The monitor is an estimate, 1 + |1 - L / l| per spring; measured monitor / truth: rest 1,
  // stretched 2x 1.48, squashed to 0.3 2.26, to 0.1 1.60, flattened 1.34, generic 2.04. It must not
  // be below the truth (a spring squashed to L / 9 is 6x stiffer across than along at rest).
  const struct { const char* what; double F[3][3]; } cases[] = {
      {"rest", {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}},
      {"stretched 2", {{2, 0, 0}, {0, 1, 0}, {0, 0, 1}}},
      {"squashed 0.3", {{1, 0, 0}, {0, 1, 0}, {0, 0, 0.3}}},
      {"squashed 0.1", {{1, 0, 0}, {0, 1, 0}, {0, 0, 0.1}}},
      {"flattened 0.1 x 0.2", {{1, 0, 0}, {0, 0.2, 0}, {0, 0, 0.1}}},
      {"generic", {{1.3, 0.2, -0.1}, {0.05, 0.8, 0.3}, {-0.2, 0.1, 0.4}}},
  };
  for (const auto& k : cases) {
    const double truth = springs_hessian_ratio(k.F);
    UnitTet t(k.F, kLambda, kMu);
    double ratio = 0;
    element_stiffness_ratio_springs(t.c, Range{0, 1}, &ratio);
    std::printf("springs %-20s monitor %.6g, finite-difference Hessian %.6g (%.3g x)\n", k.what, ratio, truth,
                ratio / truth);
    EXPECT_GE(ratio, truth * (1 - 1e-6)) << k.what;
  }
}

}  // namespace
}  // namespace pliant
