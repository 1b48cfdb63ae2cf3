// The half-space obstacle pass (kernels/obstacle_passes.hpp) node by node: a node inside the solid
// goes back onto the plane and loses its velocity into it, with Coulomb friction on its sliding
// velocity; nodes on the free side and non-free nodes are untouched; the impulse record is
// m (v_after - v_before); and splitting the node range differently gives the same bits.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <vector>

#include "pliant/kernels/node_passes.hpp"
#include "pliant/kernels/obstacle_passes.hpp"

namespace pliant {
namespace {

template <class T>
struct Nodes {
  std::vector<T> x[3], v[3], mass;
  std::vector<std::uint8_t> state;
  std::vector<double> J[3];
  explicit Nodes(std::size_t n) {
    for (int k = 0; k < 3; ++k) {
      x[k].assign(n, T(0));
      v[k].assign(n, T(0));
      J[k].assign(n, 0.0);
    }
    mass.assign(n, T(2));
    state.assign(n, kNodeFree);
  }
  HalfSpaceContext<T> context(const double p[3], const double nrm[3], double mu) {
    HalfSpaceContext<T> c;
    for (int k = 0; k < 3; ++k) {
      c.x[k] = x[k].data();
      c.v[k] = v[k].data();
      c.impulse[k] = J[k].data();
      c.point[k] = T(p[k]);
      c.normal[k] = T(nrm[k]);
    }
    c.mass = mass.data();
    c.state = state.data();
    c.friction = T(mu);
    return c;
  }
  void set(std::size_t i, std::array<double, 3> p, std::array<double, 3> vel) {
    for (int k = 0; k < 3; ++k) {
      x[k][i] = T(p[k]);
      v[k][i] = T(vel[k]);
    }
  }
};

constexpr double kFloor[3] = {0, 0, 0.5}, kUp[3] = {0, 0, 1};

TEST(ObstaclePass, ANodeInsideGoesBackOntoThePlaneAndLosesItsInwardVelocity) {
  Nodes<double> n(1);
  n.set(0, {0.3, -0.2, 0.49}, {1.5, -0.5, -2.0});
  resolve_half_space(n.context(kFloor, kUp, 0.0), {0, 1});
  EXPECT_EQ(n.x[0][0], 0.3);
  EXPECT_EQ(n.x[1][0], -0.2);
  EXPECT_DOUBLE_EQ(n.x[2][0], 0.5);
  // Frictionless: the sliding velocity is kept, the normal one removed.
  EXPECT_EQ(n.v[0][0], 1.5);
  EXPECT_EQ(n.v[1][0], -0.5);
  EXPECT_EQ(n.v[2][0], 0.0);
  // Impulse: m * (0 - (-2)) = 4 N s upwards, nothing along the plane.
  EXPECT_EQ(n.J[0][0], 0.0);
  EXPECT_EQ(n.J[1][0], 0.0);
  EXPECT_EQ(n.J[2][0], 4.0);
}

TEST(ObstaclePass, ANodeLeavingTheSolidKeepsItsVelocity) {
  Nodes<double> n(1);
  n.set(0, {0, 0, 0.4}, {1, 0, 3});
  resolve_half_space(n.context(kFloor, kUp, 0.8), {0, 1});
  EXPECT_DOUBLE_EQ(n.x[2][0], 0.5);
  EXPECT_EQ(n.v[0][0], 1.0);  // no friction without a normal impulse
  EXPECT_EQ(n.v[2][0], 3.0);
  EXPECT_EQ(n.J[2][0], 0.0);
}

TEST(ObstaclePass, NodesOnTheFreeSideAndNonFreeNodesAreUntouched) {
  Nodes<double> n(3);
  n.set(0, {0, 0, 0.5}, {1, 0, -3});   // exactly on the plane: free side
  n.set(1, {0, 0, 0.7}, {1, 0, -3});   // above
  n.set(2, {0, 0, 0.1}, {1, 0, -3});   // inside, but fixed
  n.state[2] = kNodeFixed;
  resolve_half_space(n.context(kFloor, kUp, 0.5), {0, 3});
  for (int i = 0; i < 3; ++i) {
    EXPECT_EQ(n.v[2][i], -3.0) << i;
    EXPECT_EQ(n.v[0][i], 1.0) << i;
    EXPECT_EQ(n.J[2][i], 0.0) << i;
  }
  EXPECT_EQ(n.x[2][2], 0.1);
}

TEST(ObstaclePass, CoulombFrictionTakesAtMostMuTimesTheNormalVelocityChange) {
  Nodes<double> n(2);
  n.set(0, {0, 0, 0.45}, {3, 4, -2});    // sliding at 5 m/s, normal change 2 m/s, mu 0.5: loses 1 m/s
  n.set(1, {0, 0, 0.45}, {0.3, 0.4, -2});  // sliding at 0.5 m/s < 1 m/s: stops
  resolve_half_space(n.context(kFloor, kUp, 0.5), {0, 2});
  EXPECT_DOUBLE_EQ(n.v[0][0], 3 * 4.0 / 5);
  EXPECT_DOUBLE_EQ(n.v[1][0], 4 * 4.0 / 5);
  EXPECT_EQ(n.v[2][0], 0.0);
  EXPECT_EQ(n.v[0][1], 0.0);
  EXPECT_EQ(n.v[1][1], 0.0);
  EXPECT_DOUBLE_EQ(n.J[0][0], 2 * (2.4 - 3));
  EXPECT_DOUBLE_EQ(n.J[1][0], 2 * (3.2 - 4));
  EXPECT_DOUBLE_EQ(n.J[0][1], 2 * -0.3);
  EXPECT_DOUBLE_EQ(n.J[2][1], 4.0);
}

TEST(ObstaclePass, ATiltedPlaneProjectsAlongItsNormal) {
  const double s = std::sqrt(0.5);
  const double p[3] = {1, 0, 0}, nrm[3] = {s, 0, s};  // the plane x + z = 1, free side above
  Nodes<double> n(1);
  n.set(0, {0.5, 0.2, 0.3}, {-1, 0, -1});  // d = s (0.5 - 1 + 0.3) = -0.2 s
  resolve_half_space(n.context(p, nrm, 0.0), {0, 1});
  EXPECT_NEAR(n.x[0][0] + n.x[2][0], 1.0, 1e-15);
  EXPECT_NEAR(n.x[0][0], 0.6, 1e-15);
  EXPECT_NEAR(n.x[2][0], 0.4, 1e-15);
  EXPECT_EQ(n.x[1][0], 0.2);
  EXPECT_NEAR(n.v[0][0], 0.0, 1e-15);
  EXPECT_NEAR(n.v[2][0], 0.0, 1e-15);
}

// Random nodes around a tilted plane, resolved in one range and in many uneven ones: the same bits.
template <class T>
void check_split_independence() {
  const std::size_t N = 1001;
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1, 1);
  Nodes<T> a(N);
  for (std::size_t i = 0; i < N; ++i) {
    a.set(i, {u(rng), u(rng), u(rng)}, {u(rng), u(rng), u(rng)});
    a.mass[i] = T(1 + 0.5 * u(rng));
    if (i % 13 == 0) a.state[i] = kNodeFixed;
  }
  Nodes<T> b = a;
  const double p[3] = {0.1, -0.2, 0.05}, nrm[3] = {0.36, 0.48, 0.8};
  resolve_half_space(a.context(p, nrm, 0.4), {0, N});
  const HalfSpaceContext<T> cb = b.context(p, nrm, 0.4);
  for (std::size_t begin = 0, step = 1; begin < N; begin += step, step = step * 3 % 17 + 1)
    resolve_half_space(cb, {begin, std::min(N, begin + step)});
  std::size_t inside_before = 0;
  double min_d = 0;
  for (std::size_t i = 0; i < N; ++i) {
    for (int k = 0; k < 3; ++k) {
      EXPECT_EQ(std::memcmp(&a.x[k][i], &b.x[k][i], sizeof(T)), 0);
      EXPECT_EQ(std::memcmp(&a.v[k][i], &b.v[k][i], sizeof(T)), 0);
      EXPECT_EQ(a.J[k][i], b.J[k][i]);
    }
    inside_before += a.J[0][i] != 0 || a.J[1][i] != 0 || a.J[2][i] != 0;
    if (a.state[i] != kNodeFree) continue;
    const double d = nrm[0] * (double(a.x[0][i]) - p[0]) + nrm[1] * (double(a.x[1][i]) - p[1]) +
                     nrm[2] * (double(a.x[2][i]) - p[2]);
    min_d = std::min(min_d, d);
  }
  EXPECT_GT(inside_before, 100u);  // the data did exercise contacts
  // Every free node ends on the free side, up to rounding of the projection (measured: -0.72 eps
  // in float, -1.0 eps in double, eps of T; the coordinates are below 1 in magnitude).
  EXPECT_GE(min_d, -4 * double(std::numeric_limits<T>::epsilon()));
}

TEST(ObstaclePass, SameBitsForAnyRangeSplitFloat) { check_split_independence<float>(); }
TEST(ObstaclePass, SameBitsForAnyRangeSplitDouble) { check_split_independence<double>(); }

}  // namespace
}  // namespace pliant
