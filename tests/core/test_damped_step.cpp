// The damped stable step (engine/src/core/stable_step.cpp; docs/architecture.md, "Time step"):
// the step is built for the damping ratio of the most damped element mode,
// beta* = max((3 phi + 2 psi) / (3 lambda + 2 mu), psi / mu). Checked against the generalised
// eigenvalues of one element's damping and stiffness matrices (assembled from the force kernels,
// solved densely by Eigen), and by running the non-proportional cases that diverged with the
// former beta = (phi + 2 psi) / (lambda + 2 mu) at Courant number 1.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

#include "pliant/kernels/element_forces.hpp"
#include "pliant/world.hpp"

namespace pliant {
namespace {

struct Viscous {
  double nu, phi, psi;  // Poisson ratio, bulk and shear viscosity (Pa s)
};
constexpr double kYoung = 1e6;  // Pa
const Viscous kCases[] = {{0.0, 1e4, 0},  {0.3, 1e4, 0},    {0.45, 1e4, 0},  {0.0, 0, 1e4},  {0.3, 0, 1e4},
                          {0.45, 0, 1e4}, {0.3, 1e4, 1e3}, {0.3, 1e2, 1e4}, {0.45, 1e3, 30}, {0.3, 300, 500}};

BodyDef box_body(const Viscous& c, int tets_per_cell) {
  BodyDef b;
  b.name = "box";
  b.model = ForceModel::linear;
  b.mesh.kind = MeshSourceDef::Kind::box;
  b.mesh.min = {0, 0, 0};
  b.mesh.max = {0.2, 0.05, 0.05};
  b.mesh.cells = {8, 2, 2};
  b.mesh.tets_per_cell = tets_per_cell;
  b.material.young = kYoung;
  b.material.poisson = c.nu;
  b.material.density = 1000;
  b.material.damping.bulk_viscosity = c.phi;
  b.material.damping.shear_viscosity = c.psi;
  return b;
}

// The largest generalised eigenvalue of (C_e, K_e) over the deformation modes of one tet (the
// 6 rigid modes, the null space of K_e, left out): the highest damping-to-stiffness ratio of an
// element mode, i.e. the Rayleigh factor of the most damped one. K_e and C_e are read column by
// column from the linear force kernel: K e_j = f(X) - f(X + e_j), C e_j = -f(v = e_j) at rest.
double element_damping_ratio(const Viscous& c, const double rest[4][3]) {
  const double lambda = kYoung * c.nu / ((1 + c.nu) * (1 - 2 * c.nu)), mu = kYoung / (2 * (1 + c.nu));
  double volume, g[9];
  EXPECT_TRUE(tet_rest_geometry(rest[0], rest[1], rest[2], rest[3], &volume, g));
  std::vector<double> X[3], x[3], v[3];
  for (int k = 0; k < 3; ++k)
    for (int a = 0; a < 4; ++a) {
      X[k].push_back(rest[a][k]);
      x[k].push_back(rest[a][k]);
      v[k].push_back(0.0);
    }
  std::int32_t idx[4][1] = {{0}, {1}, {2}, {3}};
  double vol[1] = {volume}, grad[9][1], cf[12][1];
  for (int q = 0; q < 9; ++q) grad[q][0] = g[q];
  ElementContext<double> ec;
  for (int k = 0; k < 3; ++k) {
    ec.X[k] = X[k].data();
    ec.x[k] = x[k].data();
    ec.v[k] = v[k].data();
  }
  for (int a = 0; a < 4; ++a) ec.tet[a] = idx[a];
  ec.volume = vol;
  for (int q = 0; q < 9; ++q) ec.grad[q] = grad[q];
  for (int q = 0; q < 12; ++q) ec.corner_force[q] = cf[q];
  ec.lambda = lambda;
  ec.mu = mu;
  auto force = [&](Eigen::Matrix<double, 12, 1>& f) {
    element_forces_linear(ec, Range{0, 1});
    for (int q = 0; q < 12; ++q) f[q] = cf[q][0];
  };
  Eigen::Matrix<double, 12, 12> K, C;
  Eigen::Matrix<double, 12, 1> f0, f;
  force(f0);
  const double h = 1e-3;  // m; the linear kernel is affine in x, so any size gives K to rounding
  for (int j = 0; j < 12; ++j) {  // dof j = 3 * corner + axis
    x[j % 3][std::size_t(j / 3)] += h;
    force(f);
    K.col(j) = (f0 - f) / h;
    x[j % 3][std::size_t(j / 3)] -= h;
  }
  ec.bulk_viscosity = c.phi;
  ec.shear_viscosity = c.psi;
  for (int j = 0; j < 12; ++j) {
    v[j % 3][std::size_t(j / 3)] = 1;
    force(f);
    C.col(j) = -(f - f0);
    v[j % 3][std::size_t(j / 3)] = 0;
  }
  K = 0.5 * (K + K.transpose()).eval();
  C = 0.5 * (C + C.transpose()).eval();
  // Deformation modes: the eigenvectors of K with a non-zero eigenvalue (6 of 12).
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 12, 12>> ks(K);
  Eigen::Matrix<double, 12, 6> Q;
  int m = 0;
  for (int i = 0; i < 12; ++i)
    if (ks.eigenvalues()[i] > 1e-9 * ks.eigenvalues().maxCoeff()) Q.col(m++) = ks.eigenvectors().col(i);
  EXPECT_EQ(m, 6);
  const Eigen::Matrix<double, 6, 6> Kq = Q.transpose() * K * Q, Cq = Q.transpose() * C * Q;
  const Eigen::GeneralizedSelfAdjointEigenSolver<Eigen::Matrix<double, 6, 6>> gs(Cq, Kq);
  return gs.eigenvalues().maxCoeff();
}

// The Rayleigh factor the engine's step is built for, read back from the step itself:
// stable_dt = C (2 / omega) (sqrt(1 + zeta^2) - zeta) with zeta = beta omega / 2 (no mass damping).
double engine_damping_ratio(const Viscous& c) {
  WorldDef wd;
  wd.time_step.courant = 1.0;
  World w(wd);
  const BodyId b = w.add_body(box_body(c, 6));
  const double omega = w.level<double>(b).omega_max;
  const double s = w.stable_dt() * omega / 2;  // sqrt(1 + zeta^2) - zeta
  const double zeta = (1 - s * s) / (2 * s);
  return 2 * zeta / omega;
}

TEST(DampedStableStep, DampingRatioIsTheLargestOverAnElementsModes) {
  const double tets[][4][3] = {
      {{0, 0, 0}, {0.1, 0.01, 0}, {0.02, 0.09, 0.01}, {0.01, 0.015, 0.11}},
      {{0, 0, 0}, {0.025, 0, 0}, {0.025, 0.025, 0}, {0.025, 0.025, 0.025}},  // a Kuhn tet of the box mesh
      {{0, 0, 0}, {0.3, 0, 0}, {0, 0.02, 0}, {0.05, 0.01, 0.01}}};          // a sliver
  // Measured: the engine's ratio is within 7.2e-13 of the largest generalised eigenvalue (the
  // rounding of reading it back through the step); the former formula was off by up to 5.5x.
  double worst = 0;
  for (const Viscous& c : kCases) {
    const double engine = engine_damping_ratio(c);
    for (const auto& t : tets) {
      const double element = element_damping_ratio(c, t);
      const double rel = std::fabs(engine / element - 1);
      worst = std::max(worst, rel);
      EXPECT_LT(rel, 5e-12) << "nu " << c.nu << " phi " << c.phi << " psi " << c.psi << ": engine " << engine
                           << " s, element modes " << element << " s";
    }
  }
  std::printf("largest relative difference, engine against the element's generalised eigenvalues: %.3g\n", worst);
}

// With the former beta these diverged (bulk viscosity 1e4 Pa s, nu = 0: step 552; nu = 0.3: step 798).
TEST(DampedStableStep, NonProportionalViscosityIsStableAtCourantOne) {
  for (const Viscous& c : kCases)
    for (int tets_per_cell : {5, 6}) {
      WorldDef wd;
      wd.time_step.courant = 1.0;
      wd.gravity = {0, 0, 0};  // a free, damped body: its energy can only go down
      World w(wd);
      const BodyId b = w.add_body(box_body(c, tets_per_cell));
      // A kick of every mode: a random velocity field of 1 mm/s.
      Level<double>& L = w.level<double>(b);
      std::uint64_t s = 12345;
      for (std::size_t n = 0; n < L.node_count; ++n)
        for (int k = 0; k < 3; ++k) {
          s = s * 6364136223846793005ull + 1442695040888963407ull;
          L.v[k][n] = 1e-3 * (double(s >> 11) * 0x1.0p-53 * 2 - 1);
        }
      const double e0 = w.energies().total();
      bool diverged = false;
      try {
        for (int i = 0; i < 3000; ++i) w.step();
      } catch (const DivergenceError& e) {
        diverged = true;
        ADD_FAILURE() << "nu " << c.nu << " phi " << c.phi << " psi " << c.psi << ", " << tets_per_cell
                      << " tets per cell: " << e.what();
      }
      if (diverged) continue;
      EXPECT_GT(e0, 0.0);
      EXPECT_LT(w.energies().total(), e0) << "nu " << c.nu << " phi " << c.phi << " psi " << c.psi;
    }
}

}  // namespace
}  // namespace pliant
