// The precision-specific state behind World: bodies made of levels, prescribed motions, probes,
// and the step. World holds one Simulation<float> or Simulation<double>.
#pragma once
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "pliant/defs.hpp"
#include "pliant/level.hpp"
#include "pliant/scheduler/executor.hpp"

namespace pliant::detail {

struct MotionState {
  std::vector<std::int32_t> nodes;       // level-0 node indices of the region
  std::vector<KeyframeDef> keyframes;
  bool host_driven = false;               // set_motion_offset() took over
  Vec3d host_offset{};                    // m
  Vec3d host_from{};                      // m, host offset at the start of the next step
  Vec3d offset_at(double time) const;     // m
};

template <class T>
struct SimBody {
  BodyDef def;
  std::vector<Level<T>> levels;   // 0 (coarsest) .. L (finest); one level until multiresolution lands
  std::vector<MotionState> motions;
};

struct ProbeState {
  std::string name;
  int body = 0, level = 0;
  std::int32_t tet = 0;
  std::array<double, 4> weights{};  // barycentric weights of the tet's corners
};

// Builds a level from a validated mesh: SoA arrays, rest geometry, masses, incidence, boundary,
// node states from the body's regions, stable step (measured with exec's threads; the result
// does not depend on their number). Throws InputError on bad regions or material.
template <class T>
Level<T> build_level(const TetMesh& mesh, const BodyDef& def, double courant, std::vector<MotionState>& motions,
                     Executor& exec);

// Sizes the level's obstacle impulse record and refuses (InputError naming the node) a body
// whose free nodes start inside one of the (unit-normal) obstacles (obstacles.cpp).
template <class T>
void prepare_obstacles(Level<T>& level, const std::vector<ObstacleDef>& obstacles, const std::string& body);

// ---- the stable step (stable_step.cpp) ----
// 2 c_p / h_min (rad/s): the highest frequency of a mesh of smallest altitude h_min (m) as the
// classic Courant estimate has it (not a bound: Kuhn meshes go 22% above it).
double geometric_frequency(double h_min, const MaterialDef& material);
// Highest angular frequency (rad/s) of the level's linearised undamped dynamics at rest, over
// its free nodes: sqrt of the largest Ritz value of `iterations` Lanczos steps on M^-1 K, with
// K from the level's model (linear elasticity for linear/stvk/corotational, the springs' own).
// From below: a lower bound of the true value, within 4e-4 at 30 iterations on the meshes
// measured (tests/core/test_physics_validation.cpp). Deterministic (fixed start, fixed-order
// sums). Uses the level's corner-force arrays as scratch (zeroed on return). 0 without free nodes.
template <class T>
double highest_frequency(Executor& exec, Level<T>& level, int iterations);
inline constexpr int kFrequencyIterations = 30;
inline constexpr double kFrequencyMargin = 0.98;  // the step is built for measured / margin
// Stable step (s) of the explicit integrator for highest frequency omega_max (rad/s), times the
// Courant number, tightened by damping: courant (2 / omega) (sqrt(1 + zeta^2) - zeta).
double stable_step_for(double omega_max, const MaterialDef& material, ForceModel model, double courant);
// stable_step_for(geometric_frequency(h_min)): the classic Courant bound, tightened by damping.
double courant_time_step(double h_min, const MaterialDef& material, ForceModel model, double courant);

template <class T>
class Simulation {
 public:
  std::vector<SimBody<T>> bodies;
  std::vector<ProbeState> probes;
  T gravity[3] = {0, 0, 0};
  std::vector<ObstacleDef> obstacles;  // static half-spaces, unit normals (World checks them)

  // One step of size dt from time t for every body and level. Returns false (and fills
  // `where`) if a free node's state became non-finite.
  bool step(Executor& exec, double t, double dt, std::string& where, std::int64_t step_index);

  void elastic_energies(Executor& exec, double& elastic) const;
  // Kinetic energy (J) at the time of the positions: 1/2 sum m |v_c|^2 with, on free nodes,
  // v_c = v + (h/2) a(x, v), the mean of the stored velocity (v_{n+1/2}: the one that moved x_n to
  // x_{n+1}) and the one the next sub-step of size h will give (v_{n+3/2}); a is the force of the
  // current state (element pass on scratch copies, so measuring never changes the trajectory)
  // over the mass, plus gravity, minus mass damping. Non-free nodes: their stored velocity.
  // `stored` receives 1/2 sum m |v|^2 of the stored velocities.
  double centred_kinetic(Executor& exec, double h, double& stored) const;
  // Largest element stiffness ratio over every stvk and corotational level (1 if none): how far
  // the current deformation has raised the highest frequency squared above the rest state's
  // (kernels element_stiffness.hpp). Deterministic (a max), whatever the thread split.
  // Allocation-free once `scratch` has been sized (add_body does).
  double stiffness_ratio(Executor& exec) const;
  // True if some level's model can stiffen beyond its rest state (stvk, corotational).
  bool can_stiffen() const;
  mutable std::vector<double> scratch;  // per-tet energies/stresses for reports (not the hot path)
};

}  // namespace pliant::detail
