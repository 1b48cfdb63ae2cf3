// Renumbering for memory locality. The element pass reads the 4 corner nodes of every tet and
// the gather reads the corner forces of every tet around a node; both stream through memory
// only if neighbours in space are neighbours in the arrays. Meshers and files give no such
// guarantee (CGAL's order follows its refinement, a file's whatever wrote it): over 1M tets a
// random order makes a step several times slower than grid order. Here nodes are sorted along
// a 3D Hilbert curve through their positions, and tets by their smallest (then second smallest)
// new corner index. Ties keep their original order, so the result is deterministic. Corner
// order inside a tet is kept, so orientation is unchanged.
#include <algorithm>
#include <cstdint>
#include <limits>
#include <numeric>
#include <random>
#include <vector>

#include "pliant/tet_mesh.hpp"

namespace pliant {
namespace {

constexpr int kBits = 21;  // per axis: 63-bit keys

// Index along the Hilbert curve of order kBits of a point with integer coordinates in
// [0, 2^kBits): J. Skilling, "Programming the Hilbert curve", AIP Conf. Proc. 707 (2004).
std::uint64_t hilbert_index(std::uint32_t X[3]) {
  const std::uint32_t M = 1u << (kBits - 1);
  for (std::uint32_t Q = M; Q > 1; Q >>= 1) {  // inverse undo excess work
    const std::uint32_t P = Q - 1;
    for (int i = 0; i < 3; ++i) {
      if (X[i] & Q) {
        X[0] ^= P;
      } else {
        const std::uint32_t t = (X[0] ^ X[i]) & P;
        X[0] ^= t;
        X[i] ^= t;
      }
    }
  }
  for (int i = 1; i < 3; ++i) X[i] ^= X[i - 1];  // Gray encode
  std::uint32_t t = 0;
  for (std::uint32_t Q = M; Q > 1; Q >>= 1)
    if (X[2] & Q) t ^= Q - 1;
  for (int i = 0; i < 3; ++i) X[i] ^= t;
  std::uint64_t key = 0;  // interleave the transposed bits, most significant first
  for (int b = kBits - 1; b >= 0; --b)
    for (int i = 0; i < 3; ++i) key = (key << 1) | ((X[i] >> b) & 1u);
  return key;
}

struct Quantiser {
  double lo[3] = {0, 0, 0};
  double scale = 0;  // cells per m, the same on every axis so the curve is not stretched
  explicit Quantiser(const std::vector<double>& points) {
    double hi[3];
    for (int k = 0; k < 3; ++k) {
      lo[k] = std::numeric_limits<double>::infinity();
      hi[k] = -lo[k];
    }
    for (std::size_t i = 0; i + 2 < points.size(); i += 3)
      for (int k = 0; k < 3; ++k) {
        lo[k] = std::min(lo[k], points[i + k]);
        hi[k] = std::max(hi[k], points[i + k]);
      }
    const double extent = std::max({hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]});
    scale = extent > 0 ? double((1u << kBits) - 1) / extent : 0.0;
  }
  std::uint64_t key(const double p[3]) const {
    std::uint32_t X[3];
    for (int k = 0; k < 3; ++k) {
      const double c = (p[k] - lo[k]) * scale;
      X[k] = c <= 0 ? 0u : c >= double((1u << kBits) - 1) ? (1u << kBits) - 1 : std::uint32_t(c);
    }
    return hilbert_index(X);
  }
};

// Permutation sorting `keys` (ties in index order): order[new] = old.
std::vector<std::int32_t> sorted_order(const std::vector<std::uint64_t>& keys) {
  std::vector<std::int32_t> order(keys.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](std::int32_t a, std::int32_t b) { return keys[a] < keys[b]; });
  return order;
}

}  // namespace

std::vector<std::int32_t> renumber_for_locality(TetMesh& mesh) {
  const std::size_t nn = mesh.node_count(), nt = mesh.tet_count();
  const Quantiser quantiser(mesh.points);

  std::vector<std::uint64_t> keys(nn);
  for (std::size_t i = 0; i < nn; ++i) keys[i] = quantiser.key(&mesh.points[3 * i]);
  const std::vector<std::int32_t> node_order = sorted_order(keys);
  std::vector<std::int32_t> old_to_new(nn);
  std::vector<double> points(mesh.points.size());
  for (std::size_t j = 0; j < nn; ++j) {
    const std::int32_t i = node_order[j];
    old_to_new[std::size_t(i)] = std::int32_t(j);
    for (int k = 0; k < 3; ++k) points[3 * j + k] = mesh.points[3 * std::size_t(i) + k];
  }
  mesh.points = std::move(points);

  // Tets by their two smallest new corner indices: a tet comes where its first node does, so
  // the tets around a node sit together, and consecutive nodes share them (the gather walks the
  // corner forces nearly in order). Sorting tets along the curve by centroid instead gave the
  // same element pass but a gather 2x slower over 1M tets (docs/performance.md).
  keys.assign(nt, 0);
  for (std::size_t t = 0; t < nt; ++t) {
    std::int32_t c[4];
    for (int a = 0; a < 4; ++a) c[a] = old_to_new[std::size_t(mesh.tets[t][a])];
    std::sort(c, c + 4);
    keys[t] = (std::uint64_t(std::uint32_t(c[0])) << 32) | std::uint32_t(c[1]);
  }
  const std::vector<std::int32_t> tet_order = sorted_order(keys);
  std::vector<Tet> tets(nt);
  for (std::size_t j = 0; j < nt; ++j) {
    const Tet& old = mesh.tets[std::size_t(tet_order[j])];
    for (int a = 0; a < 4; ++a) tets[j][a] = old_to_new[std::size_t(old[a])];
  }
  mesh.tets = std::move(tets);
  return old_to_new;
}

TetMesh shuffled_order(const TetMesh& mesh, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::vector<std::int32_t> perm(mesh.node_count());
  std::iota(perm.begin(), perm.end(), 0);
  std::shuffle(perm.begin(), perm.end(), rng);  // perm[old] = new
  TetMesh m;
  m.points.resize(mesh.points.size());
  for (std::size_t i = 0; i < mesh.node_count(); ++i)
    for (int k = 0; k < 3; ++k) m.points[3 * std::size_t(perm[i]) + k] = mesh.points[3 * i + k];
  m.tets = mesh.tets;
  for (auto& t : m.tets)
    for (auto& c : t) c = perm[std::size_t(c)];
  std::shuffle(m.tets.begin(), m.tets.end(), rng);
  return m;
}

}  // namespace pliant
