// Who is active where in a multiresolution body (activation.hpp).
#include "activation.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <fmt/format.h>

#include "pliant/error.hpp"
#include "tet_locator.hpp"

namespace pliant::detail {
namespace {

bool region_holds(const RegionDef& r, const Vec3d& p, double tol) {
  if (r.kind == RegionDef::Kind::box) {
    for (int k = 0; k < 3; ++k)
      if (!(p[std::size_t(k)] >= r.min[std::size_t(k)] - tol && p[std::size_t(k)] <= r.max[std::size_t(k)] + tol)) return false;
    return true;
  }
  if (r.kind == RegionDef::Kind::sphere)
    return std::hypot(p[0] - r.center[0], p[1] - r.center[1], p[2] - r.center[2]) <= r.radius + tol;
  return false;  // node lists: handled by index
}

double mesh_diagonal(const TetMesh& m) {
  Vec3d lo{1e300, 1e300, 1e300}, hi{-1e300, -1e300, -1e300};
  for (std::size_t i = 0; i < m.node_count(); ++i)
    for (std::size_t k = 0; k < 3; ++k) {
      lo[k] = std::min(lo[k], m.points[3 * i + k]);
      hi[k] = std::max(hi[k], m.points[3 * i + k]);
    }
  return std::hypot(hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]);
}

double mean_edge(const TetMesh& m) {
  double sum = 0;
  for (const Tet& t : m.tets)
    for (int a = 0; a < 4; ++a)
      for (int b = a + 1; b < 4; ++b) {
        const Vec3d p = m.point(std::size_t(t[std::size_t(a)])), q = m.point(std::size_t(t[std::size_t(b)]));
        sum += std::hypot(p[0] - q[0], p[1] - q[1], p[2] - q[2]);
      }
  return m.tets.empty() ? 0 : sum / (6.0 * double(m.tets.size()));
}

// A stepped tet with three or four of its faces against refined tets, or none against a stepped tet
// of its level, is a dangling piece of its level: non-nested meshes leave such tets at the edge of
// a finer region, held by a node or an edge, and they flap. Refine them too (and again, for the tets
// this leaves dangling).
void refine_dangling(const TetMesh& m, const std::vector<std::uint8_t>& present, std::vector<std::uint8_t>& refined) {
  constexpr int kFace[4][3] = {{1, 2, 3}, {0, 2, 3}, {0, 1, 3}, {0, 1, 2}};
  std::map<std::array<std::int32_t, 3>, std::array<std::int32_t, 2>> faces;
  for (std::size_t t = 0; t < m.tet_count(); ++t)
    for (const auto& f : kFace) {
      std::array<std::int32_t, 3> key{m.tets[t][std::size_t(f[0])], m.tets[t][std::size_t(f[1])], m.tets[t][std::size_t(f[2])]};
      std::sort(key.begin(), key.end());
      auto [it, fresh] = faces.try_emplace(key, std::array<std::int32_t, 2>{std::int32_t(t), -1});
      if (!fresh) it->second[1] = std::int32_t(t);
    }
  std::vector<std::vector<std::int32_t>> neighbours(m.tet_count());
  for (const auto& [key, pair] : faces)
    if (pair[1] >= 0) {
      neighbours[std::size_t(pair[0])].push_back(pair[1]);
      neighbours[std::size_t(pair[1])].push_back(pair[0]);
    }
  for (bool changed = true; changed;) {
    changed = false;
    for (std::size_t t = 0; t < m.tet_count(); ++t) {
      if (!present[t] || refined[t]) continue;
      int against = 0, with = 0;
      for (auto u : neighbours[t]) {
        const bool refined_u = present[std::size_t(u)] && refined[std::size_t(u)];
        against += refined_u;
        with += present[std::size_t(u)] && !refined[std::size_t(u)];
      }
      if (against >= 3 || (with == 0 && against > 0)) {
        refined[t] = 1;
        changed = true;
      }
    }
  }
}

}  // namespace

std::vector<std::vector<int>> node_targets(const Hierarchy& h, const ActiveDef& active) {
  const int n = int(h.levels());
  std::vector<std::vector<int>> target(static_cast<std::size_t>(n));
  for (int l = 0; l < n; ++l) {
    const TetMesh& m = h.meshes[std::size_t(l)];
    auto& t = target[std::size_t(l)];
    switch (active.kind) {
      case ActiveDef::Kind::finest: t.assign(m.node_count(), n - 1); break;
      case ActiveDef::Kind::coarsest: t.assign(m.node_count(), 0); break;
      case ActiveDef::Kind::level: t.assign(m.node_count(), active.level); break;
      case ActiveDef::Kind::regions: {
        t.assign(m.node_count(), 0);
        const double tol = 1e-9 * mesh_diagonal(m);
        for (const ActiveRegionDef& a : active.regions) {
          if (a.level < 0 || a.level >= n)
            throw InputError(fmt::format("multiresolution.active: level {} does not exist (levels 0 .. {})", a.level, n - 1));
          if (a.region.kind == RegionDef::Kind::nodes) {
            if (l != n - 1) continue;  // node lists count in the finest mesh
            for (auto i : a.region.nodes) {
              if (i < 0 || std::size_t(i) >= m.node_count())
                throw InputError(fmt::format("multiresolution.active: node {} does not exist (the finest mesh has {} nodes)",
                                             i, m.node_count()));
              t[std::size_t(i)] = std::max(t[std::size_t(i)], a.level);
            }
          } else {
            for (std::size_t i = 0; i < m.node_count(); ++i)
              if (region_holds(a.region, m.point(i), tol)) t[i] = std::max(t[i], a.level);
          }
        }
        break;
      }
    }
  }
  // A node whose Voronoi zone reaches into a finer region is split: raise it to its children's.
  for (int l = n - 2; l >= 0; --l) {
    const LevelLinks& lk = h.links[std::size_t(l)];
    auto& t = target[std::size_t(l)];
    for (std::size_t i = 0; i < t.size(); ++i)
      for (auto c = lk.child_offsets[i]; c < lk.child_offsets[i + 1]; ++c)
        t[i] = std::max(t[i], target[std::size_t(l) + 1][std::size_t(lk.children[std::size_t(c)])]);
  }
  return target;
}

Activation activate(const Hierarchy& h, const ActiveDef& active) {
  const int n = int(h.levels());
  const auto target = node_targets(h, active);
  Activation a;
  a.levels.resize(std::size_t(n));

  // Step 2: present, refined, stepped tets.
  std::vector<std::vector<std::uint8_t>> present(static_cast<std::size_t>(n)), refined(static_cast<std::size_t>(n));
  for (int l = 0; l < n; ++l) {
    const TetMesh& m = h.meshes[std::size_t(l)];
    auto& pr = present[std::size_t(l)];
    auto& rf = refined[std::size_t(l)];
    pr.assign(m.tet_count(), 0);
    rf.assign(m.tet_count(), 0);
    for (std::size_t t = 0; t < m.tet_count(); ++t) {
      if (l == 0) {
        pr[t] = 1;
      } else {
        const std::int32_t p = h.links[std::size_t(l)].tet_parent[t];
        pr[t] = p >= 0 && present[std::size_t(l) - 1][std::size_t(p)] && refined[std::size_t(l) - 1][std::size_t(p)];
      }
      if (l + 1 < n)
        for (int c = 0; c < 4; ++c) rf[t] |= std::uint8_t(target[std::size_t(l)][std::size_t(m.tets[t][std::size_t(c)])] > l);
    }
    if (l + 1 < n) refine_dangling(m, pr, rf);
    auto& st = a.levels[std::size_t(l)].stepped;
    st.resize(m.tet_count());
    for (std::size_t t = 0; t < m.tet_count(); ++t) st[t] = pr[t] && !rf[t];
  }

  // Step 3: roles and ghost sources, coarse to fine (a ghost's sources are final before it).
  std::vector<TetLocator> locators;
  locators.reserve(std::size_t(n));
  for (int l = 0; l < n; ++l) locators.emplace_back(h.meshes[std::size_t(l)]);
  // Non-nested meshes leave slivers between the stepped tets of neighbouring levels; a node of a
  // finer level this close to a coarser stepped tet (a quarter of its own level's mean edge) is
  // still tied to it (its weights there extrapolate slightly), so that no stepped part floats free.
  std::vector<double> reach(static_cast<std::size_t>(n));
  for (int l = 0; l < n; ++l) reach[std::size_t(l)] = 0.25 * mean_edge(h.meshes[std::size_t(l)]);
  for (int l = 0; l < n; ++l) {
    const TetMesh& m = h.meshes[std::size_t(l)];
    LevelActivation& la = a.levels[std::size_t(l)];
    std::vector<std::uint8_t> used(m.node_count(), 0);
    for (std::size_t t = 0; t < m.tet_count(); ++t)
      if (la.stepped[t])
        for (int c = 0; c < 4; ++c) used[std::size_t(m.tets[t][std::size_t(c)])] = 1;
    la.role.assign(m.node_count(), NodeRole::inactive);
    la.source_offsets.assign(1, 0);
    std::vector<GhostSource> acc;
    for (std::size_t i = 0; i < m.node_count(); ++i) {
      if (!used[i]) continue;
      la.role[i] = NodeRole::active;
      for (int c = 0; c < l; ++c) {  // the coarsest stepped tet covering the node
        const TetLink link =
            locators[std::size_t(c)].containing_or_near(m.point(i), a.levels[std::size_t(c)].stepped, reach[std::size_t(l)]);
        if (link.tet < 0) continue;
        la.role[i] = NodeRole::ghost;
        acc.clear();
        const LevelActivation& lc = a.levels[std::size_t(c)];
        const Tet& tet = h.meshes[std::size_t(c)].tets[std::size_t(link.tet)];
        for (int k = 0; k < 4; ++k) {
          const std::int32_t s = tet[std::size_t(k)];
          if (lc.role[std::size_t(s)] == NodeRole::active) {
            acc.push_back({c, s, link.weights[std::size_t(k)]});
          } else {  // a ghost corner: its own (active) sources
            const auto g = std::lower_bound(lc.ghosts.begin(), lc.ghosts.end(), s) - lc.ghosts.begin();
            for (auto e = lc.source_offsets[std::size_t(g)]; e < lc.source_offsets[std::size_t(g) + 1]; ++e) {
              GhostSource src = lc.sources[std::size_t(e)];
              src.weight *= link.weights[std::size_t(k)];
              acc.push_back(src);
            }
          }
        }
        std::sort(acc.begin(), acc.end(), [](const GhostSource& x, const GhostSource& y) {
          return x.level != y.level ? x.level < y.level : x.node < y.node;
        });
        std::size_t out = 0;
        for (std::size_t e = 0; e < acc.size(); ++e) {
          if (out > 0 && acc[out - 1].level == acc[e].level && acc[out - 1].node == acc[e].node)
            acc[out - 1].weight += acc[e].weight;
          else
            acc[out++] = acc[e];
        }
        acc.resize(out);
        la.ghosts.push_back(std::int32_t(i));
        la.sources.insert(la.sources.end(), acc.begin(), acc.end());
        la.source_offsets.push_back(std::int32_t(la.sources.size()));
        break;
      }
    }
  }
  return a;
}

}  // namespace pliant::detail
