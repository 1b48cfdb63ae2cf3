// Stiffness calibration of the coarser levels of a multiresolution body (docs/multiresolution.md,
// "Modes across levels"). Linear tetrahedra lock in bending, the more so the fewer of them span
// the body (a cantilever one tet thick is 70% stiffer in its first mode than one four thick), so
// the levels of one body would not agree on its motion. Each coarser level's moduli are scaled so
// that the frequency of the lowest mode its own weight excites equals the finest level's, in the
// axis in which the finest level is softest: the static deflection under that weight (K u = M g,
// conjugate gradients with the rest stiffness, the level's fixed nodes held), then four steps of
// inverse iteration (K u' = M u), omega^2 the Rayleigh quotient of the last. A level without fixed
// nodes (a free body) is left alone.
#pragma once
#include <array>

#include "../core/simulation.hpp"

namespace pliant::detail {

struct Compliance {
  std::array<double, 3> omega2{};  // (rad/s)^2 per axis of the weight; 0 without fixed nodes
  int iterations = 0;              // CG iterations, summed over the axes
  bool converged = false;
};

// The level as built (all tets, its own lumped masses and fixed nodes).
template <class T>
Compliance weight_compliance(Executor& exec, Level<T>& level);

// Scales the level's elastic moduli (and the viscosities that follow them through a Rayleigh
// factor) by `factor`, and recomputes its stable step.
template <class T>
void scale_stiffness(Executor& exec, Level<T>& level, const MaterialDef& material, double factor, double courant);

}  // namespace pliant::detail
