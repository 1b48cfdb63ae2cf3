// Every array of a Level, as (first byte, bytes): for World::touch_pages, which reads a byte of
// each page of them in turn. A new array of Level belongs here too; one left out is simply not
// kept warm (nothing else depends on this list).
#pragma once
#include <cstddef>

#include "pliant/level.hpp"

namespace pliant::detail {

template <class T, class F>
void for_each_level_array(const Level<T>& L, F&& f) {
  const auto one = [&](const auto& a) {
    if (!a.empty()) f(static_cast<const void*>(a.data()), a.size() * sizeof(a[0]));
  };
  for (int k = 0; k < 3; ++k) {
    one(L.X[k]);
    one(L.x[k]);
    one(L.v[k]);
    one(L.f[k]);
    one(L.external[k]);
    one(L.obstacle_impulse[k]);
    one(L.impulse[k]);
  }
  one(L.inv_mass);
  one(L.mass);
  one(L.state);
  one(L.x_packed);
  one(L.v_packed);
  for (int a = 0; a < 4; ++a) one(L.tet[a]);
  one(L.volume);
  for (int q = 0; q < 9; ++q) one(L.grad[q]);
  for (int k = 0; k < 4; ++k) one(L.rotation[k]);
  for (const auto& a : L.corner_force) one(a);
  one(L.incidence_offsets);
  one(L.incidence);
  one(L.corner_offset);
  one(L.ghosts);
  one(L.ghost_offsets);
  one(L.ghost_source_level);
  one(L.ghost_source_node);
  one(L.ghost_weight);
  one(L.receivers);
  one(L.receive_offsets);
  one(L.receive_ghost_level);
  one(L.receive_ghost_node);
  one(L.receive_weight);
}

}  // namespace pliant::detail
