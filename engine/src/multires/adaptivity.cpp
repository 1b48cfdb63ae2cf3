// adapt_body (adaptivity.hpp): measure, decide, re-activate, carry the state over.
#include "adaptivity.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstring>
#include <memory>

#include "../collision/closest_points.hpp"
#include "../core/simulation.hpp"
#include "pliant/kernels/strain_measure.hpp"

namespace pliant::detail {
namespace {

// Position and velocity of every simulated (not inactive) node of every level now (ghosts where
// their sources are, as current_state gives them: summed in double, rounded to T), in double, into
// x and v (3 arrays per level, reused: no allocation once sized). An inactive node's entries are
// left as they were: a decision reads the simulated field only (an inactive node's own position, for
// the distance to a tool, is_near reads from the level). On the 50k-tet organ at its
// coarsest, 9 000 of its 10 700 nodes are inactive.
template <class T>
void field_now(const SimBody<T>& body, std::vector<std::vector<double>>& x, std::vector<std::vector<double>>& v) {
  const std::size_t n = body.levels.size();
  x.resize(3 * n);
  v.resize(3 * n);
  for (std::size_t l = 0; l < n; ++l) {
    const Level<T>& L = body.levels[l];
    for (std::size_t k = 0; k < 3; ++k) {
      x[3 * l + k].resize(L.node_count);
      v[3 * l + k].resize(L.node_count);
    }
    // A level that steps no tet simulates no node (its free, fixed and ghost nodes are the corners
    // of its stepped tets): the organ's finest level, 10 700 nodes, at most decisions.
    if (L.stepped_count == 0) continue;
    for (std::size_t i = 0; i < L.node_count; ++i)
      if (L.state[i] != kNodeInactive)
        for (std::size_t k = 0; k < 3; ++k) {
          x[3 * l + k][i] = double(L.x[k][i]);
          v[3 * l + k][i] = double(L.v[k][i]);
        }
    for (std::size_t g = 0; g < L.ghosts.size(); ++g) {
      double gx[3], gv[3];
      ghost_now(body, L, g, gx, gv);
      const auto i = std::size_t(L.ghosts[g]);
      for (std::size_t k = 0; k < 3; ++k) {
        x[3 * l + k][i] = double(T(gx[k]));
        v[3 * l + k][i] = double(T(gv[k]));
      }
    }
  }
}

// The finer level's free nodes restricted onto the nodes of level l: per node, the sums of
// w m u (3), w m v (3) and w m over the finer free nodes whose coarse tet has it as a corner with
// weight w (m: their mass, u: displacement).
template <class T>
void restrict_field(const SimBody<T>& body, const Hierarchy& h, int l, const std::vector<std::vector<double>>& x,
                    const std::vector<std::vector<double>>& v, std::vector<std::array<double, 7>>& acc) {
  acc.assign(body.levels[std::size_t(l)].node_count, std::array<double, 7>{});
  const Level<T>& F = body.levels[std::size_t(l) + 1];
  if (F.stepped_count == 0) return;  // no free node (field_now)
  const LevelLinks& fl = h.links[std::size_t(l) + 1];
  for (std::size_t f = 0; f < F.node_count; ++f) {
    if (F.state[f] != kNodeFree || fl.to_coarser[f].tet < 0) continue;
    const double m = double(F.mass[f]);
    const auto& tet = h.meshes[std::size_t(l)].tets[std::size_t(fl.to_coarser[f].tet)];
    for (int a = 0; a < 4; ++a) {
      const double wm = fl.to_coarser[f].weights[std::size_t(a)] * m;
      if (wm == 0) continue;
      auto& q = acc[std::size_t(tet[std::size_t(a)])];
      for (int k = 0; k < 3; ++k) {
        q[std::size_t(k)] += wm * (x[3 * (std::size_t(l) + 1) + std::size_t(k)][f] - double(F.X[k][f]));
        q[3 + std::size_t(k)] += wm * v[3 * (std::size_t(l) + 1) + std::size_t(k)][f];
      }
      q[6] += wm;
    }
  }
}

// The simulated field carried to the nodes of every level, for a node that starts being simulated
// with no simulated level next to it (a 3-level body jumping from its coarsest level to its finest,
// or back, has the field two levels away; the node's own state is stale, from whenever it was last
// simulated). A node that was not simulated takes the field through its links, one level at a
// time: from the finer level where all four corners of its finer tet have it (coarser levels in
// turn, so that the middle level gets it before the coarsest), else from the coarser one (finer
// levels in turn). Displacements and velocities interpolated, as for one level (adapt_body).
struct CarriedField {
  std::vector<std::vector<double>> x, v;  // as field_now, filled where `known`
  std::vector<std::vector<char>> known;
};

// state(l, i): the node's state when x and v were taken.
template <class T, class State>
CarriedField carried_field(const SimBody<T>& body, const Hierarchy& h, const State& state,
                           const std::vector<std::vector<double>>& x, const std::vector<std::vector<double>>& v) {
  const std::size_t levels = body.levels.size();
  CarriedField f{x, v, std::vector<std::vector<char>>(levels)};
  for (std::size_t l = 0; l < levels; ++l) {
    f.known[l].resize(body.levels[l].node_count);
    for (std::size_t i = 0; i < f.known[l].size(); ++i) f.known[l][i] = state(l, i) != kNodeInactive;
  }
  auto carry = [&](std::size_t l, std::size_t src, const TetLink& link, std::size_t i) {
    if (link.tet < 0) return;
    const auto& tet = h.meshes[src].tets[std::size_t(link.tet)];
    for (int a = 0; a < 4; ++a)
      if (!f.known[src][std::size_t(tet[std::size_t(a)])]) return;
    for (std::size_t k = 0; k < 3; ++k) {
      double xs = 0, vs = 0, xr = 0;
      for (std::size_t a = 0; a < 4; ++a) {
        const auto c = std::size_t(tet[a]);
        xs += link.weights[a] * f.x[3 * src + k][c];
        vs += link.weights[a] * f.v[3 * src + k][c];
        xr += link.weights[a] * double(body.levels[src].X[k][c]);
      }
      f.x[3 * l + k][i] = double(body.levels[l].X[k][i]) + (xs - xr);
      f.v[3 * l + k][i] = vs;
    }
    f.known[l][i] = 1;
  };
  for (std::size_t l = levels - 1; l-- > 0;)
    for (std::size_t i = 0; i < body.levels[l].node_count; ++i)
      if (!f.known[l][i]) carry(l, l + 1, h.links[l].to_finer[i], i);
  for (std::size_t l = 1; l < levels; ++l)
    for (std::size_t i = 0; i < body.levels[l].node_count; ++i)
      if (!f.known[l][i]) carry(l, l - 1, h.links[l].to_coarser[i], i);
  return f;
}

// The state an undo restores (AdaptiveState::Scratch::before): every node's x, v, mass and
// inv_mass, copied as they are (bytes: a copy, not a conversion), for the levels the change can
// write: those that step a tet before it or start stepping one with it (ch.tets_on). A level that
// steps none before or after has only inactive nodes: the change carries no state to them (only
// to nodes whose role changes), keep_momentum moves free nodes only, and a mass written to them
// (a renormalisation writes every node's) is 0, as it was (an inactive node weighs nothing;
// tests/multires/test_apply_changes.cpp checks it). On the 50k-tet organ held at its middle level,
// the finest level's 8 arrays of 10 700 nodes (340 KB, idle since the last change) were most of a
// save: 64 us on average, up to 210 (frame_probe at cap 1, 2026-11-28), for nothing.
template <class T>
std::array<AlignedVector<T>*, 8> undo_arrays(Level<T>& L) {
  return {&L.x[0], &L.x[1], &L.x[2], &L.v[0], &L.v[1], &L.v[2], &L.mass, &L.inv_mass};
}

template <class T>
void save_state(SimBody<T>& body, AdaptiveState& st, const ActivationState::Changes& ch) {
  auto& before = st.scratch.before;
  before.resize(body.levels.size());
  for (std::size_t l = 0; l < body.levels.size(); ++l) {
    const Level<T>& L = body.levels[l];
    const bool written = L.stepped_count > 0 || !ch.tets_on[l].empty();
    const std::size_t bytes = written ? L.node_count * sizeof(T) : 0;
    before[l].resize(8 * bytes);  // empty: not saved, restore_state leaves the level as it is
    if (bytes == 0) continue;  // (memcpy from an empty array's null data() is undefined)
    std::size_t at = 0;
    for (const AlignedVector<T>* a : undo_arrays(body.levels[l])) {
      std::memcpy(before[l].data() + at, a->data(), bytes);
      at += bytes;
    }
  }
  st.scratch.raw_total = st.patch.raw_total;
  st.scratch.touched_since = st.patch.touched_since;
  st.scratch.renormalisations = st.patch.renormalisations;
}

template <class T>
void restore_state(SimBody<T>& body, AdaptiveState& st) {
  for (std::size_t l = 0; l < body.levels.size(); ++l) {
    const std::size_t bytes = st.scratch.before[l].size() / 8;
    if (bytes == 0) continue;
    std::size_t at = 0;
    for (AlignedVector<T>* a : undo_arrays(body.levels[l])) {
      std::memcpy(a->data(), st.scratch.before[l].data() + at, bytes);
      at += bytes;
    }
  }
  st.patch.raw_total = st.scratch.raw_total;
  st.patch.touched_since = st.scratch.touched_since;
  st.patch.renormalisations = st.scratch.renormalisations;
}

}  // namespace

// save: keep the state before the change for undo_change (save_state, once update() has said
// which levels the change writes).
template <class T>
bool apply_targets(SimBody<T>& body, double t, bool save = false);

template <class T>
bool adapt_body(SimBody<T>& body, double t, const std::vector<NearShape>& near, const std::function<void()>& before_change,
                Executor* exec, const ListedRest<T>* finest) {
  AdaptiveState& st = *body.adapt;
  // World::force_level acts at once, and so does a tool pressing a triangle it cannot push (not
  // within the change interval: AdaptiveState::decision_due).
  bool unresolved = false;
  for (const NearShape& s : near) unresolved |= s.unresolved_contact;
  if (!st.decision_due(t, unresolved)) return false;
  st.next_check = t + st.def.check_every;
  ++st.checks;
  const Hierarchy& h = *st.hierarchy;
  ActivationState& as = *st.activation;
  const int levels = int(h.levels());

  // Nothing can change when every split is capped away (World::set_adapt_cap(body, 0), the
  // real-time controller's coarsest rung) and no node is split (nothing to merge): the measure is
  // not taken (on the 50k-tet organ at its coarsest, it made a decision point cost about 57 us,
  // about a fifth of a 1 ms frame's stepping there). The decision it skips would change nothing:
  // no split is allowed, no node has a target above its level, and the calm times are kept for
  // split nodes only.
  if (st.forced_target < 0 && st.cap <= 0) {
    bool split = false;
    for (int l = 0; l + 1 < levels && !split; ++l)
      for (std::int32_t i = 0; i < std::int32_t(h.meshes[std::size_t(l)].node_count()) && !split; ++i) split = as.target(l, i) > l;
    if (!split) return false;
  }

  // 1. The measure: per stepped tet, the largest jump |F_t - F_u| (Frobenius) of the deformation
  // gradient to a stepped face neighbour of the same level; per node, the largest over the stepped
  // tets around it. Piecewise-constant F jumps by about h |grad F| between tets: where it jumps,
  // the level's tets are too coarse for how fast the deformation varies there. A rigid motion or a
  // uniform strain gives no jump (F -> R F leaves |F_t - F_u| as it is).
  // Scratch kept between decisions (AdaptiveState::Scratch): resized, never freed.
  AdaptiveState::Scratch& sc = st.scratch;
  auto& x = sc.x;
  auto& v = sc.v;
  field_now(body, x, v);
  auto& measure = sc.measure;  // read for the levels that can split (all but the finest)
  measure.resize(std::size_t(levels - 1));
  auto& F = sc.F;  // written for the stepped tets, and only they are read (a neighbour is read if stepped)
  // The peak is taken over squared strains and rooted once (sqrt is monotone and correctly
  // rounded: the root of the largest is the largest root, to the bit), per chunk of the level's
  // stepped tets, the chunks on exec's threads (a level of kSerialBelow stepped tets or more): on
  // the 50k-tet organ this part took a third of a decision (3 800 finest tets, 140 us on one thread).
  double peak2 = 0;  // the body's largest squared Green-Lagrange strain |(F^T F - I) / 2|^2 over its stepped tets
  constexpr std::size_t kChunk = 256;  // tets per chunk: about 8 us of work, a few chunks per level
  for (int l = 0; l < levels; ++l) {
    const Level<T>& L = body.levels[std::size_t(l)];
    const std::vector<double>* xl = &x[3 * std::size_t(l)];  // x, y, z of level l
    const std::vector<std::uint8_t>& on = as.stepped_mask(l);
    if (F.size() < L.tet_count) F.resize(L.tet_count);
    auto& ids = sc.ids;
    ids.clear();
    // F and the squared strains in vector lanes (kernels: the same bits as one tet at a time).
    StrainMeasureContext<T> smc;
    for (int k = 0; k < 3; ++k) smc.x[k] = xl[k].data();
    if (l + 1 == levels && finest && finest->count == L.stepped_count) {  // list positions (adapt_body's `finest`)
      for (std::size_t i = 0; i < finest->count; ++i) ids.push_back(std::int32_t(i));
      for (int a = 0; a < 4; ++a) smc.tet[a] = finest->tet[a];
      for (int q = 0; q < 9; ++q) smc.grad[q] = finest->grad[q];
    } else {
      for (const Range& run : L.stepped_runs)
        for (std::size_t e = run.begin; e < run.end; ++e) ids.push_back(std::int32_t(e));
      for (int a = 0; a < 4; ++a) smc.tet[a] = L.tet[a].data();
      for (int q = 0; q < 9; ++q) smc.grad[q] = L.grad[q].data();
    }
    const std::size_t chunks = (ids.size() + kChunk - 1) / kChunk;
    sc.chunk_peak.assign(chunks, 0.0);
    auto measure_chunks = [&](Range r) {
      for (std::size_t c = r.begin; c < r.end; ++c)
        sc.chunk_peak[c] = deformation_gradients_listed(smc, ids.data(), Range{c * kChunk, std::min(ids.size(), (c + 1) * kChunk)}, F.data());
    };
    // In parallel from kSerialBelow tets, as the passes: below, the fork-join cost more than it
    // saved (the 50k-tet organ at its middle level, 667 + 342 tets stepped: 56-57 us a decision in
    // parallel, 36 on the calling thread; frame_probe, alternated x3, 2026-11-26).
    if (exec && chunks > 1 && ids.size() >= kSerialBelow) {
      exec->parallel_for(chunks, 1, measure_chunks);
    } else {
      measure_chunks(Range{0, chunks});
    }
    for (const double c : sc.chunk_peak) peak2 = std::max(peak2, c);
    if (l + 1 == levels) break;  // the finest level never splits: its peak strain is all it gives
    // Nor does a level at or beyond the cap (World::set_adapt_cap: the real-time controller's
    // rungs), unless force_level asks: its jump measure would not be read.
    if (l + 1 > st.cap && st.forced_target < 0) continue;
    auto& m = measure[std::size_t(l)];
    m.assign(L.node_count, 0.0);
    const auto& nb = st.neighbours[std::size_t(l)];
    for (const Range& run : L.stepped_runs)
      for (std::size_t e = run.begin; e < run.end; ++e) {
        double jump2 = 0;  // rooted once, as the peak
        for (std::int32_t u : nb[e]) {
          if (u < 0 || !on[std::size_t(u)]) continue;
          double d2 = 0;
          for (int k = 0; k < 9; ++k) d2 += (F[e][std::size_t(k)] - F[std::size_t(u)][std::size_t(k)]) * (F[e][std::size_t(k)] - F[std::size_t(u)][std::size_t(k)]);
          jump2 = std::max(jump2, d2);
        }
        const double jump = std::sqrt(jump2);
        for (int a = 0; a < 4; ++a) {
          double& q = m[std::size_t(L.tet[a][e])];
          q = std::max(q, jump);
        }
      }
  }

  // Measure::relative: both measures over the body's peak strain (at least kStrainFloor), so that
  // the thresholds are fractions of how much the body deforms now.
  const double peak = std::sqrt(peak2);
  st.peak_strain = peak;
  const double unit = st.def.measure == AdaptDef::Measure::relative ? std::max(peak, AdaptDef::kStrainFloor) : 1.0;
  const double split_above = st.def.refine_above * st.scale * unit;
  const double merge_below = st.def.coarsen_below * st.scale * unit;

  // The merge measure: how far the finer field is from what the coarser level would give there.
  // For a child c (a finer node in a split node's Voronoi zone), its displacement against the
  // coarse field interpolated at its rest place (the coarse tet's corners: their own displacement
  // when simulated, else the finer field restricted onto them), over the coarser level's mean edge:
  // a strain-like number, small where the coarse level would represent the motion as well.
  auto detail_of = [&](int l, std::int32_t i, const std::vector<std::array<double, 7>>& restricted) {
    const LevelLinks& lk = h.links[std::size_t(l)];
    const LevelLinks& fl = h.links[std::size_t(l) + 1];
    const Level<T>& C = body.levels[std::size_t(l)];
    const Level<T>& F = body.levels[std::size_t(l) + 1];
    double worst = 0;
    for (auto c = lk.child_offsets[std::size_t(i)]; c < lk.child_offsets[std::size_t(i) + 1]; ++c) {
      const auto child = std::size_t(lk.children[std::size_t(c)]);
      if (F.state[child] != kNodeFree || fl.to_coarser[child].tet < 0) continue;
      const auto& tet = h.meshes[std::size_t(l)].tets[std::size_t(fl.to_coarser[child].tet)];
      double pred[3] = {0, 0, 0};
      for (int a = 0; a < 4; ++a) {
        const auto j = std::size_t(tet[std::size_t(a)]);
        const double w = fl.to_coarser[child].weights[std::size_t(a)];
        for (int k = 0; k < 3; ++k) {
          double u = x[3 * std::size_t(l) + std::size_t(k)][j] - double(C.X[k][j]);
          if (C.state[j] == kNodeInactive) u = restricted[j][6] > 0 ? restricted[j][std::size_t(k)] / restricted[j][6] : 0.0;
          pred[k] += w * u;
        }
      }
      double d2 = 0;
      for (int k = 0; k < 3; ++k) {
        const double d = x[3 * (std::size_t(l) + 1) + std::size_t(k)][child] - double(F.X[k][child]) - pred[k];
        d2 += d * d;
      }
      worst = std::max(worst, std::sqrt(d2) / st.edge[std::size_t(l)]);
    }
    return worst;
  };
  auto& restricted_now = sc.restricted;
  restricted_now.resize(std::size_t(levels - 1));
  for (int l = 0; l + 1 < levels; ++l) restrict_field(body, h, l, x, v, restricted_now[std::size_t(l)]);

  // Near a tool, a prescribed motion or a refining probe (AdaptDef::refine_near; < 0: one mean edge
  // of the node's own level): a node within that distance of a shape's surface.
  // With refine_near 0 nothing refines by distance, but a node within one mean edge of its level
  // from a tool (its merge would change the tets the tool touches) does not merge (`kept_fine`).
  // (Within a quarter edge until 2026-11-28: a merge next to the tool moved the finer level's
  // border, with its ghost corners, under it.)
  // `contacts`: only the unresolved contacts (at one edge of level l), else only the other shapes.
  auto near_within = [&](int l, std::size_t i, bool tools_only, double reach, bool contacts = false) {
    const Level<T>& L = body.levels[std::size_t(l)];
    const bool simulated = L.state[i] != kNodeInactive;  // else x holds nothing for it: its own place
    P3 p;
    for (std::size_t k = 0; k < 3; ++k) p[k] = simulated ? x[3 * std::size_t(l) + k][i] : double(L.x[k][i]);
    for (const NearShape& s : near) {
      if (s.unresolved_contact != contacts || (tools_only && !s.tool)) continue;
      double d2 = 0;
      if (s.box) {
        for (std::size_t k = 0; k < 3; ++k) {
          const double d = std::max({s.a[k] - p[k], 0.0, p[k] - s.b[k]});
          d2 += d * d;
        }
      } else {
        double u = 0, unused = 0;
        closest_segment_segment(s.a, s.b, p, p, u, unused);
        d2 = norm2(sub(p, add(s.a, mul(sub(s.b, s.a), u))));
      }
      if (std::sqrt(d2) <= s.radius + reach) return true;
    }
    return false;
  };
  // A tool pressing a triangle it cannot push (a point on a fixed or ghost corner: a coarse
  // triangle at a clamped end) sank through it 19 mm unseen with refine_near 0 (a stress scene, then
  // 2.2x its energy budget when a split put a finer surface there): such a contact refines.
  auto at_unresolved_contact = [&](int l, std::size_t i) {
    return !near.empty() && near_within(l, i, true, st.edge[std::size_t(l)], true);
  };
  auto is_near = [&](int l, std::size_t i) {
    if (near.empty()) return false;
    if (at_unresolved_contact(l, i)) return true;
    if (st.def.refine_near == 0) return false;
    return near_within(l, i, false, st.def.refine_near >= 0 ? st.def.refine_near : st.edge[std::size_t(l)]);
  };
  auto kept_fine = [&](int l, std::size_t i) {  // a merge would coarsen it: near (or inside a tool)
    if (near.empty()) return false;
    return st.def.refine_near == 0 ? near_within(l, i, true, st.edge[std::size_t(l)]) || at_unresolved_contact(l, i)
                                   : is_near(l, i);
  };

  // 2. Decisions, coarse to fine, nodes in order (deterministic), each kept in st.decided.
  st.decided.clear();
  auto decide = [&](int l, std::int32_t i, int from, int to, TargetChange::Kind kind) {
    as.set_target(l, i, to);
    st.decided.push_back({i, std::int16_t(l), std::int8_t(from), std::int8_t(to), kind});
  };
  int splits_left = st.split_budget;  // World::set_adapt_split_budget: the rest wait for the next decision
  for (int l = 0; l + 1 < levels; ++l) {
    const Level<T>& L = body.levels[std::size_t(l)];
    auto& calm = st.calm_since[std::size_t(l)];
    for (std::int32_t i = 0; i < std::int32_t(L.node_count); ++i) {
      const int target = as.target(l, i);
      if (st.forced_target >= 0) {
        const int want = std::min(st.forced_target, l + 1) > l ? l + 1 : l;
        if (target != want) {
          decide(l, i, target, want, TargetChange::command);
          (want > l ? st.splits : st.merges)++;
        }
        continue;
      }
      if (target == l + 1 && l + 1 > st.cap) {  // the cap came down: merge at once
        decide(l, i, target, l, TargetChange::command);
        calm[std::size_t(i)] = -1;
        ++st.merges;
        continue;
      }
      if (target <= l) {  // not split (an adaptive body starts with every target at 0)
        // A node that is not split but not simulated either lies in a region refined by a split
        // neighbour: when that neighbour merges, the tets around this node go back to level l
        // unless it is split itself. It splits where its own merge would be refused (the finer
        // field differs from level l's there), so that no merge drops detail it never measured
        // (a bent 3-level bar went from its 752 finest tets to its 12 coarsest at once).
        // (Not measured beyond the cap, where no node splits: on the organ capped at its middle
        // level, the 1 300 middle nodes' children read for nothing at every decision.)
        const bool refined_around = l + 1 <= st.cap && L.state[std::size_t(i)] == kNodeInactive &&
                                    detail_of(l, i, restricted_now[std::size_t(l)]) >= merge_below;
        // The budget limits the splits that refine more; a node inside a refined region splits
        // whatever it is (it keeps refinement that is there: the merge it prevents is the bug above).
        const bool refine = l + 1 <= st.cap && splits_left > 0 && L.state[std::size_t(i)] == kNodeFree &&
                            (measure[std::size_t(l)][std::size_t(i)] > split_above || is_near(l, std::size_t(i)));
        if (l + 1 <= st.cap && (refined_around || refine)) {
          decide(l, i, target, l + 1, TargetChange::split);
          calm[std::size_t(i)] = -1;
          ++st.splits;
          if (refined_around) {
            ++st.keeping_splits;
          } else {
            --splits_left;
          }
        }
      } else if (target == l + 1) {
        bool quiet = true;
        const LevelLinks& lk = h.links[std::size_t(l)];
        for (auto c = lk.child_offsets[std::size_t(i)]; c < lk.child_offsets[std::size_t(i) + 1] && quiet; ++c)
          quiet = as.target(l + 1, lk.children[std::size_t(c)]) <= l + 1;  // no child split further
        for (auto c = lk.child_offsets[std::size_t(i)]; c < lk.child_offsets[std::size_t(i) + 1] && quiet; ++c)
          quiet = !kept_fine(l + 1, std::size_t(lk.children[std::size_t(c)]));  // a tool keeps its region fine
        quiet = quiet && !kept_fine(l, std::size_t(i)) && detail_of(l, i, restricted_now[std::size_t(l)]) < merge_below;
        if (!quiet) {
          calm[std::size_t(i)] = -1;
        } else if (calm[std::size_t(i)] < 0) {
          calm[std::size_t(i)] = t;
        }
        if (quiet && t - calm[std::size_t(i)] >= st.def.min_dwell) {
          decide(l, i, target, l, TargetChange::merge);
          calm[std::size_t(i)] = -1;
          ++st.merges;
        }
      }
    }
  }
  st.forced_target = -1;
  if (st.decided.empty()) return false;
  if (before_change) before_change();

  // 3. Re-activate and carry the state over; the state before is kept for undo_change when the
  // decision can be undone: it merges, and no command is among its changes.
  bool merges = false, commands = false;
  for (const TargetChange& c : st.decided) {
    merges |= c.kind == TargetChange::merge;
    commands |= c.kind == TargetChange::command;
  }
  st.undoable = merges && !commands;
  if (!apply_targets(body, t, st.undoable)) {
    st.undoable = false;
    return false;
  }
  ++st.changes;
  st.last_change = t;
  return true;
}

template <class T>
bool undo_change(SimBody<T>& body, double t) {
  AdaptiveState& st = *body.adapt;
  ActivationState& as = *st.activation;
  // Back to the activation before the decision, then to its state (apply_changes leaves the
  // masses of a non-nested body depending on the history of changes: they are restored too).
  for (auto c = st.decided.rbegin(); c != st.decided.rend(); ++c) as.set_target(c->level, c->node, c->from);
  const auto start = std::chrono::steady_clock::now();
  const ActivationState::Changes ch = as.update();
  const ChangeSet cs = apply_changes(body, st.patch, as, ch, t);
  st.touched_nodes += std::int64_t(cs.stats.nodes);
  st.touched_tets += std::int64_t(cs.stats.tets);
  restore_state(body, st);
  st.apply_seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  ++st.undone;
  // The merges are dropped (they lock a bent region into coarser tets); they wait min_dwell again.
  std::size_t kept = 0;
  for (const TargetChange& c : st.decided) {
    if (c.kind != TargetChange::merge) {
      st.decided[kept++] = c;
      continue;
    }
    --st.merges;
    ++st.deferred_merges;
    st.calm_since[std::size_t(c.level)][std::size_t(c.node)] = t;  // calm, but min_dwell again
  }
  st.decided.resize(kept);
  st.undoable = false;
  for (const TargetChange& c : st.decided) as.set_target(c.level, c.node, c.to);
  if (st.decided.empty() || !apply_targets(body, t)) {
    st.undoable = false;
    --st.changes;
    return false;
  }
  return true;
}

// Re-activates from the targets as they are now, patches the body's arrays and carries the state
// over to the nodes that change (the field taken before the decision, in st.scratch). Returns
// false if the activation did not change.
template <class T>
bool apply_targets(SimBody<T>& body, double t, bool save) {
  AdaptiveState& st = *body.adapt;
  const Hierarchy& h = *st.hierarchy;
  ActivationState& as = *st.activation;
  const int levels = int(h.levels());
  const auto& x = st.scratch.x;
  const auto& v = st.scratch.v;
  const auto start = std::chrono::steady_clock::now();
  const ActivationState::Changes ch = as.update();
  bool changed = false;
  for (int l = 0; l < levels; ++l)
    changed |= !ch.tets_on[std::size_t(l)].empty() || !ch.tets_off[std::size_t(l)].empty() ||
               !ch.tets_reweighed[std::size_t(l)].empty() || !ch.nodes[std::size_t(l)].empty();
  if (!changed) return false;
  if (save) save_state(body, st, ch);
  // Patched in place, over the changed nodes and tets only (apply_changes.hpp).
  const ChangeSet cs = apply_changes(body, st.patch, as, ch, t);
  st.touched_nodes += std::int64_t(cs.stats.nodes);
  st.touched_tets += std::int64_t(cs.stats.tets);

  // Nodes that start being simulated take the field that was simulated there: from the finer
  // level where it was active (a merge), else from the coarser one (a split).
  auto from_link = [&](int l, const TetLink& link, std::size_t i) {
    if (link.tet < 0) return false;
    const TetMesh& m = h.meshes[std::size_t(l)];
    const auto& tet = m.tets[std::size_t(link.tet)];
    for (int a = 0; a < 4; ++a) {
      const std::int32_t c = tet[std::size_t(a)];
      if (cs.was(l, c, body.levels[std::size_t(l)].state[std::size_t(c)]) == kNodeInactive) return false;
    }
    (void)i;
    return true;
  };
  // A merge restricts the finer field onto the coarse node: the average of the finer free nodes'
  // displacements and velocities around it, weighted by their masses and their weights in the
  // coarse tets (momentum-preserving, and never adding kinetic energy: sampling one finer node's
  // velocity instead gave the coarse node, with its larger mass, whatever mode that node was in,
  // and 100 forced cycles pumped a block's energy up 10^7-fold).
  const auto& restricted = st.scratch.restricted;  // taken before the change, from the field as it was
  std::unique_ptr<CarriedField> carried;     // made at the first node that needs it
  for (int l = 0; l < levels; ++l) {
    Level<T>& L = body.levels[std::size_t(l)];
    const LevelLinks& lk = h.links[std::size_t(l)];
    for (std::size_t k = 0; k < cs.changed[std::size_t(l)].size(); ++k) {  // only they can change state
      const auto i = std::size_t(cs.changed[std::size_t(l)][k]);
      const std::uint8_t was = cs.old_state[std::size_t(l)][k], now = L.state[i];
      if (now == kNodeFixed && was != kNodeFixed) {
        bool prescribed = false;
        for (const MotionState& ms : body.motions)
          prescribed |= std::binary_search(ms.nodes[std::size_t(l)].begin(), ms.nodes[std::size_t(l)].end(), std::int32_t(i));
        if (!prescribed)
          for (int k = 0; k < 3; ++k) {
            L.x[k][i] = L.X[k][i];
            L.v[k][i] = T(0);
          }
        continue;
      }
      if (now != kNodeFree || was == kNodeFree) continue;
      if (was == kNodeGhost) {  // where its sources are now (its own entries lag by a window)
        for (int k = 0; k < 3; ++k) {
          L.x[k][i] = T(x[3 * std::size_t(l) + std::size_t(k)][i]);
          L.v[k][i] = T(v[3 * std::size_t(l) + std::size_t(k)][i]);
        }
        continue;
      }
      if (l + 1 < levels && restricted[std::size_t(l)][i][6] > 0) {  // a merge
        // Velocity: the finer free nodes' restricted onto it (above). Position: the finer field
        // interpolated at its rest place, which reproduces any affine field (a turn, a uniform
        // strain) exactly; the restricted average of the displacements does not: it is the field
        // at the weighted centroid of the node's hat function, about h/4 inside the body at its
        // surface (a turned block's coarse nodes landed 12 mm off, 1.5 J of strain from nothing).
        const auto& q = restricted[std::size_t(l)][i];
        const TetLink& link = lk.to_finer[i];
        const bool interpolate = from_link(l + 1, link, i);
        for (int k = 0; k < 3; ++k) {
          double u = q[std::size_t(k)] / q[6];
          if (interpolate) {
            u = 0;
            const auto& tet = h.meshes[std::size_t(l) + 1].tets[std::size_t(link.tet)];
            for (int a = 0; a < 4; ++a) {
              const auto c = std::size_t(tet[std::size_t(a)]);
              u += link.weights[std::size_t(a)] *
                   (x[3 * (std::size_t(l) + 1) + std::size_t(k)][c] - double(body.levels[std::size_t(l) + 1].X[k][c]));
            }
          }
          L.x[k][i] = T(double(L.X[k][i]) + u);
          L.v[k][i] = T(q[3 + std::size_t(k)] / q[6]);
        }
        continue;
      }
      int src = -1;
      const TetLink* link = nullptr;
      if (l + 1 < levels && from_link(l + 1, lk.to_finer[i], i)) {
        src = l + 1;
        link = &lk.to_finer[i];
      } else if (l > 0 && from_link(l - 1, lk.to_coarser[i], i)) {
        src = l - 1;
        link = &lk.to_coarser[i];
      }
      if (src < 0) {  // nothing simulated on the next levels: the field two or more levels away
        if (!carried) {
          auto was = [&](std::size_t ll, std::size_t n) {
            return cs.was(int(ll), std::int32_t(n), body.levels[ll].state[n]);
          };
          carried = std::make_unique<CarriedField>(carried_field(body, h, was, x, v));
        }
        if (!carried->known[std::size_t(l)][i]) continue;  // simulated nowhere around: its last state
        for (int k = 0; k < 3; ++k) {
          L.x[k][i] = T(carried->x[3 * std::size_t(l) + std::size_t(k)][i]);
          L.v[k][i] = T(carried->v[3 * std::size_t(l) + std::size_t(k)][i]);
        }
        continue;
      }
      const auto& tet = h.meshes[std::size_t(src)].tets[std::size_t(link->tet)];
      for (int k = 0; k < 3; ++k) {
        double xs = 0, vs = 0;
        for (int a = 0; a < 4; ++a) {
          const auto c = std::size_t(tet[std::size_t(a)]);
          xs += link->weights[std::size_t(a)] * x[3 * std::size_t(src) + std::size_t(k)][c];
          vs += link->weights[std::size_t(a)] * v[3 * std::size_t(src) + std::size_t(k)][c];
        }
        // Displacement, not position, is interpolated: a node off its source tet (outside the
        // other mesh) keeps its own rest place plus the field's displacement there.
        double xr = 0;
        for (int a = 0; a < 4; ++a) xr += link->weights[std::size_t(a)] * double(body.levels[std::size_t(src)].X[k][std::size_t(tet[std::size_t(a)])]);
        L.x[k][i] = T(double(L.X[k][i]) + (xs - xr));
        L.v[k][i] = T(vs);
      }
    }
  }
  // Linear momentum kept: a uniform velocity change of the free nodes takes up what the new masses
  // and the carried-over velocities changed (summed over the touched nodes only), for a body
  // nothing holds (keep_momentum).
  keep_momentum(body, cs);
  st.apply_seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return true;
}

template <class T>
std::shared_ptr<AdaptiveState> make_adaptive_state(std::shared_ptr<const Hierarchy> h, const ActiveDef& active, SimBody<T>& body) {
  auto a = std::make_shared<AdaptiveState>();
  a->hierarchy = h;
  a->activation = std::make_unique<ActivationState>(*h, node_targets(*h, active));
  a->def = active.adapt;
  for (const TetMesh& m : h->meshes) {
    a->calm_since.emplace_back(m.node_count(), -1.0);
    a->neighbours.push_back(face_neighbours(m));
    double sum = 0;
    for (const Tet& t : m.tets)
      for (int e = 0; e < 3; ++e) {
        const Vec3d p = m.point(std::size_t(t[std::size_t(e)])), q = m.point(std::size_t(t[std::size_t(e) + 1]));
        sum += std::sqrt((p[0] - q[0]) * (p[0] - q[0]) + (p[1] - q[1]) * (p[1] - q[1]) + (p[2] - q[2]) * (p[2] - q[2]));
      }
    a->edge.push_back(sum / (3.0 * double(m.tet_count())));
  }
  a->patch = make_patch_state(body, *h, *a->activation);
  size_adapt_scratch(*a);
  return a;
}
template std::shared_ptr<AdaptiveState> make_adaptive_state<float>(std::shared_ptr<const Hierarchy>, const ActiveDef&, SimBody<float>&);
template std::shared_ptr<AdaptiveState> make_adaptive_state<double>(std::shared_ptr<const Hierarchy>, const ActiveDef&, SimBody<double>&);

void size_adapt_scratch(AdaptiveState& st) {
  const Hierarchy& h = *st.hierarchy;
  const std::size_t levels = h.levels();
  AdaptiveState::Scratch& sc = st.scratch;
  sc.x.resize(3 * levels);
  sc.v.resize(3 * levels);
  sc.measure.resize(levels - 1);
  sc.restricted.resize(levels - 1);
  std::size_t tets = 0;
  for (std::size_t l = 0; l < levels; ++l) {
    const std::size_t n = h.meshes[l].node_count();
    for (std::size_t k = 0; k < 3; ++k) {
      sc.x[3 * l + k].resize(n);
      sc.v[3 * l + k].resize(n);
    }
    if (l + 1 < levels) {
      sc.measure[l].resize(n);
      sc.restricted[l].resize(n);
    }
    tets = std::max(tets, h.meshes[l].tet_count());
  }
  sc.F.resize(tets);
}

std::vector<std::array<std::int32_t, 4>> face_neighbours(const TetMesh& mesh) {
  std::vector<std::array<std::int32_t, 4>> nb(mesh.tet_count(), {-1, -1, -1, -1});
  // Faces keyed by their sorted corners; the face opposite corner a of tet t.
  std::vector<std::pair<std::array<std::int32_t, 3>, std::int64_t>> faces;
  faces.reserve(4 * mesh.tet_count());
  for (std::size_t t = 0; t < mesh.tet_count(); ++t)
    for (int a = 0; a < 4; ++a) {
      std::array<std::int32_t, 3> f;
      int k = 0;
      for (int b = 0; b < 4; ++b)
        if (b != a) f[std::size_t(k++)] = mesh.tets[t][std::size_t(b)];
      std::sort(f.begin(), f.end());
      faces.push_back({f, std::int64_t(4 * t + std::size_t(a))});
    }
  std::sort(faces.begin(), faces.end());
  for (std::size_t i = 0; i + 1 < faces.size(); ++i)
    if (faces[i].first == faces[i + 1].first) {
      const std::int64_t p = faces[i].second, q = faces[i + 1].second;
      nb[std::size_t(p / 4)][std::size_t(p % 4)] = std::int32_t(q / 4);
      nb[std::size_t(q / 4)][std::size_t(q % 4)] = std::int32_t(p / 4);
    }
  return nb;
}

template bool undo_change<float>(SimBody<float>&, double);
template bool undo_change<double>(SimBody<double>&, double);
template bool adapt_body<float>(SimBody<float>&, double, const std::vector<NearShape>&, const std::function<void()>&, Executor*,
                                const ListedRest<float>*);
template bool adapt_body<double>(SimBody<double>&, double, const std::vector<NearShape>&, const std::function<void()>&,
                                 Executor*, const ListedRest<double>*);

}  // namespace pliant::detail
