// A change of an adaptive body's activation applied in place (issue 14 §1: a split or a merge costs
// in proportion to the nodes it changes, never to the body). apply_activation rebuilds every level's
// arrays from a whole snapshot; apply_changes patches the same arrays from the Changes that
// ActivationState::update() found, and gives the same result (tests/multires/test_apply_changes.cpp):
//  - stepped runs: the hierarchy's tet order is kept (an adaptive body is not reordered), and each
//    tet that turns on or off joins, splits or shrinks the run around it (binary search);
//  - own masses (rho V / 4 of the stepped tets around a node, times each tet's mass share) again
//    for the corners of those tets and of the tets whose share changed (tets_reweighed) only,
//    summed in the full apply's order (ascending tets); a node's mass is its own plus its
//    receiver entries' w x the ghost's own, again only for the nodes whose mass can change: the
//    corners of the tets, the changed nodes, and the old and new sources of both;
//  - the body's total: the full apply scales every mass so that the body weighs rho x the volume of
//    its finest mesh (non-nested levels tile the body only up to slivers). Here the nodes whose mass
//    changed keep, together, the mass they had (their new masses scaled by old sum / new sum), so
//    the total stays what it was (rho x V since the build) without touching another node. For
//    nested meshes the factor is 1 to rounding and the masses equal the full apply's to rounding.
//    For non-nested ones, keeping the touched nodes' sum lets a region's mass depend on the history
//    of changes, and a sliver large against the few nodes touched shifts their masses a lot (16%
//    off the full apply's on some organ nodes over 1 000 random changes). So a change is
//    renormalised — every node's mass made the full apply's (the same bits: raw masses summed in
//    its order, its factor), and the momentum correction spread over every free node — when the
//    touched nodes' factor is more than 2% off the body-wide one (kept from a running total of the
//    raw masses; 2% is about how far the full apply's own factor is from 1 on the organ), or once
//    the changes have touched as many nodes as the body has (amortised: at most one more node
//    visited per node touched). Nested meshes never need the first;
//  - ghost and receiver CSRs: the entries of the changed nodes are replaced, the segments between
//    them block-copied into a buffer kept from the last change (swapped, so no allocation once it
//    is large enough): the hot path keeps reading plain sorted CSRs;
//  - regions: the nodes each fixed / prescribed / load region selects on each level are found once
//    (geometry, at build); a change only filters its changed nodes by their role. A load's force is
//    spread over its active nodes, so when their count changes its region's nodes are written again.
// The state carried over to the changed nodes is adapt_body's (adaptivity.cpp), over ChangeSet's
// nodes only; the momentum correction (keep_momentum, below) is a rigid shift of every free node.
#pragma once
#include <cstdint>
#include <vector>

#include "activation.hpp"
#include "pliant/aligned.hpp"
#include "pliant/hierarchy.hpp"

namespace pliant::detail {

template <class T>
struct SimBody;

// What apply_changes keeps between changes; built once, from the body as the full apply left it.
struct PatchState {
  std::vector<std::vector<double>> quarter_mass;  // per level, per tet: rho V / 4 (kg)
  std::vector<std::vector<double>> own_mass;      // per level, per node: quarter masses of its stepped tets (kg)
  // Per region, per level: the nodes it selects at rest whatever their role (sorted).
  std::vector<std::vector<std::vector<std::int32_t>>> fixed, prescribed, loads;
  std::vector<std::size_t> fixed_count, prescribed_count, load_count;  // per region: active nodes selected, all levels
  std::vector<std::vector<double>> raw_mass;  // per level, per node: own + the ghosts' own moved to it (kg, before the factor)
  double raw_total = 0;               // kg, their sum (kept as they change; exact at each renormalisation)
  double volume = 0;                  // m^3, of the finest mesh (the full apply's sum): the body weighs rho x this
  std::size_t renormalise_after = 0;  // nodes of all levels: a change renormalises once this many were touched
  std::size_t touched_since = 0;      // nodes touched since the last renormalisation
  std::int64_t renormalisations = 0;
  // A change whose touched nodes' factor (keeping their sum) is further than this from the body-wide
  // one (the full apply's) is renormalised: past it, slivers would distort those nodes' masses more
  // than the full apply's own factor moves them off rho V / 4 per tet (up to 2% on the organ).
  double factor_tolerance = 0.02;
  std::vector<std::vector<std::uint8_t>> mark;  // per level, per node: 0 (set and cleared within a call, to dedupe)
  // Buffers the CSRs are spliced into (then swapped with the level's).
  AlignedVector<std::int32_t> keys, offsets, col_a, col_b;
  AlignedVector<double> col_w;
};

// The work of one apply, for the cost measurements and the locality test: what it read or wrote.
struct PatchStats {
  std::size_t nodes = 0;    // nodes whose mass, state, entries or region membership were evaluated
  std::size_t tets = 0;     // tets turned on or off, and tets read to sum an own mass
  std::size_t entries = 0;  // ghost and receiver entries written for the changed nodes
};

// The nodes a change touched, per level (ascending), with what adapt_body needs to carry the state
// over and keep the momentum.
struct ChangeSet {
  std::vector<std::vector<std::int32_t>> changed;        // role or sources changed (ActivationState::Changes::nodes)
  std::vector<std::vector<std::uint8_t>> old_state;      // their NodeStateCode before the change
  std::vector<std::vector<std::int32_t>> mass_changed;   // nodes whose mass may have changed (includes `changed`;
                                                         // every node when the change renormalised)
  double p_before[3] = {0, 0, 0};                        // kg m/s: momentum of the free nodes of mass_changed, before
  bool held = false;                                     // some node is fixed or prescribed after the change
  PatchStats stats;
  // A node's state before the change: `now` (its current one) if it is not in `changed`.
  std::uint8_t was(int l, std::int32_t node, std::uint8_t now) const;
};

// Once, after build_multilevel_body (its full apply): the own masses, the region selections, and
// the corner forces of the tets not stepped cleared (every later change clears those it turns off).
template <class T>
PatchState make_patch_state(SimBody<T>& body, const Hierarchy& h, const ActivationState& as);

// The level arrays of `body` made those of the activation `as` now is, from the changes its last
// update() returned (`time`: s, for the offset of the nodes that become prescribed). Throws
// InputError as apply_activation does when a region no longer selects any simulated node.
template <class T>
ChangeSet apply_changes(SimBody<T>& body, PatchState& ps, const ActivationState& as, const ActivationState::Changes& ch,
                        double time);

// Linear momentum kept: what the change did to it is summed over cs.mass_changed only (no other
// node's mass, state or velocity changed), and given back as one uniform velocity change of every
// free node, a rigid motion. Spreading it over the touched free nodes only would be local, but it is
// a velocity jump at the edge of the touched patch, that is a strain: on a clamped bar pushed 3 cm,
// 32 splits instead of 25 with the same thresholds (the lead's RelativeThresholds test). The shift
// is one pass over the free nodes' velocities (3 adds a node), the one body-wide part of a change.
// Only for a body nothing holds (cs.held false): a held body exchanges momentum with its fixed and
// prescribed nodes, and mass a change moves onto or off them is not momentum lost (correcting for
// it set clamped bodies moving). Returns the free nodes shifted.
template <class T>
std::size_t keep_momentum(SimBody<T>& body, const ChangeSet& cs);

}  // namespace pliant::detail
