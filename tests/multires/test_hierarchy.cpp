// The hierarchy of a multiresolution body at rest: level meshes, links between levels, and who
// is active where (engine/src/multires/). Box hierarchies with an even ratio and Kuhn cells nest
// exactly, so there the stepped tets must tile the body exactly and every ghost must sit exactly
// where its weights put it.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <memory>
#include <numeric>

#include <fmt/format.h>

#include "../../engine/src/multires/activation.hpp"
#include "../../engine/src/multires/tet_locator.hpp"
#include "pliant/hierarchy.hpp"
#include "pliant/world.hpp"

namespace pliant {
namespace {

BodyDef box_body(std::array<int, 3> cells, int levels, int tets_per_cell = 6) {
  BodyDef b;
  b.mesh.kind = MeshSourceDef::Kind::box;
  b.mesh.min = {0, 0, 0};
  b.mesh.max = {0.8, 0.2, 0.2};
  b.mesh.cells = cells;
  b.mesh.tets_per_cell = tets_per_cell;
  b.multiresolution.levels = levels;
  return b;
}

Hierarchy box_hierarchy(std::array<int, 3> cells, int levels, int tets_per_cell = 6) {
  const BodyDef b = box_body(cells, levels, tets_per_cell);
  return link_levels(build_level_meshes(b, build_mesh(b.mesh)));
}

double tet_volume(const TetMesh& m, std::size_t t) {
  const Tet& q = m.tets[t];
  return signed_tet_volume(m.point(q[0]), m.point(q[1]), m.point(q[2]), m.point(q[3]));
}

TEST(Hierarchy, BoxLevelsHaveCellsDividedByTheRatio) {
  const Hierarchy h = box_hierarchy({8, 2, 3}, 3);
  ASSERT_EQ(h.levels(), 3u);
  EXPECT_EQ(h.meshes[2].tet_count(), 8u * 2 * 3 * 6);
  EXPECT_EQ(h.meshes[1].tet_count(), 4u * 1 * 2 * 6);  // ceil(3 / 2) = 2
  EXPECT_EQ(h.meshes[0].tet_count(), 2u * 1 * 1 * 6);
}

TEST(Hierarchy, LinksLocateEveryNodeAndChildrenPartitionTheFinerNodes) {
  const Hierarchy h = box_hierarchy({8, 2, 2}, 3);
  for (std::size_t l = 0; l + 1 < h.levels(); ++l) {
    const LevelLinks& c = h.links[l];
    const LevelLinks& f = h.links[l + 1];
    const TetMesh& fine = h.meshes[l + 1];
    // Every finer node inside the coarser mesh (nested boxes), weights reproduce its position.
    for (std::size_t i = 0; i < fine.node_count(); ++i) {
      const TetLink& k = f.to_coarser[i];
      ASSERT_GE(k.tet, 0);
      EXPECT_EQ(k.outside, 0.0);
      Vec3d p{0, 0, 0};
      for (int a = 0; a < 4; ++a)
        for (int d = 0; d < 3; ++d) p[d] += k.weights[a] * h.meshes[l].point(h.meshes[l].tets[k.tet][a])[d];
      for (int d = 0; d < 3; ++d) EXPECT_NEAR(p[d], fine.point(i)[d], 1e-15);
    }
    // Children: each finer node exactly once, under its parent.
    EXPECT_EQ(c.children.size(), fine.node_count());
    std::vector<int> seen(fine.node_count(), 0);
    for (std::size_t p = 0; p + 1 < c.child_offsets.size(); ++p)
      for (auto e = c.child_offsets[p]; e < c.child_offsets[p + 1]; ++e) {
        ++seen[std::size_t(c.children[std::size_t(e)])];
        EXPECT_EQ(f.parent[std::size_t(c.children[std::size_t(e)])], std::int32_t(p));
      }
    for (int s : seen) EXPECT_EQ(s, 1);
  }
}

TEST(Activation, UniformChoicesStepOneLevelWithoutGhosts) {
  const Hierarchy h = box_hierarchy({8, 2, 2}, 3);
  for (int which = 0; which < 3; ++which) {
    ActiveDef a;
    a.kind = ActiveDef::Kind::level;
    a.level = which;
    const detail::Activation act = detail::activate(h, a);
    for (int l = 0; l < 3; ++l) {
      const auto& la = act.levels[std::size_t(l)];
      const std::size_t stepped = std::accumulate(la.stepped.begin(), la.stepped.end(), std::size_t(0));
      EXPECT_EQ(stepped, l == which ? h.meshes[std::size_t(l)].tet_count() : 0u) << which << " " << l;
      EXPECT_TRUE(la.ghosts.empty());
    }
  }
}

// A fine region over half of a nested box: the stepped tets of the two levels tile the box (their
// volumes sum to its volume to rounding), every ghost is at the position its weights give, and its
// sources are active nodes of a coarser level.
TEST(Activation, StaticSplitTilesTheBoxAndGhostsAreExact) {
  const Hierarchy h = box_hierarchy({16, 4, 4}, 3);
  ActiveDef a;
  a.kind = ActiveDef::Kind::regions;
  ActiveRegionDef fine;
  fine.level = 2;
  fine.region.kind = RegionDef::Kind::box;
  fine.region.min = {0.65, -1, -1};
  fine.region.max = {1, 1, 1};
  ActiveRegionDef middle = fine;
  middle.level = 1;
  middle.region.min = {0.45, -1, -1};
  a.regions = {fine, middle};
  const detail::Activation act = detail::activate(h, a);
  double volume = 0;
  std::size_t ghosts = 0;
  for (int l = 0; l < 3; ++l) {
    const auto& la = act.levels[std::size_t(l)];
    const TetMesh& m = h.meshes[std::size_t(l)];
    std::size_t stepped = 0;
    for (std::size_t t = 0; t < m.tet_count(); ++t)
      if (la.stepped[t]) {
        volume += tet_volume(m, t);
        ++stepped;
      }
    EXPECT_GT(stepped, 0u) << "level " << l;
    ghosts += la.ghosts.size();
    for (std::size_t g = 0; g < la.ghosts.size(); ++g) {
      Vec3d p{0, 0, 0};
      double wsum = 0;
      for (auto e = la.source_offsets[g]; e < la.source_offsets[g + 1]; ++e) {
        const auto& s = la.sources[std::size_t(e)];
        ASSERT_LT(s.level, l);
        EXPECT_EQ(act.levels[std::size_t(s.level)].role[std::size_t(s.node)], detail::NodeRole::active);
        wsum += s.weight;
        for (int d = 0; d < 3; ++d) p[d] += s.weight * h.meshes[std::size_t(s.level)].point(std::size_t(s.node))[d];
      }
      EXPECT_NEAR(wsum, 1.0, 1e-14);
      // measured 2.8e-17 m
      for (int d = 0; d < 3; ++d) EXPECT_NEAR(p[d], m.point(std::size_t(la.ghosts[g]))[d], 2.5e-16);
    }
  }
  EXPECT_GT(ghosts, 0u);
  EXPECT_NEAR(volume, 0.8 * 0.2 * 0.2, 1e-15);
}

}  // namespace
}  // namespace pliant

#ifdef PLIANT_HAS_CGAL
namespace pliant {
namespace {

// The levels of a non-nested hierarchy leave slivers between their stepped parts; every stepped
// part must still be tied to the others (through ghosts), or it floats free. One connected piece:
// union of the corners of every stepped tet and of every ghost with its sources.
std::size_t pieces(const Hierarchy& h, const detail::Activation& act) {
  std::vector<std::size_t> base(h.levels() + 1, 0);
  for (std::size_t l = 0; l < h.levels(); ++l) base[l + 1] = base[l] + h.meshes[l].node_count();
  std::vector<std::size_t> parent(base.back());
  for (std::size_t i = 0; i < parent.size(); ++i) parent[i] = i;
  auto find = [&](std::size_t i) {
    while (parent[i] != i) i = parent[i] = parent[parent[i]];
    return i;
  };
  auto unite = [&](std::size_t a, std::size_t b) { parent[find(a)] = find(b); };
  std::vector<char> used(base.back(), 0);
  for (std::size_t l = 0; l < h.levels(); ++l) {
    const auto& la = act.levels[l];
    for (std::size_t t = 0; t < h.meshes[l].tet_count(); ++t) {
      if (!la.stepped[t]) continue;
      const Tet& q = h.meshes[l].tets[t];
      for (int a = 0; a < 4; ++a) used[base[l] + std::size_t(q[a])] = 1;
      for (int a = 1; a < 4; ++a) unite(base[l] + std::size_t(q[0]), base[l] + std::size_t(q[a]));
    }
    for (std::size_t g = 0; g < la.ghosts.size(); ++g)
      for (auto e = la.source_offsets[g]; e < la.source_offsets[g + 1]; ++e)
        unite(base[l] + std::size_t(la.ghosts[g]),
              base[std::size_t(la.sources[std::size_t(e)].level)] + std::size_t(la.sources[std::size_t(e)].node));
  }
  std::size_t roots = 0;
  for (std::size_t i = 0; i < parent.size(); ++i) roots += used[i] && find(i) == i;
  return roots;
}

TEST(Activation, NonNestedOrganLevelsStayOnePiece) {
  BodyDef b;
  b.mesh.kind = MeshSourceDef::Kind::implicit;
  b.mesh.shape = "organ";
  b.mesh.cell_size = 0.01;
  b.multiresolution.levels = 3;
  const Hierarchy h = link_levels(build_level_meshes(b, build_mesh(b.mesh)));
  std::vector<Vec3d> centres;
  for (double x = -0.08; x <= 0.081; x += 0.04)
    for (double y = -0.04; y <= 0.041; y += 0.04)
      for (double z = -0.02; z <= 0.021; z += 0.02) centres.push_back({x, y, z});
  int bad = 0;
  double worst_volume = 0;  // relative error of the stepped tets' volume against the body's
  double worst_gap = 0;     // share of the body's volume no stepped tet covers
  double worst_weighed = 0;  // the same as worst_volume, each tet counted for its mass share
  std::vector<std::unique_ptr<detail::TetLocator>> locators;
  for (std::size_t l = 0; l < 3; ++l) locators.push_back(std::make_unique<detail::TetLocator>(h.meshes[l]));
  double fine_volume = 0;
  for (std::size_t t = 0; t < h.meshes[2].tet_count(); ++t) fine_volume += tet_volume(h.meshes[2], t);
  for (std::size_t l = 0; l < 2; ++l) {  // every level has the body's volume (scaled to it)
    double v = 0;
    for (std::size_t t = 0; t < h.meshes[l].tet_count(); ++t) v += tet_volume(h.meshes[l], t);
    // measured 8.5e-16 of it
    EXPECT_NEAR(v, fine_volume, 8e-15 * fine_volume) << "level " << l;
  }
  for (const Vec3d& centre : centres) {
    ActiveDef a;
    a.kind = ActiveDef::Kind::regions;
    ActiveRegionDef fine;
    fine.level = 2;
    fine.region.kind = RegionDef::Kind::sphere;
    fine.region.center = centre;
    fine.region.radius = 0.04;
    a.regions = {fine};
    const detail::Activation act = detail::activate(h, a);
    if (pieces(h, act) != 1) ++bad;
    double stepped = 0, weighed = 0;
    for (std::size_t l = 0; l < 3; ++l)
      for (std::size_t t = 0; t < h.meshes[l].tet_count(); ++t)
        if (act.levels[l].stepped[t]) {
          stepped += tet_volume(h.meshes[l], t);
          weighed += tet_volume(h.meshes[l], t) * act.levels[l].share[t] / detail::kMassShares;
        }
    worst_volume = std::max(worst_volume, std::abs(stepped / fine_volume - 1));
    worst_weighed = std::max(worst_weighed, std::abs(weighed / fine_volume - 1));
    // The gaps, sampled at 5 points of every finest tet (its centroid and next to its corners,
    // each standing for a fifth of its volume): a point no level's stepped tet contains.
    double gap = 0;
    const TetMesh& m = h.meshes[2];
    for (std::size_t t = 0; t < m.tet_count(); ++t) {
      Vec3d c{0, 0, 0};
      for (int a = 0; a < 4; ++a)
        for (int k = 0; k < 3; ++k) c[std::size_t(k)] += 0.25 * m.point(std::size_t(m.tets[t][std::size_t(a)]))[std::size_t(k)];
      for (int a = -1; a < 4; ++a) {
        Vec3d q = c;
        if (a >= 0)
          for (int k = 0; k < 3; ++k) {
            const double corner = m.point(std::size_t(m.tets[t][std::size_t(a)]))[std::size_t(k)];
            q[std::size_t(k)] = corner + 0.25 * (c[std::size_t(k)] - corner);
          }
        bool in_every_level = true;  // the levels' surfaces differ: a point outside one is no gap
        for (std::size_t l = 0; l < 2; ++l) in_every_level = in_every_level && locators[l]->locate(q).outside == 0;
        bool inside = false;
        for (std::size_t l = 0; l < 3 && !inside; ++l) inside = locators[l]->containing(q, act.levels[l].stepped).tet >= 0;
        if (in_every_level && !inside) gap += 0.2 * tet_volume(m, t);
      }
    }
    worst_gap = std::max(worst_gap, gap / fine_volume);
    EXPECT_EQ(pieces(h, act), 1u) << centre[0] << " " << centre[1] << " " << centre[2];
  }
  // Measured: 0 of 45; with the nodes of slivers left untied (reach 0), 5 of 45 had a stepped part
  // floating free.
  EXPECT_EQ(bad, 0);
  // Non-nested levels overlap by up to one finer tet at their interfaces (an active node has all its
  // tets, activation.hpp) and leave only small gaps; nested boxes tile exactly
  // (StaticSplitTilesTheBox...). Measured: stepped volume up to 14.3% over the body's, gaps up to
  // 1.3% of it. With a tet present by its centroid alone: 2.2% and 4.7%, the gaps at active nodes,
  // where the two sides parted like a hinge (NonNestedBarSplitInPartSagsBetweenItsLevels).
  std::printf("stepped volume within %.3g of the body's over %zu splits (weighed by the mass shares: %.3g), gaps at "
              "most %.3g of it\n", worst_volume, centres.size(), worst_weighed, worst_gap);
  EXPECT_LT(worst_volume, 0.16);
  EXPECT_LT(worst_gap, 0.02);
  // The overlap is not weighed twice: the masses the stepped tets give are the body's to within
  // this before the full apply scales them (measured 3.9%; 14.3% if every stepped tet weighed whole).
  EXPECT_LT(worst_weighed, 0.05);
}

}  // namespace
}  // namespace pliant
#endif

namespace pliant {
namespace {

bool same_state(const detail::ActivationState& a, const detail::ActivationState& b, std::string& why) {
  for (int l = 0; l < a.levels(); ++l) {
    if (a.stepped_mask(l) != b.stepped_mask(l)) {
      why = fmt::format("level {}: stepped tets differ", l);
      return false;
    }
    for (std::size_t t = 0; t < a.stepped_mask(l).size(); ++t)
      if (a.stepped(l, std::int32_t(t)) && a.mass_share(l, std::int32_t(t)) != b.mass_share(l, std::int32_t(t))) {
        why = fmt::format("level {} tet {}: mass share differs", l, t);
        return false;
      }
    const std::size_t nodes = a.hierarchy().meshes[std::size_t(l)].node_count();
    for (std::size_t i = 0; i < nodes; ++i) {
      if (a.role(l, std::int32_t(i)) != b.role(l, std::int32_t(i))) {
        why = fmt::format("level {} node {}: role differs", l, i);
        return false;
      }
      const auto &sa = a.sources(l, std::int32_t(i)), &sb = b.sources(l, std::int32_t(i));
      if (sa.size() != sb.size()) {
        why = fmt::format("level {} node {}: sources differ", l, i);
        return false;
      }
      for (std::size_t e = 0; e < sa.size(); ++e)
        if (sa[e].level != sb[e].level || sa[e].node != sb[e].node || sa[e].weight != sb[e].weight) {
          why = fmt::format("level {} node {}: source {} differs", l, i, e);
          return false;
        }
    }
  }
  return true;
}

// Adaptivity changes a few targets at a time: the incremental update must reach the state a
// fresh evaluation of the same targets gives, and examine a number of tets and nodes that
// depends on the change, not on the body. A third of the rounds are then undone as undo_change
// does (the targets set back, in reverse order, and update() again): that must reach the fresh
// state of the targets before the round.
void incremental_matches_fresh(const Hierarchy& h, int rounds, std::uint64_t seed) {
  const int n = int(h.levels());
  std::vector<std::vector<int>> targets(static_cast<std::size_t>(n));
  for (int l = 0; l < n; ++l) targets[std::size_t(l)].assign(h.meshes[std::size_t(l)].node_count(), 0);
  detail::ActivationState state(h, targets);
  std::uint64_t r = seed;
  auto next = [&] {
    r ^= r << 13;
    r ^= r >> 7;
    r ^= r << 17;
    return r;
  };
  int undone = 0;
  for (int round = 0; round < rounds; ++round) {
    struct Was {
      int level;
      std::int32_t node;
      int target;
    };
    std::vector<Was> round_changes;
    // Split or merge a few nodes, keeping a split node's parent split (as adaptivity does).
    for (int k = 0; k < 3; ++k) {
      const int l = int(next() % std::uint64_t(n - 1));
      const auto node = std::int32_t(next() % h.meshes[std::size_t(l)].node_count());
      const bool split = targets[std::size_t(l)][std::size_t(node)] == l;
      const int parent_ok = l == 0 || targets[std::size_t(l) - 1][std::size_t(h.links[std::size_t(l)].parent[std::size_t(node)])] > l - 1;
      if (split && !parent_ok) continue;
      int t = split ? l + 1 : l;
      if (!split) {  // merge only if no child is split
        const auto& lk = h.links[std::size_t(l)];
        bool child_split = false;
        for (auto c = lk.child_offsets[std::size_t(node)]; c < lk.child_offsets[std::size_t(node) + 1]; ++c)
          child_split |= targets[std::size_t(l) + 1][std::size_t(lk.children[std::size_t(c)])] > l + 1;
        if (child_split) continue;
      }
      round_changes.push_back({l, node, targets[std::size_t(l)][std::size_t(node)]});
      targets[std::size_t(l)][std::size_t(node)] = t;
      state.set_target(l, node, t);
    }
    const auto ch = state.update();
    const detail::ActivationState fresh(h, targets);
    std::string why;
    ASSERT_TRUE(same_state(state, fresh, why)) << "round " << round << ": " << why;
    (void)ch;
    if (round_changes.empty() || next() % 3 != 0) continue;
    for (auto c = round_changes.rbegin(); c != round_changes.rend(); ++c) {
      targets[std::size_t(c->level)][std::size_t(c->node)] = c->target;
      state.set_target(c->level, c->node, c->target);
    }
    state.update();
    ++undone;
    const detail::ActivationState before(h, targets);
    ASSERT_TRUE(same_state(state, before, why)) << "round " << round << " undone: " << why;
  }
  EXPECT_GT(undone, rounds / 6);
}

TEST(ActivationState, IncrementalUpdatesMatchAFreshEvaluationOnANestedBox) {
  incremental_matches_fresh(box_hierarchy({16, 4, 4}, 3), 60, 0x9e3779b97f4a7c15ull);
}

// 15 x 3 x 3 cells over 8 x 2 x 2 over 4 x 1 x 1: no level nests in the next, so finer tets are also
// stepped by their corners (activation.hpp, rule 2), and that presence depends on which coarser
// tets are stepped near them: the lists update() reads must find every tet it changes. Without a
// mesher, so that sanitizer builds (CGAL off) run this path too.
TEST(ActivationState, IncrementalUpdatesMatchAFreshEvaluationOnANonNestedBox) {
  const Hierarchy h = box_hierarchy({15, 3, 3}, 3);
  std::size_t straddling = 0;
  for (std::size_t l = 1; l < 3; ++l)
    for (std::size_t t = 0; t + 1 < h.links[l].tet_parent_offsets.size(); ++t)
      straddling += h.links[l].tet_parent_offsets[t + 1] - h.links[l].tet_parent_offsets[t] > 1;
  EXPECT_GT(straddling, 0u);
  incremental_matches_fresh(h, 200, 0x5851f42d4c957f2dull);
}

#ifdef PLIANT_HAS_CGAL
TEST(ActivationState, IncrementalUpdatesMatchAFreshEvaluationOnTheOrgan) {
  BodyDef b;
  b.mesh.kind = MeshSourceDef::Kind::implicit;
  b.mesh.shape = "organ";
  b.mesh.cell_size = 0.01;
  b.multiresolution.levels = 3;
  const Hierarchy h = link_levels(build_level_meshes(b, build_mesh(b.mesh)));
  incremental_matches_fresh(h, 200, 0x2545f4914f6cdd1dull);
}
#endif

// Deterministic numbers in [0, 1) for the locator tests (a 64-bit LCG, its top 53 bits).
struct Uniform {
  std::uint64_t seed;
  double operator()() {
    seed = seed * 6364136223846793005ull + 1442695040888963407ull;
    return double(seed >> 11) * 0x1.0p-53;
  }
};

TEST(TetLocator, ContainingOrNearIsTheBruteForceAnswer) {
  // containing_or_near skips the tets whose bounding box lies farther than the best so far: the
  // answer must be the one a scan of every tet gives (the same tet, the same weights), for points
  // inside, at the surface and outside, with masks of few stepped tets (ghost sources far away).
  const TetMesh m = make_box_mesh({0, 0, 0}, {0.4, 0.1, 0.1}, {12, 3, 3}, 6);
  const detail::TetLocator loc(m);
  Uniform uniform{12345};
  // The clamped distance of the near search (tet_locator.cpp): the distance to the point of
  // the tet's barycentric weights clamped at 0 and normalised.
  auto clamped = [&](std::size_t t, const Vec3d& p) {
    auto w = loc.weights(std::int32_t(t), p);
    double sum = 0;
    for (double& v : w) sum += (v = std::max(v, 0.0));
    for (double& v : w) v /= sum;
    Vec3d q{0, 0, 0};
    for (int c = 0; c < 4; ++c)
      for (int d = 0; d < 3; ++d) q[std::size_t(d)] += w[std::size_t(c)] * m.points[3 * std::size_t(m.tets[t][std::size_t(c)]) + std::size_t(d)];
    return std::hypot(p[0] - q[0], p[1] - q[1], p[2] - q[2]);
  };
  int near_answers = 0;
  for (int trial = 0; trial < 400; ++trial) {
    std::vector<std::uint8_t> mask(m.tet_count(), 0);
    const double share = trial % 4 == 0 ? 0.02 : 0.3;
    for (auto& b : mask) b = uniform() < share;
    const Vec3d p{-0.05 + 0.5 * uniform(), -0.05 + 0.2 * uniform(), -0.05 + 0.2 * uniform()};
    const double radius = 0.15 * uniform();
    const TetLink got = loc.containing_or_near(p, mask, radius);
    TetLink want = loc.containing(p, mask);
    if (want.tet < 0) {
      double best = radius;
      for (std::size_t t = 0; t < m.tet_count(); ++t) {
        if (!mask[t]) continue;
        const double d = clamped(t, p);
        if (d < best || (d == best && want.tet >= 0 && std::int32_t(t) < want.tet)) {
          best = d;
          want.tet = std::int32_t(t);
          want.weights = loc.weights(std::int32_t(t), p);
        }
      }
      near_answers += want.tet >= 0;
    }
    ASSERT_EQ(got.tet, want.tet) << "trial " << trial;
    for (int c = 0; c < 4; ++c) EXPECT_EQ(got.weights[std::size_t(c)], want.weights[std::size_t(c)]) << "trial " << trial;
  }
  EXPECT_GT(near_answers, 100);  // the near search decided most of them
}

TEST(TetLocator, HintsAndCoversAgreeWithinTheContainmentTolerance) {
  // containing() accepts a tet whose weights are all >= -1e-10 at p, so a point just outside a tet
  // (by less than 1e-10 of its size) is "in" it. Two tets sharing the face x + y + z = 1: A below
  // it, B above it. A point 1e-12 inside A (across the face from B) is contained in B within the
  // tolerance; a point 1e-12 outside A's face x = 0, in no other tet, is contained in A within it
  // and lies outside A's bounding box. With radii of 0 and far below the tolerance, the hinted
  // search and covers() must still give containing_or_near's answer (found by review of the
  // first version, which pruned or short-cut these).
  TetMesh m;
  m.points = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 1, 1, 1};
  m.tets = {{0, 1, 2, 3}, {1, 2, 3, 4}};  // A, B (both positively oriented)
  ASSERT_GT(signed_tet_volume(m.point(0), m.point(1), m.point(2), m.point(3)), 0);
  ASSERT_GT(signed_tet_volume(m.point(1), m.point(2), m.point(3), m.point(4)), 0);
  const detail::TetLocator loc(m);
  const double d = 1e-12;
  const Vec3d inside_a_by_the_face{1.0 / 3 - d, 1.0 / 3, 1.0 / 3};
  const Vec3d outside_a{-d, 0.2, 0.2};
  const std::vector<std::uint8_t> only_b{0, 1}, only_a{1, 0};
  for (const double radius : {0.0, 1e-13, 1e-3}) {
    for (const auto& [p, mask, hint] : {std::tuple{inside_a_by_the_face, only_b, 0}, std::tuple{outside_a, only_a, 0},
                                        std::tuple{outside_a, only_a, -1}, std::tuple{inside_a_by_the_face, only_a, 0}}) {
      const TetLink plain = loc.containing_or_near(p, mask, radius);
      const TetLink hinted = loc.containing_or_near(p, mask, radius, hint);
      EXPECT_EQ(hinted.tet, plain.tet) << "radius " << radius << " hint " << hint;
      for (int c = 0; c < 4; ++c) EXPECT_EQ(hinted.weights[std::size_t(c)], plain.weights[std::size_t(c)]);
      EXPECT_EQ(loc.covers(p, mask, radius, hint), plain.tet >= 0) << "radius " << radius << " hint " << hint;
      EXPECT_EQ(loc.covers(p, mask, radius), plain.tet >= 0) << "radius " << radius;
    }
  }
  // The tolerance cases themselves (what the checks above rely on).
  EXPECT_EQ(loc.containing(inside_a_by_the_face, only_b).tet, 1);
  EXPECT_EQ(loc.containing(outside_a, only_a).tet, 0);
}

TEST(TetLocator, TheFirstMaskedCandidateIsContainingOrNearsAnswer) {
  // ActivationState lists each node's candidates once (TetLocator::candidates) and takes the first
  // one its mask has as the node's ghost source: for every mask, that must be containing_or_near's
  // tet (with its weights), and covers() must say whether there is one. Points near faces and deep
  // inside, radii from 0 to an edge, masks with few or many tets, hints right, wrong and absent;
  // then the tolerance cases of the test above (a point 1e-12 across a shared face, and outside
  // its tet's bounding box).
  const TetMesh m = make_box_mesh({0, 0, 0}, {0.4, 0.1, 0.1}, {12, 3, 3}, 6);
  const detail::TetLocator loc(m);
  Uniform uniform{77};
  auto check = [](const detail::TetLocator& l, const Vec3d& p, const std::vector<std::uint8_t>& mask, double radius,
                  std::int32_t hint, const std::vector<std::int32_t>& list) {
    const TetLink want = l.containing_or_near(p, mask, radius);
    std::int32_t first = -1;
    for (auto t : list)
      if (mask[std::size_t(t)]) {
        first = t;
        break;
      }
    EXPECT_EQ(first, want.tet) << "radius " << radius << " hint " << hint;
    if (first >= 0 && first == want.tet) {
      for (int c = 0; c < 4; ++c) EXPECT_EQ(l.weights(first, p)[std::size_t(c)], want.weights[std::size_t(c)]);
    }
    EXPECT_EQ(l.covers(p, mask, radius, hint), first >= 0);
    return first >= 0 && l.containing(p, mask).tet < 0;  // found by the near search
  };
  int near_answers = 0, longer = 0;
  for (int trial = 0; trial < 600; ++trial) {
    const Vec3d p{-0.02 + 0.44 * uniform(), -0.02 + 0.14 * uniform(), -0.02 + 0.14 * uniform()};
    const double radius = trial % 5 == 0 ? 0.0 : 0.035 * uniform();
    const std::int32_t inside = loc.locate(p).tet;
    for (const std::int32_t hint : {inside, std::int32_t((std::size_t(inside) + m.tet_count() / 2) % m.tet_count()), -1}) {
      std::vector<std::int32_t> list;
      loc.candidates(p, radius, hint, list);
      longer += list.size() > 1;
      for (int k = 0; k < 4; ++k) {  // masks drawn for the same list
        std::vector<std::uint8_t> mask(m.tet_count(), 0);
        const double share = k == 0 ? 0.05 : k == 1 ? 0.5 : k == 2 ? 0.95 : 1.0;
        for (auto& b : mask) b = uniform() < share;
        near_answers += check(loc, p, mask, radius, hint, list);
      }
    }
  }
  EXPECT_GT(near_answers, 200);  // the near part of the lists decided many
  EXPECT_GT(longer, 500);        // lists of several tets, whose order matters

  TetMesh two;
  two.points = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 1, 1, 1};
  two.tets = {{0, 1, 2, 3}, {1, 2, 3, 4}};
  const detail::TetLocator pair(two);
  const double d = 1e-12;
  for (const double radius : {0.0, 1e-13, 1e-3})
    for (const Vec3d& p : {Vec3d{1.0 / 3 - d, 1.0 / 3, 1.0 / 3}, Vec3d{-d, 0.2, 0.2}})
      for (const std::int32_t hint : {0, -1}) {
        std::vector<std::int32_t> list;
        pair.candidates(p, radius, hint, list);
        for (const std::vector<std::uint8_t>& mask : {std::vector<std::uint8_t>{1, 0}, std::vector<std::uint8_t>{0, 1},
                                                      std::vector<std::uint8_t>{1, 1}, std::vector<std::uint8_t>{0, 0}})
          check(pair, p, mask, radius, hint, list);
      }
}

TEST(TetLocator, HintsAndCoversGiveContainingOrNearsAnswer) {
  // With a hint (the tet holding p, as a node's link to the coarser level gives it), a point deeper
  // than the radius inside it is answered by that tet alone; covers() says whether a tet would be
  // found at all, stopping at the first. Both must give containing_or_near's answer without a
  // hint: the same tet and the same weights, the same yes or no. Points are drawn near faces as
  // well as deep inside (a radius up to an edge), masks with few or many tets, hints right, far
  // (a tet elsewhere) and absent.
  const TetMesh m = make_box_mesh({0, 0, 0}, {0.4, 0.1, 0.1}, {12, 3, 3}, 6);
  const detail::TetLocator loc(m);
  Uniform uniform{2026};
  int shortcuts = 0, covered = 0, near_only = 0;
  for (int trial = 0; trial < 2000; ++trial) {
    std::vector<std::uint8_t> mask(m.tet_count(), 0);
    const double share = trial % 3 == 0 ? 0.05 : trial % 3 == 1 ? 0.5 : 0.95;
    for (auto& b : mask) b = uniform() < share;
    const Vec3d p{-0.02 + 0.44 * uniform(), -0.02 + 0.14 * uniform(), -0.02 + 0.14 * uniform()};
    const double radius = trial % 5 == 0 ? 0.0 : 0.035 * uniform();  // the cells are 0.033 m
    const TetLink plain = loc.containing_or_near(p, mask, radius);
    const std::int32_t inside = loc.locate(p).tet;
    const std::int32_t hints[3] = {inside, std::int32_t((std::size_t(inside) + m.tet_count() / 2) % m.tet_count()), -1};
    for (const std::int32_t hint : hints) {
      const TetLink got = loc.containing_or_near(p, mask, radius, hint);
      ASSERT_EQ(got.tet, plain.tet) << "trial " << trial << " hint " << hint;
      for (int c = 0; c < 4; ++c) EXPECT_EQ(got.weights[std::size_t(c)], plain.weights[std::size_t(c)]) << "trial " << trial;
      EXPECT_EQ(got.outside, plain.outside) << "trial " << trial;
      EXPECT_EQ(loc.covers(p, mask, radius, hint), plain.tet >= 0) << "trial " << trial << " hint " << hint;
    }
    shortcuts += inside >= 0 && loc.depth(inside, p) > radius;
    covered += plain.tet >= 0;
    near_only += plain.tet >= 0 && loc.containing(p, mask).tet < 0;
  }
  // The cases the shortcuts and the early exit must get right all occurred (240, 1 129 and 648 of
  // the 2 000 with this seed).
  EXPECT_GT(shortcuts, 200);
  EXPECT_GT(covered, 500);
  EXPECT_GT(near_only, 200);
  EXPECT_LT(covered, 1900);
}

}  // namespace
}  // namespace pliant
