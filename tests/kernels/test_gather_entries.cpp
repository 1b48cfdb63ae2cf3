// The gather's three ways of finding an incidence entry's corner forces (kernels/src/node_passes.cpp:
// offsets into one block, a base pointer per corner, a pointer per component) sum the same values in
// the same order: the node forces, and the fused pass's positions and velocities, are the same bits
// whichever is taken and however the node range is cut (odd and even starts: the offset path sums
// two nodes side by side and the last one of an odd range alone).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <random>
#include <vector>

#include "pliant/kernels/node_passes.hpp"

#include "../support/same_bits.hpp"

namespace pliant {
namespace {

using test::same_bits;

// A random "mesh": tets over nodes, so that nodes have from 0 to about 20 entries (uneven
// neighbours are what the pairs' tails are for), corner forces of mixed signs and magnitudes
// (so that the sum order shows in the bits), in a 12-array block with padding between arrays.
template <class T>
struct Gather {
  std::size_t nn = 301, nt = 1000, stride = 1008;
  std::vector<std::int32_t> offsets, incidence, corner_offset;
  std::vector<T> block;             // 12 arrays of stride elements
  std::vector<std::vector<T>> own;  // the same values in 12 separate vectors
  std::vector<T> ext[3], inv_mass;
  std::vector<std::uint8_t> state;
  explicit Gather(unsigned seed) {
    std::mt19937 rng(seed);
    std::uniform_int_distribution<std::size_t> node(0, nn - 1);
    std::uniform_real_distribution<double> u(-1, 1);
    std::vector<std::vector<std::int32_t>> around(nn);
    for (std::size_t t = 0; t < nt; ++t) {
      // nodes 0..49 crowded (many entries), the rest sparse, some with none
      for (int a = 0; a < 4; ++a) {
        std::size_t n = node(rng);
        if (a < 2 && t % 3 == 0) n %= 50;
        around[n].push_back(std::int32_t(4 * t + std::size_t(a)));
      }
    }
    offsets.assign(nn + 1, 0);
    for (std::size_t n = 0; n < nn; ++n) {
      incidence.insert(incidence.end(), around[n].begin(), around[n].end());
      offsets[n + 1] = std::int32_t(incidence.size());
    }
    block.assign(12 * stride, T(0));
    own.assign(12, std::vector<T>(nt));
    for (int q = 0; q < 12; ++q)
      for (std::size_t t = 0; t < nt; ++t) {
        const T value = T(u(rng) * std::pow(10.0, 3 * u(rng)));
        block[std::size_t(q) * stride + t] = value;
        own[std::size_t(q)][t] = value;
      }
    corner_offset.resize(incidence.size());
    EXPECT_TRUE(encode_corner_offsets(incidence.data(), incidence.size(), stride, corner_offset.data()));
    for (auto& e : ext) e.resize(nn);
    inv_mass.resize(nn);
    state.assign(nn, kNodeFree);
    for (std::size_t n = 0; n < nn; ++n) {
      for (auto& e : ext) e[n] = T(u(rng));
      inv_mass[n] = T(1.5 + u(rng));
      if (n % 7 == 0) state[n] = kNodeFixed;
    }
  }
  enum class Layout { kOwn, kBlock, kBlockOffsets };
  GatherContext<T> context(Layout layout, bool external, std::vector<T> f[3]) const {
    GatherContext<T> g;
    g.offsets = offsets.data();
    g.incidence = incidence.data();
    for (int q = 0; q < 12; ++q)
      g.corner_force[q] = layout == Layout::kOwn ? own[std::size_t(q)].data() : block.data() + std::size_t(q) * stride;
    if (layout == Layout::kBlockOffsets) {
      g.corner_offset = corner_offset.data();
      g.corner_stride = stride;
    }
    for (int k = 0; k < 3; ++k) {
      f[k].assign(nn, T(-7));
      g.f[k] = f[k].data();
      g.external[k] = external ? ext[k].data() : nullptr;
    }
    return g;
  }
};

// Each node's force by its definition: its entries' forces in incidence order, then its load.
template <class T>
std::vector<T> reference_forces(const Gather<T>& s, bool external, int k) {
  std::vector<T> f(s.nn);
  for (std::size_t n = 0; n < s.nn; ++n) {
    T sum = 0;
    for (auto e = s.offsets[n]; e < s.offsets[n + 1]; ++e) {
      const std::int32_t code = s.incidence[std::size_t(e)];
      sum += s.own[std::size_t(3 * (code & 3) + k)][std::size_t(code >> 2)];
    }
    if (external) sum += s.ext[k][n];
    f[n] = sum;
  }
  return f;
}

template <class T>
void check_gather_layouts() {
  const Gather<T> s(3);
  using Layout = typename Gather<T>::Layout;
  for (bool external : {false, true})
    for (Layout layout : {Layout::kOwn, Layout::kBlock, Layout::kBlockOffsets})
      for (std::size_t cut : {std::size_t(301), std::size_t(37), std::size_t(2), std::size_t(1)}) {
        std::vector<T> f[3];
        const GatherContext<T> g = s.context(layout, external, f);
        for (std::size_t b = 0; b < s.nn; b += cut) gather_forces(g, Range{b, std::min(s.nn, b + cut)});
        for (int k = 0; k < 3; ++k)
          EXPECT_TRUE(same_bits(f[k], reference_forces(s, external, k)))
              << "layout " << int(layout) << " external " << external << " cut " << cut << " component " << k;
      }
}

TEST(GatherEntries, EveryLayoutSumsTheEntriesInIncidenceOrderFloat) { check_gather_layouts<float>(); }
TEST(GatherEntries, EveryLayoutSumsTheEntriesInIncidenceOrderDouble) { check_gather_layouts<double>(); }

// The fused pass with offsets gives the bits of the gather and the integrator apart (without them).
template <class T>
void check_fused_with_offsets(bool external) {
  const Gather<T> s(5);
  using Layout = typename Gather<T>::Layout;
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<T> x0[3], v0[3];
  for (int k = 0; k < 3; ++k)
    for (std::size_t n = 0; n < s.nn; ++n) {
      x0[k].push_back(T(u(rng)));
      v0[k].push_back(T(u(rng)));
    }
  auto run = [&](bool fused, std::vector<T> x[3], std::vector<T> v[3], std::vector<T> f[3]) {
    const GatherContext<T> g = s.context(fused ? Layout::kBlockOffsets : Layout::kOwn, external, f);
    IntegrateContext<T> ic;
    for (int k = 0; k < 3; ++k) {
      x[k] = x0[k];
      v[k] = v0[k];
      ic.x[k] = x[k].data();
      ic.v[k] = v[k].data();
      ic.f[k] = f[k].data();
    }
    ic.inv_mass = s.inv_mass.data();
    ic.state = s.state.data();
    ic.dt = T(1e-3);
    ic.gravity[2] = T(-9.81);
    ic.mass_damping = T(0.3);
    bool ok = true;
    for (std::size_t b = 0; b < s.nn; b += 37) {
      const Range r{b, std::min(s.nn, b + 37)};
      if (fused) {
        ok &= gather_integrate_symplectic_euler(g, ic, r);
      } else {
        gather_forces(g, r);
        ok &= integrate_symplectic_euler(ic, r);
      }
    }
    return ok;
  };
  std::vector<T> x1[3], v1[3], f1[3], x2[3], v2[3], f2[3];
  EXPECT_TRUE(run(false, x1, v1, f1));
  EXPECT_TRUE(run(true, x2, v2, f2));
  for (int k = 0; k < 3; ++k) {
    EXPECT_TRUE(same_bits(x1[k], x2[k])) << k;
    EXPECT_TRUE(same_bits(v1[k], v2[k])) << k;
    EXPECT_TRUE(same_bits(f1[k], f2[k])) << k;
  }
  EXPECT_NE(x1[0], x0[0]);
}

TEST(GatherEntries, FusedPassWithOffsetsGivesTheBitsOfTheTwoPasses) {
  for (bool external : {false, true}) {
    check_fused_with_offsets<float>(external);
    check_fused_with_offsets<double>(external);
  }
}

// The offsets are read when the block is the one they were made for, and only then: offsets that
// point one tet further give other forces; the same offsets with a stride that does not match the
// pointers (arrays moved since) are ignored, and the entries are read from `incidence`.
TEST(GatherEntries, OffsetsAreUsedOnlyForTheirBlock) {
  Gather<double> s(7);
  std::vector<std::int32_t> shifted = s.corner_offset;
  for (auto& o : shifted) o += 1;
  using Layout = Gather<double>::Layout;
  std::vector<double> f[3];
  GatherContext<double> g = s.context(Layout::kBlockOffsets, false, f);
  g.corner_offset = shifted.data();
  gather_forces(g, Range{0, s.nn});
  EXPECT_FALSE(same_bits(f[0], reference_forces(s, false, 0)));  // the (shifted) offsets were read
  g.corner_stride = s.stride + 16;                                  // not this block's stride
  gather_forces(g, Range{0, s.nn});
  for (int k = 0; k < 3; ++k) EXPECT_TRUE(same_bits(f[k], reference_forces(s, false, k))) << k;
}

TEST(GatherEntries, OffsetsThatWouldNotFitAreRefused) {
  const std::int32_t incidence[2] = {4 * 5 + 3, 4 * 9 + 0};
  std::int32_t out[2] = {-1, -1};
  EXPECT_TRUE(encode_corner_offsets(incidence, 2, 16, out));
  EXPECT_EQ(out[0], 3 * 16 * 3 + 5);
  EXPECT_EQ(out[1], 9);
  out[0] = out[1] = -1;
  const std::size_t huge = std::size_t(INT32_MAX) / 9 + 1;  // 9 x stride past 2^31
  EXPECT_FALSE(encode_corner_offsets(incidence, 2, huge, out));
  EXPECT_EQ(out[0], -1);  // untouched
}

}  // namespace
}  // namespace pliant
