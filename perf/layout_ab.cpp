// Side-by-side measurements of the data layout of a step (issue 15 §1, docs/performance.md), in
// one process with the variants alternating every iteration, so that other processes on a
// shared machine slow them alike (separate runs minutes apart were up to 2x apart there):
//  1. "packed": the corotational element pass reading corners from the interleaved copy
//     (ElementContext::xp; the pack timed with it, as the step runs it) against the same pass
//     gathering from x[3][n] (xp = null: the code before the change), on box worlds, float and
//     double (whatever packed_corners_pay says), undamped and damped (velocities gathered;
//     damped also a third variant, the velocities packed too: ElementContext::vp),
//     1 and 2 threads.
//  2. "incidence": a prototype, not the engine: the element pass (float, undamped, packed
//     positions) writes each corner's force as (x y z 0) to the slot of its (tet, corner) in the
//     node -> corner incidence, so the node pass sums each node's slots as one contiguous run (a
//     streaming segmented sum) instead of loading them through the incidence codes. The node
//     forces must be the same bits (same values summed in the same order).
//  3. "listed": the element pass over listed tets (a multiresolution level stepping part of its
//     mesh: LevelInfo::listed), runs of 4 tets in every 16 (a quarter of the mesh, as a middle
//     level's stepped region in runs of about 4), against the range pass over as many consecutive
//     tets. The per-tet data of listed tets is gathered and their results scattered; the ratio is
//     what that costs (docs/performance.md, "Partly stepped levels").
//  4. "entries": the fused node pass (gather + integrate) reading its incidence entries as
//     offsets into the corner-force block and summing two nodes side by side
//     (GatherContext::corner_offset: the engine's path since 2026-11-28) against the same pass
//     looking each entry's corner up in a table (corner_offset = null: the code before), on the
//     same world and forces, corotational box, float and double, 1 and 2 threads, 1k to 1M tets.
//     The node forces must be the same bits.
//  5. "rayleigh": the corotational element pass with Rayleigh stiffness damping (beta = 1e-4 s, the
//     default scene's), the viscous stress as one Hooke law of eps + beta eps_dot
//     (ElementContext::rayleigh: the engine's path since 2026-11-28) against two Hooke laws added
//     (rayleigh = 0: the code before), positions and velocities packed as the step packs them,
//     float and double, 1 and 2 threads, 1k to 1M tets. Not the same bits: the largest corner
//     force difference is printed, relative to the largest corner force.
//   ./perf/layout_ab [samples] [packed, incidence, listed, entries or rayleigh]
#include <immintrin.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "pliant/level_passes.hpp"
#include "pliant/scheduler/executor.hpp"
#include "pliant/perf/workload.hpp"
// White box: the batched helpers of the element kernels.
#include "../kernels/src/tet_batch.hpp"

using namespace pliant;
using namespace pliant::perf;
using detail::Mat3;
using V = simd::Pack<float>::V;
constexpr int W = simd::Pack<float>::W;

namespace {

// Stores the 3 components of W corner forces as (x y z 0) at out + 4 * slot[l], lanes < count.
void scatter_xyz(float* out, const std::int32_t* slot, int count, const V f[3]) {
#if PLIANT_SIMD_BYTES == 64
  const __m512 X = (__m512)f[0], Y = (__m512)f[1], Z = (__m512)f[2], O = _mm512_setzero_ps();
  const __m512 t0 = _mm512_unpacklo_ps(X, Y), t1 = _mm512_unpackhi_ps(X, Y);
  const __m512 t2 = _mm512_unpacklo_ps(Z, O), t3 = _mm512_unpackhi_ps(Z, O);
  __m512 r[4];
  r[0] = _mm512_castpd_ps(_mm512_unpacklo_pd(_mm512_castps_pd(t0), _mm512_castps_pd(t2)));
  r[1] = _mm512_castpd_ps(_mm512_unpackhi_pd(_mm512_castps_pd(t0), _mm512_castps_pd(t2)));
  r[2] = _mm512_castpd_ps(_mm512_unpacklo_pd(_mm512_castps_pd(t1), _mm512_castps_pd(t3)));
  r[3] = _mm512_castpd_ps(_mm512_unpackhi_pd(_mm512_castps_pd(t1), _mm512_castps_pd(t3)));
  if (count == W) {
    for (int j = 0; j < 4; ++j) {
      _mm_storeu_ps(out + 4 * std::ptrdiff_t(slot[j]), _mm512_castps512_ps128(r[j]));
      _mm_storeu_ps(out + 4 * std::ptrdiff_t(slot[j + 4]), _mm512_extractf32x4_ps(r[j], 1));
      _mm_storeu_ps(out + 4 * std::ptrdiff_t(slot[j + 8]), _mm512_extractf32x4_ps(r[j], 2));
      _mm_storeu_ps(out + 4 * std::ptrdiff_t(slot[j + 12]), _mm512_extractf32x4_ps(r[j], 3));
    }
    return;
  }
#endif
  for (int l = 0; l < count; ++l) {
    float* p = out + 4 * std::ptrdiff_t(slot[l]);
    p[0] = f[0][l];
    p[1] = f[1][l];
    p[2] = f[2][l];
    p[3] = 0;
  }
}

// corotational_pass of element_forces.cpp (undamped), corner forces to their incidence slots.
void corotational_slots(const ElementContext<float>& c, const std::int32_t* const slot[4], float* out, Range r) {
  for (std::size_t t = r.begin; t < r.end; t += W) {
    const int count = int(std::min<std::size_t>(W, r.end - t));
    detail::TetBatch<float> e;
    detail::load_batch(c, detail::ConsecutiveTets<float>{t, count}, e);
    const Mat3<V> F[1] = {detail::corner_gradient(e.x, e.g)};
    V q[1][4];
    for (int k = 0; k < 4; ++k) q[0][k] = simd::load(c.rotation[k] + t, count);
    Mat3<V> R[1];
    detail::extract_rotation_batches<float, 1>(F, q, R);
    for (int k = 0; k < 4; ++k) simd::store(c.rotation[k] + t, count, q[0][k]);
    Mat3<V> eps = detail::sym(detail::mul_tn(R[0], F[0]));
    for (int i = 0; i < 3; ++i) eps.m[i][i] -= 1.0f;
    const Mat3<V> P = detail::mul(R[0], detail::hooke(eps, c.lambda, c.mu));
    // store_corner_forces_batch's arithmetic.
    V f[4][3];
    V f0[3] = {V{}, V{}, V{}};
    for (int a = 0; a < 3; ++a)
      for (int i = 0; i < 3; ++i) {
        const V fi = -e.volume * (P.m[i][0] * e.g[a][0] + P.m[i][1] * e.g[a][1] + P.m[i][2] * e.g[a][2]);
        f[a + 1][i] = fi;
        f0[i] -= fi;
      }
    for (int i = 0; i < 3; ++i) f[0][i] = f0[i];
    std::int32_t s[W];
    for (int a = 0; a < 4; ++a) {
      for (int l = 0; l < W; ++l) s[l] = slot[a][t + std::size_t(std::min(l, count - 1))];
      scatter_xyz(out, s, count, f[a]);
    }
  }
}

// gather_integrate_symplectic_euler (no external loads) over the slots: node n sums slots
// offsets[n] .. offsets[n+1] in order, 4 lanes at once (lane k is component k's scalar chain).
bool gather_integrate_slots(const std::int32_t* offsets, const float* cf, const IntegrateContext<float>& c,
                            float* const f[3], Range r) {
  bool finite = true;
  const float dt = c.dt;
  for (std::size_t n = r.begin; n < r.end; ++n) {
    __m128 s = _mm_setzero_ps();
    for (std::int32_t e = offsets[n]; e < offsets[n + 1]; ++e) s = _mm_add_ps(s, _mm_loadu_ps(cf + 4 * std::ptrdiff_t(e)));
    alignas(16) float fn[4];
    _mm_store_ps(fn, s);
    f[0][n] = fn[0];
    f[1][n] = fn[1];
    f[2][n] = fn[2];
    if (c.state[n] != kNodeFree) continue;
    for (int k = 0; k < 3; ++k) {
      const float a = fn[k] * c.inv_mass[n] + c.gravity[k] - c.mass_damping * c.v[k][n];
      const float v = c.v[k][n] + dt * a;
      const float x = c.x[k][n] + dt * v;
      c.v[k][n] = v;
      c.x[k][n] = x;
      finite &= within_bounds(x, v);
    }
  }
  return finite;
}

struct Stat {
  double med, lo, hi;
};
Stat stat(std::vector<double> v, double scale) {
  std::sort(v.begin(), v.end());
  return {v[v.size() / 2] * scale, v.front() * scale, v.back() * scale};
}
using Clock = std::chrono::steady_clock;
double since(Clock::time_point& t) {
  const auto now = Clock::now();
  const double s = std::chrono::duration<double>(now - t).count();
  t = now;
  return s;
}
void print(const char* what, const Stat& s) { std::printf("  %-34s %7.2f  [%6.2f - %6.2f]\n", what, s.med, s.lo, s.hi); }

// Times `before` then `after` back to back, `samples` times after 3 untimed rounds: the seconds of
// each and their ratio after / before, pair by pair (alternated, so a busy host slows both alike).
struct Pairs {
  std::vector<double> before, after, ratio;
};
template <class Before, class After>
Pairs time_pairs(int samples, const Before& before, const After& after) {
  Pairs out;
  for (int i = 0; i < samples + 3; ++i) {
    auto t = Clock::now();
    before();
    const double a = since(t);
    after();
    const double b = since(t);
    if (i < 3) continue;
    out.before.push_back(a);
    out.after.push_back(b);
    out.ratio.push_back(b / a);
  }
  return out;
}

// A corotational box world of `size`, damped by Rayleigh beta (s; 0: undamped; the default
// scene's is 1e-4), after `steps` steps (a deformed, moving state).
World damped_box_world(const BoxSize& size, Precision p, int threads, double beta, int steps) {
  BodyDef b = box_body(ForceModel::corotational, size.cells);
  b.material.damping.stiffness = beta;
  WorldDef wd;
  wd.precision = p;
  wd.threads = threads;
  World w(wd);
  w.add_body(b, box_mesh(size.cells, Order::grid));
  for (int i = 0; i < steps; ++i) w.step();
  return w;
}

// 1: packed against gathered corners, element pass (+ pack) and the fused node pass after it.
template <class T>
void packed_vs_gathered(const BoxSize& size, Precision p, int threads, bool damped, int samples) {
  World w = damped_box_world(size, p, threads, damped ? 1e-4 : 0.0, 3);
  Level<T>& L = w.level<T>(0);
  Executor ex(threads);
  const std::size_t nt = L.tet_count, nn = L.node_count;
  ElementContext<T> gathered = element_context(L), packed = gathered;
  AlignedVector<T> xp(4 * L.node_count);  // its own copy: the engine packs only where it pays
  PackContext<T> pk = pack_context(L);
  pk.xp = xp.data();
  pk.vp = nullptr;  // positions only (the engine's context packs the velocities where that pays)
  use_packed(packed, pk, true);
  // Damped: the velocities packed too (ElementContext::vp), a third variant.
  AlignedVector<T> vp(4 * L.node_count);
  PackContext<T> pkv = pk;
  for (int k = 0; k < 3; ++k) pkv.v[k] = L.v[k].data();
  pkv.vp = vp.data();
  ElementContext<T> packed_v = packed;
  packed_v.vp = vp.data();
  const GatherContext<T> gc = gather_context(L);
  const IntegrateContext<T> ic = integrate_context(L, std::array<double, 3>{0, 0, -9.81}, w.dt());
  const ElementPass<T> pass = force_kernel<T>(L.model);
  auto element = [&](const ElementContext<T>& ec) {
    ex.parallel_for(nt, pass_grain(nt, kTetGrain), [&](Range r) { pass(ec, r); });
  };
  auto pack = [&] { ex.parallel_for(nn, pass_grain(nn, kNodeGrain), [&](Range r) { pack_positions(pk, r); }); };
  auto pack_v = [&] { ex.parallel_for(nn, pass_grain(nn, kNodeGrain), [&](Range r) { pack_positions(pkv, r); }); };
  auto nodes = [&] {
    ex.parallel_all(nn, pass_grain(nn, kNodeGrain), [&](Range r) { return gather_integrate_symplectic_euler(gc, ic, r); });
  };
  std::vector<double> eg, ng, pp, ep, np, evp;
  for (int i = 0; i < samples + 3; ++i) {
    if (damped) {  // before the others, so that its pair (packed x) is timed right after it
      auto tv = Clock::now();
      pack_v();
      element(packed_v);
      if (i >= 3) evp.push_back(since(tv));
      nodes();
    }
    auto t = Clock::now();
    element(gathered);
    const double a = since(t);
    nodes();
    const double b2 = since(t);
    pack();
    const double c = since(t);
    element(packed);
    const double d = since(t);
    nodes();
    const double e = since(t);
    if (i < 3) continue;
    eg.push_back(a);
    ng.push_back(b2);
    pp.push_back(c);
    ep.push_back(c + d);
    np.push_back(e);
  }
  const double k = 1e9 / double(nt);
  std::vector<double> ratio(eg.size()), sg(eg.size()), sp(eg.size());
  for (std::size_t i = 0; i < eg.size(); ++i) {
    ratio[i] = ep[i] / eg[i];
    sg[i] = eg[i] + ng[i];
    sp[i] = ep[i] + np[i];
  }
  std::printf("%s tets, %s, %s, %d thread(s): ns/tet, median [min - max] of %d\n", size.label,
              p == Precision::float32 ? "float" : "double", damped ? "damped" : "undamped", threads, samples);
  print("element, gathered corners", stat(eg, k));
  print("pack", stat(pp, k));
  print("element, packed (pack included)", stat(ep, k));
  print("  ratio packed / gathered (per pair)", stat(ratio, 1.0));
  if (damped) {
    std::vector<double> rv(evp.size());
    for (std::size_t i = 0; i < evp.size(); ++i) rv[i] = evp[i] / ep[i];
    print("element, packed x and v (pack included)", stat(evp, k));
    print("  ratio packed x and v / packed x (per pair)", stat(rv, 1.0));
  }
  print("node pass after gathered", stat(ng, k));
  print("node pass after packed", stat(np, k));
  print("element + node pass, gathered", stat(sg, k));
  print("element + node pass, packed", stat(sp, k));
}

// 2: the prototype of corner forces in incidence order (float, 1 thread, undamped).
template <class T>
void listed_vs_range(const BoxSize& size, Precision p, bool damped, int samples) {
  World w = damped_box_world(size, p, 1, damped ? 1e-4 : 0.0, 3);
  Level<T>& L = w.level<T>(0);
  const ElementContext<T> ec = element_context(L);  // corners gathered, as listed levels read them
  std::vector<std::int32_t> ids;
  for (std::size_t t = 0; t + 4 <= L.tet_count; t += 16)
    for (std::size_t k = 0; k < 4; ++k) ids.push_back(std::int32_t(t + k));
  const Range all{0, ids.size()};
  // The same list with its rest data copied in list order, as Simulation::prepare does for a
  // listed level (ElementContext::listed_tet, listed_grad, listed_volume).
  ElementContext<T> in_order = ec;
  std::vector<std::int32_t> tet_copy[4];
  std::vector<T> grad_copy[9], volume_copy;
  for (const std::int32_t t : ids) {
    for (int a = 0; a < 4; ++a) tet_copy[a].push_back(L.tet[a][std::size_t(t)]);
    for (int q = 0; q < 9; ++q) grad_copy[q].push_back(L.grad[q][std::size_t(t)]);
    volume_copy.push_back(L.volume[std::size_t(t)]);
  }
  for (int a = 0; a < 4; ++a) in_order.listed_tet[a] = tet_copy[a].data();
  for (int q = 0; q < 9; ++q) in_order.listed_grad[q] = grad_copy[q].data();
  in_order.listed_volume = volume_copy.data();
  // And its corner forces stored by list position (ElementContext::listed_corner_forces), as the
  // step keeps a listed level's since 2026-11-26.
  ElementContext<T> by_position = in_order;
  CornerForceArrays<T> listed_forces;
  listed_forces.assign(ids.size(), T(0));
  for (int q = 0; q < 12; ++q) by_position.corner_force[q] = listed_forces[q].data();
  by_position.listed_corner_forces = true;
  std::vector<double> listed, ordered, positioned, range, ratio, ratio_ordered, ratio_positioned;
  for (int i = 0; i < samples + 3; ++i) {
    auto t = Clock::now();
    element_forces_corotational_listed(ec, ids.data(), all);
    const double a = since(t);
    element_forces_corotational_listed(in_order, ids.data(), all);
    const double b2 = since(t);
    element_forces_corotational_listed(by_position, ids.data(), all);
    const double d = since(t);
    element_forces_corotational(ec, all);
    const double c = since(t);
    if (i < 3) continue;
    listed.push_back(a);
    ordered.push_back(b2);
    positioned.push_back(d);
    range.push_back(c);
    ratio.push_back(a / c);
    ratio_ordered.push_back(b2 / c);
    ratio_positioned.push_back(d / c);
  }
  const double k = 1e9 / double(ids.size());
  std::printf("%s tets, %s, %s, 1 thread, %zu listed tets (runs of 4 in every 16): ns/tet, median [min - max] of %d\n",
              size.label, p == Precision::float32 ? "float" : "double", damped ? "damped" : "undamped", ids.size(), samples);
  print("element, listed tets", stat(listed, k));
  print("element, listed, rest data in order", stat(ordered, k));
  print("element, listed, + forces by position", stat(positioned, k));
  print("element, as many consecutive tets", stat(range, k));
  print("  ratio listed / range (per pair)", stat(ratio, 1.0));
  print("  ratio in order / range (per pair)", stat(ratio_ordered, 1.0));
  print("  ratio by position / range (per pair)", stat(ratio_positioned, 1.0));
}

bool incidence_order(const BoxSize& size, int samples) {
  World w = make_box_world(ForceModel::corotational, Precision::float32, 1, size.cells, Order::grid);
  Level<float>& L = w.level<float>(0);
  const std::size_t nt = L.tet_count, nn = L.node_count;
  // Slot of (tet, corner): its position in the incidence.
  std::vector<std::int32_t> slot[4];
  for (auto& s : slot) s.assign(nt, -1);
  for (std::size_t e = 0; e < L.incidence.size(); ++e) {
    const std::int32_t code = L.incidence[e];
    slot[code & 3][std::size_t(code >> 2)] = std::int32_t(e);
  }
  const std::int32_t* slots[4] = {slot[0].data(), slot[1].data(), slot[2].data(), slot[3].data()};
  AlignedVector<float> cf(4 * L.incidence.size(), 0.0f);

  ElementContext<float> ec = element_context(L);
  AlignedVector<float> xp(4 * L.node_count);
  PackContext<float> pk = pack_context(L);
  pk.xp = xp.data();
  use_packed(ec, pk, true);
  GatherContext<float> gc = gather_context(L);
  IntegrateContext<float> ic = integrate_context(L, std::array<double, 3>{0, 0, -9.81}, w.dt());
  const ElementPass<float> pass = force_kernel<float>(L.model);
  const Range tets{0, nt}, nodes{0, nn};

  // Same bits: node forces of the engine's passes and of the prototype from the same state.
  std::vector<float> rot[4], f_ref[3];
  for (int k = 0; k < 4; ++k) rot[k].assign(L.rotation[k].begin(), L.rotation[k].end());
  pack_positions(pk, nodes);
  pass(ec, tets);
  gather_forces(gc, nodes);
  for (int k = 0; k < 3; ++k) f_ref[k].assign(L.f[k].begin(), L.f[k].end());
  for (int k = 0; k < 4; ++k) std::copy(rot[k].begin(), rot[k].end(), L.rotation[k].begin());
  corotational_slots(ec, slots, cf.data(), tets);
  IntegrateContext<float> no_motion = ic;
  no_motion.dt = 0;  // x, v unchanged: only the forces are compared
  float* f[3] = {L.f[0].data(), L.f[1].data(), L.f[2].data()};
  gather_integrate_slots(L.incidence_offsets.data(), cf.data(), no_motion, f, nodes);
  bool same = true;
  for (int k = 0; k < 3; ++k) same &= std::memcmp(f_ref[k].data(), L.f[k].data(), nn * sizeof(float)) == 0;

  std::vector<double> e_eng, g_eng, e_pro, g_pro;
  for (int i = 0; i < samples + 3; ++i) {
    auto t = Clock::now();
    pack_positions(pk, nodes);  // the engine: pack + element pass, fused gather + integrate
    pass(ec, tets);
    const double a = since(t);
    gather_integrate_symplectic_euler(gc, ic, nodes);
    const double b = since(t);
    pack_positions(pk, nodes);  // the prototype
    corotational_slots(ec, slots, cf.data(), tets);
    const double c = since(t);
    gather_integrate_slots(L.incidence_offsets.data(), cf.data(), ic, f, nodes);
    const double d = since(t);
    if (i < 3) continue;
    e_eng.push_back(a);
    g_eng.push_back(b);
    e_pro.push_back(c);
    g_pro.push_back(d);
  }
  const double k = 1e9 / double(nt);
  std::printf("%s tets, float, undamped, 1 thread, corner forces in incidence order (prototype): node forces %s\n",
              size.label, same ? "bitwise identical" : "DIFFER");
  std::printf("  ns/tet, median [min - max] of %d\n", samples);
  print("element (packed), corner arrays", stat(e_eng, k));
  print("element (packed), incidence slots", stat(e_pro, k));
  print("node pass, through the incidence", stat(g_eng, k));
  print("node pass, streaming slots", stat(g_pro, k));
  std::vector<double> se(e_eng.size()), sp(e_eng.size());
  for (std::size_t i = 0; i < se.size(); ++i) {
    se[i] = e_eng[i] + g_eng[i];
    sp[i] = e_pro[i] + g_pro[i];
  }
  print("both, engine", stat(se, k));
  print("both, prototype", stat(sp, k));
  return same;
}


// 4. "blocked": the whole step of a large body (pack, element pass, fused gather + integrate) as
//    one region of three phases, against the same passes cut into blocks of `block` tets: the
//    element pass over block k, then the gather + integrate of the nodes whose tets all lie in
//    blocks <= k (a prefix of the node order), so that the corner forces are summed while they are
//    still in cache. Same kernels, same sums in the same order: the same bits.
template <class T>
struct BlockedCase {
  ElementContext<T> ec;
  PackContext<T> pk;
  GatherContext<T> gc;
  IntegrateContext<T> ic;
  void (*pass)(const ElementContext<T>&, Range);
};
template <class T>
struct Offset {
  const BlockedCase<T>* c;
  std::size_t first;
};
template <class T>
void blk_pack(const void* p, Range r) {
  const auto& o = *static_cast<const Offset<T>*>(p);
  pack_positions(o.c->pk, r);
}
template <class T>
void blk_element(const void* p, Range r) {
  const auto& o = *static_cast<const Offset<T>*>(p);
  o.c->pass(o.c->ec, Range{o.first + r.begin, o.first + r.end});
}
template <class T>
bool blk_nodes(const void* p, Range r) {
  const auto& o = *static_cast<const Offset<T>*>(p);
  return gather_integrate_symplectic_euler(o.c->gc, o.c->ic, Range{o.first + r.begin, o.first + r.end});
}

template <class T>
void blocked_vs_whole(const BoxSize& size, Precision p, int threads, int samples, std::size_t block) {
  World w = make_box_world(ForceModel::corotational, p, threads, size.cells, Order::grid);
  Level<T>& L = w.level<T>(0);
  const std::size_t nt = L.tet_count, nn = L.node_count;
  Executor ex(threads);
  BlockedCase<T> c;
  c.ec = element_context(L);
  c.pk = pack_context(L);
  const bool packed = pack_pays(L, nt);
  use_packed(c.ec, c.pk, packed);
  c.pass = force_kernel<T>(L.model);
  c.gc = gather_context(L);
  c.ic = integrate_context(L, std::array<double, 3>{0, 0, -9.81}, w.dt());
  // last[n]: the last tet around node n; node_end[k]: the nodes below it have all their tets in blocks <= k.
  std::vector<std::size_t> last(nn, 0);
  for (std::size_t n = 0; n < nn; ++n)
    for (auto e = L.incidence_offsets[n]; e < L.incidence_offsets[n + 1]; ++e)
      last[n] = std::max(last[n], std::size_t(L.incidence[std::size_t(e)] >> 2));
  const std::size_t blocks = (nt + block - 1) / block;
  std::vector<std::size_t> node_end(blocks, nn);
  {
    std::size_t n = 0;
    for (std::size_t k = 0; k + 1 < blocks; ++k) {
      const std::size_t bound = (k + 1) * block;
      while (n < nn && last[n] < bound) ++n;
      node_end[k] = n;
    }
  }
  const int th = ex.threads();
  std::vector<Offset<T>> offs;
  offs.reserve(2 * blocks + 4);
  std::vector<Executor::Segment> segs;
  std::vector<Executor::PredicateSegment> preds;
  segs.reserve(blocks + 4);
  preds.reserve(blocks + 4);
  // Whole: pack, element, nodes.
  offs.push_back({&c, 0});
  const Offset<T>* whole = &offs.back();
  segs.push_back({nn, tick_grain(nn, kTickNodeChunk, kNodeGrain, th), &blk_pack<T>, whole});
  segs.push_back({nt, tick_grain(nt, kTickTetChunk, kTetGrain, th), &blk_element<T>, whole});
  preds.push_back({nn, tick_grain(nn, kTickNodeChunk, kNodeGrain, th), &blk_nodes<T>, whole});
  Executor::Phase whole_phases[3] = {{&segs[0], packed ? 1u : 0u, nullptr, 0}, {&segs[1], 1, nullptr, 0}, {nullptr, 0, &preds[0], 1}};
  // Blocked.
  std::vector<Executor::Phase> bph;
  bph.push_back({&segs[0], packed ? 1u : 0u, nullptr, 0});
  std::size_t nb = 0;
  for (std::size_t k = 0; k < blocks; ++k) {
    const std::size_t t0 = k * block, t1 = std::min(nt, t0 + block);
    offs.push_back({&c, t0});
    segs.push_back({t1 - t0, tick_grain(t1 - t0, kTickTetChunk, kTetGrain, th), &blk_element<T>, &offs.back()});
    bph.push_back({&segs.back(), 1, nullptr, 0});
    const std::size_t n1 = node_end[k];
    if (n1 > nb) {
      offs.push_back({&c, nb});
      preds.push_back({n1 - nb, tick_grain(n1 - nb, kTickNodeChunk, kNodeGrain, th), &blk_nodes<T>, &offs.back()});
      bph.push_back({nullptr, 0, &preds.back(), 1});
      nb = n1;
    }
  }
  std::vector<double> tw, tb, ratio;
  for (int i = 0; i < samples + 2; ++i) {
    auto t = Clock::now();
    ex.run_phases(whole_phases, 3);
    const double a = since(t);
    ex.run_phases(bph.data(), bph.size());
    const double b2 = since(t);
    if (i < 2) continue;
    tw.push_back(a);
    tb.push_back(b2);
    ratio.push_back(b2 / a);
  }
  const double k = 1e9 / double(nt);
  std::printf("%s tets, %s, %d thread(s), blocks of %zu tets (%zu phases): whole step ns/tet, median [min - max] of %d\n",
              size.label, p == Precision::float32 ? "float" : "double", th, block, bph.size(), samples);
  print("whole passes", stat(tw, k));
  print("blocked", stat(tb, k));
  print("  ratio blocked / whole (per pair)", stat(ratio, 1.0));
}
template <class T>
bool entries_ab(const BoxSize& size, Precision p, int threads, int samples) {
  World w = make_box_world(ForceModel::corotational, p, threads, size.cells, Order::grid);
  for (int i = 0; i < 3; ++i) w.step();  // corner forces of a deformed state
  Level<T>& L = w.level<T>(0);
  Executor ex(threads);
  const std::size_t nn = L.node_count, nt = L.tet_count;
  const GatherContext<T> offsets = gather_context(L);
  GatherContext<T> table = offsets;
  table.corner_offset = nullptr;
  // Same bits: each variant's node forces into arrays of its own.
  std::vector<T> fa[3], fb[3];
  GatherContext<T> ga = offsets, gb = table;
  for (int k = 0; k < 3; ++k) {
    fa[k].assign(nn, T(0));
    fb[k].assign(nn, T(1));
    ga.f[k] = fa[k].data();
    gb.f[k] = fb[k].data();
  }
  gather_forces(ga, Range{0, nn});
  gather_forces(gb, Range{0, nn});
  bool same = offsets.corner_offset != nullptr;
  for (int k = 0; k < 3; ++k) same &= std::memcmp(fa[k].data(), fb[k].data(), nn * sizeof(T)) == 0;
  const IntegrateContext<T> ic = integrate_context(L, std::array<double, 3>{0, 0, -9.81}, w.dt());
  auto nodes = [&](const GatherContext<T>& gc) {
    ex.parallel_all(nn, pass_grain(nn, kNodeGrain), [&](Range r) { return gather_integrate_symplectic_euler(gc, ic, r); });
  };
  const Pairs pairs = time_pairs(samples, [&] { nodes(table); }, [&] { nodes(offsets); });
  const double k = 1e9 / double(nt);
  std::printf("%s tets, %s, %d thread(s): gather + integrate, ns/tet, median [min - max] of %d%s\n", size.label,
              p == Precision::float32 ? "float" : "double", threads, samples, same ? "" : "  NODE FORCES DIFFER");
  print("entries looked up (before)", stat(pairs.before, k));
  print("entries as offsets, pairs", stat(pairs.after, k));
  print("  ratio offsets / table (per pair)", stat(pairs.ratio, 1.0));
  std::fflush(stdout);
  return same;
}
// 5: Rayleigh damping as one Hooke law against two added (the element pass alone).
template <class T>
void rayleigh_ab(const BoxSize& size, Precision p, int threads, int samples) {
  // A deformed, moving state: 100 steps of sag. After 3 (as the other modes) the strains are
  // ~1e-5, near float's rounding of R^T F - I (1.2e-7), and the two ways' rounding differs by up to
  // 1 % of the forces (0.0008-0.014 measured); after 100, 1e-5 (double 2e-14): rounding.
  World w = damped_box_world(size, p, threads, 1e-4, 100);
  Level<T>& L = w.level<T>(0);
  Executor ex(threads);
  const std::size_t nt = L.tet_count, nn = L.node_count;
  ElementContext<T> one = element_context(L);
  const PackContext<T> pk = pack_context(L);
  if (pack_pays(L, nt)) {  // as the step: positions (and velocities where that pays) packed
    pack_positions(pk, Range{0, nn});
    use_packed(one, pk, true);
  }
  ElementContext<T> two = one;
  two.rayleigh = T(0);
  const ElementPass<T> pass = force_kernel<T>(L.model);
  auto element = [&](const ElementContext<T>& ec) {
    ex.parallel_for(nt, pass_grain(nt, kTetGrain), [&](Range r) { pass(ec, r); });
  };
  // The forces of each from the same stored rotations (each pass refines them in place, within
  // the rotation's tolerance: a pass repeated differs from itself by that much, printed too).
  std::vector<T> rot[4], f_two[12];
  for (int k = 0; k < 4; ++k) rot[k].assign(L.rotation[k].begin(), L.rotation[k].end());
  auto from_saved_rotations = [&](const ElementContext<T>& ec) {
    for (int k = 0; k < 4; ++k) std::copy(rot[k].begin(), rot[k].end(), L.rotation[k].begin());
    element(ec);
  };
  from_saved_rotations(two);
  for (int q = 0; q < 12; ++q) f_two[q].assign(L.corner_force[q].begin(), L.corner_force[q].end());
  auto difference = [&](double& diff, double& largest) {
    diff = largest = 0;
    for (int q = 0; q < 12; ++q)
      for (std::size_t t = 0; t < nt; ++t) {
        diff = std::max(diff, std::fabs(double(L.corner_force[q][t]) - double(f_two[q][t])));
        largest = std::max(largest, std::fabs(double(f_two[q][t])));
      }
  };
  double diff = 0, largest = 0, again = 0;
  element(two);  // from the refined rotations
  difference(again, largest);
  from_saved_rotations(one);
  difference(diff, largest);
  const Pairs pairs = time_pairs(samples, [&] { element(two); }, [&] { element(one); });
  const double k = 1e9 / double(nt);
  std::printf("%s tets, %s, %d thread(s), rayleigh %s: element pass ns/tet, median [min - max] of %d; forces differ by %.2g "
              "of the largest (a pass repeated: %.2g)\n",
              size.label, p == Precision::float32 ? "float" : "double", threads, one.rayleigh != T(0) ? "on" : "NOT SET",
              samples, diff / largest, again / largest);
  print("two Hooke laws (before)", stat(pairs.before, k));
  print("one Hooke law", stat(pairs.after, k));
  print("  ratio one / two (per pair)", stat(pairs.ratio, 1.0));
  std::fflush(stdout);
}
}  // namespace

int main(int argc, char** argv) {
  const int samples = argc > 1 ? std::atoi(argv[1]) : 41;
  const std::string only = argc > 2 ? argv[2] : "";
  bool ok = true;
  if (only == "entries") {
    for (const auto& size : standard_sizes())
      for (int threads : {1, 2}) {
        ok &= entries_ab<float>(size, Precision::float32, threads, samples);
        ok &= entries_ab<double>(size, Precision::float64, threads, samples);
      }
    return ok ? 0 : 1;
  }
  if (only == "rayleigh") {
    for (const auto& size : standard_sizes())
      for (int threads : {1, 2}) {
        rayleigh_ab<float>(size, Precision::float32, threads, samples);
        rayleigh_ab<double>(size, Precision::float64, threads, samples);
      }
    return 0;
  }
  if (only == "blocked") {
    const std::size_t block = argc > 3 ? std::size_t(std::atol(argv[3])) : 32768;
    for (const auto& size : standard_sizes()) {
      if (std::string(size.label) == "1k" || std::string(size.label) == "10k") continue;
      for (int threads : {1, 2}) {
        blocked_vs_whole<float>(size, Precision::float32, threads, samples, block);
        blocked_vs_whole<double>(size, Precision::float64, threads, samples, block);
      }
    }
    return 0;
  }
  for (const auto& size : standard_sizes()) {
    if (std::string(size.label) != "10k" && std::string(size.label) != "100k") continue;
    if (only.empty() || only == "packed")
      for (int threads : {1, 2})
        for (bool damped : {false, true}) {
          packed_vs_gathered<float>(size, Precision::float32, threads, damped, samples);
          packed_vs_gathered<double>(size, Precision::float64, threads, damped, samples);
        }
    if (only.empty() || only == "incidence") ok &= incidence_order(size, samples);
    if (only.empty() || only == "listed")
      for (bool damped : {false, true}) {
        listed_vs_range<float>(size, Precision::float32, damped, samples);
        listed_vs_range<double>(size, Precision::float64, damped, samples);
      }
  }
  return ok ? 0 : 1;
}
