// Level::corner_force (pliant/corner_forces.hpp): the 12 corner-force arrays in one block, equally
// spaced whatever the heap's history — the precondition of the gather's fast path (CornerTable in
// kernels/src/node_passes.cpp). With 12 separate vectors a benchmark's 10k-tet body took the
// general path for about half of its float gathers (docs/performance.md), depending on what the
// process had freed before.
#include <gtest/gtest.h>

#include <cstdint>
#include <memory>
#include <utility>
#include <vector>

#include "pliant/corner_forces.hpp"
#include "pliant/world.hpp"

namespace pliant {
namespace {

template <class T>
void expect_equally_spaced(const CornerForceArrays<T>& cf, std::size_t n) {
  ASSERT_EQ(cf.stride() % 16, 0u);
  ASSERT_GE(cf.stride(), n);
  for (std::size_t q = 0; q < 12; ++q) {
    EXPECT_EQ(cf[q].size(), n);
    EXPECT_EQ(cf[q].data() - cf[0].data(), std::ptrdiff_t(q * cf.stride())) << "array " << q;
    EXPECT_EQ(reinterpret_cast<std::uintptr_t>(cf[q].data()) % 64, 0u) << "array " << q;
  }
}

TEST(CornerForces, OneBlockOfTwelveEquallySpacedArrays) {
  CornerForceArrays<float> cf;
  cf.assign(1001, 0.5f);
  expect_equally_spaced(cf, 1001);
  EXPECT_EQ(cf.stride(), 1008u);
  int arrays = 0;
  for (const auto& a : cf) {
    for (float v : a) EXPECT_EQ(v, 0.5f);
    a[1000] = float(arrays++);  // a span writes into the block
  }
  EXPECT_EQ(arrays, 12);
  EXPECT_EQ(cf[11][1000], 11.0f);
}

TEST(CornerForces, CopiesAndMovesPointIntoTheirOwnBlock) {
  CornerForceArrays<double> a;
  a.assign(40, 1.0);
  a[7][3] = 7.0;
  const CornerForceArrays<double> b = a;  // copy: its spans point into b's block, not a's
  expect_equally_spaced(b, 40);
  EXPECT_NE(b[0].data(), a[0].data());
  EXPECT_EQ(b[7][3], 7.0);
  a[7][3] = 8.0;
  EXPECT_EQ(b[7][3], 7.0);
  const double* block = a[0].data();
  CornerForceArrays<double> c = std::move(a);  // move: the block moves, the spans follow it
  EXPECT_EQ(c[0].data(), block);
  EXPECT_EQ(c[7][3], 8.0);
  EXPECT_TRUE(a[0].empty());
  std::vector<CornerForceArrays<double>> grown(1, c);  // a vector that reallocates moves them
  for (int i = 0; i < 20; ++i) grown.push_back(c);
  for (const auto& g : grown) expect_equally_spaced(g, 40);
}

TEST(CornerForces, EveryLevelOfEveryWorldIsEquallySpacedWhateverWasFreedBefore) {
  // Worlds of several sizes built and dropped in turn leave holes of every array size in the heap.
  BodyDef b;
  b.name = "box";
  b.mesh.min = {0, 0, 0};
  b.mesh.max = {0.1, 0.05, 0.05};
  b.mesh.tets_per_cell = 6;
  for (int round = 0; round < 3; ++round)
    for (int cells : {2, 5, 9, 5, 3}) {
      b.mesh.cells = {2 * cells, cells, cells};
      WorldDef wd;
      wd.precision = round == 1 ? Precision::float64 : Precision::float32;
      auto w = std::make_unique<World>(wd);
      w->add_body(b);
      if (wd.precision == Precision::float32) {
        const Level<float>& L = w->level<float>(0);
        expect_equally_spaced(L.corner_force, L.tet_count);
      } else {
        const Level<double>& L = w->level<double>(0);
        expect_equally_spaced(L.corner_force, L.tet_count);
      }
    }
}

}  // namespace
}  // namespace pliant
