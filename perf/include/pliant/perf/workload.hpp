// What the benchmarks run: box bodies of a given size in grid, random or renumbered memory
// order; the passes of a step (element, gather, integrate, fused gather + integrate) run on a
// World's level through an Executor, as Simulation::step runs them; and the cost model of each
// pass (bytes and flops per tet, working set) that the roofline judges them by.
#pragma once
#include <array>
#include <cstddef>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "pliant/scheduler/executor.hpp"
#include "pliant/world.hpp"

namespace pliant::perf {

enum class Order { grid, random, renumbered };
const char* to_string(Order o);

// The benchmark body: a box 1 x 0.25 x 0.25 m of cells[0] x cells[1] x cells[2] cells of 6 tets,
// clamped at x = 0, hanging under gravity; default material, no damping.
BodyDef box_body(ForceModel model, const std::array<int, 3>& cells);
// Box mesh in grid order (as generated), random order (nodes and tets shuffled, fixed seed)
// or renumbered (shuffled, then renumber_for_locality).
TetMesh box_mesh(const std::array<int, 3>& cells, Order order);
// A world with that body, stepped `warm_steps` times so that the state is deformed.
World make_box_world(ForceModel model, Precision precision, int threads, const std::array<int, 3>& cells,
                     Order order, int warm_steps = 20);

// Standard sizes: cells for about 1k, 10k, 100k and 1M tets.
struct BoxSize {
  const char* label;
  std::array<int, 3> cells;
};
const std::vector<BoxSize>& standard_sizes();

enum class Pass { element, gather, integrate, gather_integrate, step };
const char* to_string(Pass p);

// The data a pass must move at least once (bytes, counted the STREAM way: each array read or
// written once, read-modify-write twice, no write-allocate), its arithmetic (flops, hand count
// of the kernels' source; corotational assumes one Newton update of the warm-started rotation)
// and its working set (bytes of the distinct arrays it touches).
struct PassCost {
  double bytes = 0, flops = 0, footprint = 0;  // per call
};
PassCost pass_cost(const World& world, BodyId body, Pass pass);

// The passes of a step of the world's first body (level 0), one call each, run on `exec` as
// Simulation::step runs them (same kernels, same grains: pliant/level_passes.hpp). A full step is element(), then
// gather() + integrate() or gather_integrate() (the same bits). The box world's gravity is used.
class StepRunner {
 public:
  StepRunner(World& world, Executor& exec);
  ~StepRunner();
  StepRunner(const StepRunner&) = delete;
  StepRunner& operator=(const StepRunner&) = delete;
  void element();
  void gather();
  void integrate();
  void gather_integrate();

  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
};

// Seconds per call of each pass over repeated steps of the world's first body (level 0),
// run on `exec`. Each step runs the element pass, then alternately gather + integrate and the
// fused gather + integrate (the same bits), so the state evolves as in a real run and every
// pass is timed on it.
struct PartTimes {
  std::vector<double> element, gather, integrate, gather_integrate;
};
struct TimingOptions {
  double min_seconds = 0.2;  // of measured work, per case
  int min_samples = 10;
  int max_samples = 100000;
  int warmup = 3;
};
PartTimes time_step_parts(World& world, Executor& exec, const TimingOptions& options);

// Seconds per call of fn(), after warm-up calls.
std::vector<double> time_calls(const std::function<void()>& fn, const TimingOptions& options);

struct Stats {
  double median = 0, p99 = 0, max = 0, min = 0, mean = 0;
  std::size_t n = 0;
};
Stats stats_of(std::vector<double> samples);

}  // namespace pliant::perf
