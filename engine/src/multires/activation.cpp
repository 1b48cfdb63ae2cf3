// Who is active where in a multiresolution body (activation.hpp).
#include "activation.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <fmt/format.h>

#include "pliant/error.hpp"
#include "tet_locator.hpp"
#include <array>

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
  // Whether each region held a node of some level: one outside the body left it at its coarsest
  // level without a word (fixed and load regions that select nothing are errors too).
  std::vector<std::uint8_t> selected(active.regions.size(), 0);
  for (int l = 0; l < n; ++l) {
    const TetMesh& m = h.meshes[std::size_t(l)];
    auto& t = target[std::size_t(l)];
    switch (active.kind) {
      case ActiveDef::Kind::finest: t.assign(m.node_count(), n - 1); break;
      case ActiveDef::Kind::coarsest:
      case ActiveDef::Kind::adaptive: t.assign(m.node_count(), 0); break;  // adaptive: starts coarsest
      case ActiveDef::Kind::level: t.assign(m.node_count(), active.level); break;
      case ActiveDef::Kind::regions: {
        t.assign(m.node_count(), 0);
        const double tol = 1e-9 * mesh_diagonal(m);
        for (std::size_t r = 0; r < active.regions.size(); ++r) {
          const ActiveRegionDef& a = active.regions[r];
          if (a.level < 0 || a.level >= n)
            throw InputError(fmt::format("multiresolution.active: level {} does not exist (levels 0 .. {})", a.level, n - 1));
          if (a.region.kind == RegionDef::Kind::nodes) {
            if (l != n - 1) continue;  // node lists count in the finest mesh
            for (auto i : a.region.nodes) {
              if (i < 0 || std::size_t(i) >= m.node_count())
                throw InputError(fmt::format("multiresolution.active: node {} does not exist (the finest mesh has {} nodes)",
                                             i, m.node_count()));
              t[std::size_t(i)] = std::max(t[std::size_t(i)], a.level);
              selected[r] = 1;
            }
          } else {
            for (std::size_t i = 0; i < m.node_count(); ++i)
              if (region_holds(a.region, m.point(i), tol)) {
                t[i] = std::max(t[i], a.level);
                selected[r] = 1;
              }
          }
        }
        break;
      }
    }
  }
  for (std::size_t r = 0; r < selected.size(); ++r)
    if (active.kind == ActiveDef::Kind::regions && !selected[r])
      throw InputError(fmt::format("multiresolution.active.regions[{}] selects no node of any level", r));
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
  return ActivationState(h, node_targets(h, active)).snapshot();
}

void sort_unique_marked(std::vector<std::int32_t>& v, std::vector<std::uint8_t>& mark) {
  std::size_t out = 0;
  for (std::size_t i = 0; i < v.size(); ++i)
    if (!mark[std::size_t(v[i])]) {
      mark[std::size_t(v[i])] = 1;
      v[out++] = v[i];
    }
  v.resize(out);
  for (auto x : v) mark[std::size_t(x)] = 0;
  std::sort(v.begin(), v.end());
}

namespace {

void sort_unique(std::vector<std::int32_t>& v) {
  std::sort(v.begin(), v.end());
  v.erase(std::unique(v.begin(), v.end()), v.end());
}

}  // namespace

ActivationState::~ActivationState() = default;

ActivationState::ActivationState(const Hierarchy& h, std::vector<std::vector<int>> targets) : h_(h), targets_(std::move(targets)) {
  const std::size_t n = h.levels();
  constexpr int kFace[4][3] = {{1, 2, 3}, {0, 2, 3}, {0, 1, 3}, {0, 1, 2}};
  tet_locators_.resize(n);
  node_locators_.resize(n);
  reach_.resize(n);
  node_tet_offsets_.resize(n);
  node_tet_list_.resize(n);
  child_offsets_.resize(n);
  child_list_.resize(n);
  neighbours_.resize(n);
  present_.resize(n);
  refined_.resize(n);
  stepped_.resize(n);
  share_.resize(n);
  cover_offsets_.resize(n);
  cover_list_.resize(n);
  node_mark_.resize(n);
  tet_mark_.resize(n);
  stepped_incident_.resize(n);
  role_.resize(n);
  sources_.resize(n);
  dependents_.resize(n);
  reads_.resize(n);
  dirty_targets_.resize(n);
  for (std::size_t l = 0; l < n; ++l) {
    const TetMesh& m = h.meshes[l];
    tet_locators_[l] = std::make_unique<TetLocator>(m);
    node_mark_[l].assign(m.node_count(), 0);
    tet_mark_[l].assign(m.tet_count(), 0);
    node_locators_[l] = std::make_unique<NodeLocator>(m);
    // Non-nested meshes leave slivers between the stepped tets of neighbouring levels; a node of a
    // finer level this close to a coarser stepped tet (a quarter of its own level's mean edge) is
    // still tied to it (its weights there extrapolate slightly), so that no stepped part floats free.
    reach_[l] = 0.25 * mean_edge(m);
    // Per node, per coarser level c: the tets of c that can be its ghost source or cover it, in the
    // order containing_or_near prefers them (TetLocator::candidates; hinted by the node's link for
    // the next coarser level, by its located tet for the others, as the searches were). A change's
    // roles and coverage then read masks: on the 50k-tet organ a node's search took ~1 us, about
    // 40 % of the update() of a change (2026-11-28).
    cover_offsets_[l].resize(l);
    cover_list_[l].resize(l);
    for (std::size_t c = 0; c < l; ++c) {
      auto& off = cover_offsets_[l][c];
      auto& list = cover_list_[l][c];
      off.assign(1, 0);
      off.reserve(m.node_count() + 1);
      for (std::size_t i = 0; i < m.node_count(); ++i) {
        const Vec3d p = m.point(i);
        const std::int32_t hint = c + 1 == l ? h.links[l].to_coarser[i].tet : tet_locators_[c]->locate(p).tet;
        tet_locators_[c]->candidates(p, reach_[l], hint, list);
        off.push_back(std::int32_t(list.size()));
      }
    }
    auto& off = node_tet_offsets_[l];
    off.assign(m.node_count() + 1, 0);
    for (const Tet& t : m.tets)
      for (int c = 0; c < 4; ++c) ++off[std::size_t(t[std::size_t(c)]) + 1];
    for (std::size_t i = 0; i < m.node_count(); ++i) off[i + 1] += off[i];
    node_tet_list_[l].resize(std::size_t(off.back()));
    {
      std::vector<std::int32_t> cursor(off.begin(), off.end() - 1);
      for (std::size_t t = 0; t < m.tet_count(); ++t)
        for (int c = 0; c < 4; ++c) node_tet_list_[l][std::size_t(cursor[std::size_t(m.tets[t][std::size_t(c)])]++)] = std::int32_t(t);
    }
    std::map<std::array<std::int32_t, 3>, std::array<std::int32_t, 2>> faces;
    for (std::size_t t = 0; t < m.tet_count(); ++t)
      for (const auto& f : kFace) {
        std::array<std::int32_t, 3> key{m.tets[t][std::size_t(f[0])], m.tets[t][std::size_t(f[1])], m.tets[t][std::size_t(f[2])]};
        std::sort(key.begin(), key.end());
        auto [it, fresh] = faces.try_emplace(key, std::array<std::int32_t, 2>{std::int32_t(t), -1});
        if (!fresh) it->second[1] = std::int32_t(t);
      }
    neighbours_[l].assign(m.tet_count(), {-1, -1, -1, -1});
    for (const auto& [key, pair] : faces)
      if (pair[1] >= 0) {
        for (int side = 0; side < 2; ++side) {
          auto& nb = neighbours_[l][std::size_t(pair[std::size_t(side)])];
          for (auto& slot : nb)
            if (slot < 0) {
              slot = pair[std::size_t(1 - side)];
              break;
            }
        }
      }
  }
  straddling_.assign(n, 0);
  for (std::size_t l = 1; l < n; ++l)
    for (std::size_t t = 0; t < h.meshes[l].tet_count(); ++t) straddling_[l] += straddles(l, std::int32_t(t));
  // Coarser tet -> the straddling finer tets with a corner near its surface (within the finer
  // level's reach, not deeper inside it): those whose presence can change with its coverage.
  near_offsets_.assign(n, std::vector<std::vector<std::int32_t>>(n));
  near_list_.assign(n, std::vector<std::vector<std::int32_t>>(n));
  for (std::size_t l = 1; l < n; ++l) {
    if (straddling_[l] == 0) continue;
    const TetMesh& m = h.meshes[l];
    for (std::size_t c = 0; c < l; ++c) {
      // Per corner node of a straddling tet (a node is a corner of about 20 tets), then per tet.
      std::vector<std::int32_t> node_off(m.node_count() + 1, 0), node_list;
      std::vector<std::uint8_t> corner(m.node_count(), 0);
      for (std::size_t t = 0; t < m.tet_count(); ++t)
        if (straddles(l, std::int32_t(t)))
          for (int a = 0; a < 4; ++a) corner[std::size_t(m.tets[t][std::size_t(a)])] = 1;
      for (std::size_t v = 0; v < m.node_count(); ++v) {
        if (corner[v]) tet_locators_[c]->near_surface(m.point(v), reach_[l], node_list);
        node_off[v + 1] = std::int32_t(node_list.size());
      }
      std::vector<std::pair<std::int32_t, std::int32_t>> pairs;  // (coarse tet, fine tet)
      std::vector<std::int32_t> found;
      for (std::size_t t = 0; t < m.tet_count(); ++t) {
        if (!straddles(l, std::int32_t(t))) continue;
        found.clear();
        for (int a = 0; a < 4; ++a) {
          const auto v = std::size_t(m.tets[t][std::size_t(a)]);
          found.insert(found.end(), node_list.begin() + node_off[v], node_list.begin() + node_off[v + 1]);
        }
        sort_unique(found);
        for (auto k : found) pairs.push_back({k, std::int32_t(t)});
      }
      std::sort(pairs.begin(), pairs.end());
      auto& off = near_offsets_[c][l];
      off.assign(h.meshes[c].tet_count() + 1, 0);
      for (const auto& pr : pairs) ++off[std::size_t(pr.first) + 1];
      for (std::size_t k = 0; k < h.meshes[c].tet_count(); ++k) off[k + 1] += off[k];
      auto& list = near_list_[c][l];
      list.reserve(pairs.size());
      for (const auto& pr : pairs) list.push_back(pr.second);
    }
  }
  for (std::size_t l = 0; l + 1 < n; ++l) {  // tet -> the finer tets that reach into it
    const auto& poff = h.links[l + 1].tet_parent_offsets;
    const auto& parents = h.links[l + 1].tet_parents;
    auto& off = child_offsets_[l];
    off.assign(h.meshes[l].tet_count() + 1, 0);
    for (auto p : parents) ++off[std::size_t(p) + 1];
    for (std::size_t t = 0; t < h.meshes[l].tet_count(); ++t) off[t + 1] += off[t];
    child_list_[l].resize(std::size_t(off.back()));
    std::vector<std::int32_t> cursor(off.begin(), off.end() - 1);
    for (std::size_t c = 0; c + 1 < poff.size(); ++c)
      for (auto e = poff[c]; e < poff[c + 1]; ++e)
        child_list_[l][std::size_t(cursor[std::size_t(parents[std::size_t(e)])]++)] = std::int32_t(c);
  }

  // The whole body, as for a static split.
  for (std::size_t l = 0; l < n; ++l) {
    const TetMesh& m = h.meshes[l];
    auto& pr = present_[l];
    auto& rf = refined_[l];
    pr.assign(m.tet_count(), 0);
    rf.assign(m.tet_count(), 0);
    for (std::size_t t = 0; t < m.tet_count(); ++t) {
      pr[t] = l == 0 ? 1 : present_from_parents(l, std::int32_t(t));
      if (l + 1 < n)
        for (int c = 0; c < 4; ++c) rf[t] |= std::uint8_t(targets_[l][std::size_t(m.tets[t][std::size_t(c)])] > int(l));
    }
    if (l + 1 < n) refine_dangling(m, pr, rf);
    stepped_[l].resize(m.tet_count());
    share_[l].resize(m.tet_count());
    for (std::size_t t = 0; t < m.tet_count(); ++t) share_[l][t] = share_from_parents(l, std::int32_t(t));
    stepped_incident_[l].assign(m.node_count(), 0);
    stepped_count_.resize(n);
    stepped_count_[l] = 0;
    split_count_.resize(n);
    split_count_[l] = 0;
    for (std::size_t t = 0; t < m.tet_count(); ++t) split_count_[l] += pr[t] && rf[t];
    for (std::size_t t = 0; t < m.tet_count(); ++t) {
      stepped_[l][t] = pr[t] && !rf[t];
      stepped_count_[l] += stepped_[l][t];
      if (stepped_[l][t])
        for (int c = 0; c < 4; ++c) ++stepped_incident_[l][std::size_t(m.tets[t][std::size_t(c)])];
    }
    role_[l].assign(m.node_count(), NodeRole::inactive);
    sources_[l].assign(m.node_count(), {});
    reads_[l].assign(m.node_count(), {-1, -1, -1, -1, -1});
    dependents_[l].assign(m.node_count(), {});
  }
  for (std::size_t l = 0; l < n; ++l) {
    bool changed = false;
    for (std::size_t i = 0; i < h.meshes[l].node_count(); ++i) evaluate_node(int(l), std::int32_t(i), changed);
  }
}

std::pair<const std::int32_t*, const std::int32_t*> ActivationState::node_tets(int l, std::int32_t node) const {
  const auto& off = node_tet_offsets_[std::size_t(l)];
  const std::int32_t* base = node_tet_list_[std::size_t(l)].data();
  return {base + off[std::size_t(node)], base + off[std::size_t(node) + 1]};
}

bool ActivationState::straddles(std::size_t l, std::int32_t t) const {
  const LevelLinks& lk = h_.links[l];
  return lk.tet_parent_offsets[std::size_t(t) + 1] - lk.tet_parent_offsets[std::size_t(t)] > 1;
}

bool ActivationState::split(std::size_t l, std::int32_t t) const {
  return t >= 0 && present_[l][std::size_t(t)] && refined_[l][std::size_t(t)];
}

std::uint8_t ActivationState::present_from_parents(std::size_t l, std::int32_t t) const {
  const LevelLinks& lk = h_.links[l];
  if (split(l - 1, lk.tet_parent[std::size_t(t)])) return 1;
  const Tet& tet = h_.meshes[l].tets[std::size_t(t)];
  for (int a = 0; a < 4; ++a)
    if (split(l - 1, lk.tet_corner_parent[std::size_t(t)][std::size_t(a)]) && !covered(int(l), tet[std::size_t(a)])) return 1;
  return 0;
}

std::uint8_t ActivationState::share_from_parents(std::size_t l, std::int32_t t) const {
  if (l == 0) return kMassShares;
  const LevelLinks& lk = h_.links[l];
  int share = split(l - 1, lk.tet_parent[std::size_t(t)]);
  for (int a = 0; a < 4; ++a) share += split(l - 1, lk.tet_corner_parent[std::size_t(t)][std::size_t(a)]);
  return std::uint8_t(share);
}

std::int32_t ActivationState::source_tet(int l, std::int32_t node, int c) const {
  const auto& off = cover_offsets_[std::size_t(l)][std::size_t(c)];
  const auto& list = cover_list_[std::size_t(l)][std::size_t(c)];
  const auto& stepped = stepped_[std::size_t(c)];
  for (auto e = off[std::size_t(node)]; e < off[std::size_t(node) + 1]; ++e)
    if (stepped[std::size_t(list[std::size_t(e)])]) return list[std::size_t(e)];
  return -1;
}

bool ActivationState::covered(int l, std::int32_t node) const {
  for (int c = 0; c < l; ++c)
    if (source_tet(l, node, c) >= 0) return true;
  return false;
}

void ActivationState::evaluate_node(int l, std::int32_t i, bool& changed) {
  NodeRole role = NodeRole::inactive;
  std::vector<GhostSource>& acc = acc_;  // scratch kept between calls (a vector per node was a malloc each)
  acc.clear();
  std::array<std::int32_t, 5> reads{-1, -1, -1, -1, -1};  // the level and corners of the tet it reads
  if (stepped_incident_[std::size_t(l)][std::size_t(i)] > 0) {
    role = NodeRole::active;
    for (int c = 0; c < l; ++c) {  // the coarsest stepped tet covering the node
      // containing_or_near(p, stepped_[c], reach_[l]) from the node's listed candidates.
      TetLink link;
      link.tet = source_tet(l, i, c);
      if (link.tet < 0) continue;
      link.weights = tet_locators_[std::size_t(c)]->weights(link.tet, h_.meshes[std::size_t(l)].point(std::size_t(i)));
      role = NodeRole::ghost;
      const Tet& tet = h_.meshes[std::size_t(c)].tets[std::size_t(link.tet)];
      reads = {c, tet[0], tet[1], tet[2], tet[3]};
      for (int k = 0; k < 4; ++k) {
        const std::int32_t s = tet[std::size_t(k)];
        if (role_[std::size_t(c)][std::size_t(s)] == NodeRole::active) {
          acc.push_back({c, s, link.weights[std::size_t(k)]});
        } else {  // a ghost corner: its own (active) sources
          for (GhostSource src : sources_[std::size_t(c)][std::size_t(s)]) {
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
      break;
    }
  }
  auto& old_sources = sources_[std::size_t(l)][std::size_t(i)];
  auto same = [&] {
    if (role != role_[std::size_t(l)][std::size_t(i)] || acc.size() != old_sources.size()) return false;
    for (std::size_t e = 0; e < acc.size(); ++e)
      if (acc[e].level != old_sources[e].level || acc[e].node != old_sources[e].node || acc[e].weight != old_sources[e].weight)
        return false;
    return true;
  };
  // A ghost depends on the corners of the tet it reads (their roles and sources make its own).
  auto& old_reads = reads_[std::size_t(l)][std::size_t(i)];
  if (old_reads != reads) {
    for (int k = 1; k < 5 && old_reads[0] >= 0; ++k) {
      auto& d = dependents_[std::size_t(old_reads[0])][std::size_t(old_reads[std::size_t(k)])];
      d.erase(std::remove(d.begin(), d.end(), std::pair<std::int32_t, std::int32_t>{l, i}), d.end());
    }
    for (int k = 1; k < 5 && reads[0] >= 0; ++k)
      dependents_[std::size_t(reads[0])][std::size_t(reads[std::size_t(k)])].push_back({l, i});
    old_reads = reads;
  }
  if (same()) return;
  changed = true;
  role_[std::size_t(l)][std::size_t(i)] = role;
  old_sources.assign(acc.begin(), acc.end());
}

void ActivationState::set_target(int l, std::int32_t node, int target) {
  if (targets_[std::size_t(l)][std::size_t(node)] == target) return;
  targets_[std::size_t(l)][std::size_t(node)] = target;
  dirty_targets_[std::size_t(l)].push_back(node);
}

ActivationState::Changes ActivationState::update() {
  const std::size_t n = h_.levels();
  Changes ch;
  ch.tets_on.resize(n);
  ch.tets_off.resize(n);
  ch.tets_reweighed.resize(n);
  ch.nodes.resize(n);
  std::vector<std::vector<std::int32_t>> nodes(n);  // to evaluate, per level
  std::vector<std::int32_t> from_parents;           // tets of this level whose parent changed
  // The boxes of the tets that changed, per level: the finer nodes they cover are evaluated again
  // (their ghost sources may change), on the finer levels that step a tet before or after. A level
  // that steps none has no node but inactive ones, whatever covers them (the 50k-tet organ capped
  // at its middle level found ~100 of its inactive fine nodes per changed coarse tet, 7 us each).
  std::vector<std::size_t> stepped_before = stepped_count_;
  std::vector<std::vector<std::pair<Vec3d, Vec3d>>> boxes(n);
  std::vector<std::vector<std::int32_t>> changed_tets(n);  // per level: the tets of `boxes`
  for (std::size_t l = 0; l < n; ++l) {
    const TetMesh& m = h_.meshes[l];
    std::vector<std::int32_t> cand = std::move(from_parents);
    from_parents.clear();
    sort_unique(dirty_targets_[l]);
    for (auto node : dirty_targets_[l]) {
      auto [b, e] = node_tets(int(l), node);
      cand.insert(cand.end(), b, e);
    }
    dirty_targets_[l].clear();
    // A tet is also present by its corners that no coarser stepped tet covers (present_from_parents):
    // where coarser tets started or stopped being stepped, the straddling tets listed near them
    // (none in nested levels; and none can be present while the level above has no split tet).
    if (l > 0 && straddling_[l] > 0 && split_count_[l - 1] > 0) {
      auto& tm = tet_mark_[l];
      std::vector<std::int32_t>& near_tets = scratch_tets_;
      for (std::size_t c = 0; c < l; ++c)
        for (auto k : changed_tets[c])
          for (auto e = near_offsets_[c][l][std::size_t(k)]; e < near_offsets_[c][l][std::size_t(k) + 1]; ++e) {
            const auto t = near_list_[c][l][std::size_t(e)];
            if (tm[std::size_t(t)]) continue;
            tm[std::size_t(t)] = 1;
            near_tets.push_back(t);
          }
      // Only those whose presence the coverage changes (the coarser levels are final by now).
      for (auto t : near_tets) {
        tm[std::size_t(t)] = 0;
        if (present_from_parents(l, t) != present_[l][std::size_t(t)]) cand.push_back(t);
      }
      near_tets.clear();
      }
    sort_unique_marked(cand, tet_mark_[l]);
    // The tets whose refinement rule may give another answer: the candidates and their face
    // neighbours (a dangling tet is one whose neighbours changed).
    std::vector<std::int32_t> region = cand;
    for (auto t : cand)
      for (auto nb : neighbours_[l][std::size_t(t)])
        if (nb >= 0) region.push_back(nb);
    // With them, every tet refined only by the dangling rule that touches the region (through such
    // tets): once the refinement that made them dangle is gone they may not dangle any more. The
    // rule's least fixed point is then recomputed from the targets over the whole region.
    if (l + 1 < n) {
      // (The region's tets marked while it grows: a sorted copy searched and inserted into was
      // quadratic in the region, 85-100 us of the first change of the 50k-tet organ's middle level.)
      auto& tm = tet_mark_[l];
      std::vector<std::int32_t>& stack = scratch_tets_;
      stack.clear();
      for (auto t : region)
        if (!tm[std::size_t(t)]) {
          tm[std::size_t(t)] = 1;
          stack.push_back(t);
        }
      while (!stack.empty()) {
        const auto t = stack.back();
        stack.pop_back();
        for (auto nb : neighbours_[l][std::size_t(t)]) {
          if (nb < 0 || !refined_[l][std::size_t(nb)] || tm[std::size_t(nb)]) continue;
          bool by_target = false;
          for (int c = 0; c < 4; ++c) by_target |= targets_[l][std::size_t(m.tets[std::size_t(nb)][std::size_t(c)])] > int(l);
          if (by_target) continue;  // refined by its corners, not by the dangling rule
          tm[std::size_t(nb)] = 1;
          region.push_back(nb);
          stack.push_back(nb);
        }
      }
      for (auto t : region) tm[std::size_t(t)] = 0;
    }
    sort_unique_marked(region, tet_mark_[l]);
    std::vector<std::uint8_t> was_stepped, was_split;
    was_stepped.reserve(region.size());
    was_split.reserve(region.size());
    for (auto t : region) {
      was_stepped.push_back(stepped_[l][std::size_t(t)]);
      was_split.push_back(present_[l][std::size_t(t)] && refined_[l][std::size_t(t)]);
      // Present from the parent, refined from the corners' targets; the dangling rule below.
      if (l > 0) present_[l][std::size_t(t)] = present_from_parents(l, t);
      std::uint8_t rf = 0;
      if (l + 1 < n)
        for (int c = 0; c < 4; ++c) rf |= std::uint8_t(targets_[l][std::size_t(m.tets[std::size_t(t)][std::size_t(c)])] > int(l));
      refined_[l][std::size_t(t)] = rf;
    }
    if (l + 1 < n) {
      // The rule's cascade may refine tets beyond the region: they join it (stepped before, since
      // they were present and unrefined).
      // (The search runs over the sorted region only: the cascade's tets appended after it are not
      // sorted, and a region tet missed there was listed twice, once as turned off.)
      std::vector<std::int32_t> cascade;
      for (std::size_t k = 0; k < region.size(); ++k) refine_rule(int(l), region[k], cascade);
      const auto sorted = std::ptrdiff_t(region.size());
      for (auto t : cascade)
        if (!std::binary_search(region.begin(), region.begin() + sorted, t)) {
          region.push_back(t);
          was_stepped.push_back(present_[l][std::size_t(t)]);
          was_split.push_back(0);
        }
    }
    ch.tets_examined += region.size();
    for (std::size_t k = 0; k < region.size(); ++k) {
      const auto t = region[k];
      const std::uint8_t now = present_[l][std::size_t(t)] && !refined_[l][std::size_t(t)];
      const std::uint8_t split = present_[l][std::size_t(t)] && refined_[l][std::size_t(t)];
      if (split != was_split[k]) split_count_[l] = split ? split_count_[l] + 1 : split_count_[l] - 1;
      if (split != was_split[k] && l + 1 < n)
        from_parents.insert(from_parents.end(), child_list_[l].begin() + child_offsets_[l][std::size_t(t)],
                            child_list_[l].begin() + child_offsets_[l][std::size_t(t) + 1]);
      const std::uint8_t share = share_from_parents(l, t);
      if (share != share_[l][std::size_t(t)]) {
        share_[l][std::size_t(t)] = share;
        if (now && was_stepped[k]) ch.tets_reweighed[l].push_back(t);
      }
      if (now == was_stepped[k]) continue;
      stepped_[l][std::size_t(t)] = now;
      stepped_count_[l] = now ? stepped_count_[l] + 1 : stepped_count_[l] - 1;
      (now ? ch.tets_on : ch.tets_off)[l].push_back(t);
      Vec3d lo{1e300, 1e300, 1e300}, hi{-1e300, -1e300, -1e300};
      for (int c = 0; c < 4; ++c) {
        const std::int32_t v = m.tets[std::size_t(t)][std::size_t(c)];
        stepped_incident_[l][std::size_t(v)] += now ? 1 : -1;
        nodes[l].push_back(v);
        const Vec3d p = m.point(std::size_t(v));
        for (int d = 0; d < 3; ++d) {
          lo[std::size_t(d)] = std::min(lo[std::size_t(d)], p[std::size_t(d)]);
          hi[std::size_t(d)] = std::max(hi[std::size_t(d)], p[std::size_t(d)]);
        }
      }
      boxes[l].push_back({lo, hi});
      changed_tets[l].push_back(t);
    }
  }
  // Only nodes of a stepped tet: a node with none is inactive whatever covers it, and was so
  // before unless its own level's tets changed (then it is in nodes[f] already, as a corner of one
  // of them). On the 50k-tet organ a change's boxes held up to 50 000 fine nodes, a few thousand
  // of them at stepped tets.
  for (std::size_t l = 0; l < n; ++l)
    for (const auto& [lo, hi] : boxes[l])
      for (std::size_t f = l + 1; f < n; ++f) {  // the finer nodes this tet covers (or covered)
        if (stepped_before[f] == 0 && stepped_count_[f] == 0) continue;
        const double r = reach_[f];
        node_locators_[f]->in_box({lo[0] - r, lo[1] - r, lo[2] - r}, {hi[0] + r, hi[1] + r, hi[2] + r}, stepped_incident_[f], nodes[f]);
      }
  // Roles, coarse to fine: a ghost's sources are final before it; a node whose role or sources
  // changed sends the ghosts that read it to be evaluated again.
  for (std::size_t l = 0; l < n; ++l) {
    sort_unique_marked(nodes[l], node_mark_[l]);
    ch.nodes_examined += nodes[l].size();
    for (auto v : nodes[l]) {
      bool changed = false;
      evaluate_node(int(l), v, changed);
      if (!changed) continue;
      ch.nodes[l].push_back(v);
      for (const auto& [dl, dn] : dependents_[l][std::size_t(v)]) nodes[std::size_t(dl)].push_back(dn);
    }
  }
  return ch;
}

// The dangling rule of refine_dangling at one tet, and at its neighbours when it changes; the tets
// it refines are appended to `refined_now`.
void ActivationState::refine_rule(int l, std::int32_t t0, std::vector<std::int32_t>& refined_now) {
  std::vector<std::int32_t>& work = rule_work_;
  work.assign(1, t0);
  auto& pr = present_[std::size_t(l)];
  auto& rf = refined_[std::size_t(l)];
  while (!work.empty()) {
    const std::int32_t t = work.back();
    work.pop_back();
    if (!pr[std::size_t(t)] || rf[std::size_t(t)]) continue;
    int against = 0, with = 0;
    for (auto u : neighbours_[std::size_t(l)][std::size_t(t)]) {
      if (u < 0) continue;
      against += pr[std::size_t(u)] && rf[std::size_t(u)];
      with += pr[std::size_t(u)] && !rf[std::size_t(u)];
    }
    if (against >= 3 || (with == 0 && against > 0)) {
      rf[std::size_t(t)] = 1;
      refined_now.push_back(t);
      for (auto u : neighbours_[std::size_t(l)][std::size_t(t)])
        if (u >= 0) work.push_back(u);
    }
  }
}

void ActivationState::for_each_array(const std::function<void(const void*, std::size_t)>& f) const {
  const auto one = [&](const auto& a) {
    if (!a.empty()) f(static_cast<const void*>(a.data()), a.size() * sizeof(a[0]));
  };
  for (std::size_t l = 0; l < h_.levels(); ++l) {
    tet_locators_[l]->for_each_array(f);
    node_locators_[l]->for_each_array(f);
    one(node_tet_offsets_[l]);
    one(node_tet_list_[l]);
    one(child_offsets_[l]);
    one(child_list_[l]);
    one(neighbours_[l]);
    one(targets_[l]);
    one(present_[l]);
    one(refined_[l]);
    one(stepped_[l]);
    one(share_[l]);
    one(stepped_incident_[l]);
    for (std::size_t c = 0; c < near_list_.size(); ++c) {
      one(near_offsets_[c][l]);
      one(near_list_[c][l]);
    }
    one(role_[l]);
    one(sources_[l]);  // (the vectors, not their few heap blocks: a walk over every node)
    one(dependents_[l]);
    one(reads_[l]);
    for (std::size_t c = 0; c < cover_list_[l].size(); ++c) {
      one(cover_offsets_[l][c]);
      one(cover_list_[l][c]);
    }
    one(node_mark_[l]);
    one(tet_mark_[l]);
  }
}

Activation ActivationState::snapshot() const {
  Activation a;
  a.levels.resize(h_.levels());
  for (std::size_t l = 0; l < h_.levels(); ++l) {
    LevelActivation& la = a.levels[l];
    la.stepped = stepped_[l];
    la.share = share_[l];
    la.role = role_[l];
    la.source_offsets.assign(1, 0);
    for (std::size_t i = 0; i < role_[l].size(); ++i) {
      if (role_[l][i] != NodeRole::ghost) continue;
      la.ghosts.push_back(std::int32_t(i));
      la.sources.insert(la.sources.end(), sources_[l][i].begin(), sources_[l][i].end());
      la.source_offsets.push_back(std::int32_t(la.sources.size()));
    }
  }
  return a;
}

}  // namespace pliant::detail
