// The kernel contexts of a Level and how its passes are split into tasks: one definition shared
// by the engine's step (engine/src/core/simulation.cpp) and the benchmarks (perf/), so that
// perf/ times exactly the loops the engine runs.
#pragma once
#include <cstddef>

#include "pliant/kernels/element_forces.hpp"
#include "pliant/kernels/node_passes.hpp"
#include "pliant/kernels/obstacle_passes.hpp"
#include "pliant/level.hpp"

namespace pliant {

// Tasks of about 1024 tets (5-20 us) or nodes (3-5 us): enough tasks for balance on 2 threads
// from about 10k tets on. Below kSerialBelow items a loop runs on the calling thread: waking a
// second thread costs more than it saves there (1k tets: 2 threads were 1.4x slower than 1).
inline constexpr std::size_t kTetGrain = 1024;
inline constexpr std::size_t kNodeGrain = 1024;
inline constexpr std::size_t kSerialBelow = 2048;
inline std::size_t pass_grain(std::size_t n, std::size_t g) { return n < kSerialBelow ? n : g; }

// The passes of a tick run as phases of one parallel region (Executor::run_phases; a small region
// runs on the calling thread alone where that was timed faster on this machine, RegionChooser),
// whose threads take chunks one at a time, their own
// block of each phase first. One chunk per thread and pass (about n / threads items), but none
// under kTickTetChunk tets or kTickNodeChunk nodes. Measured on a 2-vCPU Xeon (AVX-512), corotational float, 2 threads, idle
// host, p50 per step: 4 chunks per thread capped at the loop grain were slower than the old
// per-pass fork-joins (default scene 71-90 us against 64-65, 10k box 135 against 112), 1 per
// thread faster (59-62 us; 10k box 106-110); docs/performance.md "Small bodies". Chunks are
// whole vectors (kTickAlign items: 16 floats of AVX-512), so only a segment's last chunk has a
// partial batch. On one thread, pass_grain. Kernels give the same bits however a range is cut
// (tests/kernels/test_kernel_batches.cpp).
inline constexpr std::size_t kTickTetChunk = 128;
inline constexpr std::size_t kTickNodeChunk = 128;
inline constexpr std::size_t kTickAlign = 16;
// n items of a pass; max_grain: the grain of the pass as a single loop (pass_grain on one thread).
inline std::size_t tick_grain(std::size_t n, std::size_t min_chunk, std::size_t max_grain, int threads) {
  if (threads <= 1) return pass_grain(n, max_grain);
  const std::size_t even = (n + std::size_t(threads) - 1) / std::size_t(threads);
  const std::size_t g = even < min_chunk ? min_chunk : even;
  return (g + kTickAlign - 1) / kTickAlign * kTickAlign;
}

// Pointers into L for the element passes. The kernels write only corner forces and the
// corotational warm-start rotation, which are per-tet scratch of the level (hence the casts).
template <class T>
ElementContext<T> element_context(const Level<T>& L) {
  ElementContext<T> c;
  for (int k = 0; k < 3; ++k) {
    c.X[k] = L.X[k].data();
    c.x[k] = L.x[k].data();
    c.v[k] = L.v[k].data();
  }
  for (int a = 0; a < 4; ++a) c.tet[a] = L.tet[a].data();
  c.volume = L.volume.data();
  for (int q = 0; q < 9; ++q) c.grad[q] = L.grad[q].data();
  if (!L.rotation[0].empty())
    for (int k = 0; k < 4; ++k) c.rotation[k] = const_cast<T*>(L.rotation[k].data());
  c.lambda = L.lambda;
  c.mu = L.mu;
  c.bulk_viscosity = L.bulk_viscosity;
  c.shear_viscosity = L.shear_viscosity;
  c.rayleigh = rayleigh_factor(L.lambda, L.mu, L.bulk_viscosity, L.shear_viscosity);
  c.young = L.young;
  c.spring_damping = L.stiffness_damping;
  for (int q = 0; q < 12; ++q) c.corner_force[q] = const_cast<T*>(L.corner_force[q].data());
  return c;
}

// The pack of L's positions into L.x_packed (ElementContext::xp), which the step runs right
// before the element passes of a level where packed_corners_pay<T>() (the kernels' ISA and
// precision; measured in docs/performance.md; WorldDef::packed_corners may override it) and the
// pass is large enough for the pack to pay:
// the pack costs about 1 ns per node, the packed corners save 0.8-2.3 ns per tet (float, 10k-100k
// tets), so it takes at least 2 tets per node of the level (a whole mesh has 4.5-6; a
// multiresolution level stepping a small region of its mesh may have far fewer). Results are the
// same bits either way.
// The velocities are packed too where that pays (packed_velocities_pay<T>()) and the level's
// passes read them (it is damped: the kernels' has_viscosity). WorldDef::packed_corners may
// override the kernels' choice: on packs positions and (damped) velocities, off neither.
template <class T>
void size_packed(Level<T>& L, PackedCorners mode = PackedCorners::automatic) {
  const bool positions = mode == PackedCorners::on || (mode == PackedCorners::automatic && packed_corners_pay<T>());
  const bool velocities = mode == PackedCorners::on || (mode == PackedCorners::automatic && packed_velocities_pay<T>());
  const std::size_t n = positions ? 4 * L.node_count : 0;
  if (L.x_packed.size() != n) L.x_packed.assign(n, T(0));
  const bool damped = L.bulk_viscosity != T(0) || L.shear_viscosity != T(0);
  const std::size_t nv = n > 0 && damped && velocities ? n : 0;
  if (L.v_packed.size() != nv) L.v_packed.assign(nv, T(0));
}
template <class T>
PackContext<T> pack_context(Level<T>& L) {
  PackContext<T> c;
  for (int k = 0; k < 3; ++k) c.x[k] = L.x[k].data();
  c.xp = L.x_packed.data();
  if (!L.v_packed.empty()) {
    for (int k = 0; k < 3; ++k) c.v[k] = L.v[k].data();
    c.vp = L.v_packed.data();
  }
  return c;
}
// `nodes`: how many of the level's nodes the pack copies (a multiresolution level packs only its
// node pieces, the corners of its stepped tets: Simulation::step).
template <class T>
bool pack_pays(const Level<T>& L, std::size_t tets, std::size_t nodes) {
  return L.node_count > 0 && L.x_packed.size() == 4 * L.node_count && nodes > 0 &&
         tets >= 2 * nodes;
}
template <class T>
bool pack_pays(const Level<T>& L, std::size_t tets) {
  return pack_pays(L, tets, L.node_count);
}
// Points ec at the packed copies (on) or back at x and v only (off).
template <class T>
void use_packed(ElementContext<T>& ec, const PackContext<T>& pc, bool on) {
  ec.xp = on ? pc.xp : nullptr;
  ec.vp = on ? pc.vp : nullptr;
}

template <class T>
GatherContext<T> gather_context(Level<T>& L) {
  GatherContext<T> gc;
  gc.offsets = L.incidence_offsets.data();
  gc.incidence = L.incidence.data();
  gc.corner_offset = L.corner_offset.empty() ? nullptr : L.corner_offset.data();
  gc.corner_stride = L.corner_force.stride();
  for (int q = 0; q < 12; ++q) gc.corner_force[q] = L.corner_force[q].data();
  for (int k = 0; k < 3; ++k) {
    gc.external[k] = L.external[k].empty() ? nullptr : L.external[k].data();
    gc.f[k] = L.f[k].data();
  }
  return gc;
}

// gravity: any three numbers indexable by [k] (m/s^2); dt in s.
template <class T, class Gravity>
IntegrateContext<T> integrate_context(Level<T>& L, const Gravity& gravity, double dt) {
  IntegrateContext<T> ic;
  for (int k = 0; k < 3; ++k) {
    ic.x[k] = L.x[k].data();
    ic.v[k] = L.v[k].data();
    ic.f[k] = L.f[k].data();
    ic.gravity[k] = T(gravity[k]);
  }
  ic.inv_mass = L.inv_mass.data();
  ic.state = L.state.data();
  ic.dt = T(dt);
  ic.mass_damping = L.mass_damping;
  return ic;
}

// The obstacle pass of a level against one half-space (normal already of unit length; the
// point in the level's coordinates, which are world coordinates).
template <class T>
// origin: the level's body frame (World::body_origin; obstacles are given in the world frame).
HalfSpaceContext<T> half_space_context(Level<T>& L, const ObstacleDef& o, const Vec3d& origin) {
  HalfSpaceContext<T> c;
  for (int k = 0; k < 3; ++k) {
    c.x[k] = L.x[k].data();
    c.v[k] = L.v[k].data();
    c.impulse[k] = L.obstacle_impulse[k].empty() ? nullptr : L.obstacle_impulse[k].data();
    c.point[k] = T(o.point[k] - origin[k]);
    c.normal[k] = T(o.normal[k]);
  }
  c.mass = L.mass.data();
  c.state = L.state.data();
  c.friction = T(o.friction);
  return c;
}

template <class T>
using ElementPass = void (*)(const ElementContext<T>&, Range);

template <class T>
ElementPass<T> force_kernel(ForceModel m) {
  switch (m) {
    case ForceModel::linear: return &element_forces_linear<T>;
    case ForceModel::stvk: return &element_forces_stvk<T>;
    case ForceModel::corotational: return &element_forces_corotational<T>;
    case ForceModel::springs: return &element_forces_springs<T>;
  }
  return &element_forces_linear<T>;
}

template <class T>
using ListedElementPass = void (*)(const ElementContext<T>&, const std::int32_t*, Range);

template <class T>
ListedElementPass<T> listed_force_kernel(ForceModel m) {
  switch (m) {
    case ForceModel::linear: return &element_forces_linear_listed<T>;
    case ForceModel::stvk: return &element_forces_stvk_listed<T>;
    case ForceModel::corotational: return &element_forces_corotational_listed<T>;
    case ForceModel::springs: return &element_forces_springs_listed<T>;
  }
  return &element_forces_linear_listed<T>;
}

}  // namespace pliant
