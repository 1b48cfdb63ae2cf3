// renumber_for_locality: the result is the same mesh (every tet keeps its corners, in order, at
// the same positions), the node map is a permutation that says where each node went, the
// order is deterministic, and a scrambled mesh comes back with neighbours near each other in
// memory (the property the kernels need).
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <map>
#include <numeric>
#include <random>
#include <vector>

#include "pliant/tet_mesh.hpp"

using namespace pliant;

namespace {

// A box mesh with its nodes and tets in random order (a stand-in for a mesher's output).
TetMesh scrambled_box(int n, unsigned seed) {
  return shuffled_order(make_box_mesh({0, 0, 0}, {1.0, 0.5, 0.25}, {n, n / 2, n / 4}, 6), seed);
}

// Mean over tets of (largest - smallest corner index): small when tets touch nearby nodes.
double mean_index_span(const TetMesh& m) {
  double sum = 0;
  for (const auto& t : m.tets) sum += *std::max_element(t.begin(), t.end()) - *std::min_element(t.begin(), t.end());
  return sum / double(m.tet_count());
}

// Mean jump in smallest node index from one tet to the next in the tet array.
double mean_tet_to_tet_jump(const TetMesh& m) {
  double sum = 0;
  for (std::size_t t = 1; t < m.tet_count(); ++t)
    sum += std::abs(double(*std::min_element(m.tets[t].begin(), m.tets[t].end())) -
                    double(*std::min_element(m.tets[t - 1].begin(), m.tets[t - 1].end())));
  return sum / double(m.tet_count() - 1);
}

using Corners = std::array<std::array<double, 3>, 4>;
std::vector<Corners> tets_by_position(const TetMesh& m) {
  std::vector<Corners> out;
  for (const auto& t : m.tets) {
    Corners c;
    for (int a = 0; a < 4; ++a) c[a] = m.point(std::size_t(t[a]));
    out.push_back(c);
  }
  std::sort(out.begin(), out.end());
  return out;
}

TEST(Renumber, KeepsTheMeshAndReturnsWhereEachNodeWent) {
  const TetMesh original = scrambled_box(12, 1);
  TetMesh m = original;
  const std::vector<std::int32_t> old_to_new = renumber_for_locality(m);
  ASSERT_EQ(old_to_new.size(), original.node_count());
  ASSERT_EQ(m.node_count(), original.node_count());
  ASSERT_EQ(m.tet_count(), original.tet_count());
  // A permutation.
  std::vector<std::int32_t> sorted = old_to_new;
  std::sort(sorted.begin(), sorted.end());
  for (std::size_t i = 0; i < sorted.size(); ++i) EXPECT_EQ(sorted[i], std::int32_t(i));
  // Node i of the original is node old_to_new[i] now.
  for (std::size_t i = 0; i < original.node_count(); ++i) EXPECT_EQ(m.point(std::size_t(old_to_new[i])), original.point(i));
  // The same tets, corners in the same order (so the same orientation), maybe in another order.
  EXPECT_EQ(tets_by_position(m), tets_by_position(original));
  for (const auto& t : m.tets)
    EXPECT_GT(signed_tet_volume(m.point(t[0]), m.point(t[1]), m.point(t[2]), m.point(t[3])), 0.0);
}

TEST(Renumber, IsDeterministicAndIdempotentUpToOrder) {
  TetMesh a = scrambled_box(10, 2), b = a;
  EXPECT_EQ(renumber_for_locality(a), renumber_for_locality(b));
  EXPECT_EQ(a.points, b.points);
  EXPECT_EQ(a.tets, b.tets);
  // Renumbering a renumbered mesh changes nothing: the order depends on positions only.
  TetMesh c = a;
  const auto again = renumber_for_locality(c);
  for (std::size_t i = 0; i < again.size(); ++i) EXPECT_EQ(again[i], std::int32_t(i));
  EXPECT_EQ(c.tets, a.tets);
}

TEST(Renumber, RestoresLocalityOfAScrambledMesh) {
  const TetMesh grid = make_box_mesh({0, 0, 0}, {1.0, 0.5, 0.25}, {24, 12, 6}, 6);
  TetMesh m = scrambled_box(24, 3);
  const double span_random = mean_index_span(m), jump_random = mean_tet_to_tet_jump(m);
  renumber_for_locality(m);
  const double span = mean_index_span(m), jump = mean_tet_to_tet_jump(m);
  // Random order: corners are a third of the mesh apart on average; renumbered: as close as in
  // grid order or closer, and consecutive tets touch nearby nodes.
  EXPECT_GT(span_random, 0.2 * double(m.node_count()));
  EXPECT_LT(span, 1.2 * mean_index_span(grid));
  EXPECT_LT(span, 0.15 * span_random);
  EXPECT_LT(jump, 0.003 * jump_random);  // measured 5.4e-4 x jump_random
}

TEST(Renumber, NodeListsMappedThroughTheMapSelectTheSameMaterialPoints) {
  // What World::add_body does with a "nodes" region of a file mesh: indices given in the
  // file's numbering go through old_to_new and land on the same positions.
  const TetMesh original = scrambled_box(8, 4);
  TetMesh m = original;
  const auto old_to_new = renumber_for_locality(m);
  const std::vector<std::int32_t> listed = {0, 5, 17, 42, std::int32_t(original.node_count() - 1)};
  for (auto i : listed) EXPECT_EQ(m.point(std::size_t(old_to_new[std::size_t(i)])), original.point(std::size_t(i)));
}

TEST(Renumber, SingleTetAndFlatExtents) {
  TetMesh m;
  m.points = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1};
  m.tets = {{0, 1, 2, 3}};
  const TetMesh before = m;
  const auto map = renumber_for_locality(m);
  ASSERT_EQ(map.size(), 4u);
  for (int a = 0; a < 4; ++a) EXPECT_EQ(m.point(std::size_t(m.tets[0][a])), before.point(std::size_t(before.tets[0][a])));
}

}  // namespace
