// Which level simulates which part of a multiresolution body (docs/multiresolution.md, "Who is
// active where"): from the hierarchy at rest and the body's `active` setting, the tets each level
// steps, and each node's role in its level — active (integrated by that level), ghost (a corner of
// a stepped tet whose position comes from coarser levels) or inactive.
//
// The rule, in three steps:
//  1. Targets. A node's target is the finest level any `active` region containing it asks for
//     (0 outside every region), raised to its children's targets (its Voronoi zone reaches into a
//     finer region: the node is split).
//  2. Stepped tets. A tet of level l is refined when one of its corners targets a finer level; a
//     level-0 tet is present, a finer tet is present when its parent tet (the coarser tet holding
//     its centroid) is present and refined. Stepped = present and not refined. The stepped tets of
//     all levels tile the body: exactly for nested meshes (Kuhn boxes with an even ratio), up to
//     slivers of the interface otherwise.
//  3. Roles. A node of a stepped tet is a ghost if a stepped tet of a coarser level covers its rest
//     position (inside or on its boundary), with the barycentric weights of the coarsest such tet,
//     its sources made active by composing through ghost corners; otherwise it is active. Ghosts
//     only ever read coarser levels, so there are no cycles, and a level's ghosts never move while
//     that level's window is open (coarser windows contain finer ones).
// With nested meshes this is finite elements with hanging-node constraints: exact patch test,
// exact mass, exact momentum.
#pragma once
#include <cstdint>
#include <vector>

#include "pliant/defs.hpp"
#include "pliant/hierarchy.hpp"

namespace pliant::detail {

enum class NodeRole : std::uint8_t { active, ghost, inactive };

struct GhostSource {
  std::int32_t level = 0, node = 0;  // an active node of a coarser level
  double weight = 0;
};

struct LevelActivation {
  std::vector<std::uint8_t> stepped;  // per tet: 1 if this level steps it
  std::vector<NodeRole> role;         // per node
  std::vector<std::int32_t> ghosts;   // ghost nodes, ascending
  std::vector<std::int32_t> source_offsets;  // per ghost (CSR, ghosts.size() + 1)
  std::vector<GhostSource> sources;          // sorted by (level, node) within a ghost
};

struct Activation {
  std::vector<LevelActivation> levels;
};

// Targets of the nodes of every level (step 1).
std::vector<std::vector<int>> node_targets(const Hierarchy& h, const ActiveDef& active);

Activation activate(const Hierarchy& h, const ActiveDef& active);

}  // namespace pliant::detail
