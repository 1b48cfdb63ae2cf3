// An adaptive multiresolution body built as World builds one (its hierarchy, levels, activation
// and patch state), for tests that drive changes of resolution by hand: set targets on `as`,
// ActivationState::update(), then apply_changes on `body` with `ps`.
#pragma once
#include <memory>
#include <random>
#include <vector>

#include "../../engine/src/core/simulation.hpp"
#include "../../engine/src/multires/activation.hpp"
#include "../../engine/src/multires/adaptivity.hpp"
#include "../../engine/src/multires/apply_changes.hpp"
#include "pliant/hierarchy.hpp"
#include "pliant/scheduler/executor.hpp"

namespace pliant::detail {

template <class T>
struct AdaptiveBody {
  Hierarchy h;
  Executor exec{1};
  SimBody<T> body;
  std::unique_ptr<ActivationState> as;
  PatchState ps;
  explicit AdaptiveBody(const BodyDef& def) : h(link_levels(build_level_meshes(def, build_mesh(def.mesh)))) {
    body = build_multilevel_body<T>(h, def, 0.5, exec);
    as = std::make_unique<ActivationState>(h, node_targets(h, def.multiresolution.active));
    ps = make_patch_state(body, h, *as);
  }
  // 1 to max_moves random nodes of the levels that can split, each given a random target: mostly
  // one level finer (4 in 8) or its own (3 in 8), sometimes the finest at once. Then update() and
  // apply_changes make the change.
  void set_random_targets(std::mt19937& rng, unsigned max_moves) {
    const int levels = int(h.levels());
    const int moves = 1 + int(rng() % max_moves);
    for (int k = 0; k < moves; ++k) {
      const int l = int(rng() % unsigned(levels - 1));
      const auto node = std::int32_t(rng() % h.meshes[std::size_t(l)].node_count());
      const unsigned pick = rng() % 8;
      as->set_target(l, node, pick < 4 ? l + 1 : pick < 7 ? l : levels - 1);
    }
  }
  // The body as the full apply makes it from the activation's snapshot now.
  SimBody<T> full(double t) const {
    SimBody<T> f = body;
    std::vector<const TetMesh*> meshes;
    for (const TetMesh& m : h.meshes) meshes.push_back(&m);
    apply_activation(f, as->snapshot(), h, meshes, t);
    return f;
  }
};

}  // namespace pliant::detail
