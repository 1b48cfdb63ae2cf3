// Every array an adaptive body's decisions and changes read, as (first byte, bytes): for
// World::touch_pages, after the levels' own (level_arrays.hpp). The hierarchy's meshes and links,
// the activation state with its locators, the patch state and the decision scratch. The undo's
// copy (scratch.before) is left out: a change writes it before it reads it. An array left out is
// simply not kept warm (nothing else depends on this list).
#pragma once
#include <cstddef>

#include "activation.hpp"
#include "adaptivity.hpp"
#include "apply_changes.hpp"

namespace pliant::detail {

template <class F>
void for_each_adapt_array(const AdaptiveState& st, F&& f) {
  const auto one = [&](const auto& a) {
    if (!a.empty()) f(static_cast<const void*>(a.data()), a.size() * sizeof(a[0]));
  };
  const Hierarchy& h = *st.hierarchy;
  for (std::size_t l = 0; l < h.levels(); ++l) {
    one(h.meshes[l].points);
    one(h.meshes[l].tets);
    const LevelLinks& k = h.links[l];
    one(k.to_coarser);
    one(k.to_finer);
    one(k.parent);
    one(k.child_offsets);
    one(k.children);
    one(k.ring_offsets);
    one(k.ring);
    one(k.tet_parent);
    one(k.tet_corner_parent);
    one(k.tet_parent_offsets);
    one(k.tet_parents);
  }
  if (st.activation) st.activation->for_each_array([&](const void* data, std::size_t bytes) { f(data, bytes); });
  for (const auto& a : st.neighbours) one(a);
  for (const auto& a : st.calm_since) one(a);
  const PatchState& p = st.patch;
  for (const auto& a : p.quarter_mass) one(a);
  for (const auto& a : p.own_mass) one(a);
  for (const auto& a : p.raw_mass) one(a);
  for (const auto& a : p.mark) one(a);
  const auto& s = st.scratch;
  for (const auto& a : s.x) one(a);
  for (const auto& a : s.v) one(a);
  one(s.F);
  one(s.ids);
  one(s.chunk_peak);
  for (const auto& a : s.measure) one(a);
  for (const auto& a : s.restricted) one(a);
}

}  // namespace pliant::detail
