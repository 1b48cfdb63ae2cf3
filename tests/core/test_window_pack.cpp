// The packed copy of a level's positions and velocities (Level::x_packed, v_packed), which a level
// stepped every p ticks packs once, at the first slice of its window, for every slice of the window
// (Simulation::step, LevelJobState::window_pack): while the window is open, every corner of the
// level's stepped tets must read what the level holds (the element passes load the copy instead of
// gathering x and v, and must compute the same bits); a host that takes a level between steps
// (World::level) and writes it is read at the next tick; taking it without writing changes nothing.
// And the rotations a listed level keeps in list order (LevelJobState::listed_rotation): the
// reports that read rotations by tet (the snapshot's stresses) start from the current ones.
#include <gtest/gtest.h>

#include <array>
#include <cstdint>

#include "pliant/world.hpp"

namespace pliant {
namespace {

// A float bar 0.4 x 0.1 x 0.1 m of `cells`, clamped at x = 0, with three levels, under gravity.
BodyDef clamped_bar(std::array<int, 3> cells, double young) {
  BodyDef b;
  b.mesh.min = {0, 0, 0};
  b.mesh.max = {0.4, 0.1, 0.1};
  b.mesh.cells = cells;
  b.material.young = young;
  RegionDef clamp;
  clamp.min = {-1, -1, -1};
  clamp.max = {1e-6, 1, 1};
  b.fixed.push_back(clamp);
  b.multiresolution.levels = 3;
  return b;
}
// The windows are packed whatever the kernels would choose on this machine (packed_corners "on"),
// so that these tests check the packing on every ISA.
World float_world_with(const BodyDef& b, PackedCorners packed = PackedCorners::on, Precision precision = Precision::float32) {
  WorldDef wd;
  wd.precision = precision;
  wd.packed_corners = packed;
  World w(wd);
  w.add_body(b);
  return w;
}

// A damped bar whose finest level steps its last fifth, the coarser ones the rest (their periods 2
// and 4 fine ticks), bending under gravity, so that positions and velocities change from one
// window to the next.
World three_level_bar(PackedCorners packed = PackedCorners::on, Precision precision = Precision::float32) {
  BodyDef b = clamped_bar({48, 12, 12}, 2e5);
  b.material.damping.stiffness = 0.002;  // Rayleigh: the damped passes read the corners' velocities too
  b.multiresolution.active.kind = ActiveDef::Kind::regions;
  ActiveRegionDef fine;
  fine.level = 2;
  fine.region.min = {0.32, -1, -1};
  fine.region.max = {1, 1, 1};
  b.multiresolution.active.regions.push_back(fine);
  return float_world_with(b, packed, precision);
}

// Whether level l's windows are packed (pack_pays: its stepped tets at least twice the nodes of its
// passes, and a packed copy at all: the kernels' ISA and precision decide, level_passes.hpp).
bool packs(const World& w, int l) {
  const LevelInfo li = w.level_info(0, l);
  return !w.level<float>(0, l).x_packed.empty() && li.period > 1 && li.stepped_tets >= 2 * li.pass_nodes;
}

// Corners of level l's stepped tets whose packed position (and velocity, when packed) differs from
// the level's own.
std::size_t stale_corners(const World& w, int l) {
  const Level<float>& L = w.level<float>(0, l);
  std::size_t stale = 0;
  for (const Range& r : L.stepped_runs)
    for (std::size_t t = r.begin; t < r.end; ++t)
      for (int a = 0; a < 4; ++a) {
        const auto n = std::size_t(L.tet[a][t]);
        for (int k = 0; k < 3; ++k) {
          stale += L.x_packed[4 * n + std::size_t(k)] != L.x[k][n];
          if (!L.v_packed.empty()) stale += L.v_packed[4 * n + std::size_t(k)] != L.v[k][n];
        }
      }
  return stale;
}

TEST(WindowPack, EveryCornerOfAnOpenWindowReadsWhatItsLevelHolds) {
  World w = three_level_bar();
  ASSERT_EQ(w.level_count(0), 3);
  bool any = false;
  for (int l = 0; l < 3; ++l) any |= packs(w, l);
  ASSERT_TRUE(any) << "no level of the bar packs its windows: the test would check nothing";
  std::size_t checked = 0;
  std::int64_t ticks = 0;  // fine ticks: a step takes substeps() of them (the deformation monitor may sub-step)
  for (int i = 0; i < 64; ++i) {
    ticks += w.substeps();
    w.step();
    const std::int64_t tick = ticks - 1;  // the last one run
    for (int l = 0; l < 3; ++l) {
      const int p = w.level_info(0, l).period;
      // The window is open after this tick and its first slices have run (and packed).
      if (!packs(w, l) || tick % p == p - 1 || tick % p == 0) continue;
      EXPECT_EQ(stale_corners(w, l), 0u) << "level " << l << ", tick " << tick;
      ++checked;
    }
  }
  EXPECT_GT(checked, 8u);
}

TEST(WindowPack, AHostThatTakesALevelBetweenStepsIsReadAtTheNextTick) {
  World w = three_level_bar();
  ASSERT_TRUE(packs(w, 0));
  const int p = w.level_info(0, 0).period;
  ASSERT_GE(p, 4);
  for (int i = 0; i < 4 * p + 1; ++i) w.step();  // the coarsest level's window open, its first slice run
  Level<float>& L = w.level<float>(0, 0);
  std::size_t node = L.node_count;
  for (std::size_t n = 0; n < L.node_count && node == L.node_count; ++n)
    if (L.state[n] == kNodeFree) node = n;
  ASSERT_LT(node, L.node_count);
  L.x[2][node] += 1e-3f;  // m
  L.v[2][node] += 0.01f;  // m/s
  w.step();  // still within the window (its second tick)
  EXPECT_EQ(stale_corners(w, 0), 0u);
}

TEST(WindowPack, TakingTheLevelsWithoutWritingThemChangesNothing) {
  World quiet = three_level_bar(), host = three_level_bar();
  for (int i = 0; i < 48; ++i) {
    quiet.step();
    for (int l = 0; l < 3; ++l) (void)host.level<float>(0, l);  // each window packed again
    host.step();
  }
  EXPECT_EQ(quiet.state_hash(), host.state_hash());
}

// Packed or gathered, the element passes read the same corner values: the same bits, in float and
// double, whatever the kernels would choose here (WorldDef::packed_corners).
TEST(WindowPack, PackedAndGatheredCornersGiveTheSameBits) {
  for (const Precision precision : {Precision::float32, Precision::float64}) {
    World on = three_level_bar(PackedCorners::on, precision), off = three_level_bar(PackedCorners::off, precision),
          automatic = three_level_bar(PackedCorners::automatic, precision);
    for (int i = 0; i < 64; ++i) {
      on.step();
      off.step();
      automatic.step();
    }
    const bool single = precision == Precision::float32;
    const std::size_t packed_on = single ? on.level<float>(0, 0).x_packed.size() : on.level<double>(0, 0).x_packed.size();
    const std::size_t packed_off = single ? off.level<float>(0, 0).x_packed.size() : off.level<double>(0, 0).x_packed.size();
    ASSERT_GT(packed_on, 0u) << "packed_corners on did not pack";
    ASSERT_EQ(packed_off, 0u) << "packed_corners off packed";
    EXPECT_EQ(on.state_hash(), off.state_hash()) << (single ? "float" : "double");
    EXPECT_EQ(on.state_hash(), automatic.state_hash()) << (single ? "float" : "double");
  }
}

// An adaptive bar (the hierarchy's tet order kept) bending under gravity: the levels it refines
// step regions of their meshes in short runs, so they are stepped from lists (LevelInfo::listed).
World adaptive_bar() {
  BodyDef b = clamped_bar({32, 8, 8}, 1e5);
  b.multiresolution.active.kind = ActiveDef::Kind::adaptive;
  return float_world_with(b);
}

TEST(WindowPack, TheSnapshotsStressesStartFromAListedLevelsCurrentRotations) {
  World w = adaptive_bar();
  int level = -1;  // a listed level, once the bar has refined
  for (int i = 0; i < 2000 && level < 0; ++i) {
    w.step();
    for (int l = 0; l < w.level_count(0) && level < 0; ++l)
      if (w.level_info(0, l).listed && w.level_info(0, l).stepped_tets > 0) level = l;
  }
  ASSERT_GE(level, 0) << "the test needs a listed level";
  for (int i = 0; i < 50; ++i) w.step();  // its rotations move on from the list's copy
  ASSERT_TRUE(w.level_info(0, level).listed);
  const World::Snapshot listed = w.snapshot(0, level);
  // Another body prepares the step again, which writes the listed rotations back to
  // Level::rotation: the snapshot must not change.
  BodyDef other;
  other.name = "other";
  other.mesh.min = {1, 1, 1};
  other.mesh.max = {1.02, 1.02, 1.02};
  other.mesh.cells = {1, 1, 1};
  w.add_body(other);
  const World::Snapshot written_back = w.snapshot(0, level);
  ASSERT_EQ(listed.stress.size(), written_back.stress.size());
  ASSERT_GT(listed.stress.size(), 0u);
  std::size_t differ = 0;
  for (std::size_t i = 0; i < listed.stress.size(); ++i) differ += listed.stress[i] != written_back.stress[i];
  EXPECT_EQ(differ, 0u) << "of " << listed.stress.size();
}

}  // namespace
}  // namespace pliant
