// apply_changes (apply_changes.hpp): a change of activation patched into the level arrays.
#include "apply_changes.hpp"

#include <algorithm>
#include <initializer_list>
#include <cmath>
#include <fmt/format.h>

#include "../core/simulation.hpp"
#include "adaptivity.hpp"
#include "pliant/error.hpp"
#include "pliant/kernels/element_forces.hpp"

namespace pliant::detail {
namespace {

void sort_unique(std::vector<std::int32_t>& v) {
  std::sort(v.begin(), v.end());
  v.erase(std::unique(v.begin(), v.end()), v.end());
}

// sort_unique for long lists of few distinct nodes (the corners of many tets): duplicates dropped
// with the level's marks first (cleared again), then the distinct ones sorted.
bool holds(const std::vector<std::int32_t>& sorted, std::int32_t x) { return std::binary_search(sorted.begin(), sorted.end(), x); }

// The first run that begins after tet t.
std::vector<Range>::iterator run_after(std::vector<Range>& runs, std::size_t t) {
  return std::upper_bound(runs.begin(), runs.end(), t, [](std::size_t x, const Range& r) { return x < r.begin; });
}

// Tet t starts being stepped: it extends, joins or starts a run (the runs stay maximal, as
// runs_of would give them).
void run_on(std::vector<Range>& runs, std::size_t t) {
  const auto next = run_after(runs, t);
  const bool joins_prev = next != runs.begin() && std::prev(next)->end == t;
  const bool joins_next = next != runs.end() && next->begin == t + 1;
  if (joins_prev && joins_next) {
    std::prev(next)->end = next->end;
    runs.erase(next);
  } else if (joins_prev) {
    std::prev(next)->end = t + 1;
  } else if (joins_next) {
    next->begin = t;
  } else {
    runs.insert(next, Range{t, t + 1});
  }
}

// Tet t stops being stepped: its run shrinks, splits or goes.
void run_off(std::vector<Range>& runs, std::size_t t) {
  const auto at = std::prev(run_after(runs, t));  // the run holding t
  if (at->begin == t && at->end == t + 1) {
    runs.erase(at);
  } else if (at->begin == t) {
    at->begin = t + 1;
  } else if (at->end == t + 1) {
    at->end = t;
  } else {
    const Range tail{t + 1, at->end};
    at->end = t;
    runs.insert(std::next(at), tail);
  }
}

// One entry of a CSR being spliced: its key (ghost, or receiver node) and its columns.
struct Entry {
  std::int32_t key, a, b;
  double w;
};

// The CSR (sorted keys, offsets, columns a, b, w) with the entries of the keys in `changed`
// (ascending) replaced by those of `fresh` (sorted by key; a changed key without any goes). The
// untouched segments are block-copied into ps's buffers, which are then swapped in.
void splice(AlignedVector<std::int32_t>& keys, AlignedVector<std::int32_t>& offsets, AlignedVector<std::int32_t>& ca,
            AlignedVector<std::int32_t>& cb, AlignedVector<double>& cw, const std::vector<std::int32_t>& changed,
            const std::vector<Entry>& fresh, bool no_offsets_without_keys, PatchState& ps) {
  auto &K = ps.keys, &O = ps.offsets, &A = ps.col_a, &B = ps.col_b;
  auto& W = ps.col_w;
  K.clear();
  O.clear();
  A.clear();
  B.clear();
  W.clear();
  K.reserve(keys.size() + changed.size());
  O.reserve(keys.size() + changed.size() + 1);
  A.reserve(ca.size() + fresh.size());
  B.reserve(ca.size() + fresh.size());
  W.reserve(ca.size() + fresh.size());
  O.push_back(0);
  const std::size_t g = keys.size();
  auto copy_old = [&](std::size_t from, std::size_t to) {  // old keys [from, to) and their entries
    if (from >= to) return;
    const std::int32_t shift = std::int32_t(A.size()) - offsets[from];
    K.insert(K.end(), keys.begin() + std::ptrdiff_t(from), keys.begin() + std::ptrdiff_t(to));
    for (std::size_t k = from + 1; k <= to; ++k) O.push_back(offsets[k] + shift);
    const auto b = std::ptrdiff_t(offsets[from]), e = std::ptrdiff_t(offsets[to]);
    A.insert(A.end(), ca.begin() + b, ca.begin() + e);
    B.insert(B.end(), cb.begin() + b, cb.begin() + e);
    W.insert(W.end(), cw.begin() + b, cw.begin() + e);
  };
  std::size_t i = 0, f = 0;
  for (const std::int32_t key : changed) {
    const auto j = std::size_t(std::lower_bound(keys.begin() + std::ptrdiff_t(i), keys.end(), key) - keys.begin());
    copy_old(i, j);
    i = j < g && keys[j] == key ? j + 1 : j;
    const std::size_t before = A.size();
    for (; f < fresh.size() && fresh[f].key == key; ++f) {
      A.push_back(fresh[f].a);
      B.push_back(fresh[f].b);
      W.push_back(fresh[f].w);
    }
    if (A.size() > before) {
      K.push_back(key);
      O.push_back(std::int32_t(A.size()));
    }
  }
  copy_old(i, g);
  if (K.empty() && no_offsets_without_keys) O.clear();
  keys.swap(K);
  offsets.swap(O);
  ca.swap(A);
  cb.swap(B);
  cw.swap(W);
}

std::uint8_t state_of(NodeRole r) { return r == NodeRole::active ? kNodeFree : r == NodeRole::ghost ? kNodeGhost : kNodeInactive; }
bool active_state(std::uint8_t s) { return s == kNodeFree || s == kNodeFixed; }

[[noreturn]] void none(const BodyDef& def, const std::string& what) {
  throw InputError(fmt::format("body '{}': {} selects no node simulated at any level (the region lies where "
                               "no level is active, or between nodes)",
                               def.name, what));
}

}  // namespace

std::uint8_t ChangeSet::was(int l, std::int32_t node, std::uint8_t now) const {
  const auto& c = changed[std::size_t(l)];
  const auto it = std::lower_bound(c.begin(), c.end(), node);
  return it != c.end() && *it == node ? old_state[std::size_t(l)][std::size_t(it - c.begin())] : now;
}

template <class T>
PatchState make_patch_state(SimBody<T>& body, const Hierarchy& h, const ActivationState& as) {
  const std::size_t n = h.levels();
  const BodyDef& def = body.def;
  PatchState ps;
  ps.quarter_mass.resize(n);
  ps.own_mass.resize(n);
  ps.mark.resize(n);
  for (std::size_t l = 0; l < n; ++l) {
    const TetMesh& m = h.meshes[l];
    Level<T>& L = body.levels[l];
    ps.mark[l].assign(m.node_count(), 0);
    auto& q = ps.quarter_mass[l];
    q.resize(m.tet_count());
    for (std::size_t t = 0; t < m.tet_count(); ++t) q[t] = def.material.density * tet_rest_volume(m, t) / 4;
    if (l + 1 == n) {  // the finest volume, summed as the full apply sums it
      ps.volume = 0;
      for (std::size_t t = 0; t < m.tet_count(); ++t) ps.volume += tet_rest_volume(m, t);
    }
    ps.renormalise_after += m.node_count();
    std::vector<std::uint8_t> on(m.tet_count(), 0);
    for (const Range& r : L.stepped_runs)
      for (std::size_t t = r.begin; t < r.end; ++t) on[t] = 1;
    auto& own = ps.own_mass[l];
    own.assign(m.node_count(), 0.0);
    for (std::size_t t = 0; t < m.tet_count(); ++t) {
      if (on[t]) {
        const double share = q[t] * as.mass_share(int(l), std::int32_t(t));
        for (int a = 0; a < 4; ++a) own[std::size_t(m.tets[t][std::size_t(a)])] += share;
      } else {  // never written by an element pass from now on, and summed by the gather
        for (auto& c : L.corner_force) c[t] = T(0);
      }
    }
  }
  // Raw masses (before the factor): own, plus the ghosts' own moved to their sources.
  ps.raw_mass = ps.own_mass;
  for (std::size_t l = 0; l < n; ++l) {
    const Level<T>& L = body.levels[l];
    for (std::size_t g = 0; g < L.ghosts.size(); ++g) {
      const auto node = std::size_t(L.ghosts[g]);
      for (auto e = L.ghost_offsets[g]; e < L.ghost_offsets[g + 1]; ++e)
        ps.raw_mass[std::size_t(L.ghost_source_level[std::size_t(e)])][std::size_t(L.ghost_source_node[std::size_t(e)])] +=
            L.ghost_weight[std::size_t(e)] * ps.own_mass[l][node];
      ps.raw_mass[l][node] = 0;
    }
  }
  ps.raw_total = 0;
  for (const auto& level : ps.raw_mass)
    for (const double m : level) ps.raw_total += m;
  auto select = [&](const RegionDef& r, const std::string& what, std::vector<std::vector<std::int32_t>>& per_level) {
    std::size_t count = 0;
    per_level.resize(n);
    for (std::size_t l = 0; l < n; ++l) {
      per_level[l] = select_nodes(h.meshes[l], r, what, def.name, true);
      for (auto v : per_level[l]) count += active_state(body.levels[l].state[std::size_t(v)]);
    }
    return count;
  };
  ps.fixed.resize(def.fixed.size());
  for (std::size_t i = 0; i < def.fixed.size(); ++i)
    ps.fixed_count.push_back(select(def.fixed[i], fmt::format("fixed[{}]", i), ps.fixed[i]));
  ps.prescribed.resize(def.prescribed.size());
  for (std::size_t i = 0; i < def.prescribed.size(); ++i)
    ps.prescribed_count.push_back(select(def.prescribed[i].region, fmt::format("prescribed[{}]", i), ps.prescribed[i]));
  ps.loads.resize(def.loads.size());
  for (std::size_t i = 0; i < def.loads.size(); ++i)
    ps.load_count.push_back(select(def.loads[i].region, fmt::format("loads[{}]", i), ps.loads[i]));
  return ps;
}

template <class T>
ChangeSet apply_changes(SimBody<T>& body, PatchState& ps, const ActivationState& as, const ActivationState::Changes& ch,
                        double time) {
  const std::size_t n = std::size_t(as.levels());
  const BodyDef& def = body.def;
  ChangeSet cs;
  cs.changed.resize(n);
  cs.old_state.resize(n);
  cs.mass_changed.resize(n);
  PatchStats& stats = cs.stats;

  // 1. The nodes: changed (role or sources), own mass changed (corners of the tets turned on or
  // off), and the sources, old and new, of both (their masses hold the ghosts').
  std::vector<std::vector<std::int32_t>> own_changed(n), on(n), off(n);
  for (std::size_t l = 0; l < n; ++l) {
    cs.changed[l] = ch.nodes[l];
    sort_unique(cs.changed[l]);
    on[l] = ch.tets_on[l];
    off[l] = ch.tets_off[l];
    std::sort(on[l].begin(), on[l].end());
    std::sort(off[l].begin(), off[l].end());
    const Level<T>& L = body.levels[l];
    for (const std::vector<std::int32_t>* list : std::initializer_list<const std::vector<std::int32_t>*>{&on[l], &off[l], &ch.tets_reweighed[l]})
      for (auto t : *list)
        for (int a = 0; a < 4; ++a) own_changed[l].push_back(L.tet[a][std::size_t(t)]);
    sort_unique_marked(own_changed[l], ps.mark[l]);
    stats.tets += on[l].size() + off[l].size() + ch.tets_reweighed[l].size();
  }
  auto& touched = cs.mass_changed;
  for (std::size_t l = 0; l < n; ++l) {
    const Level<T>& L = body.levels[l];
    touched[l].insert(touched[l].end(), cs.changed[l].begin(), cs.changed[l].end());
    touched[l].insert(touched[l].end(), own_changed[l].begin(), own_changed[l].end());
    for (const auto* list : {&cs.changed[l], &own_changed[l]})
      for (const std::int32_t v : *list) {
        const auto it = std::lower_bound(L.ghosts.begin(), L.ghosts.end(), v);
        if (it != L.ghosts.end() && *it == v) {
          const auto g = std::size_t(it - L.ghosts.begin());
          for (auto e = L.ghost_offsets[g]; e < L.ghost_offsets[g + 1]; ++e)
            touched[std::size_t(L.ghost_source_level[std::size_t(e)])].push_back(L.ghost_source_node[std::size_t(e)]);
        }
        if (as.role(int(l), v) == NodeRole::ghost)
          for (const GhostSource& s : as.sources(int(l), v)) touched[std::size_t(s.level)].push_back(s.node);
      }
  }
  for (std::size_t l = 0; l < n; ++l) sort_unique_marked(touched[l], ps.mark[l]);

  // 2. Before the change: the states of the changed nodes, the momentum and mass of the touched ones.
  double mass_before = 0;
  for (std::size_t l = 0; l < n; ++l) {
    const Level<T>& L = body.levels[l];
    for (auto v : cs.changed[l]) cs.old_state[l].push_back(L.state[std::size_t(v)]);
    for (auto v : touched[l]) {
      const auto i = std::size_t(v);
      mass_before += double(L.mass[i]);
      if (L.state[i] == kNodeFree)
        for (int k = 0; k < 3; ++k) cs.p_before[k] += double(L.mass[i]) * double(L.v[k][i]);
    }
    stats.nodes += touched[l].size();
  }

  // 3. Stepped tets: the runs around them, and no corner forces left on those turned off. The
  // runs are what the level steps, the activation's mask what it should: a listed tet whose state
  // did not change is left as it is (a guard: update() once listed such a tet, activation.cpp).
  for (std::size_t l = 0; l < n; ++l) {
    Level<T>& L = body.levels[l];
    for (const auto* list : {&on[l], &off[l]})
      for (auto t : *list) {
        const bool want = as.stepped(int(l), t), have = L.steps(std::size_t(t));
        if (want && !have) {
          run_on(L.stepped_runs, std::size_t(t));
          ++L.stepped_count;
        } else if (!want && have) {
          run_off(L.stepped_runs, std::size_t(t));
          --L.stepped_count;
          for (auto& c : L.corner_force) c[std::size_t(t)] = T(0);
        }
      }
  }

  // 4. Own masses of the corners of those tets, summed in ascending tet order (as the full apply).
  for (std::size_t l = 0; l < n; ++l)
    for (const std::int32_t v : own_changed[l]) {
      double m = 0;
      const auto [b, e] = as.node_tets(int(l), v);
      for (const std::int32_t* t = b; t != e; ++t)
        if (as.stepped(int(l), *t)) m += ps.quarter_mass[l][std::size_t(*t)] * as.mass_share(int(l), *t);
      ps.own_mass[l][std::size_t(v)] = m;
      stats.tets += std::size_t(e - b);
    }

  // 5. Receivers (before the ghosts: the old sources are read from the ghost CSRs): a receiver
  // touched by a changed ghost keeps its other entries and takes the changed ghosts' new ones.
  std::vector<std::vector<Entry>> fresh(n);
  std::vector<std::vector<std::int32_t>> receivers(n);
  for (std::size_t l = 0; l < n; ++l) {
    const Level<T>& L = body.levels[l];
    for (const std::int32_t v : cs.changed[l]) {
      const auto it = std::lower_bound(L.ghosts.begin(), L.ghosts.end(), v);
      if (it != L.ghosts.end() && *it == v) {
        const auto g = std::size_t(it - L.ghosts.begin());
        for (auto e = L.ghost_offsets[g]; e < L.ghost_offsets[g + 1]; ++e)
          receivers[std::size_t(L.ghost_source_level[std::size_t(e)])].push_back(L.ghost_source_node[std::size_t(e)]);
      }
      if (as.role(int(l), v) == NodeRole::ghost)
        for (const GhostSource& s : as.sources(int(l), v)) {
          receivers[std::size_t(s.level)].push_back(s.node);
          fresh[std::size_t(s.level)].push_back({s.node, std::int32_t(l), v, s.weight});
        }
    }
  }
  for (std::size_t l = 0; l < n; ++l) {
    Level<T>& L = body.levels[l];
    sort_unique_marked(receivers[l], ps.mark[l]);
    if (receivers[l].empty()) continue;
    auto& fr = fresh[l];
    for (const std::int32_t r : receivers[l]) {  // the entries of unchanged ghosts stay
      const auto it = std::lower_bound(L.receivers.begin(), L.receivers.end(), r);
      if (it == L.receivers.end() || *it != r) continue;
      const auto i = std::size_t(it - L.receivers.begin());
      for (auto e = L.receive_offsets[i]; e < L.receive_offsets[i + 1]; ++e) {
        const std::int32_t gl = L.receive_ghost_level[std::size_t(e)], g = L.receive_ghost_node[std::size_t(e)];
        if (!holds(cs.changed[std::size_t(gl)], g)) fr.push_back({r, gl, g, L.receive_weight[std::size_t(e)]});
      }
    }
    std::sort(fr.begin(), fr.end(), [](const Entry& x, const Entry& y) {
      if (x.key != y.key) return x.key < y.key;
      if (x.a != y.a) return x.a < y.a;
      return x.b < y.b;
    });
    stats.entries += fr.size();
    stats.nodes += receivers[l].size();
    splice(L.receivers, L.receive_offsets, L.receive_ghost_level, L.receive_ghost_node, L.receive_weight, receivers[l], fr,
           /*no_offsets_without_keys=*/true, ps);
    if (L.receivers.empty()) {
      for (auto& j : L.impulse) j.clear();
    } else if (L.impulse[0].empty()) {
      for (auto& j : L.impulse) j.assign(L.node_count, T(0));
    }
  }

  // 6. Ghosts: the changed nodes' entries.
  for (std::size_t l = 0; l < n; ++l) {
    if (cs.changed[l].empty()) continue;
    Level<T>& L = body.levels[l];
    std::vector<Entry> fr;
    for (const std::int32_t v : cs.changed[l])
      if (as.role(int(l), v) == NodeRole::ghost)
        for (const GhostSource& s : as.sources(int(l), v)) fr.push_back({v, s.level, s.node, s.weight});
    stats.entries += fr.size();
    splice(L.ghosts, L.ghost_offsets, L.ghost_source_level, L.ghost_source_node, L.ghost_weight, cs.changed[l], fr,
           /*no_offsets_without_keys=*/false, ps);
  }

  // 7. States from the roles, then the regions on the changed nodes that are active now.
  for (std::size_t l = 0; l < n; ++l)
    for (const std::int32_t v : cs.changed[l]) body.levels[l].state[std::size_t(v)] = state_of(as.role(int(l), v));
  // +1 / -1 / 0: the changed node k of level l starts / stops being active, or neither.
  auto delta = [&](std::size_t l, std::size_t k) {
    return int(as.role(int(l), cs.changed[l][k]) == NodeRole::active) - int(active_state(cs.old_state[l][k]));
  };
  for (std::size_t i = 0; i < ps.fixed.size(); ++i) {
    for (std::size_t l = 0; l < n; ++l)
      for (std::size_t k = 0; k < cs.changed[l].size(); ++k) {
        const std::int32_t v = cs.changed[l][k];
        if (!holds(ps.fixed[i][l], v)) continue;
        ps.fixed_count[i] = std::size_t(std::int64_t(ps.fixed_count[i]) + delta(l, k));
        if (as.role(int(l), v) == NodeRole::active) body.levels[l].state[std::size_t(v)] = kNodeFixed;
      }
    if (ps.fixed_count[i] == 0) none(def, fmt::format("fixed[{}]", i));
  }
  for (std::size_t i = 0; i < ps.prescribed.size(); ++i) {
    MotionState& ms = body.motions[i];
    const Vec3d o = ms.host_driven ? ms.host_offset : ms.offset_at(time);
    for (std::size_t l = 0; l < n; ++l) {
      Level<T>& L = body.levels[l];
      auto& nodes = ms.nodes[l];
      for (std::size_t k = 0; k < cs.changed[l].size(); ++k) {
        const std::int32_t v = cs.changed[l][k];
        if (!holds(ps.prescribed[i][l], v)) continue;
        ps.prescribed_count[i] = std::size_t(std::int64_t(ps.prescribed_count[i]) + delta(l, k));
        const auto at = std::lower_bound(nodes.begin(), nodes.end(), v);
        const bool listed = at != nodes.end() && *at == v;
        if (as.role(int(l), v) == NodeRole::active) {
          if (!listed) nodes.insert(at, v);
          L.state[std::size_t(v)] = kNodeFixed;
          for (int k3 = 0; k3 < 3; ++k3) L.x[k3][std::size_t(v)] = L.X[k3][std::size_t(v)] + T(o[std::size_t(k3)]);
        } else if (listed) {
          nodes.erase(at);
        }
      }
    }
    if (ps.prescribed_count[i] == 0) none(def, fmt::format("prescribed[{}]", i));
  }
  bool loads_changed = false;
  for (std::size_t i = 0; i < ps.loads.size(); ++i) {
    for (std::size_t l = 0; l < n; ++l)
      for (std::size_t k = 0; k < cs.changed[l].size(); ++k)
        if (holds(ps.loads[i][l], cs.changed[l][k]) && delta(l, k) != 0) {
          ps.load_count[i] = std::size_t(std::int64_t(ps.load_count[i]) + delta(l, k));
          loads_changed = true;
        }
    if (ps.load_count[i] == 0) none(def, fmt::format("loads[{}]", i));
  }
  if (loads_changed) {  // a load's force is spread over its active nodes: its region is written again
    for (std::size_t l = 0; l < n; ++l) {
      Level<T>& L = body.levels[l];
      bool any = false;
      for (std::size_t i = 0; i < ps.loads.size() && !any; ++i)
        for (auto v : ps.loads[i][l])
          if (active_state(L.state[std::size_t(v)])) {
            any = true;
            break;
          }
      if (!any) {
        for (auto& e : L.external) e.clear();
        continue;
      }
      if (L.external[0].empty()) {
        for (auto& e : L.external) e.assign(L.node_count, T(0));
      } else {
        for (std::size_t i = 0; i < ps.loads.size(); ++i)
          for (auto v : ps.loads[i][l])
            for (auto& e : L.external) e[std::size_t(v)] = T(0);
      }
      for (std::size_t i = 0; i < ps.loads.size(); ++i) {
        stats.nodes += ps.loads[i][l].size();
        for (auto v : ps.loads[i][l])
          if (active_state(L.state[std::size_t(v)]))
            for (int k = 0; k < 3; ++k)
              L.external[k][std::size_t(v)] += T(def.loads[i].total_force[std::size_t(k)] / double(ps.load_count[i]));
      }
    }
  }

  // 8. Masses of the touched nodes: own plus their receiver entries' share of the ghosts' own (in
  // the order of the entries, as the full apply adds them), scaled so that together they weigh
  // what they weighed (the body's total stays rho x V), unless the change is renormalised
  // (apply_changes.hpp): then every node's, scaled as the full apply does.
  auto raw_of = [&](std::size_t l, std::int32_t v) {
    if (as.role(int(l), v) != NodeRole::active) return 0.0;
    const Level<T>& L = body.levels[l];
    double m = ps.own_mass[l][std::size_t(v)];
    const auto it = std::lower_bound(L.receivers.begin(), L.receivers.end(), v);
    if (it != L.receivers.end() && *it == v) {
      const auto i = std::size_t(it - L.receivers.begin());
      for (auto e = L.receive_offsets[i]; e < L.receive_offsets[i + 1]; ++e)
        m += L.receive_weight[std::size_t(e)] *
             ps.own_mass[std::size_t(L.receive_ghost_level[std::size_t(e)])][std::size_t(L.receive_ghost_node[std::size_t(e)])];
    }
    return m;
  };
  std::vector<std::vector<double>> raw(n);
  double mass_after = 0, raw_before = 0;
  std::size_t count = 0;
  for (std::size_t l = 0; l < n; ++l) {
    raw[l].reserve(touched[l].size());
    for (const std::int32_t v : touched[l]) {
      raw[l].push_back(raw_of(l, v));
      mass_after += raw[l].back();
      raw_before += ps.raw_mass[l][std::size_t(v)];
    }
    count += touched[l].size();
  }
  const double density = def.material.density;
  const double local = mass_after > 0 && mass_before > 0 ? mass_before / mass_after : 1.0;
  const double raw_total = ps.raw_total - raw_before + mass_after;  // every node's, kept as it changes
  const double global = raw_total > 0 ? density * ps.volume / raw_total : 1.0;  // the full apply's factor
  double factor = local;
  if (ps.touched_since + count >= ps.renormalise_after || std::abs(local / global - 1) > ps.factor_tolerance) {
    // Every node: the momentum of those not touched yet (their mass and velocity still as before).
    for (std::size_t l = 0; l < n; ++l) {
      const Level<T>& L = body.levels[l];
      for (const std::int32_t v : touched[l]) ps.mark[l][std::size_t(v)] = 1;
      for (std::size_t i = 0; i < L.node_count; ++i)
        if (!ps.mark[l][i] && L.state[i] == kNodeFree)
          for (int k = 0; k < 3; ++k) cs.p_before[k] += double(L.mass[i]) * double(L.v[k][i]);
      for (const std::int32_t v : touched[l]) ps.mark[l][std::size_t(v)] = 0;
    }
    mass_after = 0;
    for (std::size_t l = 0; l < n; ++l) {
      touched[l].resize(body.levels[l].node_count);
      raw[l].resize(touched[l].size());
      for (std::size_t i = 0; i < touched[l].size(); ++i) {
        touched[l][i] = std::int32_t(i);
        raw[l][i] = raw_of(l, std::int32_t(i));
        mass_after += raw[l][i];
      }
      stats.nodes += touched[l].size();
    }
    factor = mass_after > 0 ? density * ps.volume / mass_after : 1.0;
    ps.raw_total = mass_after;
    ps.touched_since = 0;
    ++ps.renormalisations;
  } else {
    ps.raw_total = raw_total;
    ps.touched_since += count;
  }
  for (std::size_t l = 0; l < n; ++l) {
    Level<T>& L = body.levels[l];
    for (std::size_t k = 0; k < touched[l].size(); ++k) {
      const auto i = std::size_t(touched[l][k]);
      const double m = raw[l][k] * factor;
      ps.raw_mass[l][i] = raw[l][k];
      L.mass[i] = T(m);
      L.inv_mass[i] = L.state[i] == kNodeFree ? T(1.0 / m) : T(0);
    }
  }
  // Held: a fixed or prescribed region selects an active node (those nodes are kNodeFixed).
  for (const std::size_t c : ps.fixed_count) cs.held |= c > 0;
  for (const std::size_t c : ps.prescribed_count) cs.held |= c > 0;
  return cs;
}

template <class T>
std::size_t keep_momentum(SimBody<T>& body, const ChangeSet& cs) {
  if (cs.held) return 0;
  // What the change did to the momentum: only the touched nodes' masses, states and velocities changed.
  double dp[3] = {cs.p_before[0], cs.p_before[1], cs.p_before[2]};
  for (std::size_t l = 0; l < cs.mass_changed.size(); ++l) {
    const Level<T>& L = body.levels[l];
    for (const std::int32_t v : cs.mass_changed[l]) {
      const auto i = std::size_t(v);
      if (L.state[i] == kNodeFree)
        for (int k = 0; k < 3; ++k) dp[k] -= double(L.mass[i]) * double(L.v[k][i]);
    }
  }
  // Given back as one rigid velocity shift of every free node (apply_changes.hpp: a shift of the
  // touched ones only is a velocity jump at their edge, a strain the measure then reads).
  double m_free = 0;
  std::size_t count = 0;
  for (const auto& L : body.levels)
    for (std::size_t i = 0; i < L.node_count; ++i)
      if (L.state[i] == kNodeFree) {
        m_free += double(L.mass[i]);
        ++count;
      }
  if (!(m_free > 0)) return 0;
  for (auto& L : body.levels)
    for (std::size_t i = 0; i < L.node_count; ++i)
      if (L.state[i] == kNodeFree)
        for (int k = 0; k < 3; ++k) L.v[k][i] = T(double(L.v[k][i]) + dp[k] / m_free);
  return count;
}

template PatchState make_patch_state<float>(SimBody<float>&, const Hierarchy&, const ActivationState&);
template PatchState make_patch_state<double>(SimBody<double>&, const Hierarchy&, const ActivationState&);
template ChangeSet apply_changes<float>(SimBody<float>&, PatchState&, const ActivationState&, const ActivationState::Changes&, double);
template ChangeSet apply_changes<double>(SimBody<double>&, PatchState&, const ActivationState&, const ActivationState::Changes&, double);
template std::size_t keep_momentum<float>(SimBody<float>&, const ChangeSet&);
template std::size_t keep_momentum<double>(SimBody<double>&, const ChangeSet&);

}  // namespace pliant::detail
