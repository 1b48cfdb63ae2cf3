// The per-node and per-tet arrays of a kernel test's tets, and an ElementContext pointing at them
// with a rubber-like material (E = 1 MPa, nu = 0.3): what the kernel fixtures (test_kernel_batches,
// test_stiffness_lanes) fill in their own ways and then wire alike.
#pragma once
#include <cstdint>
#include <vector>

#include "pliant/kernels/element_context.hpp"

namespace pliant::test {

template <class T>
struct ElementArrays {
  std::vector<T> X[3], x[3], v[3], volume, grad[9], rot[4], cf[12];
  std::vector<std::int32_t> tet[4];
  ElementContext<T> c;

  // Sizes the per-tet arrays for n tets (corner forces zeroed).
  void size_tets(std::size_t n) {
    for (auto& a : tet) a.resize(n);
    volume.resize(n);
    for (auto& g : grad) g.resize(n);
    for (auto& q : rot) q.resize(n);
    for (auto& f : cf) f.assign(n, T(0));
  }
  // Points c at the arrays (call once they are sized: a later resize moves them) and sets the material.
  void wire() {
    for (int k = 0; k < 3; ++k) {
      c.X[k] = X[k].data();
      c.x[k] = x[k].data();
      c.v[k] = v[k].data();
    }
    for (int a = 0; a < 4; ++a) c.tet[a] = tet[a].data();
    c.volume = volume.data();
    for (int q = 0; q < 9; ++q) c.grad[q] = grad[q].data();
    for (int k = 0; k < 4; ++k) c.rotation[k] = rot[k].data();
    for (int q = 0; q < 12; ++q) c.corner_force[q] = cf[q].data();
    const double E = 1e6, nu = 0.3;
    c.lambda = T(E * nu / ((1 + nu) * (1 - 2 * nu)));
    c.mu = T(E / (2 * (1 + nu)));
    c.young = T(E);
  }

  // The rest data of the tets ids in list order, as Simulation::prepare copies a listed level's
  // (ElementContext::listed_tet, listed_grad, listed_volume), and c pointed at them; an empty list
  // clears the pointers (the kernels then gather).
  std::vector<T> listed_volume, listed_grad[9];
  std::vector<std::int32_t> listed_tet[4];
  void list_rest(const std::vector<std::int32_t>& ids) {
    listed_volume.clear();
    for (auto& g : listed_grad) g.clear();
    for (auto& a : listed_tet) a.clear();
    for (const std::int32_t t : ids) {
      listed_volume.push_back(volume[std::size_t(t)]);
      for (int q = 0; q < 9; ++q) listed_grad[q].push_back(grad[q][std::size_t(t)]);
      for (int a = 0; a < 4; ++a) listed_tet[a].push_back(tet[a][std::size_t(t)]);
    }
    const bool on = !ids.empty();
    c.listed_volume = on ? listed_volume.data() : nullptr;
    for (int q = 0; q < 9; ++q) c.listed_grad[q] = on ? listed_grad[q].data() : nullptr;
    for (int a = 0; a < 4; ++a) c.listed_tet[a] = on ? listed_tet[a].data() : nullptr;
  }

  // The rotations of the tets ids in list order, as Simulation::prepare copies a corotational
  // listed level's (ElementContext::listed_rotation), and c pointed at them (an empty list clears
  // the pointers); write_back_rotations copies them back to rot, by tet, as the step does.
  std::vector<T> listed_rot[4];
  void list_rotations(const std::vector<std::int32_t>& ids) {
    for (int k = 0; k < 4; ++k) {
      listed_rot[k].clear();
      for (const std::int32_t t : ids) listed_rot[k].push_back(rot[k][std::size_t(t)]);
      c.listed_rotation[k] = ids.empty() ? nullptr : listed_rot[k].data();
    }
  }
  void write_back_rotations(const std::vector<std::int32_t>& ids) {
    for (int k = 0; k < 4; ++k)
      for (std::size_t i = 0; i < ids.size(); ++i) rot[k][std::size_t(ids[i])] = listed_rot[k][i];
  }
};

}  // namespace pliant::test
