// The symplectic Euler update runs a vector register of nodes at a time (kernels/src/node_passes.cpp,
// integrate_nodes), in integrate_symplectic_euler and in the fused pass with offset entries. Every
// lane must give the bits of the scalar update, nodes that are not free must keep their bits, and
// a diverged free node must be reported whichever lane holds it.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <random>
#include <vector>

#include "pliant/kernels/node_passes.hpp"

#include "../support/same_bits.hpp"

namespace pliant {
namespace {

using test::same_bits;

template <class T>
struct Nodes {
  std::size_t nn = 203;
  std::vector<T> x[3], v[3], f[3], inv_mass;
  std::vector<std::uint8_t> state;
  T dt = T(1.3e-4), gravity[3] = {T(0.1), T(-0.2), T(-9.81)}, alpha = T(0.7);
  explicit Nodes(unsigned seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u(-1, 1);
    for (int k = 0; k < 3; ++k)
      for (std::size_t n = 0; n < nn; ++n) {
        x[k].push_back(T(u(rng)));
        v[k].push_back(T(u(rng) * std::pow(10.0, 2 * u(rng))));
        f[k].push_back(T(u(rng) * std::pow(10.0, 3 * u(rng))));
      }
    const std::uint8_t states[4] = {kNodeFree, kNodeFixed, kNodeGhost, kNodeInactive};
    for (std::size_t n = 0; n < nn; ++n) {
      inv_mass.push_back(T(0.5 + u(rng) * 0.4));
      state.push_back(n % 5 == 0 ? states[(n / 5) % 4] : std::uint8_t(kNodeFree));  // runs of free nodes, and not
    }
  }
  IntegrateContext<T> context(std::vector<T> xs[3], std::vector<T> vs[3]) {
    IntegrateContext<T> c;
    for (int k = 0; k < 3; ++k) {
      c.x[k] = xs[k].data();
      c.v[k] = vs[k].data();
      c.f[k] = f[k].data();
      c.gravity[k] = gravity[k];
    }
    c.inv_mass = inv_mass.data();
    c.state = state.data();
    c.dt = dt;
    c.mass_damping = alpha;
    return c;
  }
};

// The update as node_passes.hpp defines it, one node and component at a time.
template <class T>
void reference_update(const Nodes<T>& s, std::vector<T> x[3], std::vector<T> v[3]) {
  for (std::size_t n = 0; n < s.nn; ++n) {
    if (s.state[n] != kNodeFree) continue;
    for (int k = 0; k < 3; ++k) {
      const T a = s.f[k][n] * s.inv_mass[n] + s.gravity[k] - s.alpha * v[k][n];
      v[k][n] = v[k][n] + s.dt * a;
      x[k][n] = x[k][n] + s.dt * v[k][n];
    }
  }
}

template <class T>
void check_lanes() {
  Nodes<T> s(11);
  std::vector<T> xr[3], vr[3];
  for (int k = 0; k < 3; ++k) {
    xr[k] = s.x[k];
    vr[k] = s.v[k];
  }
  reference_update(s, xr, vr);
  for (std::size_t cut : {std::size_t(203), std::size_t(64), std::size_t(37), std::size_t(7), std::size_t(1)}) {
    std::vector<T> x[3], v[3];
    for (int k = 0; k < 3; ++k) {
      x[k] = s.x[k];
      v[k] = s.v[k];
    }
    const IntegrateContext<T> c = s.context(x, v);
    bool ok = true;
    for (std::size_t b = 0; b < s.nn; b += cut) ok &= integrate_symplectic_euler(c, Range{b, std::min(s.nn, b + cut)});
    EXPECT_TRUE(ok) << cut;
    for (int k = 0; k < 3; ++k) {
      EXPECT_TRUE(same_bits(x[k], xr[k])) << "cut " << cut << " component " << k;
      EXPECT_TRUE(same_bits(v[k], vr[k])) << "cut " << cut << " component " << k;
    }
  }
  for (std::size_t n = 0; n < s.nn; ++n)  // the nodes that are not free kept their bits
    if (s.state[n] != kNodeFree)
      for (int k = 0; k < 3; ++k) {
        EXPECT_EQ(std::memcmp(&xr[k][n], &s.x[k][n], sizeof(T)), 0);
        EXPECT_EQ(std::memcmp(&vr[k][n], &s.v[k][n], sizeof(T)), 0);
      }
  EXPECT_FALSE(same_bits(xr[0], s.x[0]));  // and the free ones moved
}

TEST(IntegrateLanes, GiveTheBitsOfTheScalarUpdateFloat) { check_lanes<float>(); }
TEST(IntegrateLanes, GiveTheBitsOfTheScalarUpdateDouble) { check_lanes<double>(); }

// A free node with a non-finite or runaway velocity is reported, in every position of a 40-node
// range (every lane of full registers, and the scalar tail); the same on a node that is not free
// is not (it is not integrated), and its bits are kept.
template <class T>
void check_divergence_in_every_lane(T bad) {
  Nodes<T> s(13);
  s.nn = 40;
  for (std::size_t p = 0; p < 40; ++p) {
    for (std::uint8_t st : {std::uint8_t(kNodeFree), std::uint8_t(kNodeFixed)}) {
      std::vector<T> x[3], v[3];
      for (int k = 0; k < 3; ++k) {
        x[k].assign(s.x[k].begin(), s.x[k].begin() + 40);
        v[k].assign(s.v[k].begin(), s.v[k].begin() + 40);
      }
      std::vector<std::uint8_t> state(40, kNodeFree);
      state[p] = st;
      v[int(p % 3)][p] = bad;
      IntegrateContext<T> c = s.context(x, v);
      c.state = state.data();
      const bool ok = integrate_symplectic_euler(c, Range{0, 40});
      EXPECT_EQ(ok, st != kNodeFree) << "node " << p << " state " << int(st) << " value " << double(bad);
      if (st != kNodeFree) {
        EXPECT_EQ(std::memcmp(&v[int(p % 3)][p], &bad, sizeof(T)), 0);
      }
    }
  }
}

TEST(IntegrateLanes, ReportADivergedFreeNodeInAnyLane) {
  check_divergence_in_every_lane<float>(std::numeric_limits<float>::quiet_NaN());
  check_divergence_in_every_lane<float>(3e15f);
  check_divergence_in_every_lane<double>(std::numeric_limits<double>::infinity());
  check_divergence_in_every_lane<double>(-1e160);
}

}  // namespace
}  // namespace pliant
