// Adaptivity (ActiveDef::Kind::adaptive, AdaptDef; docs/multiresolution.md "Adaptivity"): where a
// multiresolution body's levels are active changes while it runs. At the ticks where every level's
// window ends (the only points where no level is in the middle of a step), the strain measure of
// AdaptDef decides which coarse nodes split and which split nodes merge back; ActivationState
// re-evaluates the activation around them, and apply_changes patches the level arrays it drives
// (stepped runs, roles, ghosts, receivers, masses, regions) over the changed nodes and tets only.
// Nodes that become active take their position and velocity from the field that was simulated
// there (barycentric, from the neighbouring level); the mass stays exactly rho x volume and the
// body's linear momentum is kept to rounding (a uniform velocity correction over the free nodes).
#pragma once
#include <algorithm>
#include <array>
#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <vector>

#include "activation.hpp"
#include "apply_changes.hpp"
#include "pliant/hierarchy.hpp"
#include "pliant/scheduler/executor.hpp"

namespace pliant::detail {

template <class T>
struct SimBody;

// One target change of a decision, as AdaptiveState::decided keeps it for an undo.
struct TargetChange {
  enum Kind : std::uint8_t {
    split,   // the measure, a near shape, or a refined region around the node asked for it
    merge,   // its children stayed calm for min_dwell
    command  // World::force_level or a lowered cap: never undone
  };
  std::int32_t node;
  std::int16_t level;
  std::int8_t from, to;  // its target before and after
  Kind kind;
};

struct AdaptiveState {
  std::shared_ptr<const Hierarchy> hierarchy;  // outlives `activation`, which refers to it
  std::unique_ptr<ActivationState> activation;
  std::vector<std::vector<std::array<std::int32_t, 4>>> neighbours;  // per level, per tet: face neighbours (-1: boundary)
  AdaptDef def;
  double next_check = 0;                       // s: no decision before this time
  std::vector<double> edge;                    // per level: mean edge length at rest (m), the scale of the merge measure
  std::vector<std::vector<double>> calm_since;  // per level, per node: time its children became calm (-1: not calm)
  std::int64_t splits = 0, merges = 0, checks = 0, changes = 0;
  std::int64_t keeping_splits = 0;             // of splits, those inside refined regions (World::AdaptStats)
  double scale = 1;                            // both thresholds times this (the real-time controller raises it to coarsen)
  int cap = 1 << 20;                           // no node is split beyond this level; split nodes above it merge at once
  int split_budget = std::numeric_limits<int>::max();  // splits per decision at most (World::set_adapt_split_budget)
  double change_interval = 0;                  // s: after a change, no decision for this long (World::set_adapt_change_interval)
  double last_change = -std::numeric_limits<double>::infinity();  // s: the time of the last change
  double peak_strain = 0;                      // the body's largest |E| at the last decision (diagnostics)
  int forced_target = -1;                      // >= 0: the next decision activates every node up to this level (World::force_level)
  double apply_seconds = 0;                    // wall time spent applying changes (for the cost measurement)
  double check_seconds = 0;                    // wall time of the decision points: measure, decide, apply,
                                               // give back the energy (Simulation::step)
  double check_max_seconds = 0;                // the longest decision point
  std::int64_t touched_nodes = 0, touched_tets = 0;  // work of the applies so far (PatchStats summed)
  PatchState patch;                            // what the applies keep between changes (make_patch_state at build)
  // Undoing a change that adds more energy than the body's motion can give back (undo_change).
  std::vector<TargetChange> decided;           // the last decision's target changes, in decision order
  bool undoable = false;                       // the last change can be undone: it merged, no command is among
                                               // its changes, and the state before it is in scratch.before
  std::int64_t undone = 0;                     // changes undone (applied again without their merges)
  // J: energy changes added that the body's motion could not give back at once (Simulation::step:
  // taken from that motion at the next decision points that have it).
  double owed_energy = 0;
  std::int64_t deferred_merges = 0;            // merges those undos dropped
  // What a decision computes, kept from one decision to the next so that a decision allocates
  // nothing once the body's arrays are sized (a fresh 0.5 MB of field on the 50k-tet organ was
  // page faults at every decision; adapt_body sizes these on first use).
  struct Scratch {
    std::vector<std::vector<double>> x, v;                        // per level x 3: every node's position, velocity now
    std::vector<std::array<double, 9>> F;                         // per tet of one level: F, written for stepped tets
    std::vector<std::int32_t> ids;                                 // one level's stepped tets, in run order
    std::vector<double> chunk_peak;                                // per chunk of ids: its largest squared strain
    std::vector<std::vector<double>> measure;                     // per level but the finest: per node
    std::vector<std::vector<std::array<double, 7>>> restricted;   // per level but the finest (restrict_field)
    // The state the last undoable change started from, per level: the bytes of x, v (3 arrays
    // each), mass and inv_mass of every node, one after the other (8 x node_count x sizeof(T)),
    // and what of the PatchState is a running value rather than a function of the activation.
    std::vector<std::vector<unsigned char>> before;
    double raw_total = 0;
    std::size_t touched_since = 0;
    std::int64_t renormalisations = 0;
  } scratch;

  // Whether a decision is due at time t (s): at its check_every (next_check); at once when forced
  // (World::force_level) or when a tool presses a triangle it cannot push (`unresolved`), except
  // within change_interval of the last change (World::set_adapt_change_interval: the real-time
  // controller's one change a frame; a tool of the 50k-tet organ pressed a finer surface's ghost
  // corners right after the first change, and the decisions at once put three changes of
  // 0.45-0.9 ms in one 1 ms frame). force_level is never held back.
  bool decision_due(double t, bool unresolved) const {
    if (forced_target >= 0) return true;
    if (t + 1e-12 < last_change + change_interval) return false;
    return unresolved || t + 1e-12 >= next_check;
  }
  // The earliest time (s) from which decision_due holds without an unresolved contact: the later
  // of next_check and the end of the change interval (-infinity when forced). The decision itself
  // comes at the first tick from then on where every level's window ends (World::adapt_next_decision).
  double next_decision() const {
    if (forced_target >= 0) return -std::numeric_limits<double>::infinity();
    return std::max(next_check, last_change + change_interval);
  }
};

// The arrays of `body` that follow from an activation (every level): stepped runs, node states,
// ghosts and their sources, receivers and their impulse arrays, masses (stepped tets' rho V / 4,
// ghosts' masses moved to their sources, scaled so that the body weighs rho x the volume of its
// finest mesh), fixed / prescribed / loaded nodes among the active ones (prescribed nodes at
// rest + offset(time)). `meshes` are the level meshes in the levels' tet order.
template <class T>
void apply_activation(SimBody<T>& body, const Activation& act, const Hierarchy& h, const std::vector<const TetMesh*>& meshes,
                      double time);

// The adaptive state of a multilevel body just built from `h` (build_multilevel_body, whose full
// apply make_patch_state starts from): its activation from `active`'s targets, the face neighbours
// and mean edges of every level, the calm and retry times, the patch state, the sized scratch.
template <class T>
std::shared_ptr<AdaptiveState> make_adaptive_state(std::shared_ptr<const Hierarchy> h, const ActiveDef& active, SimBody<T>& body);

// Sizes (and so touches) the decision scratch for the hierarchy's levels, when the body is built:
// the first decision of a real-time run would otherwise fault in its pages (1.8 ms on the 50k-tet organ).
void size_adapt_scratch(AdaptiveState& st);

// The rest volume of tet t of a mesh (m^3), as the masses of apply_activation and apply_changes
// take it (one expression, so that both give the same bits).
double tet_rest_volume(const TetMesh& mesh, std::size_t t);

// The face neighbours of every tet of a mesh (-1 across the boundary).
std::vector<std::array<std::int32_t, 4>> face_neighbours(const TetMesh& mesh);

// One decision of an adaptive body at time t (s), at a tick where every level's window ends.
// Returns true if the activation changed (the caller re-prepares its jobs).
// `near`: what refines by distance (AdaptDef::refine_near), in the body frame: segments a-b with a
// radius (m; the tools touching the body, a probe as a point) or boxes a..b (a prescribed
// motion's nodes); nodes within refine_near of their surface are split and kept split.
struct NearShape {
  std::array<double, 3> a{}, b{};
  double radius = 0;
  bool box = false;
  bool tool = false;  // a tool's swept sphere: also keeps the nodes inside it from merging when refine_near is 0
  // A point where a tool presses a triangle it cannot push (LevelContact::unresolved): nodes within
  // one mean edge of their level split and stay split whatever refine_near, 0 included.
  bool unresolved_contact = false;
};
// `before_change`, if given, is called once, after the decisions and before the first change to
// the body (when there is one): the caller's measurements of the state as it was (the energy give-back
// of Simulation::step) are taken only at decision points that change something.
// `exec`, if given, computes the deformation gradients of the measure on its threads (the same
// bits as without: each tet's on its own, the peak a maximum).
// `finest`, if given, is the finest level's stepped tets as its force pass reads them (the corners
// and rest gradients of each, in the pass's list order; Simulation's listed levels). That level's
// gradients give the peak strain only (it never splits), a maximum, so their order does not matter:
// read there, warm from the step, instead of from the level's arrays by tet, which only decisions
// read and which a large body leaves cold (on a bar of 196 608 fine tets stepping 14 000, those
// 14 000 tets took 500 us a decision, 35 ns each, on one thread).
template <class T>
struct ListedRest {
  const std::int32_t* tet[4] = {};  // corner node indices, per listed tet
  const T* grad[9] = {};            // rest gradients, as Level::grad, per listed tet (1/m)
  std::size_t count = 0;            // listed tets: the level's stepped tets, each once
};
template <class T>
bool adapt_body(SimBody<T>& body, double t, const std::vector<NearShape>& near = {},
                const std::function<void()>& before_change = {}, Executor* exec = nullptr,
                const ListedRest<T>* finest = nullptr);

// Undoes the last change adapt_body applied (it must be `undoable`): the activation and every
// node's position, velocity and mass are made what they were before it, to the bit, and it is
// applied again without its merges (their nodes, calm, wait min_dwell again); its splits stay, so
// that refinement is never refused. Returns true if something is applied again (its state carried
// over as adapt_body does), false if the body is as it was before the decision.
// For Simulation::step: a change whose added energy the body's motion cannot give back.
template <class T>
bool undo_change(SimBody<T>& body, double t);

}  // namespace pliant::detail
