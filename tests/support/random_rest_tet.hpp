// A random, well-shaped rest tet for the kernel tests: a right-angled corner of 2 cm edges at a
// random place within 0.1 m of the origin, each corner moved by up to 8 mm, turned positive if it
// came out inverted; with its rest volume (m^3) and corner gradients (1/m) from tet_rest_geometry.
// Draws 12 numbers from rng (uniform in [-1, 1]) in a fixed order, so that a fixture's sequence
// of tets stays the same.
#pragma once
#include <gtest/gtest.h>

#include <random>
#include <utility>

#include "pliant/kernels/element_forces.hpp"

namespace pliant::test {

inline void random_rest_tet(std::mt19937& rng, double p[4][3], double& volume, double g[9]) {
  std::uniform_real_distribution<double> u(-1, 1);
  for (int k = 0; k < 3; ++k) p[0][k] = 0.1 * u(rng);
  for (int a = 1; a < 4; ++a)
    for (int k = 0; k < 3; ++k) p[a][k] = p[0][k] + 0.02 * (a - 1 == k ? 1.0 : 0.0) + 0.008 * u(rng);
  if (!tet_rest_geometry(p[0], p[1], p[2], p[3], &volume, g)) {
    for (int k = 0; k < 3; ++k) std::swap(p[2][k], p[3][k]);
    EXPECT_TRUE(tet_rest_geometry(p[0], p[1], p[2], p[3], &volume, g));
  }
}

}  // namespace pliant::test
