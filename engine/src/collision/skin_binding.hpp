// Binding a skin (pliant/skin.hpp) to the levels of a body, and evaluating it on the current
// state. Binding runs once, when the body is added (Embree ball queries of growing radius find
// each skin vertex's nearest boundary triangle); evaluation is a read of three nodes per vertex,
// done when a host or a picture asks for the skin (not in the step).
#pragma once
#include <array>
#include <cstdint>
#include <vector>

#include "pliant/level.hpp"
#include "pliant/skin.hpp"

namespace pliant {
class Executor;
}

namespace pliant::detail {

// One skin vertex tied to one triangle of a level's boundary.
struct SkinLevelBinding {
  std::vector<std::array<std::int32_t, 3>> nodes;  // per skin vertex: the level nodes of its triangle
  std::vector<std::array<double, 3>> weights;      // barycentric weights of the nearest point
  std::vector<std::array<double, 3>> offset;       // vertex - nearest point in (e1, e2, n) of the triangle (m)
  double max_distance = 0;                         // m, the farthest skin vertex from its triangle at rest
};

struct SkinState {
  std::vector<std::array<std::int32_t, 3>> triangles;
  std::vector<double> rest;                 // m, world frame, 3 per vertex (after the mesh's scale/translate)
  std::vector<SkinLevelBinding> levels;     // one per level of the body
};

// Ties every vertex of `skin` (body frame: rest positions relative to the body origin) to the
// nearest boundary triangle of L at rest.
template <class T>
SkinLevelBinding bind_skin(const std::vector<double>& skin_body_frame, const Level<T>& L, Executor& exec);

// Where skin vertex i is now (body frame), following level L's triangle (node positions given by
// `at(node)`, a function returning the node's current body-frame position as std::array<double,3>).
template <class At>
std::array<double, 3> skin_vertex(const SkinLevelBinding& b, std::size_t i, const At& at);

}  // namespace pliant::detail

#include "skin_binding_eval.hpp"
