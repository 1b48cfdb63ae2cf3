// Running a scene to its end with result files: what `pliant run` does, callable from code.
#pragma once
#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "pliant/defs.hpp"
#include "pliant/world.hpp"

namespace pliant {

struct RunOptions {
  std::filesystem::path out_dir = "out";   // created if missing
  std::optional<int> threads;              // override the scene's
  std::optional<Precision> precision;      // override the scene's
  std::optional<double> duration;          // override the scene's (s)
  bool progress = false;                   // a progress line on stderr (rewritten in place)
  bool write_files = true;                 // false: compute only (tests, studies)
  // Called on the initial state and then every `frame_every` simulated seconds (0: never), for
  // pictures or custom records. It reads the world and must not change it.
  double frame_every = 0;                  // s
  std::function<void(const World&)> on_frame;
};

struct RunSummary {
  std::string status = "ok";  // "ok" | "diverged"
  std::string message;        // divergence details
  std::int64_t steps = 0;
  int substeps = 1;             // sub-steps per step as chosen at load
  int max_substeps = 1;         // most sub-steps a step took (the adaptive step, TimeStepDef::adapt)
  std::int64_t adapted_steps = 0;      // steps that took more sub-steps than chosen at load
  double max_stiffness_ratio = 1;      // largest element stiffness ratio measured (1 = rest)
  double simulated_time = 0, wall_time_s = 0, steps_per_second = 0;
  std::size_t nodes = 0, tets = 0;
  std::string model, precision;
  int threads = 1;
  double dt = 0, stable_dt = 0;  // s
  double max_displacement = 0;   // m
  double kinetic_energy = 0, elastic_energy = 0, potential_energy = 0;  // J
  std::string state_hash;        // 16 hex digits
  std::vector<std::string> files;  // written, relative to out_dir
  std::vector<std::string> notes;  // what loading fixed in the meshes (one line per body that needed it), and a
                                   // thread count clamped to the cores
};

// A World holding the scene's bodies and probes (meshes built, regions resolved).
World make_world(const SceneDef& scene, const RunOptions& options = {});

// Runs the scene for its duration, writing DIR/summary.json, DIR/probes.csv and, if asked,
// DIR/vtu/*.vtu + DIR/series.pvd. Throws InputError on bad input; on divergence writes the
// summary (status "diverged") and then throws DivergenceError.
RunSummary run_scene(const SceneDef& scene, const RunOptions& options);

std::string hash_hex(std::uint64_t h);

}  // namespace pliant
