// One step of every level (element pass -> gather + integrate -> prescribed motion), in the
// order DESIGN.md §4 gives. Allocation-free once the scratch lists have grown: contexts are
// stack structs of pointers. The passes of a tick run as phases of one parallel region
// (Executor::run_phases): for a single-level body the element pass over tets, then the fused
// gather + integrate over nodes, each range then resolved against the static obstacles (see
// docs/performance.md for why and for the grain sizes).
#include "simulation.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <fmt/format.h>

#include "pliant/kernels/element_stiffness.hpp"
#include "pliant/level_passes.hpp"
#include "probe_placement.hpp"

namespace pliant::detail {
namespace {

template <class T>
using EnergyPass = void (*)(const ElementContext<T>&, Range, double*);

template <class T>
EnergyPass<T> energy_kernel(ForceModel m) {
  switch (m) {
    case ForceModel::linear: return &element_energy_linear<T>;
    case ForceModel::stvk: return &element_energy_stvk<T>;
    case ForceModel::corotational: return &element_energy_corotational<T>;
    case ForceModel::springs: return &element_energy_springs<T>;
  }
  return &element_energy_linear<T>;
}

}  // namespace

// Whether a level steps its tets from a list (LevelJobState::stepped) rather than run by run:
// when its runs are short. A run of n tets costs ceil(n / W) batches and a task of its own, so
// runs of about 4 tets (the middle level of the 50k organ stepping the region under its tool: 291
// tets in 75 runs) filled a quarter of each 16-lane batch; a list fills them all, for gathers and
// per-lane stores in place of contiguous loads and stores. perf/frame_probe on that organ (2
// threads, Xeon KVM guest, idle): 1 ms frames took 681-696 us by runs, 427-442 us listed (and
// 360 us with the deformation monitor listed too). Its coarsest level (667 tets in 16 runs, about
// 42 per run) took the same time either way, within the noise. kListedRunsBelow: the mean run
// length (tets) under which a level is listed.
constexpr std::size_t kListedRunsBelow = 64;
template <class T>
bool steps_by_list(const Level<T>& L) {
  return L.stepped_runs.size() > 1 && L.stepped_count < kListedRunsBelow * L.stepped_runs.size();
}
// out = the level's stepped tets, run after run (the order the passes and sums go in by runs).
template <class T>
void list_stepped(const Level<T>& L, std::vector<std::int32_t>& out) {
  out.clear();
  for (const Range& r : L.stepped_runs)
    for (std::size_t t = r.begin; t < r.end; ++t) out.push_back(std::int32_t(t));
}

namespace {

// The tets of the runs `a` that are not in the runs `b` (both ascending and disjoint), as runs.
void subtract_runs(const std::vector<Range>& a, const std::vector<Range>& b, std::vector<Range>& out) {
  out.clear();
  std::size_t j = 0;  // the first run of b that ends after the current run of a begins
  for (const Range& r : a) {
    while (j < b.size() && b[j].end <= r.begin) ++j;
    std::size_t lo = r.begin;
    for (std::size_t k = j; lo < r.end; ++k) {
      if (k == b.size() || b[k].begin >= r.end) {
        out.push_back({lo, r.end});
        break;
      }
      if (b[k].begin > lo) out.push_back({lo, b[k].begin});
      lo = std::max(lo, b[k].end);
    }
  }
}

// A listed level's gather entries (LevelJobState::gather_*): node v's entries are
// incidence[offsets[v] .. end[v]), codes 4 x (list position) + corner in the order of their tets
// (Level::incidence's), each with its corner-force offset (encode_corner_offsets) when `fits`.
struct ListedGather {
  const std::int32_t* offsets;  // Level::incidence_offsets: each node's room
  std::int32_t* end;
  std::int32_t* incidence;
  std::int32_t* corner_offset;  // null when the offsets would not fit in 32 bits
  std::size_t stride;           // of the corner-force block
  const std::int32_t* list;     // LevelJobState::stepped: a position's tet

  std::int32_t offset_of(std::int32_t code) const {
    return std::int32_t(3 * std::int64_t(stride) * (code & 3) + (code >> 2));
  }
  std::int32_t find(std::int32_t v, std::int32_t code) const {
    std::int32_t e = offsets[v];
    while (incidence[e] != code) ++e;  // present: the level's list holds its tet
    return e;
  }
  void drop(std::int32_t v, std::int32_t code) {
    const std::int32_t last = end[v] - 1;
    for (std::int32_t e = find(v, code); e < last; ++e) {
      incidence[e] = incidence[e + 1];
      if (corner_offset) corner_offset[e] = corner_offset[e + 1];
    }
    end[v] = last;
  }
  void recode(std::int32_t v, std::int32_t from, std::int32_t to) {
    const std::int32_t e = find(v, from);
    incidence[e] = to;
    if (corner_offset) corner_offset[e] = offset_of(to);
  }
  // Inserts tet t's entry (code) among node v's, in tet order (list[] holds every listed tet's).
  void insert(std::int32_t v, std::int32_t t, std::int32_t code) {
    std::int32_t e = offsets[v];
    const std::int32_t stop = end[v];
    while (e < stop && list[incidence[e] >> 2] < t) ++e;
    for (std::int32_t k = stop; k > e; --k) {
      incidence[k] = incidence[k - 1];
      if (corner_offset) corner_offset[k] = corner_offset[k - 1];
    }
    incidence[e] = code;
    if (corner_offset) corner_offset[e] = offset_of(code);
    end[v] = stop + 1;
  }
  void encode_all(std::size_t nodes) {
    if (!corner_offset) return;
    for (std::size_t v = 0; v < nodes; ++v)
      for (std::int32_t e = offsets[v]; e < end[v]; ++e) corner_offset[e] = offset_of(incidence[e]);
  }
};

// Whether a corner-force block of this stride has 32-bit offsets for every entry (as
// encode_corner_offsets: 3 x stride x 3 + a position below the stride).
bool offsets_fit(std::size_t stride) { return 10 * std::int64_t(stride) <= std::int64_t(INT32_MAX); }

template <class T>
ListedGather listed_gather(const Level<T>& L, LevelJobState<T>& js) {
  const bool fits = offsets_fit(js.listed_corner_force.stride());
  return {L.incidence_offsets.data(), js.gather_end.data(), js.gather_incidence.data(),
          fits ? js.gather_corner_offset.data() : nullptr, js.listed_corner_force.stride(), js.stepped.data()};
}

template <class T>
void resize_listed_arrays(LevelJobState<T>& js, std::size_t n, bool rotations) {
  for (int a = 0; a < 4; ++a) js.listed_tet[a].resize(n);
  for (int q = 0; q < 9; ++q) js.listed_grad[q].resize(n);
  js.listed_volume.resize(n);
  if (rotations)
    for (int k = 0; k < 4; ++k) js.listed_rotation[k].resize(n);
}

// List position i takes tet e's rest data and rotation from the level's arrays.
template <class T>
void list_from_level(const Level<T>& L, LevelJobState<T>& js, std::size_t i, std::size_t e, bool rotations) {
  for (int a = 0; a < 4; ++a) js.listed_tet[a][i] = L.tet[a][e];
  for (int q = 0; q < 9; ++q) js.listed_grad[q][i] = L.grad[q][e];
  js.listed_volume[i] = L.volume[e];
  if (rotations)
    for (int k = 0; k < 4; ++k) js.listed_rotation[k][i] = L.rotation[k][e];
}

}  // namespace

// A listed level's list made afresh (its first prepare as a listed level): its stepped tets in
// ascending order, their rest data and rotations in list order (ElementContext::listed_tet,
// listed_grad, listed_volume, listed_rotation: the force passes and the monitor load them in
// sequence instead of gathering them from tets scattered over the mesh), corner forces by list
// position (zero until the level's first element pass writes them: its gather runs on the ticks it
// steps, after that pass), and its gather entries. O(stepped tets + nodes and tets of the level),
// in the memory of the level's last list or of its first prepare when it has one.
template <class T>
void Simulation<T>::make_list(const Level<T>& L, LevelJobState<T>& js) {
  list_stepped(L, js.stepped);
  const std::size_t n = js.stepped.size();
  const bool rotations = !L.rotation[0].empty();  // corotational: the warm starts in list order too
  js.listed_level = L.tet[0].data();
  js.listed_runs = L.stepped_runs;
  js.list_position.assign(L.tet_count, -1);
  resize_listed_arrays(js, n, rotations);
  for (std::size_t i = 0; i < n; ++i) {
    const auto e = std::size_t(js.stepped[i]);
    js.list_position[e] = std::int32_t(i);
    list_from_level(L, js, i, e, rotations);
  }
  // A new block with room for an eighth more tets, or the block of the level's last list, zeroed.
  if (js.listed_corner_force.resize_keeping_stride(n))
    for (int q = 0; q < 12; ++q) std::fill(js.listed_corner_force[std::size_t(q)].begin(), js.listed_corner_force[std::size_t(q)].end(), T(0));
  // Each node's entries from the front of its range, its stepped tets' corners appended in list
  // order, which ascends: the order of Level::incidence (build_level fills it in tet order).
  js.gather_end.assign(L.incidence_offsets.begin(), L.incidence_offsets.end() - 1);
  js.gather_incidence.resize(L.incidence.size());
  js.gather_corner_offset.resize(L.incidence.size());
  ListedGather g = listed_gather(L, js);
  for (std::size_t i = 0; i < n; ++i)
    for (int a = 0; a < 4; ++a) {
      const std::int32_t code = std::int32_t(4 * i + std::size_t(a));
      const std::int32_t e = g.end[js.listed_tet[a][i]]++;
      g.incidence[e] = code;
      if (g.corner_offset) g.corner_offset[e] = g.offset_of(code);
    }
}

// A listed level's list after a change of resolution, edited in place from the list before it
// (js holds that list's arrays): each tet no longer stepped leaves its rotation in Level::rotation
// and gives its position to the list's last tet, each newly stepped one is appended; their gather
// entries are dropped, recoded or inserted in the ranges of their corner nodes. O(tets the change
// turns on or off, and their nodes' entries), where making the list again read every stepped tet
// and node (the fine level of a bar of 196 608 tets stepping 14 000: the prepare after a change
// took 0.7-1.6 ms, 65-300 us with the list edited). Every tet keeps its rest data, rotation and
// gather entries' order, so the passes compute the same bits; only positions change.
template <class T>
void Simulation<T>::edit_list(Level<T>& L, LevelJobState<T>& js, std::vector<Range> (&scratch)[2]) {
  std::vector<Range>& off = scratch[0];  // tets the list holds that the level no longer steps
  std::vector<Range>& on = scratch[1];   // tets it steps that the list does not hold
  subtract_runs(js.listed_runs, L.stepped_runs, off);
  subtract_runs(L.stepped_runs, js.listed_runs, on);
  js.listed_runs = L.stepped_runs;
  if (off.empty() && on.empty()) return;
  const bool rotations = !L.rotation[0].empty();
  std::size_t n = js.stepped.size();
  std::size_t dropped = 0, added = 0;
  for (const Range& r : off) dropped += r.size();
  for (const Range& r : on) added += r.size();
  // The corner-force block for the longer of the lists before and after; a new block (a longer
  // stride) when it does not fit, every entry's offset encoded again for it.
  const std::size_t final_n = n - dropped + added;
  const bool kept = js.listed_corner_force.resize_keeping_stride(std::max(n, final_n));
  ListedGather g = listed_gather(L, js);
  if (!kept) g.encode_all(L.node_count);
  auto& cf = js.listed_corner_force;
  for (const Range& r : off)
    for (std::size_t t = r.begin; t < r.end; ++t) {
      const std::int32_t p = js.list_position[t];
      const std::size_t last = n - 1;
      if (rotations)  // its current rotation, where the level (and a list it joins again) reads it
        for (int k = 0; k < 4; ++k) L.rotation[k][t] = js.listed_rotation[k][std::size_t(p)];
      for (int a = 0; a < 4; ++a) g.drop(js.listed_tet[a][std::size_t(p)], 4 * p + a);
      if (std::size_t(p) != last) {  // the last tet takes position p
        const std::int32_t moved = js.stepped[last];
        for (int a = 0; a < 4; ++a) js.listed_tet[a][std::size_t(p)] = js.listed_tet[a][last];
        for (int q = 0; q < 9; ++q) js.listed_grad[q][std::size_t(p)] = js.listed_grad[q][last];
        js.listed_volume[std::size_t(p)] = js.listed_volume[last];
        if (rotations)
          for (int k = 0; k < 4; ++k) js.listed_rotation[k][std::size_t(p)] = js.listed_rotation[k][last];
        for (int q = 0; q < 12; ++q) cf[std::size_t(q)][std::size_t(p)] = cf[std::size_t(q)][last];
        for (int a = 0; a < 4; ++a) g.recode(js.listed_tet[a][std::size_t(p)], std::int32_t(4 * last) + a, 4 * p + a);
        js.stepped[std::size_t(p)] = moved;
        js.list_position[std::size_t(moved)] = p;
      }
      js.list_position[t] = -1;
      js.stepped.pop_back();
      --n;
    }
  resize_listed_arrays(js, final_n, rotations);
  js.stepped.resize(final_n);
  g.list = js.stepped.data();
  for (const Range& r : on)
    for (std::size_t t = r.begin; t < r.end; ++t) {
      const std::size_t p = n++;
      js.stepped[p] = std::int32_t(t);
      js.list_position[t] = std::int32_t(p);
      list_from_level(L, js, p, t, rotations);
      for (int q = 0; q < 12; ++q) cf[std::size_t(q)][p] = T(0);
      for (int a = 0; a < 4; ++a) g.insert(L.tet[a][t], std::int32_t(t), std::int32_t(4 * p) + a);
    }
  cf.resize_keeping_stride(final_n);
}

// Points a listed level's element and gather contexts at its list's arrays.
template <class T>
void Simulation<T>::bind_list(const Level<T>& L, LevelJobState<T>& js) {
  const bool rotations = !L.rotation[0].empty();
  for (int a = 0; a < 4; ++a) js.ec.listed_tet[a] = js.listed_tet[a].data();
  for (int q = 0; q < 9; ++q) js.ec.listed_grad[q] = js.listed_grad[q].data();
  js.ec.listed_volume = js.listed_volume.data();
  if (rotations)
    for (int k = 0; k < 4; ++k) js.ec.listed_rotation[k] = js.listed_rotation[k].data();
  for (int q = 0; q < 12; ++q) {
    js.ec.corner_force[q] = js.listed_corner_force[std::size_t(q)].data();
    js.gc.corner_force[q] = js.listed_corner_force[std::size_t(q)].data();
  }
  js.ec.listed_corner_forces = true;
  js.gc.offsets = L.incidence_offsets.data();
  js.gc.ends = js.gather_end.data();
  js.gc.incidence = js.gather_incidence.data();
  js.gc.corner_offset = offsets_fit(js.listed_corner_force.stride()) ? js.gather_corner_offset.data() : nullptr;
  js.gc.corner_stride = js.listed_corner_force.stride();
}

template <class T>
void Simulation<T>::write_back_rotations() {
  // The force passes write the listed rotations in a tick's phases, before ++tick_ (step): at the
  // same tick_ nothing wrote them since, and prepare() makes every list from Level::rotation or
  // from the list before (the same values).
  if (rotations_written_tick_ == tick_) return;
  rotations_written_tick_ = tick_;
  for (LevelJobState<T>& js : job_state_) {
    if (js.stepped.empty() || !js.ec.listed_rotation[0]) continue;
    Level<T>& L = bodies[std::size_t(js.body)].levels[std::size_t(js.level)];
    for (int k = 0; k < 4; ++k)
      for (std::size_t i = 0; i < js.stepped.size(); ++i) L.rotation[k][std::size_t(js.stepped[i])] = js.listed_rotation[k][i];
  }
}

template <class T>
bool Simulation<T>::listed_rotations(const SimBody<T>& body, const Level<T>& L, const std::int32_t* ids, std::size_t n,
                                     AlignedVector<T> (&out)[4]) const {
  const LevelJobState<T>* js = job_of(body, L);
  if (!js || js->stepped.empty() || !js->ec.listed_rotation[0] || js->list_position.size() != L.tet_count) return false;
  for (int k = 0; k < 4; ++k) {
    out[k].resize(n);
    for (std::size_t i = 0; i < n; ++i) {
      const std::int32_t p = js->list_position[std::size_t(ids[i])];
      out[k][i] = p >= 0 ? js->listed_rotation[k][std::size_t(p)] : L.rotation[k][std::size_t(ids[i])];
    }
  }
  return true;
}

template <class T>
void Simulation<T>::current_rotations(const SimBody<T>& body, const Level<T>& L, AlignedVector<T> (&out)[4]) const {
  for (int k = 0; k < 4; ++k) out[k].assign(L.rotation[k].begin(), L.rotation[k].end());
  const LevelJobState<T>* js = job_of(body, L);
  if (!js || !js->ec.listed_rotation[0]) return;
  for (int k = 0; k < 4; ++k)
    for (std::size_t i = 0; i < js->stepped.size(); ++i) out[k][std::size_t(js->stepped[i])] = js->listed_rotation[k][i];
}

// A level whose nodes are the sources of the ghosts of a level two or more finer (an adaptive body
// that refined a coarse region straight to its finest level) takes, through the impulses its
// receivers get, the stiffness of the fine tets around those ghosts: an interface of (h_c / h_f)^2
// times as many tets, each h_c / h_f times less stiff, so about h_c / h_f = 2^gap times its own
// tets' stiffness on such a node, and its frequency 2^(gap / 2) times what its stable step was
// measured for. Levels one apart (2x the stiffness, 1.41x the frequency) stay within the Courant
// factor's margin (0.5: a factor 2 in frequency); two apart used it all, and a stress scene
// (0x236e38a6695cca71, docs/stress.md) grew 1.75x every 3 ms at such an interface. Such a level's
// period is divided by 2^ceil((gap - 1) / 2) (2 for gaps of 2 and 3), so that its receivers are
// no closer to their limit than those of adjacent levels; never below the period of a finer level
// (windows nest).
template <class T>
void Simulation<T>::shorten_far_sources(SimBody<T>& body) {
  const std::size_t n = body.levels.size();
  for (std::size_t c = 0; c + 2 < n; ++c) {
    std::size_t gap = 0;
    for (std::size_t f = n; f-- > c + 2 && gap == 0;)
      for (const std::int32_t src : body.levels[f].ghost_source_level)
        if (std::size_t(src) == c) {
          gap = f - c;
          break;
        }
    if (gap < 2) continue;
    const int divisor = 1 << (gap / 2);  // 2^ceil((gap - 1) / 2)
    int finer = 1;
    for (std::size_t f = c + 1; f < n; ++f) finer = std::max(finer, body.levels[f].period);
    Level<T>& L = body.levels[c];
    L.period = std::max(finer, L.period / divisor);
  }
}

// A level's windows are aligned on multiples of its period (plan_tick: tick % period), so a
// period may only grow at a tick that is a multiple of the new one: a level whose period grew from
// 2 to 4 at a tick of 2 mod 4 (a change while it fed a level two finer ended that, at a decision
// point aligned on its period of 2; `pliant stress` met it 5 times in 30 s) began a window halfway,
// stepped only the second half of its staggered slices in it (the first half's corner forces left
// from the window before) and gave its prescribed nodes the offset over a window it had not
// stepped. It now grows to the longest period, at most the one wanted, whose windows start here
// (a later change at an aligned tick gives it the rest); shorter periods are always aligned (a
// change comes where every window ends); and no level's period ends up below a finer level's.
template <class T>
void Simulation<T>::align_periods(SimBody<T>& body, const std::vector<int>& before) {
  const std::size_t n = body.levels.size();
  for (std::size_t l = 0; l < n; ++l) {
    int& p = body.levels[l].period;
    while (p > before[l] && p > 1 && tick_ % p != 0) p /= 2;
  }
  for (std::size_t l = n - 1; l-- > 0;) body.levels[l].period = std::max(body.levels[l].period, body.levels[l + 1].period);
}

template <class T>
void Simulation<T>::prepare(double tick_dt) {
  period_tick_ = tick_dt;
  region_sized_ = false;
  ghosts_stale_ = true;
  // (The lists take their new tets' rotations from Level::rotation, where a tet leaves its own
  // when it leaves a list: edit_list, and a level that stops listing, below.)
  // The job states before: a listed level's list is taken over and edited (edit_list). Its corner
  // forces stay where they are: a prepare between two steps in the middle of a level's window
  // (World::add_body, when the tick stays) must keep the slices the level has computed since the
  // window began, which its gather sums at the window's end. (A change of resolution prepares at a
  // tick where every window of its body ended: nothing to keep.)
  std::vector<LevelJobState<T>> previous = std::move(job_state_);
  std::vector<std::size_t> previous_of_body = std::move(job_of_body_);
  jobs_.clear();
  job_state_.clear();
  job_of_body_.clear();
  std::size_t pieces = 0;
  for (std::size_t b = 0; b < bodies.size(); ++b) {
    SimBody<T>& body = bodies[b];
    job_of_body_.push_back(jobs_.size());
    const bool multilevel = body.levels.size() > 1;
    std::vector<int> before(body.levels.size());
    for (std::size_t l = 0; l < body.levels.size(); ++l) {
      before[l] = body.levels[l].period;
      body.levels[l].period = multilevel ? level_period(body.levels[l].stable_dt, tick_dt) : 1;
    }
    if (multilevel) {
      shorten_far_sources(body);
      align_periods(body, before);
    }
    for (std::size_t l = 0; l < body.levels.size(); ++l) {
      Level<T>& L = body.levels[l];
      jobs_.push_back({L.period, L.stepped_count});
      LevelJobState<T> js;
      js.body = int(b);
      js.level = int(l);
      size_packed(L, packed_corners);
      js.pack = pack_context(L);
      js.ec = element_context(L);
      js.pass = force_kernel<T>(L.model);
      js.run_start.assign(1, 0);
      for (const Range& r : L.stepped_runs) js.run_start.push_back(js.run_start.back() + r.size());
      js.stepped.clear();
      if (steps_by_list(L)) {  // its list: made (or edited from the one before) below
        js.listed_pass = listed_force_kernel<T>(L.model);
        jobs_.back().align = kTickAlign;  // whole batches of lanes per tick (LevelJob::align)
      }
      pieces += L.stepped_runs.size() + 1;
      js.gc = gather_context(L);
      js.ic = integrate_context(L, gravity, 0.0);
      js.obstacles.resize(obstacles.size());  // filled at each window's end (step)
      js.gh.ghosts = L.ghosts.data();
      js.gh.offsets = L.ghost_offsets.data();
      js.gh.source_level = L.ghost_source_level.data();
      js.gh.source_node = L.ghost_source_node.data();
      js.gh.weight = L.ghost_weight.data();
      js.rc.receivers = L.receivers.data();
      js.rc.offsets = L.receive_offsets.data();
      js.rc.ghost_level = L.receive_ghost_level.data();
      js.rc.ghost_node = L.receive_ghost_node.data();
      js.rc.weight = L.receive_weight.data();
      for (std::size_t m = 0; m < body.levels.size() && m < std::size_t(kMaxLevels); ++m) {
        Level<T>& S = body.levels[m];
        for (int k = 0; k < 3; ++k) {
          js.gh.source_x[m][k] = S.x[k].data();
          js.gh.source_v[m][k] = S.v[k].data();
          js.rc.ghost_f[m][k] = S.f[k].data();
        }
      }
      for (int k = 0; k < 3; ++k) {
        js.gh.x[k] = L.x[k].data();
        js.gh.v[k] = L.v[k].data();
        js.rc.impulse[k] = L.impulse[k].empty() ? nullptr : L.impulse[k].data();
      }
      job_state_.push_back(std::move(js));
    }
  }
  // Node runs: the nodes that are not inactive, gaps shorter than kNodeRunGap kept inside a run.
  // A single-level body has one run over all its nodes.
  constexpr std::size_t kNodeRunGap = 8;  // nodes: a gap's gather costs about what a piece does
  node_pieces_.clear();
  for (LevelJobState<T>& js : job_state_) {
    Level<T>& L = bodies[std::size_t(js.body)].levels[std::size_t(js.level)];
    js.first_node_piece = node_pieces_.size();
    // A level that steps no tet has only inactive nodes (ApplyChanges' random changes check it):
    // no piece, and its 10 700 states (the 50k organ's idle finest level) are not read.
    std::size_t n = L.stepped_count == 0 ? L.node_count : 0;
    while (n < L.node_count) {
      while (n < L.node_count && L.state[n] == kNodeInactive) ++n;
      if (n == L.node_count) break;
      std::size_t end = n + 1, last = n;  // last: the last node of the run that is not inactive
      while (end < L.node_count && end - last <= kNodeRunGap) {
        if (L.state[end] != kNodeInactive) last = end;
        ++end;
      }
      node_pieces_.push_back({&js, n, last + 1 - n});
      n = last + 1;
    }
    js.end_node_piece = node_pieces_.size();
    // The level's list arrays before (the same level: its identity checked), listed or not, taken
    // over: a list still listed is edited (edit_list), not made again, and a level listed again
    // makes its list in the memory it had (the gather entries take 8 bytes per corner of every
    // tet of the level: for a 196 608-tet level, 6 MB whose first touch, at the change that
    // listed it, took that change from 11-13 to 30 ms).
    bool was_listed = false;
    if (std::size_t(js.body) < previous_of_body.size()) {
      LevelJobState<T>& p = previous[previous_of_body[std::size_t(js.body)] + std::size_t(js.level)];
      if (p.listed_level == L.tet[0].data() && p.list_position.size() == L.tet_count) {
        was_listed = !p.stepped.empty();
        js.stepped = std::move(p.stepped);
        js.list_position = std::move(p.list_position);
        js.listed_runs = std::move(p.listed_runs);
        js.listed_level = p.listed_level;
        for (int a = 0; a < 4; ++a) js.listed_tet[a] = std::move(p.listed_tet[a]);
        for (int q = 0; q < 9; ++q) js.listed_grad[q] = std::move(p.listed_grad[q]);
        js.listed_volume = std::move(p.listed_volume);
        for (int k = 0; k < 4; ++k) js.listed_rotation[k] = std::move(p.listed_rotation[k]);
        js.listed_corner_force = std::move(p.listed_corner_force);
        js.gather_end = std::move(p.gather_end);
        js.gather_incidence = std::move(p.gather_incidence);
        js.gather_corner_offset = std::move(p.gather_corner_offset);
      }
    }
    if (js.listed_pass) {  // a listed level (its job state at its final address now)
      if (was_listed)
        edit_list(L, js, list_edit_scratch_);
      else
        make_list(L, js);
      bind_list(L, js);
    } else {
      // By runs: its arrays kept for a later list, its tets' rotations where the passes read them.
      if (was_listed && !js.listed_rotation[0].empty())
        for (int k = 0; k < 4; ++k)
          for (std::size_t i = 0; i < js.stepped.size(); ++i) L.rotation[k][std::size_t(js.stepped[i])] = js.listed_rotation[k][i];
      js.stepped.clear();
      // A level of several: the memory of its list taken and touched now, at load, rather than by
      // the change of resolution that first lists it: its gather entries, and room for a list of
      // an eighth of its tets (rest data, rotations, corner forces). A block allocated at that
      // change stalled it 7.4-7.5 ms in 3 runs of 4 on the 196 608-tet bar (a new huge page's
      // first touch; 0.4 ms otherwise).
      if (!js.listed_level && bodies[std::size_t(js.body)].levels.size() > 1) {
        js.listed_level = L.tet[0].data();
        js.list_position.assign(L.tet_count, -1);
        js.gather_end.assign(L.incidence_offsets.begin(), L.incidence_offsets.end() - 1);
        js.gather_incidence.assign(L.incidence.size(), 0);
        js.gather_corner_offset.assign(L.incidence.size(), 0);
        const std::size_t room = L.tet_count / 8;
        const bool rotations = !L.rotation[0].empty();
        resize_listed_arrays(js, room, rotations);  // touched...
        resize_listed_arrays(js, 0, rotations);     // ...and kept as capacity
        js.listed_corner_force.resize_keeping_stride(room);
      }
    }
  }
  due_.assign(jobs_.size(), LevelDue{});
  pieces_.clear();
  pieces_.reserve(pieces);  // element pieces keep their address for the segments pointing at them
  for (auto& list : tick_segments_) list.reserve(jobs_.size());
  for (auto& list : tick_predicates_) list.reserve(jobs_.size());
  tick_segments_[kPhaseElements].reserve(pieces);
  tick_segments_[kPhasePack].reserve(node_pieces_.size());  // a pack segment per node piece at most
  tick_predicates_[kPhaseNodes].reserve(node_pieces_.size());
  tick_predicates_[kPhaseIntegrate].reserve(node_pieces_.size());
  // The tools' margin checks read the simulated surface vertices only (LevelContact::simulated).
  for (ToolState<T>& tool : tools)
    for (LevelContact<T>& lc : tool.levels) note_simulated_surface(lc, bodies[std::size_t(lc.body)].levels[std::size_t(lc.level)]);
}

template <class T>
void Simulation<T>::size_region(Executor& exec) {
  region_sized_ = true;
  const int threads = exec.threads();
  // The chunks of a segment of at most n items (tick_grain): one per thread at most on several
  // threads, n / max_grain on one.
  auto chunks = [&](std::size_t n, std::size_t min_chunk, std::size_t max_grain) -> std::size_t {
    if (n == 0) return 0;
    if (threads > 1) return std::min(std::size_t(threads), n);
    const std::size_t g = tick_grain(n, min_chunk, max_grain, threads);
    return (n + g - 1) / g;
  };
  std::size_t total = 0;
  for (const LevelJobState<T>& js : job_state_) {
    const Level<T>& L = bodies[std::size_t(js.body)].levels[std::size_t(js.level)];
    total += chunks(L.ghosts.size(), kTickNodeChunk, kNodeGrain);
    total += chunks(L.receivers.size(), kTickNodeChunk, kNodeGrain);
    // Its node pieces: packed, gathered (and integrated), integrated again when coupled.
    for (std::size_t q = js.first_node_piece; q < js.end_node_piece; ++q)
      total += 3 * chunks(node_pieces_[q].count, kTickNodeChunk, kNodeGrain);
    // Its element slices: a listed level's from one list, a level's of ranges cut at its runs.
    if (!js.stepped.empty()) {
      total += chunks(js.stepped.size(), kTickTetChunk, kTetGrain);
    } else {
      for (const Range& r : L.stepped_runs) total += chunks(r.size(), kTickTetChunk, kTetGrain);
    }
  }
  exec.reserve_region(total, kTickPhases);
}

template <class T>
std::size_t Simulation<T>::pass_nodes(int body, int level) const {
  if (job_of_body_.size() <= std::size_t(body)) return 0;  // before the first prepare()
  const LevelJobState<T>& js = job_state_[job_of_body_[std::size_t(body)] + std::size_t(level)];
  std::size_t n = 0;
  for (std::size_t q = js.first_node_piece; q < js.end_node_piece; ++q) n += node_pieces_[q].count;
  return n;
}

template <class T>
std::size_t Simulation<T>::gather_entries(int body, int level) const {
  if (job_of_body_.size() <= std::size_t(body)) return 0;  // before the first prepare()
  const LevelJobState<T>& js = job_state_[job_of_body_[std::size_t(body)] + std::size_t(level)];
  std::size_t n = 0;
  for (std::size_t q = js.first_node_piece; q < js.end_node_piece; ++q) {
    const NodePiece<T>& p = node_pieces_[q];
    if (js.gc.ends)  // a listed level's ranges have room after their entries
      for (std::size_t v = p.first; v < p.first + p.count; ++v) n += std::size_t(js.gc.ends[v] - js.gc.offsets[v]);
    else
      n += std::size_t(js.gc.offsets[p.first + p.count] - js.gc.offsets[p.first]);
  }
  return n;
}

template <class T>
bool Simulation<T>::steps_listed(int body, int level) const {
  if (job_of_body_.size() <= std::size_t(body)) return false;  // before the first prepare()
  return !job_state_[job_of_body_[std::size_t(body)] + std::size_t(level)].stepped.empty();
}

template <class T>
std::array<std::array<double, 3>, 4> Simulation<T>::corner_forces(int body, int level, std::size_t tet) const {
  const Level<T>& L = bodies[std::size_t(body)].levels[std::size_t(level)];
  const CornerForceArrays<T>* from = &L.corner_force;
  std::size_t at = tet;
  if (steps_listed(body, level)) {
    const LevelJobState<T>& js = job_state_[job_of_body_[std::size_t(body)] + std::size_t(level)];
    if (tet >= js.list_position.size() || js.list_position[tet] < 0) return {};
    from = &js.listed_corner_force;
    at = std::size_t(js.list_position[tet]);
  }
  std::array<std::array<double, 3>, 4> f{};
  for (int c = 0; c < 4; ++c)
    for (int k = 0; k < 3; ++k) f[std::size_t(c)][std::size_t(k)] = double((*from)[3 * c + k][at]);
  return f;
}

namespace {

template <class T>
void run_piece(const void* ctx, Range r) {
  const auto& p = *static_cast<const ElementPiece<T>*>(ctx);
  p.job->pass(p.job->ec, Range{p.first_tet + r.begin, p.first_tet + r.end});
}
// A piece of a listed level: r counts from the piece's first position in the level's list.
template <class T>
void run_listed_piece(const void* ctx, Range r) {
  const auto& p = *static_cast<const ElementPiece<T>*>(ctx);
  p.job->listed_pass(p.job->ec, p.job->stepped.data(), Range{p.first_tet + r.begin, p.first_tet + r.end});
}
// The pack over a NodePiece (its level's nodes that are not inactive: every corner of its stepped
// tets): r counts from the piece's first node.
template <class T>
void run_pack_piece(const void* ctx, Range r) {
  const auto& p = *static_cast<const NodePiece<T>*>(ctx);
  pack_positions(p.job->pack, Range{p.first + r.begin, p.first + r.end});
}
template <class T>
void run_ghosts(const void* ctx, Range r) {
  refresh_ghosts(*static_cast<const GhostContext<T>*>(ctx), r);
}
template <class T>
void run_receive(const void* ctx, Range r) {
  receive_ghost_impulses(*static_cast<const ReceiveContext<T>*>(ctx), r);
}
// The node passes over a NodePiece: r counts from the piece's first node.
template <class T>
Range nodes_of(const NodePiece<T>& p, Range r) {
  return Range{p.first + r.begin, p.first + r.end};
}
template <class T>
bool run_gather(const void* ctx, Range r) {
  const auto& p = *static_cast<const NodePiece<T>*>(ctx);
  gather_forces(p.job->gc, nodes_of(p, r));
  return true;
}
// The static obstacles (kernels/obstacle_passes.hpp) over the nodes just integrated, in the
// obstacles' order: each node is resolved on its own, so resolving a range right after integrating
// it gives the bits of a pass per obstacle over the whole level after the integration (how they
// ran until 2026-11-28, in a region of their own that cost the default scene 1.7 us a step).
template <class T>
void resolve_obstacles(const LevelJobState<T>& js, Range nodes) {
  for (const HalfSpaceContext<T>& c : js.obstacles) resolve_half_space(c, nodes);
}
template <class T>
bool run_gather_integrate(const void* ctx, Range r) {
  const auto& p = *static_cast<const NodePiece<T>*>(ctx);
  const bool finite = gather_integrate_symplectic_euler(p.job->gc, p.job->ic, nodes_of(p, r));
  resolve_obstacles(*p.job, nodes_of(p, r));
  return finite;
}
template <class T>
bool run_integrate(const void* ctx, Range r) {
  const auto& p = *static_cast<const NodePiece<T>*>(ctx);
  const LevelJobState<T>& js = *p.job;
  const bool finite = js.rc.impulse[0] ? integrate_symplectic_euler_impulse(js.ic, js.rc.impulse, nodes_of(p, r))
                                       : integrate_symplectic_euler(js.ic, nodes_of(p, r));
  resolve_obstacles(js, nodes_of(p, r));
  return finite;
}

}  // namespace

template <class T>
bool Simulation<T>::step(Executor& exec, double t, double h, std::string& where, std::int64_t step_index) {
  if (!region_sized_) size_region(exec);
  plan_tick(jobs_, schedule, tick_, due_);
  const std::size_t jobs = jobs_.size();
  auto level_of = [&](std::size_t j) -> Level<T>& {
    return bodies[std::size_t(job_state_[j].body)].levels[std::size_t(job_state_[j].level)];
  };
  for (std::size_t j = 0; j < jobs; ++j) {
    Level<T>& L = level_of(j);
    if (due_[j].window_start) L.window_start = t;
    L.window_dt += h;
  }

  // The passes of the tick, phase by phase (TickPhase); every phase is planned before any runs
  // (each depends only on which windows start and end now), and all run in one parallel region
  // (Executor::run_phases): the threads meet at a barrier between phases instead of a fork-join
  // per pass. Adding a pass to a phase is one push_back on its list.
  for (auto& list : tick_segments_) list.clear();
  for (auto& list : tick_predicates_) list.clear();
  auto& ghosts = tick_segments_[kPhaseGhosts];
  auto& elements = tick_segments_[kPhaseElements];
  auto& nodes = tick_predicates_[kPhaseNodes];
  auto& receive = tick_segments_[kPhaseReceive];
  auto& integrate = tick_predicates_[kPhaseIntegrate];

  // A: ghosts take the state of their sources (coarser levels, which do not move in this window),
  // at the start of each window of their level, unless nothing they are made of has moved since
  // they last did: their sources move only at the end of their own windows (each a window of
  // another level of the body starting now), and nothing writes a ghost but this refresh (the
  // integration, the obstacles and the tools move free nodes; a prescribed motion writes its
  // nodes, so a level with one refreshes always). Skipped, a refresh would have written the values
  // its ghosts hold: the same bits. The 50k-tet organ's finest level starts a window at every
  // tick, its sources every 8 or 16 ticks: 7 of 8 refreshes skipped. After a prepare (a change)
  // or a host's write between steps (ghosts_stale_), every level refreshes.
  for (std::size_t j = 0; j < jobs; ++j) {
    const Level<T>& L = level_of(j);
    if (!due_[j].window_start || L.ghosts.empty()) continue;
    const LevelJobState<T>& js = job_state_[j];
    const SimBody<T>& body = bodies[std::size_t(js.body)];
    bool moved = ghosts_stale_;
    const std::size_t first = job_of_body_[std::size_t(js.body)];
    for (std::size_t m = first; m < first + body.levels.size() && !moved; ++m) moved = m != j && due_[m].window_start;
    for (const MotionState& ms : body.motions) moved |= !ms.nodes[std::size_t(js.level)].empty();
    if (moved)
      ghosts.push_back({L.ghosts.size(), tick_grain(L.ghosts.size(), kTickNodeChunk, kNodeGrain, exec.threads()), &run_ghosts<T>, &job_state_[j].gh});
  }
  ghosts_stale_ = false;

  // B: the element passes due now: each level's slice of its stepped tets, cut at run boundaries.
  // First the positions of those levels, interleaved for the passes' corner loads where that pays
  // (a phase of its own, between the ghosts, which it packs too, and the element passes): at the
  // first slice of each window, for the whole window (LevelJobState::window_pack), over the
  // level's node pieces (the corners of its stepped tets), when the window's tets are at least
  // twice those nodes (pack_pays). Packed or gathered, the corners are the same values: the same
  // bits. A host that took a level (World::level) may have written it between steps
  // (packs_stale_): the windows open then are packed again at their next slice.
  auto& pack = tick_segments_[kPhasePack];
  for (std::size_t j = 0; j < jobs; ++j) {
    Level<T>& L = level_of(j);
    LevelJobState<T>& js = job_state_[j];
    using WindowPack = typename LevelJobState<T>::WindowPack;
    if (due_[j].window_start || packs_stale_) js.window_pack = WindowPack::undecided;
    bool packed = false;
    if (due_[j].begin < due_[j].end) {
      if (js.window_pack == WindowPack::undecided) {
        std::size_t nodes = 0;
        for (std::size_t q = js.first_node_piece; q < js.end_node_piece; ++q) nodes += node_pieces_[q].count;
        const bool pays = pack_pays(L, L.stepped_count, nodes);
        js.window_pack = pays ? WindowPack::packed : WindowPack::gathered;
        if (pays)
          for (std::size_t q = js.first_node_piece; q < js.end_node_piece; ++q) {
            const std::size_t n = node_pieces_[q].count;
            pack.push_back({n, tick_grain(n, kTickNodeChunk, kNodeGrain, exec.threads()), &run_pack_piece<T>, &node_pieces_[q]});
          }
      }
      packed = js.window_pack == WindowPack::packed;
    }
    use_packed(js.ec, js.pack, packed);
  }
  packs_stale_ = false;
  pieces_.clear();
  last_tick_tets_ = 0;
  for (std::size_t j = 0; j < jobs; ++j) {
    std::size_t b = due_[j].begin;
    const std::size_t e = due_[j].end;
    if (b >= e) continue;
    last_tick_tets_ += e - b;
    const LevelJobState<T>& js = job_state_[j];
    if (!js.stepped.empty()) {  // listed: one piece, positions [b, e) of the list
      pieces_.push_back({&js, b});
      const std::size_t n = e - b;
      elements.push_back({n, tick_grain(n, kTickTetChunk, kTetGrain, exec.threads()), &run_listed_piece<T>, &pieces_.back()});
      continue;
    }
    const auto& runs = level_of(j).stepped_runs;
    std::size_t k = std::size_t(std::upper_bound(js.run_start.begin(), js.run_start.end(), b) - js.run_start.begin()) - 1;
    while (b < e) {
      const std::size_t stop = std::min(e, js.run_start[k + 1]);
      pieces_.push_back({&js, runs[k].begin + (b - js.run_start[k])});
      const std::size_t n = stop - b;
      elements.push_back({n, tick_grain(n, kTickTetChunk, kTetGrain, exec.threads()), &run_piece<T>, &pieces_.back()});
      b = stop;
      ++k;
    }
  }

  // C: forces on the nodes of the levels whose window ends; levels without ghosts or receivers
  // integrate at once (the fused pass of a single-level body), coupled ones wait for D. Where a
  // level integrates, its nodes then leave the static obstacles (resolve_obstacles).
  bool coupled_due = false;
  for (std::size_t j = 0; j < jobs; ++j) {
    if (!due_[j].window_end) continue;
    Level<T>& L = level_of(j);
    LevelJobState<T>& js = job_state_[j];
    js.ic.dt = T(L.window_dt);
    js.obstacles.resize(obstacles.size());  // sized by prepare(): no allocation here
    for (std::size_t o = 0; o < obstacles.size(); ++o)
      js.obstacles[o] = half_space_context(L, obstacles[o], bodies[std::size_t(js.body)].origin);
    coupled_due |= L.coupled();
    for (std::size_t q = js.first_node_piece; q < js.end_node_piece; ++q) {
      const std::size_t n = node_pieces_[q].count;
      nodes.push_back({n, tick_grain(n, kTickNodeChunk, kNodeGrain, exec.threads()),
                       L.coupled() ? &run_gather<T> : &run_gather_integrate<T>, &node_pieces_[q]});
    }
  }

  if (coupled_due) {
    // D: the forces on the ghosts of the levels whose window ends go to their sources as impulses.
    for (std::size_t j = 0; j < jobs; ++j) {
      Level<T>& L = level_of(j);
      if (L.receivers.empty()) continue;
      LevelJobState<T>& js = job_state_[j];
      const SimBody<T>& body = bodies[std::size_t(js.body)];
      const std::size_t first = job_of_body_[std::size_t(js.body)];
      bool any = false;
      for (std::size_t m = 0; m < body.levels.size(); ++m) {
        const bool now = due_[first + m].window_end && !body.levels[m].ghosts.empty();
        js.rc.ghost_dt[m] = now ? T(body.levels[m].window_dt) : T(0);
        any |= now;
      }
      if (any)
        receive.push_back({L.receivers.size(), tick_grain(L.receivers.size(), kTickNodeChunk, kNodeGrain, exec.threads()), &run_receive<T>, &js.rc});
    }
    // E: the coupled levels whose window ends integrate, with the impulses they received.
    for (std::size_t j = 0; j < jobs; ++j) {
      Level<T>& L = level_of(j);
      if (!due_[j].window_end || !L.coupled()) continue;
      const LevelJobState<T>& js = job_state_[j];
      for (std::size_t q = js.first_node_piece; q < js.end_node_piece; ++q) {
        const std::size_t n = node_pieces_[q].count;
        integrate.push_back({n, tick_grain(n, kTickNodeChunk, kNodeGrain, exec.threads()), &run_integrate<T>, &node_pieces_[q]});
      }
    }
  }

  Executor::Phase phases[kTickPhases];
  for (std::size_t p = 0; p < kTickPhases; ++p)
    phases[p] = {tick_segments_[p].data(), tick_segments_[p].size(), tick_predicates_[p].data(), tick_predicates_[p].size()};
  const bool finite = exec.run_phases(phases, kTickPhases);

  if (!finite) {
    for (std::size_t j = 0; j < jobs; ++j) {
      if (!due_[j].window_end) continue;
      const Level<T>& L = level_of(j);
      for (std::size_t n = 0; n < L.node_count; ++n) {
        if (L.state[n] != kNodeFree) continue;
        bool ok = true;
        for (int k = 0; k < 3; ++k) ok &= within_bounds(L.x[k][n], L.v[k][n]);
        if (ok) continue;
        where = fmt::format(
            "body '{}', level {}, step {} (t = {:.6g} s): node {} has a non-finite position or velocity, or one beyond "
            "{:g} (m, m/s)",
            bodies[std::size_t(job_state_[j].body)].def.name, job_state_[j].level, step_index, t + h, n,
            kDivergedMagnitude);
        return false;
      }
    }
    where = fmt::format("step {} (t = {:.6g} s): a node diverged", step_index, t + h);
    return false;
  }

  // Tools (collision/tool_contact.hpp): free surface nodes of the levels whose window ends that
  // the tool reached (or swept through) over the window go onto its surface; their forces are
  // its reading. After the divergence check: Embree must never see a non-finite triangle.
  for (ToolState<T>& tool : tools) {
    const ToolPose to = tool.pose_at(t + h);
    bool any = false;
    double work = 0;  // J, of the levels resolved in this step (the others' readings are older)
    for (LevelContact<T>& lc : tool.levels) {
      const std::size_t j = job_of_body_[std::size_t(lc.body)] + std::size_t(lc.level);
      if (!due_[j].window_end) continue;
      Level<T>& L = level_of(j);
      std::string error;
      if (!resolve_tool_contact(lc, L, tool.def.shape, to, bodies[std::size_t(lc.body)].origin, L.window_dt, exec, error)) {
        where = fmt::format("tool '{}' against body '{}', level {}, step {}: {}", tool.def.name,
                            bodies[std::size_t(lc.body)].def.name, lc.level, step_index, error);
        return false;
      }
      any = true;
      work += lc.work;
    }
    if (!any) continue;
    ToolReading& r = tool.reading;
    r = ToolReading{};
    r.time = t + h;
    r.work = work;
    tool.work_total += work;
    r.work_total = tool.work_total;
    for (const LevelContact<T>& lc : tool.levels) {
      for (int k = 0; k < 3; ++k) r.force[std::size_t(k)] += lc.force[std::size_t(k)];
      r.contacts += lc.contacts;
      r.held_nodes += int(lc.held_vertices.size());
      r.max_penetration = std::max(r.max_penetration, lc.max_penetration);
      r.refits += lc.refits;
      r.queries += lc.queries;
    }
  }

  // Prescribed motion of the levels that integrated: nodes at rest + offset(end of window),
  // velocity = the offset's change over the window.
  for (std::size_t j = 0; j < jobs; ++j) {
    if (!due_[j].window_end) continue;
    Level<T>& L = level_of(j);
    const std::size_t l = std::size_t(job_state_[j].level);
    for (MotionState& m : bodies[std::size_t(job_state_[j].body)].motions) {
      const Vec3d o1 = m.offset_at(t + h);
      const Vec3d o0 = m.host_driven ? m.host_from[l] : m.offset_at(L.window_start);
      m.host_from[l] = o1;
      for (std::int32_t n : m.nodes[l])
        for (int k = 0; k < 3; ++k) {
          L.x[k][n] = L.X[k][n] + T(o1[k]);
          L.v[k][n] = T((o1[k] - o0[k]) / L.window_dt);
        }
    }
    L.window_dt = 0;
  }
  ++tick_;

  // Adaptivity (multires/adaptivity.hpp): decided only at ticks where every level of the body ended
  // its window, so no level is ever changed in the middle of its step.
  bool adapted = false;
  for (std::size_t b = 0; b < bodies.size(); ++b) {
    SimBody<T>& body = bodies[b];
    if (!body.adapt) continue;
    bool aligned = true;
    for (std::size_t l = 0; l < body.levels.size(); ++l) aligned &= due_[job_of_body_[b] + l].window_end;
    if (!aligned) continue;
    // What refines by distance (AdaptDef::refine_near), where it is now (body frame): the tools
    // touching the body, the nodes of its prescribed motions (their bounding box), and the probes
    // that ask for it. The tools always: with refine_near 0 nothing refines by distance, but the
    // nodes next to a tool do not merge (a merge there put a coarser surface centimetres inside it,
    // and the split back put fine nodes there: a stress scene went from 7 J to 114 J), and the
    // points of the triangles the tool presses but its response cannot push (LevelContact::
    // unresolved) refine whatever refine_near.
    // (Listed in near_scratch_: kept between decision points, so that one allocates nothing once
    // the list has had its size; a local vector allocated at every decision point of every
    // adaptive body, tests/core/test_hot_path_allocations.cpp.)
    std::vector<NearShape>& near = near_scratch_;
    near.clear();
    {
      for (const ToolState<T>& tool : tools) {
        bool touches = false;
        for (const LevelContact<T>& lc : tool.levels) touches |= lc.body == int(b);
        if (!touches) continue;
        Vec3d a, e;
        tool_axis(tool.def.shape, tool.pose_at(t + h), a, e);
        NearShape s;
        for (int k = 0; k < 3; ++k) {
          s.a[std::size_t(k)] = a[std::size_t(k)] - body.origin[std::size_t(k)];
          s.b[std::size_t(k)] = e[std::size_t(k)] - body.origin[std::size_t(k)];
        }
        s.radius = tool.def.shape.radius;
        s.tool = true;
        near.push_back(s);
        for (const LevelContact<T>& lc : tool.levels) {
          if (lc.body != int(b)) continue;
          for (const auto& p : lc.unresolved) {
            NearShape c;
            c.a = c.b = p;
            c.tool = true;
            c.unresolved_contact = true;
            near.push_back(c);
          }
        }
      }
    }
    if (body.adapt->def.refine_near != 0) {
      for (const MotionState& ms : body.motions) {
        NearShape s;
        s.box = true;
        s.a = {1e300, 1e300, 1e300};
        s.b = {-1e300, -1e300, -1e300};
        for (std::size_t l = 0; l < ms.nodes.size(); ++l)
          for (std::int32_t v : ms.nodes[l])
            for (int k = 0; k < 3; ++k) {
              const double x = double(body.levels[l].x[k][std::size_t(v)]);
              s.a[std::size_t(k)] = std::min(s.a[std::size_t(k)], x);
              s.b[std::size_t(k)] = std::max(s.b[std::size_t(k)], x);
            }
        if (s.a[0] <= s.b[0]) near.push_back(s);
      }
      for (const ProbeState& p : probes) {
        if (p.body != int(b) || !p.refine) continue;
        const Level<T>& L = body.levels[std::size_t(p.level)];
        NearShape s;
        for (int c = 0; c < 4; ++c) {
          const Vec3d x = node_now(body, L, std::size_t(L.tet[c][std::size_t(p.tet)]));
          for (int k = 0; k < 3; ++k) s.a[std::size_t(k)] += p.weights[std::size_t(c)] * x[std::size_t(k)];
        }
        s.b = s.a;
        near.push_back(s);
      }
    }
    // A change of level is not energy-neutral (the coarser tets lock in bending, a merged region
    // snaps to the coarse field): what a change adds to kinetic + elastic energy is taken back from
    // the body's motion relative to its mean velocity (momentum kept). Where that motion cannot
    // give it back (a bent body at the end of its swing has almost none) and what would stay is more
    // than kUnpaidShare of the body's energy before it, a change that merged is undone and applied
    // again without its merges (undo_change).
    // Due at its check_every, at once when forced (World::force_level), and at once when a tool
    // presses a triangle it cannot push: waiting 6.6 ms for the next check let a sphere 1.5 mm
    // into a coarse triangle by a clamped end, and the split then put the finer surface inside it
    // (a stress scene, 0x9f74...: energy peak 1.67, failing above 1.5; 0.94 deciding at once).
    // Neither waits within a change interval after a change (AdaptiveState::decision_due).
    bool unresolved = false;
    for (const NearShape& s : near) unresolved |= s.unresolved_contact;
    if (!body.adapt->decision_due(t + h, unresolved)) continue;
    // Energy an earlier change added and could not take back at once (a body at the bottom of its
    // swing, bent, has little motion about its mean velocity): taken now, as far as the motion has
    // it, half of that motion at most per decision point (never stopping the motion at once). A
    // swinging box (stress seed 30) let 3.5 % of its energy through at two merges, under
    // kUnpaidShare, and rose to 2.2x its energy budget; paid when its motion has it again, it stays
    // below (Stress.AnAdaptiveSwingWhoseMergesCouldNotPayPasses).
    if (body.adapt->owed_energy > 0) {
      const BodyMotion motion = body_motion(body);
      const double paid = std::min(body.adapt->owed_energy, 0.5 * motion.relative);
      if (paid > 0) {
        take_energy(body, paid, motion);
        body.adapt->owed_energy -= paid;
      }
    }
    const auto started = std::chrono::steady_clock::now();
    auto clock_check = [&] {
      const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
      body.adapt->check_seconds += s;
      body.adapt->check_max_seconds = std::max(body.adapt->check_max_seconds, s);
    };
    // The state before is kept only where the decisions change something (most decision points
    // change nothing).
    auto before_change = [&] { save_change_energy(body); };
    // The finest level's stepped tets as its force pass reads them, when it steps from a list.
    ListedRest<T> finest;
    if (const LevelJobState<T>* js = job_of(body, body.levels.back()); js && !js->stepped.empty()) {
      for (int a = 0; a < 4; ++a) finest.tet[a] = js->listed_tet[a].data();
      for (int q = 0; q < 9; ++q) finest.grad[q] = js->listed_grad[q].data();
      finest.count = js->stepped.size();
    }
    if (!adapt_body(body, t + h, near, before_change, &exec, &finest)) {
      clock_check();
      continue;
    }
    const ChangeEnergy change = change_energy_added(body);
    double excess = change.added;
    BodyMotion motion = body_motion(body);  // what take_energy can take (all of it at most)
    // The body's energy before the change, for the undo's test, only when the test could pass: it is
    // at least the part of it where the change acted (every term is >= 0: kinetic energies, and
    // elastic energies of positive definite materials), so an unpaid excess within kUnpaidShare of
    // that part is within it of the whole (the whole body's sum: the energy now less the excess).
    if (body.adapt->undoable && excess - motion.relative > kUnpaidShare * change.before_here) {
      const double e_before = body_energy(&exec, body) - excess;
      if (excess - motion.relative > kUnpaidShare * e_before) {
        excess = undo_change(body, t + h) ? body_energy(&exec, body) - e_before : 0.0;
        motion = body_motion(body);
      }
    }
    if (excess > 0) {
      take_energy(body, excess, motion);
      if (excess > motion.relative) body.adapt->owed_energy += excess - motion.relative;
    }
    clock_check();
    adapted = true;
    place_ghosts(body);
    relocate_probes(int(b));
  }
  // Stepped runs and ghosts changed: the jobs' contexts follow (allocates). With the periods of the
  // step's own tick, not of this tick h: while the deformation monitor sub-steps, h is a fraction
  // of it, and periods made for h grew with the sub-steps, so every level stepped as long as
  // without them (and beyond its stable step once they relaxed).
  if (adapted) {
    prepare(period_tick_);
    size_region(exec);
  }
  return true;
}

// x[k][g], v[k][g] for every ghost g of L: where its sources are now (ghost_now, rounded to T).
// x and v may be L's own arrays (a ghost's sources are never ghosts).
template <class T>
void write_ghosts_now(const SimBody<T>& body, const Level<T>& L, AlignedVector<T> (&x)[3], AlignedVector<T> (&v)[3]) {
  for (std::size_t i = 0; i < L.ghosts.size(); ++i) {
    double xi[3], vi[3];
    ghost_now(body, L, i, xi, vi);
    const auto g = std::size_t(L.ghosts[i]);
    for (int k = 0; k < 3; ++k) {
      x[k][g] = T(xi[k]);
      v[k][g] = T(vi[k]);
    }
  }
}

// Every ghost of the body where its sources are now (position and velocity). The step refreshes a
// level's ghosts at the start of its windows, and a change comes where every window of the body
// ends, so the next tick computes these same places before any force; but the deformation
// monitor measures the stepped tets at the start of the next step, before that refresh, and a new
// ghost (a node inactive until the change) still held where it was when last simulated, or at rest:
// on the 50k-tet organ lifted to its finest level, 68 new ghosts up to 7.9 mm off their sources
// (the fine tets are 4.3 mm), a stiffness ratio of 140 and every step cut into 15 sub-steps for
// the next 3 ms (2026-11-28; test Adaptivity.NewGhostsStandWhereTheirSourcesAreWhenTheMonitorMeasures).
template <class T>
void Simulation<T>::place_ghosts(SimBody<T>& body) {
  for (Level<T>& L : body.levels) write_ghosts_now(body, L, L.x, L.v);
}

// A probe reads the finest level that steps a tet around its material point (World::add_probe's
// rule), again after the activation changed: from its candidates (probe_placement.hpp), or where
// no stepped candidate contains the point, by reading every stepped tet.
template <class T>
void Simulation<T>::relocate_probes(int body) {
  const SimBody<T>& B = bodies[std::size_t(body)];
  for (ProbeState& p : probes) {
    if (p.body != body) continue;
    double X[3];
    probe_rest_point(B, p, X);
    if (!place_probe_from_candidates(B, X, p)) place_probe_by_scan(B, X, p);
  }
}

template <class T>
void current_state(const SimBody<T>& body, const Level<T>& L, CurrentState<T>& out) {
  for (int k = 0; k < 3; ++k) {
    out.x[k].assign(L.x[k].begin(), L.x[k].end());
    out.v[k].assign(L.v[k].begin(), L.v[k].end());
  }
  write_ghosts_now(body, L, out.x, out.v);
}
template void current_state<float>(const SimBody<float>&, const Level<float>&, CurrentState<float>&);
template void current_state<double>(const SimBody<double>&, const Level<double>&, CurrentState<double>&);

namespace {
// Points ec at the level's current state (ghosts where their sources are now) if it has ghosts.
template <class T>
void use_current_state(const SimBody<T>& body, const Level<T>& L, ElementContext<T>& ec, CurrentState<T>& keep) {
  if (L.ghosts.empty()) return;
  current_state(body, L, keep);
  for (int k = 0; k < 3; ++k) {
    ec.x[k] = keep.x[k].data();
    ec.v[k] = keep.v[k].data();
  }
}
}  // namespace

// Adds the elastic energy of the tets level L steps (all, for one level) to `sum` (J), tet by tet
// in a fixed order, so the sum is the same bits whether exec (may be null: on this thread) splits
// the energy pass or not.
template <class T>
void Simulation<T>::add_elastic_energy(Executor* exec, const SimBody<T>& body, const Level<T>& L, double& sum) const {
  // A level that steps no tet adds nothing: skip it before current_state copies its nodes (the
  // organ's inactive finest level: 10k nodes copied at each change of resolution, for nothing).
  if (L.stepped_count == 0) return;
  grow_scratch(L.tet_count);
  ElementContext<T> ec = element_context(L);
  CurrentState<T> now;
  use_current_state(body, L, ec, now);
  const EnergyPass<T> pass = energy_kernel<T>(L.model);
  double* out = scratch.data();
  // A level of short runs (steps_by_list), corotational: over a list of its stepped tets, in full
  // lanes; the same tets in the same order as by runs, so the same sum. The list is made here from
  // the runs as they are now, not taken from prepare(): the energy after a change is measured
  // before the jobs are prepared again.
  if (L.model == ForceModel::corotational && steps_by_list(L)) {
    list_stepped(L, energy_ids);
    const std::int32_t* ids = energy_ids.data();
    const std::size_t n = energy_ids.size();
    // Their rotations: a listed level's current ones are in its job's list (listed_rotations).
    if (listed_rotations(body, L, ids, n, energy_rotation))
      for (int k = 0; k < 4; ++k) ec.listed_rotation[k] = energy_rotation[k].data();
    if (exec)
      exec->parallel_for(n, pass_grain(n, kTetGrain), [&](Range r) { element_energy_corotational_listed(ec, ids, r, out); });
    else
      element_energy_corotational_listed(ec, ids, Range{0, n}, out);
    for (std::size_t i = 0; i < n; ++i) sum += scratch[std::size_t(ids[i])];
    return;
  }
  // By runs while its job still steps a list (a change that ended the list, measured before
  // prepare()): its rotations by tet with the list's laid over.
  if (const LevelJobState<T>* js = job_of(body, L); L.model == ForceModel::corotational && js && !js->stepped.empty() && js->ec.listed_rotation[0]) {
    current_rotations(body, L, level_rotation);
    for (int k = 0; k < 4; ++k) ec.rotation[k] = level_rotation[k].data();
  }
  for (const Range& run : L.stepped_runs) {
    if (exec)
      exec->parallel_for(run.size(), pass_grain(run.size(), kTetGrain), [&](Range r) { pass(ec, Range{run.begin + r.begin, run.begin + r.end}, out); });
    else
      pass(ec, run, out);
    for (std::size_t t = run.begin; t < run.end; ++t) sum += scratch[t];
  }
}

// Kinetic (1/2 m v^2 of the free nodes) + elastic energy of one body, in a fixed order (J): the
// same bits on exec's threads as on this one (add_elastic_energy). Measured twice per change of
// resolution; on one thread it was 0.3 ms of each on the 50k-tet organ with its finest level on.
// A level that steps no tet has no free node (its free, fixed and ghost nodes are the corners of
// its stepped tets): skipped, as by add_elastic_energy (the organ's idle finest level, 10 700
// nodes read for nothing, at each of the 2 energies and 2-3 motions of a change).
template <class T>
double Simulation<T>::body_energy(Executor* exec, const SimBody<T>& body) const {
  double e = 0;
  for (const Level<T>& L : body.levels) {
    if (L.stepped_count == 0) continue;
    add_elastic_energy(exec, body, L, e);
    for (std::size_t n = 0; n < L.node_count; ++n)
      if (L.state[n] == kNodeFree)
        for (int k = 0; k < 3; ++k) e += 0.5 * double(L.mass[n]) * double(L.v[k][n]) * double(L.v[k][n]);
  }
  return e;
}

namespace {
// The 8 node states at s (of `left` nodes from there on) are all kNodeInactive.
bool inactive8(const std::uint8_t* s, std::size_t left) {
  if (left < 8) return false;
  constexpr std::uint64_t kInactive8 = 0x0101010101010101ull * kNodeInactive;
  std::uint64_t w;
  std::memcpy(&w, s, 8);
  return w == kInactive8;
}
// Tet t is in one of the runs (ascending, disjoint).
bool in_runs(const std::vector<Range>& runs, std::size_t t) {
  auto it = std::upper_bound(runs.begin(), runs.end(), t, [](std::size_t x, const Range& r) { return x < r.begin; });
  return it != runs.begin() && t < std::prev(it)->end;
}
}  // namespace

// Only the simulated nodes' masses, positions and velocities are kept (ghosts where their sources
// are): change_energy_added reads a node's saved values only where it was not inactive, and the
// corners of the tets stepped before are such nodes. The arrays keep their size between changes
// (never shrink; an inactive node's entries hold whatever an earlier change left): on a bar of
// 196 608 fine tets stepping 14 000 of them, copying every node of the finest level took
// 390-780 us a change.
template <class T>
void Simulation<T>::save_change_energy(const SimBody<T>& body) {
  auto& before = change_energy_.before;
  before.resize(body.levels.size());
  for (std::size_t l = 0; l < body.levels.size(); ++l) {
    const Level<T>& L = body.levels[l];
    ChangeEnergyLevel& b = before[l];
    b.saved = L.stepped_count > 0;  // else every node inactive (body_energy)
    if (!b.saved) continue;
    b.state.assign(L.state.begin(), L.state.begin() + std::ptrdiff_t(L.node_count));
    if (b.mass.size() < L.node_count) b.mass.resize(L.node_count);
    for (int k = 0; k < 3; ++k) {
      if (b.now.x[k].size() < L.node_count) b.now.x[k].resize(L.node_count);
      if (b.now.v[k].size() < L.node_count) b.now.v[k].resize(L.node_count);
    }
    for (std::size_t n = 0; n < L.node_count; ++n) {
      if (n % 8 == 0 && inactive8(L.state.data() + n, L.node_count - n)) {
        n += 7;
        continue;
      }
      if (L.state[n] == kNodeInactive) continue;
      b.mass[n] = L.mass[n];
      for (int k = 0; k < 3; ++k) {
        b.now.x[k][n] = L.x[k][n];
        b.now.v[k][n] = L.v[k][n];
      }
    }
    write_ghosts_now(body, L, b.now.x, b.now.v);
    b.stepped_runs = L.stepped_runs;
  }
}

template <class T>
typename Simulation<T>::ChangeEnergy Simulation<T>::change_energy_added(SimBody<T>& body) {
  ChangeEnergyScratch& ce = change_energy_;
  // The state after is the levels' own arrays with every ghost where its sources are now (as the
  // step places them after a change anyway): no copy of a level's nodes.
  place_ghosts(body);
  double e_before = 0, e_after = 0;  // J, over what changed, each in a fixed order
  for (std::size_t l = 0; l < body.levels.size(); ++l) {
    const Level<T>& L = body.levels[l];
    const ChangeEnergyLevel& b = ce.before[l];
    const bool on = L.stepped_count > 0;
    if (!b.saved && !on) continue;  // idle before and after: inactive nodes, no tet
    static const std::vector<Range> none;
    const std::vector<Range>& runs_before = b.saved ? b.stepped_runs : none;
    const std::vector<Range>& runs_after = on ? L.stepped_runs : none;
    // Nodes whose contribution may differ: another state, or (simulated) another mass, position
    // or velocity, to the bit. (b's values are read only for a node that was not inactive.)
    // Eight nodes inactive before and after are passed over at once (most of a large level's).
    ce.dirty.clear();
    for (std::size_t n = 0; n < L.node_count; ++n) {
      if (n % 8 == 0 && inactive8(L.state.data() + n, L.node_count - n) &&
          (!b.saved || inactive8(b.state.data() + n, L.node_count - n))) {
        n += 7;
        continue;
      }
      const std::uint8_t was = b.saved ? b.state[n] : std::uint8_t(kNodeInactive), now = L.state[n];
      if (was == kNodeInactive && now == kNodeInactive) continue;
      bool differs = was != now || !on || !(L.mass[n] == b.mass[n]);  // (!on: no state after to compare)
      for (int k = 0; k < 3 && !differs; ++k)
        differs = !(L.x[k][n] == b.now.x[k][n]) || !(L.v[k][n] == b.now.v[k][n]);
      if (differs) ce.dirty.push_back(std::int32_t(n));
    }
    // Tets: those stepped before or after around a dirty node, and those whose stepping changed.
    // (tet_mark: zero between calls, its marks cleared below.)
    if (ce.tet_mark.size() < L.tet_count) ce.tet_mark.resize(L.tet_count, 0);
    ce.tets.clear();
    auto was_stepped = [&](std::size_t t) { return in_runs(runs_before, t); };
    auto now_stepped = [&](std::size_t t) { return in_runs(runs_after, t); };
    auto add_tet = [&](std::size_t t) {
      if (ce.tet_mark[t] || !(was_stepped(t) || now_stepped(t))) return;
      ce.tet_mark[t] = 1;
      ce.tets.push_back(std::int32_t(t));
    };
    for (std::int32_t n : ce.dirty)
      for (auto e = L.incidence_offsets[std::size_t(n)]; e < L.incidence_offsets[std::size_t(n) + 1]; ++e)
        add_tet(std::size_t(L.incidence[std::size_t(e)] >> 2));  // 4 * tet + corner
    // The tets whose stepping changed: where exactly one of the two run lists covers them, found by
    // merging their boundaries (O(runs); comparing per-tet masks read every tet of the level).
    {
      auto boundary = [](const std::vector<Range>& r, std::size_t k) { return k % 2 ? r[k / 2].end : r[k / 2].begin; };
      const std::size_t na = 2 * runs_before.size(), nb = 2 * runs_after.size();
      std::size_t ka = 0, kb = 0, from = 0;
      bool in_a = false, in_b = false;
      while (ka < na || kb < nb) {
        const std::size_t pa = ka < na ? boundary(runs_before, ka) : SIZE_MAX;
        const std::size_t pb = kb < nb ? boundary(runs_after, kb) : SIZE_MAX;
        const std::size_t p = std::min(pa, pb);
        if (in_a != in_b)
          for (std::size_t t = from; t < p; ++t) add_tet(t);
        if (pa == p) in_a = !in_a, ++ka;
        if (pb == p) in_b = !in_b, ++kb;
        from = p;
      }
    }
    std::sort(ce.tets.begin(), ce.tets.end());
    // Their elastic energy before (the saved positions) and after, tet by tet: the same kernels,
    // rest data and warm-start rotations (listed_rotations) as the whole-body sums, so an
    // unchanged tet would give the same bits.
    if (ce.energy.size() < L.tet_count) ce.energy.resize(L.tet_count);
    double* out = ce.energy.data();
    ElementContext<T> ec = element_context(L);
    const EnergyPass<T> pass = energy_kernel<T>(L.model);
    for (std::int32_t t : ce.tets) ce.tet_mark[std::size_t(t)] = 0;
    auto elastic = [&](const AlignedVector<T> (&x)[3], const AlignedVector<T> (&v)[3], bool after, double& sum) {
      ce.phase_tets.clear();
      for (std::int32_t t : ce.tets)
        if (after ? now_stepped(std::size_t(t)) : was_stepped(std::size_t(t))) ce.phase_tets.push_back(t);
      if (ce.phase_tets.empty()) return;
      for (int k = 0; k < 3; ++k) {
        ec.x[k] = x[k].data();
        ec.v[k] = v[k].data();
      }
      const std::int32_t* ids = ce.phase_tets.data();
      const std::size_t n = ce.phase_tets.size();
      if (L.model == ForceModel::corotational) {
        // A listed level's current rotations are in its job's list (Level::rotation for the others).
        const bool listed = listed_rotations(body, L, ids, n, energy_rotation);
        for (int k = 0; k < 4; ++k) ec.listed_rotation[k] = listed ? energy_rotation[k].data() : nullptr;
        element_energy_corotational_listed(ec, ids, Range{0, n}, out);
      } else {
        for (std::size_t i = 0; i < n; ++i) pass(ec, Range{std::size_t(ids[i]), std::size_t(ids[i]) + 1}, out);
      }
      for (std::size_t i = 0; i < n; ++i) sum += out[std::size_t(ids[i])];
    };
    if (b.saved) elastic(b.now.x, b.now.v, false, e_before);
    if (on) elastic(L.x, L.v, true, e_after);
    // Their nodes' kinetic energy (free nodes: 1/2 m v^2, as body_energy counts it).
    for (std::int32_t i : ce.dirty) {
      const auto n = std::size_t(i);
      if (b.saved && b.state[n] == kNodeFree)
        for (int k = 0; k < 3; ++k) e_before += 0.5 * double(b.mass[n]) * double(b.now.v[k][n]) * double(b.now.v[k][n]);
      if (L.state[n] == kNodeFree)
        for (int k = 0; k < 3; ++k) e_after += 0.5 * double(L.mass[n]) * double(L.v[k][n]) * double(L.v[k][n]);
    }
  }
  return {e_after - e_before, e_before};
}

template <class T>
typename Simulation<T>::BodyMotion Simulation<T>::body_motion(const SimBody<T>& body) const {
  BodyMotion bm;
  for (const Level<T>& L : body.levels) {
    if (L.stepped_count == 0) continue;  // no free node (body_energy)
    for (std::size_t n = 0; n < L.node_count; ++n)
      if (L.state[n] == kNodeFree) {
        bm.mass += double(L.mass[n]);
        for (int k = 0; k < 3; ++k) bm.momentum[k] += double(L.mass[n]) * double(L.v[k][n]);
      }
  }
  if (!(bm.mass > 0)) return bm;
  for (const Level<T>& L : body.levels) {
    if (L.stepped_count == 0) continue;
    for (std::size_t n = 0; n < L.node_count; ++n)
      if (L.state[n] == kNodeFree)
        for (int k = 0; k < 3; ++k) {
          const double u = double(L.v[k][n]) - bm.momentum[k] / bm.mass;
          bm.relative += 0.5 * double(L.mass[n]) * u * u;
        }
  }
  return bm;
}

// Removes `excess` J from the free nodes' motion relative to their mean velocity (momentum kept), as
// far as that motion holds it.
template <class T>
void Simulation<T>::take_energy(SimBody<T>& body, double excess, const BodyMotion& motion) {
  const double m = motion.mass;
  const double* p = motion.momentum;
  if (!(m > 0) || !(motion.relative > 0)) return;
  const double scale = std::sqrt(std::max(0.0, 1.0 - excess / motion.relative));
  for (Level<T>& L : body.levels) {
    if (L.stepped_count == 0) continue;
    for (std::size_t n = 0; n < L.node_count; ++n)
      if (L.state[n] == kNodeFree)
        for (int k = 0; k < 3; ++k) L.v[k][n] = T(p[k] / m + scale * (double(L.v[k][n]) - p[k] / m));
  }
}

template <class T>
void Simulation<T>::elastic_energies(Executor& exec, double& elastic) const {
  elastic = 0;
  for (const SimBody<T>& body : bodies)
    for (const Level<T>& L : body.levels) add_elastic_energy(&exec, body, L, elastic);
}

template <class T>
double Simulation<T>::centred_kinetic(Executor& exec, double h, double& stored) const {
  double kinetic = 0;
  stored = 0;
  for (const SimBody<T>& body : bodies) {
    // Forces of the current state, as the next step's element passes and gathers will compute
    // them, into scratch arrays (allocated here: a report, not the hot path); for the levels of a
    // multiresolution body, the ghosts' forces go to their sources as the step sends them.
    std::vector<std::array<AlignedVector<T>, 3>> force(body.levels.size());
    for (std::size_t l = 0; l < body.levels.size(); ++l) {
      const Level<T>& L = body.levels[l];
      ElementContext<T> ec = element_context(L);
      CurrentState<T> now;
      use_current_state(body, L, ec, now);
      AlignedVector<T> corner[12], rotation[4];
      for (int q = 0; q < 12; ++q) {
        corner[q].assign(L.tet_count, T(0));
        ec.corner_force[q] = corner[q].data();
      }
      if (!L.rotation[0].empty()) {  // a listed level's current ones are its job's list copy
        current_rotations(body, L, rotation);
        for (int k = 0; k < 4; ++k) ec.rotation[k] = rotation[k].data();
      }
      const ElementPass<T> pass = force_kernel<T>(L.model);
      for (const Range& run : L.stepped_runs)
        exec.parallel_for(run.size(), pass_grain(run.size(), kTetGrain),
                          [&](Range r) { pass(ec, Range{run.begin + r.begin, run.begin + r.end}); });
      GatherContext<T> gc;
      gc.offsets = L.incidence_offsets.data();
      gc.incidence = L.incidence.data();
      for (int q = 0; q < 12; ++q) gc.corner_force[q] = corner[q].data();
      for (int k = 0; k < 3; ++k) {
        force[l][k].assign(L.node_count, T(0));
        gc.external[k] = L.external[k].empty() ? nullptr : L.external[k].data();
        gc.f[k] = force[l][k].data();
      }
      exec.parallel_for(L.node_count, pass_grain(L.node_count, kNodeGrain), [&](Range r) { gather_forces(gc, r); });
    }
    for (std::size_t l = 0; l < body.levels.size(); ++l) {
      const Level<T>& L = body.levels[l];
      std::vector<double> received;  // per receiver: the ghosts' forces, N (fixed order)
      if (!L.receivers.empty()) {
        received.assign(3 * L.receivers.size(), 0.0);
        for (std::size_t i = 0; i < L.receivers.size(); ++i)
          for (auto e = L.receive_offsets[i]; e < L.receive_offsets[i + 1]; ++e)
            for (int k = 0; k < 3; ++k)
              received[3 * i + std::size_t(k)] +=
                  L.receive_weight[std::size_t(e)] *
                  double(force[std::size_t(L.receive_ghost_level[std::size_t(e)])][std::size_t(k)]
                              [std::size_t(L.receive_ghost_node[std::size_t(e)])]);
      }
      std::size_t next_receiver = 0;
      for (std::size_t n = 0; n < L.node_count; ++n) {  // fixed order
        const double m = double(L.mass[n]);
        const bool free = L.state[n] == kNodeFree;
        const bool receives = next_receiver < L.receivers.size() && std::size_t(L.receivers[next_receiver]) == n;
        double vc2 = 0, v2 = 0;
        for (int k = 0; k < 3; ++k) {
          const double v = double(L.v[k][n]);
          const double fk = double(force[l][std::size_t(k)][n]) + (receives ? received[3 * next_receiver + std::size_t(k)] : 0.0);
          const double a = fk * double(L.inv_mass[n]) + double(gravity[k]) - double(L.mass_damping) * v;
          const double vc = free ? v + 0.5 * (h * L.period) * a : v;  // each level steps period x h
          vc2 += vc * vc;
          v2 += v * v;
        }
        if (receives) ++next_receiver;
        kinetic += 0.5 * m * vc2;
        stored += 0.5 * m * v2;
      }
    }
  }
  return kinetic;
}

template <class T>
double Simulation<T>::stiffness_ratio(Executor& exec) const {
  double ratio = 1;
  for (std::size_t b = 0; b < bodies.size(); ++b)
    for (std::size_t l = 0; l < bodies[b].levels.size(); ++l) {
      const Level<T>& L = bodies[b].levels[l];
      if (L.model == ForceModel::linear) continue;
      ElementContext<T> ec = element_context(L);
      if (L.model == ForceModel::corotational && pack_pays(L, L.stepped_count)) {
        // The corotational lanes load corners from the interleaved copy, as the force pass does
        // (4 loads and a transpose per corner instead of 3 gathers): packed here from x, the
        // positions measured. The next tick packs x again before its element pass, so writing
        // the level's step-private copy changes nothing else.
        Level<T>& mutable_level = const_cast<Level<T>&>(L);
        const PackContext<T> pc = pack_context(mutable_level);
        exec.parallel_for(L.node_count, pass_grain(L.node_count, kNodeGrain), [&](Range r) { pack_positions(pc, r); });
        ec.xp = pc.xp;
      }
      const std::vector<std::int32_t>* listed =
          b < job_of_body_.size() ? &job_state_[job_of_body_[b] + l].stepped : nullptr;
      if (L.model == ForceModel::corotational && listed && !listed->empty() && listed->size() == L.stepped_count) {
        // A level stepped from a list (prepare): its stepped tets in full lanes, as its force pass.
        const std::size_t n = listed->size(), grain = pass_grain(n, kTetGrain), chunks = (n + grain - 1) / grain;
        chunk_max.resize(chunks);
        double* top = chunk_max.data();
        const std::int32_t* ids = listed->data();
        // The rest data in list order, as the force pass loads it (prepare: made from this list).
        const ElementContext<T>& job_ec = job_state_[job_of_body_[b] + l].ec;
        for (int a = 0; a < 4; ++a) ec.listed_tet[a] = job_ec.listed_tet[a];
        for (int q = 0; q < 9; ++q) ec.listed_grad[q] = job_ec.listed_grad[q];
        ec.listed_volume = job_ec.listed_volume;
        for (int k = 0; k < 4; ++k) ec.listed_rotation[k] = job_ec.listed_rotation[k];  // the current ones
        exec.parallel_for(chunks, 1, [&](Range cr) {
          for (std::size_t i = cr.begin; i < cr.end; ++i)
            top[i] = element_stiffness_ratio_corotational_max_listed(ec, ids, Range{i * grain, std::min(n, (i + 1) * grain)});
        });
        for (std::size_t i = 0; i < chunks; ++i) ratio = std::max(ratio, top[i]);
        continue;
      }
      if (L.model != ForceModel::corotational) grow_scratch(L.tet_count);
      double* out = scratch.data();
      for (const Range& run : L.stepped_runs) {  // the tets the level steps (all, for one level)
        // Chunks of `grain` tets, each reduced to its largest ratio (in parallel), then combined in
        // chunk order: a max, so the same value for any thread split. Corotational folds the max
        // into the kernel (no per-tet output: its fast path writes nothing).
        const std::size_t grain = pass_grain(run.size(), kTetGrain), chunks = (run.size() + grain - 1) / grain;
        chunk_max.resize(chunks);
        double* top = chunk_max.data();
        exec.parallel_for(chunks, 1, [&](Range cr) {
          for (std::size_t i = cr.begin; i < cr.end; ++i) {
            const Range r{run.begin + i * grain, run.begin + std::min(run.size(), (i + 1) * grain)};
            if (L.model == ForceModel::corotational) {
              top[i] = element_stiffness_ratio_corotational_max(ec, r);
              continue;
            }
            if (L.model == ForceModel::stvk)
              element_stiffness_ratio_stvk(ec, r, out);
            else
              element_stiffness_ratio_springs(ec, r, out);
            double m = 1;
            for (std::size_t t = r.begin; t < r.end; ++t) m = std::max(m, out[t]);
            top[i] = m;
          }
        });
        for (std::size_t i = 0; i < chunks; ++i) ratio = std::max(ratio, top[i]);
      }
    }
  return ratio;
}

template <class T>
bool Simulation<T>::can_stiffen() const {
  for (const SimBody<T>& body : bodies)
    for (const Level<T>& L : body.levels)
      if (L.model != ForceModel::linear) return true;  // stvk, corotational, springs
  return false;
}

template class Simulation<float>;
template class Simulation<double>;

// Used by World::snapshot. The corotational stresses start their rotations from the current ones
// (a listed level's are its job's list copy: Simulation::current_rotations).
template <class T>
void cauchy_stress(Executor& exec, const Simulation<T>& sim, const SimBody<T>& body, const Level<T>& L,
                   std::vector<double>& sigma9) {
  sigma9.resize(9 * L.tet_count);
  ElementContext<T> ec = element_context(L);
  CurrentState<T> now;
  use_current_state(body, L, ec, now);
  AlignedVector<T> rotation[4];
  if (!L.rotation[0].empty()) {
    sim.current_rotations(body, L, rotation);
    for (int k = 0; k < 4; ++k) ec.rotation[k] = rotation[k].data();
  }
  const int measure = L.model == ForceModel::stvk ? 1 : L.model == ForceModel::corotational ? 2 : 0;
  double* out = sigma9.data();
  exec.parallel_for(L.tet_count, kTetGrain, [&](Range r) { element_cauchy_stress(ec, r, measure, out); });
}
template void cauchy_stress<float>(Executor&, const Simulation<float>&, const SimBody<float>&, const Level<float>&,
                                   std::vector<double>&);
template void cauchy_stress<double>(Executor&, const Simulation<double>&, const SimBody<double>&, const Level<double>&,
                                    std::vector<double>&);

}  // namespace pliant::detail
