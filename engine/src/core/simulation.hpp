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
// node states from the body's regions, stable step. Throws InputError on bad regions or material.
template <class T>
Level<T> build_level(const TetMesh& mesh, const BodyDef& def, double courant,
                     std::vector<MotionState>& motions);

// Courant bound (s) of a level of min altitude h (m) for a material, tightened by damping.
double courant_time_step(double h_min, const MaterialDef& material, ForceModel model, double courant);

template <class T>
class Simulation {
 public:
  std::vector<SimBody<T>> bodies;
  std::vector<ProbeState> probes;
  T gravity[3] = {0, 0, 0};

  // One step of size dt from time t for every body and level. Returns false (and fills
  // `where`) if a free node's state became non-finite.
  bool step(Executor& exec, double t, double dt, std::string& where, std::int64_t step_index);

  void elastic_energies(Executor& exec, double& elastic) const;
  mutable std::vector<double> scratch;  // per-tet energies/stresses for reports (not the hot path)
};

}  // namespace pliant::detail
