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
//     its centroid) is present and refined, or when one of its corners is a node no coarser stepped
//     tet covers (an active node, step 3) and the coarser tet next to that corner is present and
//     refined: an active node has all its tets. Stepped = present and not refined. The stepped
//     tets of all levels tile the body exactly for nested meshes (Kuhn boxes with an even ratio);
//     otherwise they overlap by up to one finer tet at the interfaces, where the centroids alone
//     left gaps that let the two sides part like a hinge.
//  3. Roles. A node of a stepped tet is a ghost if a stepped tet of a coarser level covers its rest
//     position (inside or on its boundary), with the barycentric weights of the coarsest such tet,
//     its sources made active by composing through ghost corners; otherwise it is active. Ghosts
//     only ever read coarser levels, so there are no cycles, and a level's ghosts never move while
//     that level's window is open (coarser windows contain finer ones).
// With nested meshes this is finite elements with hanging-node constraints: exact patch test,
// exact mass, exact momentum.
#pragma once
#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <utility>
#include <vector>

#include "pliant/defs.hpp"
#include "pliant/hierarchy.hpp"

namespace pliant::detail {

enum class NodeRole : std::uint8_t { active, ghost, inactive };

struct GhostSource {
  std::int32_t level = 0, node = 0;  // an active node of a coarser level
  double weight = 0;
};

// A stepped tet of a non-nested level may overlap coarser stepped tets (step 2): its mass counts
// for the share of it that lies in refined coarser tets, kMassShares of kMassShares when it all
// does (always, in nested levels), so that the overlap is not weighed twice.
inline constexpr int kMassShares = 5;

struct LevelActivation {
  std::vector<std::uint8_t> stepped;  // per tet: 1 if this level steps it
  std::vector<std::uint8_t> share;    // per tet: its mass share, 0 .. kMassShares (ActivationState::mass_share)
  std::vector<NodeRole> role;         // per node
  std::vector<std::int32_t> ghosts;   // ghost nodes, ascending
  std::vector<std::int32_t> source_offsets;  // per ghost (CSR, ghosts.size() + 1)
  std::vector<GhostSource> sources;          // sorted by (level, node) within a ghost
};

struct Activation {
  std::vector<LevelActivation> levels;
};

// Sorts v and drops its repeats, through marks (all 0 before and after, one per possible value):
// each value once, then a sort of what is left, much shorter than v when the lists that fill it
// overlap.
void sort_unique_marked(std::vector<std::int32_t>& v, std::vector<std::uint8_t>& mark);

// Targets of the nodes of every level (step 1).
std::vector<std::vector<int>> node_targets(const Hierarchy& h, const ActiveDef& active);

Activation activate(const Hierarchy& h, const ActiveDef& active);

class TetLocator;
class NodeLocator;

// The same rule kept as a state that can change: adaptivity (issue 14) sets new targets on a few
// nodes and update() re-evaluates only what they can reach — the tets around them and their
// descendants, the dangling tets next to those, the nodes of those tets, the finer nodes those tets
// cover, and the ghosts that read a node whose role changed — never the whole body. Tets and nodes
// are numbered as in the hierarchy's meshes.
class ActivationState {
 public:
  ActivationState(const Hierarchy& h, std::vector<std::vector<int>> targets);
  ~ActivationState();
  ActivationState(const ActivationState&) = delete;
  ActivationState& operator=(const ActivationState&) = delete;

  const Hierarchy& hierarchy() const { return h_; }
  int levels() const { return int(h_.levels()); }
  int target(int l, std::int32_t node) const { return targets_[std::size_t(l)][std::size_t(node)]; }
  bool stepped(int l, std::int32_t tet) const { return stepped_[std::size_t(l)][std::size_t(tet)] != 0; }
  const std::vector<std::uint8_t>& stepped_mask(int l) const { return stepped_[std::size_t(l)]; }
  // The share of tet t's mass it carries (a multiple of 1 / kMassShares; 1 at level 0): of five
  // points of it (its centroid and one next to each corner), those in a coarser tet that is present
  // and refined.
  double mass_share(int l, std::int32_t t) const { return double(share_[std::size_t(l)][std::size_t(t)]) / kMassShares; }
  NodeRole role(int l, std::int32_t node) const { return role_[std::size_t(l)][std::size_t(node)]; }
  const std::vector<GhostSource>& sources(int l, std::int32_t node) const { return sources_[std::size_t(l)][std::size_t(node)]; }
  // The tets of level l around a node (hierarchy numbering).
  std::pair<const std::int32_t*, const std::int32_t*> node_tets(int l, std::int32_t node) const;

  struct Changes {
    std::vector<std::vector<std::int32_t>> tets_on, tets_off;  // per level: tets that start / stop being stepped
    std::vector<std::vector<std::int32_t>> tets_reweighed;     // per level: stepped tets whose mass share changed
    std::vector<std::vector<std::int32_t>> nodes;              // per level: nodes whose role or sources changed
    std::size_t tets_examined = 0, nodes_examined = 0;          // the work done (for the cost measurements)
  };
  // Sets a node's target level (it takes effect at the next update()).
  void set_target(int l, std::int32_t node, int target);
  Changes update();

  Activation snapshot() const;  // every level in the CSR form of Activation

  // f(data, bytes) for each of its arrays, its locators' among them: what update() reads.
  // World::touch_pages keeps them warm between changes: the 50k-tet organ's first change after
  // seconds at its coarsest level spent 1.1-1.8 ms in update() cold, 0.5 ms warm.
  void for_each_array(const std::function<void(const void*, std::size_t)>& f) const;

 private:
  void refine_rule(int l, std::int32_t t, std::vector<std::int32_t>& refined_now);
  // Whether tet t of level l is present and refined (false for t < 0).
  bool split(std::size_t l, std::int32_t t) const;
  // Step 2's presence of a tet of level l > 0 (the stepped sets of the coarser levels final).
  std::uint8_t present_from_parents(std::size_t l, std::int32_t t) const;
  // Its mass share's numerator (kMassShares at level 0).
  std::uint8_t share_from_parents(std::size_t l, std::int32_t t) const;
  // Whether a stepped tet of a coarser level covers the node (it would be a ghost, step 3).
  bool covered(int l, std::int32_t node) const;
  // The tet of level c < l a node of level l would read as a ghost (the first stepped one of its
  // candidates: containing_or_near's answer), -1 if none.
  std::int32_t source_tet(int l, std::int32_t node, int c) const;
  // Whether a tet of level l > 0 reaches into more than one coarser tet (never in nested levels).
  bool straddles(std::size_t l, std::int32_t t) const;
  void evaluate_node(int l, std::int32_t node, bool& changed);

  const Hierarchy& h_;
  std::vector<std::unique_ptr<TetLocator>> tet_locators_;
  std::vector<std::unique_ptr<NodeLocator>> node_locators_;
  std::vector<double> reach_;                                     // per level (m)
  std::vector<std::vector<std::int32_t>> node_tet_offsets_, node_tet_list_;  // per level, CSR node -> tets
  std::vector<std::vector<std::int32_t>> child_offsets_, child_list_;         // per level, CSR tet -> tets of l + 1
  std::vector<std::vector<std::array<std::int32_t, 4>>> neighbours_;          // per level, face neighbours (-1: boundary)
  std::vector<std::vector<int>> targets_;
  std::vector<std::vector<std::uint8_t>> present_, refined_, stepped_;
  std::vector<std::vector<std::uint8_t>> share_;  // per level, per tet: mass share (0 .. kMassShares)
  std::vector<std::vector<std::int32_t>> stepped_incident_;  // per level, per node: stepped tets around it
  std::vector<std::size_t> stepped_count_;                   // per level: its stepped tets
  std::vector<std::size_t> split_count_;                     // per level: its present and refined tets
  // [c][l], c < l: CSR over the tets of level c, the straddling tets of level l with a corner near
  // their surface (built once; empty where level l has no straddling tet).
  std::vector<std::vector<std::vector<std::int32_t>>> near_offsets_, near_list_;
  std::vector<std::vector<NodeRole>> role_;
  std::vector<std::vector<std::vector<GhostSource>>> sources_;
  // per level, per node: the ghosts (level, node) that read it (it is a corner of the tet they read)
  std::vector<std::vector<std::vector<std::pair<std::int32_t, std::int32_t>>>> dependents_;
  std::vector<std::vector<std::array<std::int32_t, 5>>> reads_;  // per ghost: level and corners of the tet it reads
  std::vector<std::vector<std::int32_t>> dirty_targets_;  // per level
  std::vector<GhostSource> acc_;                          // evaluate_node's scratch (its sources)
  std::vector<std::int32_t> scratch_tets_;  // update()'s scratch
  std::vector<std::int32_t> rule_work_;     // refine_rule's stack (one per call was a malloc for each tet of a region)
  std::vector<std::size_t> straddling_;                   // per level: its tets that straddle coarser ones
  // [l][c], c < l: CSR over the nodes of level l, the tets of level c that can be the node's ghost
  // source or cover it, in the order containing_or_near prefers them (TetLocator::candidates).
  std::vector<std::vector<std::vector<std::int32_t>>> cover_offsets_, cover_list_;
  std::vector<std::vector<std::uint8_t>> node_mark_, tet_mark_;  // marks that dedupe update()'s candidates
};

}  // namespace pliant::detail
