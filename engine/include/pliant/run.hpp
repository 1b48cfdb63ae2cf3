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

// How far a run is, for progress lines (RunOptions::on_progress).
struct RunProgress {
  std::int64_t step = 0, steps = 0;  // steps done, steps in the run
  std::int64_t substeps_done = 0;    // sub-steps taken so far (a step takes one or more)
  int substeps = 1;                  // sub-steps the last step took
  double time = 0, duration = 0;     // s simulated, s to simulate
  double wall_s = 0;                 // s of wall time since stepping began
  // Remaining wall time (s): the steps left, each of the last step's sub-step count, at the
  // wall time per sub-step measured so far (the first step, which pays for warming caches and
  // threads, left out when there are others). 0 until measured.
  double eta_s = 0;
  double seconds_per_substep = 0;    // s of wall time per sub-step, as measured
  bool estimate = false;             // the first report, once the first steps are timed: the run's estimate
};

struct RunOptions {
  std::filesystem::path out_dir = "out";   // created if missing
  std::optional<int> threads;              // override the scene's
  std::optional<Precision> precision;      // override the scene's
  std::optional<double> duration;          // override the scene's (s)
  std::optional<Schedule> schedule;        // override the scene's
  // Progress: on_progress is called once when the first steps have been timed (at least 2 steps
  // and estimate_after s of wall time, RunProgress::estimate set), then about every
  // `progress_every` wall seconds (0: only the estimate). It must not change the world.
  double progress_every = 0;               // s of wall time
  double estimate_after = 0.3;             // s of wall time of stepping before the estimate (kEstimateAfter)
  std::function<void(const RunProgress&)> on_progress;
  bool write_files = true;                 // false: compute only (tests, studies)
  // Real time (SceneDef::realtime, `pliant run --realtime`): simulated time follows the wall clock.
  // The run goes in frames of realtime_frame simulated seconds (1 ms by default: a 1 kHz haptic
  // loop's tick): a frame starts when the wall clock (since the run began) reaches the simulated
  // time of its start (the runner sleeps until then), runs its steps back to back, and is a
  // deadline miss if its last step ends after the wall-clock time of its end; simulated time then
  // lags the clock (RunSummary reports both). The physics of a step never changes: only when it runs.
  std::optional<bool> realtime;            // override the scene's
  std::optional<double> realtime_frame;    // s, override the scene's frame (SceneDef::realtime_frame; 0: every step)
  // Real-time runs: step on a real-time thread (SCHED_FIFO, lowest real-time priority) for the run,
  // so that waits wake up on time when other processes hold the cores. Needs the privilege; without
  // it the run goes on at normal priority and RunSummary::notes says why.
  bool realtime_priority = false;
  // The wall clock (s, any origin) and how to wait for it, for real-time runs; empty: the steady
  // clock and std::this_thread::sleep_until. Tests give a simulated clock.
  std::function<double()> wall_clock;
  std::function<void(double)> sleep_until;
  // Called on the initial state and then every `frame_every` simulated seconds (0: never), for
  // pictures or custom records. It reads the world and must not change it.
  double frame_every = 0;                  // s
  std::function<void(const World&)> on_frame;
  // Called during the run, once, when something the caller should know at once happened (a
  // real-time run whose adaptive bodies are at their coarsest and still cost more than the clock
  // allows); the same text is kept in RunSummary::notes.
  std::function<void(const std::string&)> on_warning;
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
  // Multiresolution and the schedule (docs/multiresolution.md): every level of every body, the
  // tets computed over the run, and the per-tick work and wall time.
  struct Level {
    std::string body;
    int level = 0, period = 1;
    std::size_t nodes = 0, tets = 0;
    double active_tets_mean = 0, ghost_nodes_mean = 0;  // stepped tets, ghost nodes (means over the ticks)
    double dt = 0;  // s
  };
  std::vector<Level> levels;
  std::string schedule = "staggered";
  double tet_updates = 0;                    // tets computed, summed over the run
  double tick_tet_updates_mean = 0;
  std::size_t tick_tet_updates_max = 0;
  double tick_mean_us = 0, tick_p50_us = 0, tick_p99_us = 0, tick_max_us = 0;
  // Time: the run's simulated seconds per wall second of stepping (above 1: faster than real time).
  // Real-time runs (RunOptions::realtime) run in frames of realtime_frame_s of simulated time
  // (SceneDef::realtime_frame; 0: every step is a frame) and count the frames that ended after the
  // wall-clock time of their end (deadline_misses), how far simulated time lagged the clock at the
  // end of each frame, and the wall time each frame spent stepping (waits left out).
  double realtime_factor = 0;
  bool realtime = false;
  double realtime_frame_s = 0;
  std::int64_t frames = 0, deadline_misses = 0;
  double lag_mean_s = 0, lag_max_s = 0;
  double frame_mean_us = 0, frame_p99_us = 0, frame_max_us = 0;
  // Why frames missed: frames_over is how many took longer than a frame to step (late by their own
  // work); the others started late, behind an earlier frame or a wake-up: wake_late_max_s is the
  // most a frame started after its due time although it had waited for it (the OS's scheduling).
  std::int64_t frames_over = 0;
  double wake_late_max_s = 0;
  // Frames that started before their time, as soon as the frame before ended, because an adaptive
  // body could change its resolution in them (World::adapt_next_decision): the change gets the
  // slack of the frame before too.
  std::int64_t frames_early = 0;
  // Of the deadline misses: late_behind would have been on time had they started on time (they
  // started late, behind the frame before or a wait that woke up late); of the others,
  // late_changing held a change of resolution, and the rest were late by their stepping alone.
  std::int64_t late_behind = 0, late_changing = 0;
  // Pages of the bodies' arrays read in the waits before frames (World::touch_pages), to keep
  // memory that idle levels leave untouched from going cold under a host that reclaims it.
  std::int64_t pages_touched = 0;
  // The controller of real-time runs with adaptive bodies: how often it coarsened and refined
  // again, and the thresholds' largest and final scale (1 = the scene's).
  std::int64_t controller_coarsened = 0, controller_refined = 0;
  double controller_max_scale = 1, controller_final_scale = 1;
  int controller_min_cap = -1;  // the lowest cap on the finest level it set (-1: none)
  // Adaptive bodies (multiresolution.active = adaptive): their decisions over the run. Their
  // stepped tets per level over time are in levels.csv.
  struct Adapt {
    std::string body;
    std::int64_t splits = 0, merges = 0, changes = 0;
    double apply_us_per_change = 0;  // us of wall time to apply one change (re-activation + state transfer)
    std::int64_t checks = 0;         // decision points
    double check_us_mean = 0;        // us of wall time per decision point (measure, decide, apply, energy)
    double check_us_max = 0;         // the longest one
    std::int64_t undone = 0;         // changes undone: their added energy was more than the motion could give back
  };
  std::vector<Adapt> adapt;
  // Tools (docs/tool.md), over the run's steps.
  struct Tool {
    std::string name;
    double max_force = 0;        // N, largest |force| the bodies exerted on it
    double max_penetration = 0;  // m, deepest triangle left inside it after a step
    std::int64_t contact_steps = 0;  // steps that ended with a contact
  };
  std::vector<Tool> tools;
};

// A World holding the scene's bodies, probes and tools (meshes built, regions resolved).
World make_world(const SceneDef& scene, const RunOptions& options = {});

// Runs the scene for its duration, writing DIR/summary.json, DIR/probes.csv and, if asked,
// DIR/vtu/*.vtu + DIR/series.pvd. Throws InputError on bad input; on divergence writes the
// summary (status "diverged") and then throws DivergenceError.
RunSummary run_scene(const SceneDef& scene, const RunOptions& options);
// The same on a world already built from the scene by make_world (e.g. to show its plan first,
// run_plan.hpp); the world is stepped from where it is.
RunSummary run_world(const SceneDef& scene, World& world, const RunOptions& options);

// Wall time (s) of stepping after which the first estimate is made (RunOptions::on_progress).
inline constexpr double kEstimateAfter = 0.3;
// Steps of a run of `duration` s at step dt (s): whole steps up to the duration (the last one
// reaches or passes it).
std::int64_t steps_for(double duration, double dt);

std::string hash_hex(std::uint64_t h);

}  // namespace pliant
