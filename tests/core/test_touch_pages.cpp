// World::touch_pages: the real-time runner's reads of the bodies' arrays between frames. Each call
// reads up to the pages asked, from where the last one stopped, once round at most; every page of
// every array is read over a cycle; the state does not change.
#include <gtest/gtest.h>

#include <cstdint>

#include "../../engine/src/core/level_arrays.hpp"
#include "pliant/world.hpp"

namespace pliant {
namespace {

// Pages a cycle reads: each array from its first byte, one per started 4 KiB.
std::size_t pages_of(const World& w) {
  std::size_t pages = 0;
  for (std::size_t b = 0; b < w.body_count(); ++b)
    for (int l = 0; l < w.level_count(BodyId(b)); ++l)
      detail::for_each_level_array(w.level<double>(BodyId(b), l),
                                   [&](const void*, std::size_t bytes) { pages += (bytes + 4095) / 4096; });
  return pages;
}

// A two-level box, all fine (the default `active`) or adaptive.
World two_level_box(bool adaptive = false) {
  WorldDef wd;
  World w(wd);
  BodyDef b;
  b.mesh.min = {0, 0, 0};
  b.mesh.max = {0.2, 0.05, 0.05};
  b.mesh.cells = {24, 6, 6};
  b.multiresolution.levels = 2;
  if (adaptive) b.multiresolution.active.kind = ActiveDef::Kind::adaptive;
  w.add_body(b);
  return w;
}

TEST(TouchPages, EveryPageOnceARoundFromWhereTheLastCallStopped) {
  World w = two_level_box();
  ASSERT_EQ(w.level_count(0), 2);
  const std::size_t cycle = pages_of(w);
  ASSERT_GT(cycle, 50u);  // arrays of several pages: the cursor crosses arrays and pages
  const std::uint64_t hash = w.state_hash();
  // A call asking for more than a cycle reads each page once.
  EXPECT_EQ(w.touch_pages(10 * cycle), cycle);
  // Calls of 7 pages go round: the cycle's pages in calls of 7, the last one short only if the
  // cursor wraps inside it (then it goes on from the start, never past where it began).
  std::size_t read = 0;
  for (std::size_t i = 0; i < cycle; ++i) {
    const std::size_t n = w.touch_pages(7);
    EXPECT_EQ(n, 7u);
    read += n;
  }
  EXPECT_EQ(read, 7 * cycle);
  EXPECT_EQ(w.touch_pages(0), 0u);
  EXPECT_EQ(w.state_hash(), hash);  // reads only
  w.step();
  EXPECT_EQ(w.touch_pages(10 * cycle), cycle);
}

TEST(TouchPages, AnAdaptiveBodysCycleReadsItsHierarchyAndActivationToo) {
  // An adaptive body's first change after seconds at its coarsest level read its activation state,
  // locators and hierarchy cold (update() of the 50k-tet organ 1.1-1.8 ms against 0.5 warm): a
  // cycle reads those arrays too, after its levels' (at least the hierarchy's meshes: each level's
  // points and tets), each page once, in calls that go round as above.
  World w = two_level_box(true);
  std::size_t meshes = 0;
  for (int l = 0; l < w.level_count(0); ++l) {
    const LevelInfo i = w.level_info(0, l);
    meshes += (i.tets * sizeof(Tet) + 4095) / 4096 + (i.nodes * 3 * sizeof(double) + 4095) / 4096;
  }
  const std::size_t levels = pages_of(w);
  const std::size_t cycle = w.touch_pages(std::size_t(1) << 30);
  EXPECT_GE(cycle, levels + meshes) << "levels' pages " << levels << ", the meshes' " << meshes;
  for (std::size_t i = 0; i < cycle; ++i) ASSERT_EQ(w.touch_pages(7), 7u);
  EXPECT_EQ(w.touch_pages(std::size_t(1) << 30), cycle);
}

TEST(TouchPages, AWorldWithoutBodiesReadsNothing) {
  WorldDef wd;
  World w(wd);
  EXPECT_EQ(w.touch_pages(100), 0u);
}

}  // namespace
}  // namespace pliant
