// Element kernels on a single tetrahedron: rigid motions give no force (rotation only for the
// rotation-invariant models), forces are minus the gradient of the energy, Newton's third law.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "pliant/kernels/element_forces.hpp"

namespace pliant {
namespace {

enum class Model { linear, stvk, corotational, springs };

template <class T>
struct OneTet {
  std::vector<T> X[3], x[3], v[3];
  std::int32_t idx[4][1] = {{0}, {1}, {2}, {3}};
  T volume[1], grad[9][1], rot[4][1] = {{1}, {0}, {0}, {0}}, cf[12][1];
  ElementContext<T> c;
  Model model;

  OneTet(const double rest[4][3], Model m, double young = 1e6, double nu = 0.3) : model(m) {
    double vol, g[9];
    EXPECT_TRUE(tet_rest_geometry(rest[0], rest[1], rest[2], rest[3], &vol, g));
    volume[0] = T(vol);
    for (int q = 0; q < 9; ++q) grad[q][0] = T(g[q]);
    for (int k = 0; k < 3; ++k) {
      X[k].resize(4);
      x[k].resize(4);
      v[k].assign(4, T(0));
      for (int a = 0; a < 4; ++a) X[k][a] = x[k][a] = T(rest[a][k]);
    }
    for (int k = 0; k < 3; ++k) {
      c.X[k] = X[k].data();
      c.x[k] = x[k].data();
      c.v[k] = v[k].data();
    }
    for (int a = 0; a < 4; ++a) c.tet[a] = idx[a];
    c.volume = volume;
    for (int q = 0; q < 9; ++q) c.grad[q] = grad[q];
    for (int k = 0; k < 4; ++k) c.rotation[k] = rot[k];
    for (int q = 0; q < 12; ++q) c.corner_force[q] = cf[q];
    c.lambda = T(young * nu / ((1 + nu) * (1 - 2 * nu)));
    c.mu = T(young / (2 * (1 + nu)));
    c.young = T(young);
  }
  void forces() {
    const Range r{0, 1};
    switch (model) {
      case Model::linear: element_forces_linear(c, r); break;
      case Model::stvk: element_forces_stvk(c, r); break;
      case Model::corotational: element_forces_corotational(c, r); break;
      case Model::springs: element_forces_springs(c, r); break;
    }
  }
  double energy() {
    double e = 0;
    const Range r{0, 1};
    switch (model) {
      case Model::linear: element_energy_linear(c, r, &e); break;
      case Model::stvk: element_energy_stvk(c, r, &e); break;
      case Model::corotational: element_energy_corotational(c, r, &e); break;
      case Model::springs: element_energy_springs(c, r, &e); break;
    }
    return e;
  }
  double force(int corner, int k) const { return double(cf[3 * corner + k][0]); }
  double max_force() const {
    double m = 0;
    for (int q = 0; q < 12; ++q) m = std::max(m, std::fabs(double(cf[q][0])));
    return m;
  }
};

const double kRest[4][3] = {{0.0, 0.0, 0.0}, {0.1, 0.01, 0.0}, {0.02, 0.09, 0.01}, {0.01, 0.015, 0.11}};
const Model kAllModels[] = {Model::linear, Model::stvk, Model::corotational, Model::springs};

// Force scale of a 10% strain, to make "zero" relative.
template <class T>
double reference_force(Model m) {
  OneTet<T> t(kRest, m);
  for (int a = 0; a < 4; ++a) t.x[0][a] = T(1.1 * kRest[a][0]);
  t.forces();
  return t.max_force();
}

void rotate(const double axis_angle[3], const double p[3], double out[3]) {
  const double th = std::sqrt(axis_angle[0] * axis_angle[0] + axis_angle[1] * axis_angle[1] + axis_angle[2] * axis_angle[2]);
  const double k[3] = {axis_angle[0] / th, axis_angle[1] / th, axis_angle[2] / th};
  const double c = std::cos(th), s = std::sin(th);
  const double kp = k[0] * p[0] + k[1] * p[1] + k[2] * p[2];
  const double kxp[3] = {k[1] * p[2] - k[2] * p[1], k[2] * p[0] - k[0] * p[2], k[0] * p[1] - k[1] * p[0]};
  for (int i = 0; i < 3; ++i) out[i] = p[i] * c + kxp[i] * s + k[i] * kp * (1 - c);
}

TEST(ElementForces, RigidTranslationGivesZeroForceForEveryModel) {
  for (Model m : kAllModels) {
    OneTet<double> t(kRest, m);
    for (int a = 0; a < 4; ++a) {
      t.x[0][a] += 0.37;
      t.x[1][a] -= 1.25;
      t.x[2][a] += 3.5;
    }
    t.forces();
    EXPECT_LT(t.max_force(), 1e-9 * reference_force<double>(m)) << "model " << int(m);
  }
}

TEST(ElementForces, RigidRotationGivesZeroForceForStvkCorotationalAndSprings) {
  const double rotations[][3] = {{0, 0, 0.5235987755982988}, {1.0, 0.4, -0.3}, {0, 3.14159, 0}, {2.2, -1.1, 0.7}};
  for (const auto& w : rotations) {
    for (Model m : {Model::stvk, Model::corotational, Model::springs}) {
      OneTet<double> t(kRest, m);
      for (int a = 0; a < 4; ++a) {
        double p[3];
        rotate(w, kRest[a], p);
        for (int k = 0; k < 3; ++k) t.x[k][a] = p[k] + 0.3;
      }
      t.forces();
      EXPECT_LT(t.max_force(), 1e-9 * reference_force<double>(m)) << "model " << int(m) << " rotation " << w[0];
      EXPECT_LT(std::fabs(t.energy()), 1e-12) << "model " << int(m);
    }
  }
}

// A body turned over by 180 deg (issue 3 §3, "rotated_state"): from the identity warm start the
// gradient of tr(R^T F) is zero and Newton's Hessian is indefinite, a saddle a local iteration
// does not leave. The corotational forces must still vanish and the rotation must be found, by
// the force pass (vector lanes) and by the energy and stress reports (scalar code).
template <class T>
void check_half_turns() {
  const double axes[][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1},          {1, 1, 1},
                            {1, 1, 0}, {0.3, -0.8, 0.5}, {-0.2, 0.1, 0.97}, {0.6, 0.01, -0.02}};
  const bool single = sizeof(T) == 4;
  const double ref = reference_force<T>(Model::corotational);
  const double force_tol = single ? 2e-5 : 1e-9, quat_tol = single ? 1e-6 : 1e-12;
  for (const auto& axis : axes) {
    const double n = std::sqrt(axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]);
    const double u[3] = {axis[0] / n, axis[1] / n, axis[2] / n};
    const double w[3] = {3.141592653589793 * u[0], 3.141592653589793 * u[1], 3.141592653589793 * u[2]};
    OneTet<T> t(kRest, Model::corotational);
    for (int a = 0; a < 4; ++a) {
      double p[3];
      rotate(w, kRest[a], p);
      for (int k = 0; k < 3; ++k) t.x[k][a] = T(p[k] + 0.3);
    }
    // Scalar code first (the reports refine a copy of the stored identity).
    const double scale = double(t.c.mu) * double(t.volume[0]);  // energy of a unit strain
    EXPECT_LT(std::fabs(t.energy()), (single ? 1e-10 : 1e-20) * scale) << "axis " << u[0] << " " << u[1] << " " << u[2];
    double sigma[9];
    element_cauchy_stress(t.c, Range{0, 1}, 2, sigma);
    for (double s : sigma) EXPECT_LT(std::fabs(s), (single ? 2e-5 : 1e-9) * double(t.c.mu)) << "axis " << u[0];
    EXPECT_EQ(double(t.rot[0][0]), 1.0);  // the reports did not touch the warm start
    // The force pass (vector lanes): zero force, and the stored rotation is the half turn (0, u).
    t.forces();
    EXPECT_LT(t.max_force(), force_tol * ref) << "axis " << u[0] << " " << u[1] << " " << u[2];
    const double dot = double(t.rot[1][0]) * u[0] + double(t.rot[2][0]) * u[1] + double(t.rot[3][0]) * u[2];
    EXPECT_NEAR(std::fabs(dot), 1.0, quat_tol) << "axis " << u[0] << " " << u[1] << " " << u[2];
    EXPECT_NEAR(double(t.rot[0][0]), 0.0, std::sqrt(quat_tol));
  }
}

TEST(ElementForces, CorotationalFindsAHalfTurnFromTheIdentityWarmStartDouble) { check_half_turns<double>(); }
TEST(ElementForces, CorotationalFindsAHalfTurnFromTheIdentityWarmStartFloat) { check_half_turns<float>(); }

TEST(ElementForces, CorotationalHalfTurnPlusStrainGivesTheStrainForce) {
  // The half turn of a stretched tet: the same forces as the stretched tet, turned.
  const double w[3] = {0, 3.141592653589793, 0};
  OneTet<double> plain(kRest, Model::corotational), turned(kRest, Model::corotational);
  for (int a = 0; a < 4; ++a) {
    const double p[3] = {1.05 * kRest[a][0], 0.98 * kRest[a][1], kRest[a][2] + 0.02 * kRest[a][0]};
    double q[3];
    rotate(w, p, q);
    for (int k = 0; k < 3; ++k) {
      plain.x[k][a] = p[k];
      turned.x[k][a] = q[k];
    }
  }
  plain.forces();
  turned.forces();
  for (int a = 0; a < 4; ++a) {
    const double f[3] = {plain.force(a, 0), plain.force(a, 1), plain.force(a, 2)};
    double g[3];
    rotate(w, f, g);
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(turned.force(a, k), g[k], 1e-9 * plain.max_force());
  }
  EXPECT_NEAR(turned.energy(), plain.energy(), 1e-9 * plain.energy());
}

TEST(ElementForces, CorotationalInvertedTetGetsTheInvertibleRotation) {
  // A tet flattened through itself (corner 3 pushed below the base): det F < 0. From the identity
  // and from a half turn about x (a stationary point of tr(R^T F) with an indefinite Hessian,
  // which the iteration must leave) the rotation is the one of the SVD with the smallest singular
  // value negated, so the force pushes corner 3 back up (+z), and the energy is that of the
  // signed stretches.
  for (int start = 0; start < 2; ++start) {
    const double R[4][3] = {{0, 0, 0}, {0.1, 0, 0}, {0, 0.1, 0}, {0, 0, 0.1}};
    OneTet<double> u(R, Model::corotational);
    for (int a = 0; a < 4; ++a)
      for (int k = 0; k < 3; ++k) u.x[k][a] = R[a][k];
    u.x[2][3] = -0.05;  // F = diag(1, 1, -0.5)
    if (start == 1) {   // warm start: the half turn about x (a worse, saddle-side start)
      u.rot[0][0] = 0;
      u.rot[1][0] = 1;
    }
    u.forces();
    EXPECT_GT(u.force(3, 2), 0.0);
    EXPECT_NEAR(std::fabs(double(u.rot[0][0])), 1.0, 1e-12) << "start " << start;  // identity
    // Energy of S = diag(1, 1, -0.5): mu * 1.5^2 + lambda / 2 * 1.5^2.
    const double e = double(u.volume[0]) * (u.c.mu * 2.25 + 0.5 * u.c.lambda * 2.25);
    EXPECT_NEAR(u.energy(), e, 1e-9 * e) << "start " << start;
  }
}

TEST(ElementForces, RigidRotationGivesSpuriousForceForLinear) {
  const double w[3] = {0, 0, 0.5235987755982988};  // 30 degrees
  OneTet<double> t(kRest, Model::linear);
  for (int a = 0; a < 4; ++a) {
    double p[3];
    rotate(w, kRest[a], p);
    for (int k = 0; k < 3; ++k) t.x[k][a] = p[k];
  }
  t.forces();
  // Cauchy strain of a 30 degree rotation is (cos 30 - 1) ~ -0.134 on the diagonal.
  EXPECT_GT(t.max_force(), 0.1 * reference_force<double>(Model::linear));
}

TEST(ElementForces, ForcesAreMinusEnergyGradient) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-0.015, 0.015);
  for (Model m : kAllModels) {
    OneTet<double> t(kRest, m);
    for (int a = 0; a < 4; ++a)
      for (int k = 0; k < 3; ++k) t.x[k][a] = kRest[a][k] + u(rng);
    t.forces();
    double f[4][3];
    for (int a = 0; a < 4; ++a)
      for (int k = 0; k < 3; ++k) f[a][k] = t.force(a, k);
    const double h = 1e-7;
    for (int a = 0; a < 4; ++a)
      for (int k = 0; k < 3; ++k) {
        const double x0 = t.x[k][a];
        t.x[k][a] = x0 + h;
        const double ep = t.energy();
        t.x[k][a] = x0 - h;
        const double em = t.energy();
        t.x[k][a] = x0;
        const double fd = -(ep - em) / (2 * h);
        EXPECT_NEAR(f[a][k], fd, 1e-5 * t.max_force()) << "model " << int(m) << " corner " << a << " axis " << k;
      }
  }
}

TEST(ElementForces, CornerForcesSumToZero) {
  for (Model m : kAllModels) {
    OneTet<double> t(kRest, m);
    t.x[0][1] += 0.02;
    t.x[2][3] -= 0.01;
    t.forces();
    for (int k = 0; k < 3; ++k) {
      const double s = t.force(0, k) + t.force(1, k) + t.force(2, k) + t.force(3, k);
      EXPECT_LT(std::fabs(s), 1e-9 * t.max_force());
    }
    EXPECT_GT(t.max_force(), 0.0);
  }
}

TEST(ElementForces, FloatAgreesWithDouble) {
  for (Model m : kAllModels) {
    OneTet<double> d(kRest, m);
    OneTet<float> f(kRest, m);
    d.x[0][1] += 0.01;
    f.x[0][1] += 0.01f;
    d.x[1][2] -= 0.005;
    f.x[1][2] -= 0.005f;
    d.forces();
    f.forces();
    for (int a = 0; a < 4; ++a)
      for (int k = 0; k < 3; ++k) EXPECT_NEAR(f.force(a, k), d.force(a, k), 1e-3 * d.max_force());
  }
}

TEST(ElementForces, UniaxialStressOfLinearModelMatchesHooke) {
  // x -> (1 + e) x: sigma_xx = (lambda + 2 mu) e, sigma_yy = lambda e.
  OneTet<double> t(kRest, Model::linear);
  const double e = 1e-3;
  for (int a = 0; a < 4; ++a) t.x[0][a] = (1 + e) * kRest[a][0];
  double sigma[9];
  element_cauchy_stress(t.c, Range{0, 1}, 0, sigma);
  EXPECT_NEAR(sigma[0], (t.c.lambda + 2 * t.c.mu) * e, 1e-9 * t.c.mu);
  EXPECT_NEAR(sigma[4], t.c.lambda * e, 1e-9 * t.c.mu);
  EXPECT_NEAR(sigma[1], 0.0, 1e-9 * t.c.mu);
}

TEST(ElementForces, CorotationalStressIsRotatedWithTheBody) {
  // Stretch by 1e-3 along x, then rotate 90 degrees about z: stress becomes sigma_yy.
  OneTet<double> t(kRest, Model::corotational);
  const double e = 1e-3, w[3] = {0, 0, 1.5707963267948966};
  for (int a = 0; a < 4; ++a) {
    double p[3] = {(1 + e) * kRest[a][0], kRest[a][1], kRest[a][2]}, q[3];
    rotate(w, p, q);
    for (int k = 0; k < 3; ++k) t.x[k][a] = q[k];
  }
  double sigma[9];
  element_cauchy_stress(t.c, Range{0, 1}, 2, sigma);
  EXPECT_NEAR(sigma[4], (t.c.lambda + 2 * t.c.mu) * e, 1e-6 * t.c.mu * e * 1e3);
  EXPECT_NEAR(sigma[0], t.c.lambda * e, 1e-6 * t.c.mu * e * 1e3);
}

TEST(RestGeometry, VolumeGradientsAndAltitude) {
  const double a[3] = {0, 0, 0}, b[3] = {1, 0, 0}, c[3] = {0, 1, 0}, d[3] = {0, 0, 1};
  double vol, g[9];
  ASSERT_TRUE(tet_rest_geometry(a, b, c, d, &vol, g));
  EXPECT_DOUBLE_EQ(vol, 1.0 / 6.0);
  for (int i = 0; i < 3; ++i)
    for (int k = 0; k < 3; ++k) EXPECT_DOUBLE_EQ(g[3 * i + k], i == k ? 1.0 : 0.0);
  EXPECT_NEAR(tet_min_altitude(a, b, c, d), 1.0 / std::sqrt(3.0), 1e-15);  // from a to face bcd
  EXPECT_FALSE(tet_rest_geometry(a, c, b, d, &vol, g));                    // inverted
  const double e[3] = {2, 0, 0};
  EXPECT_FALSE(tet_rest_geometry(a, b, e, d, &vol, g) && vol > 0 && false);
}

}  // namespace
}  // namespace pliant
