// The scene runner: builds the world, steps it for the scene's duration, records probes and
// VTU frames at their own rates, prints a progress line, writes summary.json.
#include "pliant/run.hpp"

#include <chrono>
#include <cmath>
#include <optional>
#include <thread>
#include <cstdio>
#include <fmt/format.h>
#include <fstream>
#include <nlohmann/json.hpp>

#include "pliant/vtu_writer.hpp"
#include "step_clock.hpp"
#include "thread_priority.hpp"

namespace pliant {
namespace fs = std::filesystem;

std::string hash_hex(std::uint64_t h) { return fmt::format("{:016x}", h); }

World make_world(const SceneDef& scene, const RunOptions& options) {
  WorldDef wd = scene.world;
  if (options.threads) wd.threads = *options.threads;
  if (options.precision) wd.precision = *options.precision;
  if (options.schedule) wd.schedule = *options.schedule;
  // What World refuses names the body, probe or tool and its field; from a scene file, the error
  // also says which file and which entry of it (bodies[0], probes[1], ...), as the reader's do.
  const auto in_scene = [&](const std::string& entry, const auto& build) {
    try {
      build();
    } catch (const InputError& e) {
      if (scene.source.empty()) throw;
      throw InputError(fmt::format("{}: {}: {}", scene.source.string(), entry, e.what()));
    }
  };
  std::optional<World> world;
  in_scene("the world", [&] { world.emplace(wd); });
  for (std::size_t i = 0; i < scene.bodies.size(); ++i)
    in_scene(fmt::format("bodies[{}]", i), [&] { world->add_body(scene.bodies[i]); });
  for (std::size_t i = 0; i < scene.probes.size(); ++i)
    in_scene(fmt::format("probes[{}]", i), [&] { world->add_probe(scene.probes[i]); });
  for (std::size_t i = 0; i < scene.tools.size(); ++i)
    in_scene(fmt::format("tools[{}]", i), [&] { world->add_tool(scene.tools[i]); });
  return std::move(*world);
}

namespace {

// A CSV file of the run written row by row (probes.csv, tools.csv, levels.csv): opened with its
// header when enabled, closed at the end; a disabled one ignores its rows.
class CsvFile {
 public:
  CsvFile(const fs::path& path, bool enabled, const char* header) {
    if (!enabled) return;
    file_ = std::fopen(path.string().c_str(), "w");
    if (!file_) throw InputError(fmt::format("{}: cannot write", path.string()));
    std::fputs(header, file_);
    std::fputc('\n', file_);
  }
  ~CsvFile() {
    if (file_) std::fclose(file_);
  }
  CsvFile(const CsvFile&) = delete;
  CsvFile& operator=(const CsvFile&) = delete;
  std::FILE* get() const { return file_; }

 private:
  std::FILE* file_ = nullptr;
};

// probes.csv: each probe's position (m, world frame).
void write_probes(const CsvFile& csv, const World& w) {
  if (!csv.get()) return;
  for (std::size_t p = 0; p < w.probe_count(); ++p) {
    const Vec3d x = w.probe_position(int(p));
    fmt::print(csv.get(), "{:.9g},{},{:.12g},{:.12g},{:.12g}\n", w.time(), w.probe_name(int(p)), x[0], x[1], x[2]);
  }
}
constexpr const char* kProbeHeader = "time,probe,x,y,z";

// tools.csv: per tool, its pose, the force the bodies exert on it (N, world frame) and its contacts.
void write_tools(const CsvFile& csv, const World& w) {
  if (!csv.get()) return;
  for (std::size_t t = 0; t < w.tool_count(); ++t) {
    const ToolPose p = w.tool_pose(ToolId(t));
    const ToolReading r = w.tool_reading(ToolId(t));
    fmt::print(csv.get(), "{:.9g},{},{:.12g},{:.12g},{:.12g},{:.9g},{:.9g},{:.9g},{},{:.6g}\n", w.time(),
               w.tool_def(ToolId(t)).name, p.position[0], p.position[1], p.position[2], r.force[0], r.force[1], r.force[2],
               r.contacts, r.max_penetration);
  }
}
constexpr const char* kToolHeader = "time,tool,x,y,z,fx,fy,fz,contacts,max_penetration";

// levels.csv (runs with adaptive bodies): every level's stepped tets, active and ghost nodes.
void write_levels(const CsvFile& csv, const World& w) {
  if (!csv.get()) return;
  for (std::size_t b = 0; b < w.body_count(); ++b)
    for (int l = 0; l < w.level_count(BodyId(b)) && w.level_count(BodyId(b)) > 1; ++l) {
      const LevelInfo i = w.level_info(BodyId(b), l);
      fmt::print(csv.get(), "{:.9g},{},{},{},{},{}\n", w.time(), w.body_def(BodyId(b)).name, l, i.stepped_tets,
                 i.active_nodes, i.ghost_nodes);
    }
}
constexpr const char* kLevelHeader = "time,body,level,stepped_tets,active_nodes,ghost_nodes";

class VtuSeries {
 public:
  VtuSeries(const fs::path& dir, bool enabled) : dir_(dir), pvd_(dir / "series.pvd"), enabled_(enabled) {
    if (enabled_) fs::create_directories(dir_ / "vtu");
  }
  void write(const World& w, std::vector<std::string>& files) {
    if (!enabled_) return;
    int part = 0;
    for (std::size_t b = 0; b < w.body_count(); ++b) {
      // A multiresolution body: one file per level, its stepped part, so that the split shows.
      const int levels = w.level_count(BodyId(b));
      for (int l = 0; l < levels; ++l) {
        const World::Snapshot s = w.snapshot(BodyId(b), l);
        const std::string& body = w.body_def(BodyId(b)).name;
        const std::string name = levels == 1 ? fmt::format("vtu/{}_{:05d}.vtu", body, frame_)
                                             : fmt::format("vtu/{}_L{}_{:05d}.vtu", body, l, frame_);
        std::vector<VtuField> fields;
        fields.push_back({"displacement", 3, false, s.displacement});
        fields.push_back({"von_mises", 1, true, s.von_mises});
        fields.push_back({"stress", 9, true, s.stress});
        if (levels > 1) fields.push_back({"level", 1, true, std::vector<double>(s.tets.size(), double(l))});
        write_vtu(dir_ / name, s.points, s.tets, fields, VtuEncoding::base64_zlib);
        pvd_.add(w.time(), name, part++);
        files.push_back(name);
      }
    }
    pvd_.write();
    ++frame_;
  }
  bool enabled() const { return enabled_; }

 private:
  fs::path dir_;
  PvdSeries pvd_;
  bool enabled_;
  int frame_ = 0;
};

void write_node_map(const fs::path& path, const World& w) {
  std::FILE* f = std::fopen(path.string().c_str(), "w");
  if (!f) throw InputError(fmt::format("{}: cannot write", path.string()));
  std::fputs("body,file_node,node\n", f);
  for (std::size_t b = 0; b < w.body_count(); ++b) {
    const std::string& name = w.body_def(BodyId(b)).name;
    const auto& map = w.node_map(BodyId(b));
    for (std::size_t i = 0; i < map.size(); ++i) fmt::print(f, "{},{},{}\n", name, i, map[i]);
  }
  const bool ok = std::ferror(f) == 0;
  if (std::fclose(f) != 0 || !ok) throw InputError(fmt::format("{}: cannot write", path.string()));
}

// When the next record is due after one at time t (s): the first multiple of `every` (s, > 0)
// past t + eps, in closed form. Adding `every` until past t cost t / every additions, a hang for
// intervals far below the step (and forever once `every` is below the rounding unit of t).
double next_due(double every, double t, double eps) {
  const double k = std::floor((t + eps) / every) + 1;
  const double next = k * every;
  return next > t + eps ? next : (k + 1) * every;  // (k + 1): k * every rounded down onto t
}

void write_summary(const fs::path& path, const RunSummary& s) {
  nlohmann::ordered_json j;
  j["status"] = s.status;
  if (!s.message.empty()) j["message"] = s.message;
  j["steps"] = s.steps;
  j["substeps"] = s.substeps;
  j["max_substeps"] = s.max_substeps;
  j["adapted_steps"] = s.adapted_steps;
  j["max_stiffness_ratio"] = s.max_stiffness_ratio;
  j["simulated_time"] = s.simulated_time;
  j["wall_time_s"] = s.wall_time_s;
  j["steps_per_second"] = s.steps_per_second;
  j["nodes"] = s.nodes;
  j["tets"] = s.tets;
  j["model"] = s.model;
  j["precision"] = s.precision;
  j["threads"] = s.threads;
  j["dt"] = s.dt;
  j["stable_dt"] = s.stable_dt;
  j["max_displacement"] = s.max_displacement;
  j["kinetic_energy"] = s.kinetic_energy;
  j["elastic_energy"] = s.elastic_energy;
  j["potential_energy"] = s.potential_energy;
  j["state_hash"] = s.state_hash;
  j["schedule"] = s.schedule;
  nlohmann::ordered_json levels = nlohmann::ordered_json::array();
  for (const auto& l : s.levels)
    levels.push_back({{"body", l.body}, {"level", l.level}, {"nodes", l.nodes}, {"tets", l.tets},
                      {"active_tets_mean", l.active_tets_mean}, {"ghost_nodes_mean", l.ghost_nodes_mean},
                      {"period", l.period}, {"dt", l.dt}});
  j["levels"] = levels;
  j["tet_updates"] = s.tet_updates;
  j["tick_tet_updates_mean"] = s.tick_tet_updates_mean;
  j["tick_tet_updates_max"] = s.tick_tet_updates_max;
  j["tick_mean_us"] = s.tick_mean_us;
  j["tick_p50_us"] = s.tick_p50_us;
  j["tick_p99_us"] = s.tick_p99_us;
  j["tick_max_us"] = s.tick_max_us;
  j["realtime"] = s.realtime;
  j["realtime_factor"] = s.realtime_factor;
  if (s.realtime) {
    j["controller_coarsened"] = s.controller_coarsened;
    j["controller_refined"] = s.controller_refined;
    j["controller_max_scale"] = s.controller_max_scale;
    j["controller_final_scale"] = s.controller_final_scale;
    j["controller_min_cap"] = s.controller_min_cap;
    j["realtime_frame_s"] = s.realtime_frame_s;
    j["frames"] = s.frames;
    j["deadline_misses"] = s.deadline_misses;
    j["frame_mean_us"] = s.frame_mean_us;
    j["frame_p99_us"] = s.frame_p99_us;
    j["frame_max_us"] = s.frame_max_us;
    j["frames_over"] = s.frames_over;
    j["frames_early"] = s.frames_early;
    j["late_behind"] = s.late_behind;
    j["late_changing"] = s.late_changing;
    j["wake_late_max_s"] = s.wake_late_max_s;
    j["pages_touched"] = s.pages_touched;
    j["lag_mean_s"] = s.lag_mean_s;
    j["lag_max_s"] = s.lag_max_s;
  }
  if (!s.adapt.empty()) {
    nlohmann::ordered_json a = nlohmann::ordered_json::array();
    for (const auto& x : s.adapt)
      a.push_back({{"body", x.body}, {"splits", x.splits}, {"merges", x.merges}, {"changes", x.changes},
                   {"apply_us_per_change", x.apply_us_per_change}, {"checks", x.checks},
                   {"check_us_mean", x.check_us_mean}, {"check_us_max", x.check_us_max}, {"undone", x.undone}});
    j["adaptivity"] = a;
    std::int64_t splits = 0, merges = 0;
    for (const auto& x : s.adapt) {
      splits += x.splits;
      merges += x.merges;
    }
    j["splits"] = splits;
    j["merges"] = merges;
  }
  if (!s.tools.empty()) {
    nlohmann::ordered_json tools = nlohmann::ordered_json::array();
    for (const auto& t : s.tools)
      tools.push_back({{"name", t.name}, {"max_force", t.max_force}, {"max_penetration", t.max_penetration},
                       {"contact_steps", t.contact_steps}});
    j["tools"] = tools;
  }
  j["files"] = s.files;
  if (!s.notes.empty()) j["notes"] = s.notes;
  std::ofstream out(path);
  if (!out) throw InputError(fmt::format("{}: cannot write", path.string()));
  out << j.dump(2) << "\n";
}

}  // namespace

// Whole steps up to the duration, at most 2^53: beyond that the simulated time (a double,
// advanced by dt each step) no longer advances by whole steps. A count beyond int64 (1e30 s)
// used to overflow and run 0 steps reporting "ok".
std::int64_t steps_for(double duration, double dt) {
  const double step_count = std::max(1.0, std::ceil(duration / dt - 1e-9));
  constexpr double kMaxSteps = 9007199254740992.0;  // 2^53
  if (!(step_count <= kMaxSteps))
    throw InputError(fmt::format(
        "duration {:g} s needs {:.3g} steps of {:.4g} s; at most 2^53 = {:.4g} steps can be run (the simulated time, "
        "a double, stops advancing by whole steps beyond that): give a shorter duration, or check what sets the "
        "step (time_step.dt or courant, the materials' stiffness and density, the smallest tet)",
        duration, step_count, dt, kMaxSteps));
  return std::int64_t(step_count);
}

RunSummary run_scene(const SceneDef& scene, const RunOptions& options) {
  const double duration = options.duration.value_or(scene.duration);
  if (!(duration > 0 && std::isfinite(duration)))
    throw InputError(fmt::format("duration must be a finite number > 0 (s), got {}", duration));
  World world = make_world(scene, options);
  return run_world(scene, world, options);
}

RunSummary run_world(const SceneDef& scene, World& world, const RunOptions& options) {
  const double duration = options.duration.value_or(scene.duration);
  if (!(duration > 0 && std::isfinite(duration)))
    throw InputError(fmt::format("duration must be a finite number > 0 (s), got {}", duration));
  if (options.write_files) fs::create_directories(options.out_dir);

  RunSummary s;
  s.precision = to_string(world.precision());
  s.threads = world.threads();
  const int asked = options.threads.value_or(scene.world.threads);
  if (asked > world.threads())
    s.notes.push_back(fmt::format("threads: {} threads asked, {} used (the cores this process may use)", asked,
                                  world.threads()));
  s.dt = world.dt();
  s.stable_dt = world.stable_dt();
  s.substeps = world.substeps();
  s.schedule = to_string(world.schedule());
  for (std::size_t b = 0; b < world.body_count(); ++b) {
    const int finest = world.level_count(BodyId(b)) - 1;  // the body's mesh as given
    s.nodes += world.node_count(BodyId(b), finest);
    s.tets += world.tet_count(BodyId(b), finest);
    const MeshLoadReport& r = world.mesh_load_report(BodyId(b));
    if (r.skipped_cells || r.reoriented_tets || r.dropped_vertices)
      s.notes.push_back(fmt::format("body '{}': mesh loaded with {} non-tetrahedral cell(s) skipped, {} inverted tet(s) "
                                    "re-oriented, {} unused vertex(es) dropped",
                                    world.body_def(BodyId(b)).name, r.skipped_cells, r.reoriented_tets,
                                    r.dropped_vertices));
    const std::string m = to_string(world.body_def(BodyId(b)).model);
    if (s.model.find(m) == std::string::npos) s.model += (s.model.empty() ? "" : ",") + m;
  }
  const std::int64_t total_steps = steps_for(duration, world.dt());
  // A duration below one step ran 0 steps and said ok (1e-300 s), or one step far beyond it
  // without a word (1e-5 s at a step of 5e-4 s): at least one step, and said.
  if (duration < world.dt())
    s.notes.push_back(fmt::format("duration {:g} s is shorter than one step ({:g} s): one step is run", duration,
                                  world.dt()));

  // The file's node numbers -> the engine's (the .vtu files use the engine's), for file meshes.
  bool any_map = false;
  for (std::size_t b = 0; b < world.body_count(); ++b) any_map |= !world.node_map(BodyId(b)).empty();
  if (options.write_files && any_map) {
    write_node_map(options.out_dir / "node_map.csv", world);
    s.files.push_back("node_map.csv");
  }

  CsvFile probes(options.out_dir / "probes.csv", options.write_files && world.probe_count() > 0, kProbeHeader);
  if (options.write_files && world.probe_count() > 0) s.files.push_back("probes.csv");
  bool adaptive = false;
  for (std::size_t b = 0; b < world.body_count(); ++b)
    adaptive |= world.body_def(BodyId(b)).multiresolution.levels > 1 &&
                world.body_def(BodyId(b)).multiresolution.active.kind == ActiveDef::Kind::adaptive;
  CsvFile level_rows(options.out_dir / "levels.csv", options.write_files && adaptive, kLevelHeader);
  if (options.write_files && adaptive) s.files.push_back("levels.csv");
  write_levels(level_rows, world);
  const bool tools_csv = options.write_files && world.tool_count() > 0;
  CsvFile tools(options.out_dir / "tools.csv", tools_csv, kToolHeader);
  if (tools_csv) s.files.push_back("tools.csv");
  for (std::size_t t = 0; t < world.tool_count(); ++t) s.tools.push_back({world.tool_def(ToolId(t)).name});
  VtuSeries vtu(options.out_dir, options.write_files && scene.output.vtu_every > 0);
  write_probes(probes, world);
  write_tools(tools, world);
  vtu.write(world, s.files);
  const bool frames = options.on_frame && options.frame_every > 0;
  if (frames) options.on_frame(world);
  double next_probe = scene.output.probe_every, next_vtu = scene.output.vtu_every, next_frame = options.frame_every;
  const double eps = 1e-9 * world.dt();

  detail::StepClock clock;
  clock.start();
  // Real time: the wall clock since stepping began, and the pacing of the steps on it.
  const bool realtime = options.realtime.value_or(scene.realtime);
  s.realtime = realtime;
  const auto steady_start = std::chrono::steady_clock::now();
  auto wall_now = [&]() -> double {
    if (options.wall_clock) return options.wall_clock();
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - steady_start).count();
  };
  // Sleeps until kSpinBefore before t, then polls the clock: a sleep alone wakes 50-100 us late
  // (the kernel's timer slack and wake-up), a tenth of a 1 ms frame; the poll costs at most
  // kSpinBefore of a core per frame.
  constexpr double kSpinBefore = 150e-6;  // s
  auto wait_until = [&](double t) {
    if (options.sleep_until) return options.sleep_until(t);
    auto at = [&](double s) {
      return steady_start + std::chrono::duration_cast<std::chrono::steady_clock::duration>(std::chrono::duration<double>(s));
    };
    if (t - kSpinBefore > wall_now()) std::this_thread::sleep_until(at(t - kSpinBefore));
    const auto due = at(t);
    while (std::chrono::steady_clock::now() < due) {
    }
  };
  const double wall0 = realtime ? wall_now() : 0.0, sim0 = world.time();
  double lag_sum = 0;
  // Frames (SceneDef::realtime_frame; 0: every step is one): a frame waits at its start for the
  // wall clock to reach its simulated time, runs its steps back to back, and misses its deadline if
  // its last step ends after the wall-clock time of the frame's end. A frame ends with the first
  // step that reaches its end time (to within eps). Its busy time (waits left out) goes into
  // frame_stats, for the frame percentiles.
  double frame = options.realtime_frame.value_or(scene.realtime_frame);
  if (!(frame >= 0 && std::isfinite(frame)))
    throw InputError(fmt::format("realtime_frame must be a number of seconds >= 0, got {}", frame));
  // A frame shorter than a step holds one step, as frames of 0 do, but its deadline fell before
  // the step's end, and the search for the next frame's end added up frames one at a time: 1e-15 s
  // never got past the first step's end (a hang). Such frames are every step's own.
  if (realtime && frame > 0 && frame < world.dt()) {
    s.notes.push_back(fmt::format("realtime_frame {:g} s is shorter than a step ({:g} s): every step is its own frame",
                                  frame, world.dt()));
    frame = 0;
  }
  s.realtime_frame_s = realtime ? frame : 0.0;
  bool frame_open = false;
  double frame_end = sim0, frame_busy = 0;
  double frame_change_busy = 0;  // s of frame_busy spent in steps that changed an adaptive body's resolution
  double frame_start_late = 0;  // s: how long after the wall-clock time of its start the frame started (>= 0)
  double frame_room = 0;         // s of wall time from the frame's start to its deadline (more than a frame if it started early)
  TickStats frame_stats;
  detail::ThreadPriority priority;  // restored when the run ends
  if (realtime && options.realtime_priority) {
    std::string why;
    if (priority.raise(why)) {
      s.notes.push_back("real-time priority: stepping on a SCHED_FIFO thread");
    } else {
      s.notes.push_back("real-time priority not granted, stepping at normal priority: " + why);
      if (options.on_warning) options.on_warning(s.notes.back());
    }
  }
  // The real-time controller (adaptive bodies only): over windows of kControlWindow simulated
  // seconds, the wall time spent stepping (waits left out) against the window. It moves the adaptive
  // bodies along a ladder of settings, coarse to fine: rung 0 = every body capped at its level 0
  // (World::set_adapt_cap); then for each cap c = 1, 2, ... the thresholds x kMaxScale
  // (World::set_adapt_scale), coming down by kFactor per rung to x kCapScale (below the finest cap)
  // or to the scene's own (x1, at the finest cap). The rungs of high thresholds at a cap keep a
  // level's region to what refines by distance (around a tool) and to the strongest jumps: a body
  // whose region at x4 grows past the frame (the 50k-tet organ sagging under a sliding tool: 900
  // middle-level tets, 1.2 ms frames, at 2.7 s) keeps its middle level at x8 or x16 rather than
  // dropping to its coarsest. It decides where resolution goes, never what a step computes.
  //  - It starts at rung 0: a guaranteed rate cannot begin by overrunning (the 50k-tet organ, all
  //    fine, took 2 s of wall time for its first 0.1 s before the controller had caught up).
  //  - A window is busy if it used more than kBusy of its time, or if a frame in it was heavy
  //    (below): the controller steps one rung down. After a step down, the frames that still carry
  //    the rung above (settling, below) step down too, but are not held against the rungs they pass.
  //  - A window below kIdle of its time and on time steps one rung up, unless that rung was already
  //    found busy: then only if the load it measured there, scaled by how the load here changed
  //    since, would now stay below kBusy (without this memory, a rung that costs 0.9 of the clock was
  //    retried every other window, missing frames each time), or once kRetryBackoff has passed since
  //    it was found busy, twice as long each time, if its frame then fit its time (its own stepping,
  //    changes of resolution left out). (Remembered for good, the rungs the 50k-tet organ passed on
  //    its way down, each found busy while it still carried the region of the rung above at 0.85 of
  //    the clock, were never tried again: 59.5 s of a 60 s run at its coarsest level, 2026-11-28.
  //    A rung whose own stepping overran its frame, the organ's finest level at 1.4-1.8 ms, stays
  //    remembered: each try of it cost 4 late frames.)
  //  - Each decision may split at most kSplitsPerDecision nodes (World::set_adapt_split_budget): a
  //    region refines over successive decisions, so that the load rises by steps the controller
  //    sees, and no frame absorbs a whole region's split (one split applies in ~0.2 ms on the
  //    50k-tet organ; lifting its cap from level 0 to 1 split ~40 nodes at once, a 2-4 ms frame).
  //  - And a body changes its resolution at most once a frame (World::set_adapt_change_interval):
  //    its decision points come every coarsest window (0.22 ms on the 50k-tet organ), and a region
  //    growing at each of them after a lift put three changes of 0.45-0.9 ms in one frame
  //    (frames of 1.5-2.3 ms, 2026-11-28).
  constexpr double kControlWindow = 0.02, kBusy = 0.8, kIdle = 0.4, kFactor = 2, kMaxScale = 16, kCapScale = 4;
  constexpr int kSplitsPerDecision = 2;
  std::vector<BodyId> adaptive_bodies;
  for (std::size_t b = 0; b < world.body_count(); ++b)
    if (world.body_def(BodyId(b)).multiresolution.levels > 1 &&
        world.body_def(BodyId(b)).multiresolution.active.kind == ActiveDef::Kind::adaptive)
      adaptive_bodies.push_back(BodyId(b));
  auto adapt_changes = [&] {  // changes of resolution so far, over the adaptive bodies
    std::int64_t n = 0;
    for (BodyId b : adaptive_bodies) n += world.adapt_stats(b).changes;
    return n;
  };
  double window_sim0 = world.time(), window_busy = 0;
  std::int64_t window_misses = 0;
  int finest = 0;
  for (BodyId b : adaptive_bodies) finest = std::max(finest, world.level_count(b) - 1);
  struct Rung {
    int cap;
    double scale;
  };
  std::vector<Rung> ladder{{0, kMaxScale}};
  for (int c = 1; c <= finest; ++c)
    for (double x = kMaxScale; x >= (c < finest ? kCapScale : 1.0); x /= kFactor) ladder.push_back({c, x});
  const int top_rung = int(ladder.size()) - 1;
  auto cap_of = [&](int r) { return ladder[std::size_t(r)].cap; };
  auto scale_of = [&](int r) { return ladder[std::size_t(r)].scale; };
  int rung = adaptive_bodies.empty() ? top_rung : 0;
  double scale = scale_of(rung);
  int cap = cap_of(rung);
  std::vector<double> busy_load(std::size_t(top_rung) + 1, 0.0);  // per rung: the load of the window that found it busy
  std::vector<double> entry_load(std::size_t(top_rung) + 1, 0.0); // per rung: the load below it when it was entered
  // Per rung left for a heavy frame that says nothing of its load (a change of resolution that
  // overran it, or a spike: below): when it may be tried again, and the wait after the next such
  // loss (s of simulated time; kRetryBackoff first, doubling).
  constexpr double kRetryBackoff = 2.0;
  std::vector<double> retry_at(std::size_t(top_rung) + 1, 0.0);
  std::vector<double> retry_backoff(std::size_t(top_rung) + 1, kRetryBackoff);
  std::vector<std::uint8_t> overran(std::size_t(top_rung) + 1, 0);  // per rung: found busy by a frame its own stepping overran
  // A spike: a heavy frame after at least a window at its rung whose load stayed below kSpikeBelow
  // (the host took the core, or a one-off). Remembered busy at that frame's load, the 50k-tet
  // organ's middle level (frames of 0.3-0.45 ms) was never tried again after one frame of 1.05 ms
  // without a change, 52 ms into a 60 s run (2026-11-28).
  constexpr double kSpikeBelow = 0.6;
  double rung_since = world.time(), rung_busy = 0;  // since the rung was entered: s simulated, s stepping
  auto apply_rung = [&] {
    scale = scale_of(rung);
    cap = cap_of(rung);
    for (BodyId b : adaptive_bodies) {
      world.set_adapt_scale(b, scale);
      world.set_adapt_cap(b, std::min(cap, world.level_count(b) - 1));
    }
    s.controller_max_scale = std::max(s.controller_max_scale, scale);
    if (cap < finest) s.controller_min_cap = s.controller_min_cap < 0 ? cap : std::min(s.controller_min_cap, cap);
  };
  if (realtime && !adaptive_bodies.empty()) {
    for (BodyId b : adaptive_bodies) {
      world.set_adapt_split_budget(b, kSplitsPerDecision);
      if (frame > 0) world.set_adapt_change_interval(b, frame);
    }
    apply_rung();
  }
  // After a step down, the frames until the bodies have left the rung above (its region merged at
  // the next decision point, the deformation monitor back to its sub-steps) carry that rung's
  // cost, not the new one's: the 50k-tet organ's try of its finest level made the monitor sub-step
  // 19 times (frames of 5-7 ms) and the merges at the lowered cap took 0.9-1.1 ms; each such frame
  // took it one rung further down, and each of those rungs was remembered busy at 5-7 times the
  // clock, never to be tried again (2026-11-28). Heavy frames still step down while settling (the
  // clock comes first: a body that stays costly, its monitor still sub-stepping, must go lower),
  // but the rungs they pass are not remembered busy, nor does the controller refine meanwhile.
  bool settling = false, frame_settles = false;
  double settle_until = 0;
  int settle_substeps = 1;
  std::vector<std::int64_t> settle_checks(adaptive_bodies.size(), 0);  // per adaptive body: its decision points at the step down
  std::vector<int> rung_substeps(std::size_t(top_rung) + 1, 1);        // per rung: the monitor's sub-steps when it was left upwards
  bool estimated = false, coarsest_warned = false;
  double next_progress = options.progress_every;
  try {
    for (std::int64_t i = 0; i < total_steps; ++i) {
      if (realtime && !frame_open) {
        // The frame's end (simulated), and whether an adaptive body may take a decision in it.
        double next_end = frame_end;
        if (frame > 0)
          while (next_end <= world.time() + eps) next_end += frame;
        bool decides = false;
        if (frame > 0)
          for (BodyId b : adaptive_bodies) decides |= world.adapt_next_decision(b) <= next_end + eps;
        // A frame that may change a body's resolution starts up to a frame early, as soon as the
        // frame before has ended: its change (0.4-0.9 ms on the 50k-tet organ) then has that frame's
        // slack as well as its own. On time it ended 0.4-0.5 ms of stepping plus the change later
        // than its end, the last frame of most tries of the organ's middle level (2026-11-28).
        // Simulated time stays at most two frames ahead of the clock (one otherwise).
        const double due = wall0 + (world.time() - sim0) - (decides ? frame : 0.0);  // the wall-clock time of this frame's start
        const double before = wall_now();
        if (before < due) {
          // The wait first reads a few pages of the bodies' arrays (World::touch_pages), batch by
          // batch while more than kTouchStop is left: on a guest whose host reclaims memory left
          // untouched for seconds, an idle level's arrays were 100-400 us per 36 KB slower to read
          // again, paid by the frame that starts using them (docs/adaptivity.md). kTouchPerFrame
          // pages a frame go round a 50k-tet body's 10 MB in about 40 frames; a page read when
          // warm costs about a cache miss, so that is a few us of the wait.
          constexpr std::size_t kTouchPerFrame = 64, kTouchBatch = 8;
          constexpr double kTouchStop = 300e-6;  // s before the frame's start: a cold page can take ~100 us
          for (std::size_t done = 0; done < kTouchPerFrame && due - wall_now() > kTouchStop;) {
            const std::size_t n = world.touch_pages(kTouchBatch);
            if (n == 0) break;
            done += n;
            s.pages_touched += std::int64_t(n);
          }
          wait_until(due);
          const double woke = wall_now();
          clock.idle(woke - before);
          s.wake_late_max_s = std::max(s.wake_late_max_s, woke - due);
        }
        frame_open = true;
        frame_busy = 0;
        frame_change_busy = 0;
        frame_start_late = std::max(0.0, wall_now() - (wall0 + (world.time() - sim0)));
        frame_room = std::max(frame, wall0 + (next_end - sim0) - wall_now());
        if (frame > 0 && frame_room > frame) ++s.frames_early;
        // Whether this frame still carries the rung the controller has just left (settling): until
        // every adaptive body has passed a decision point since (where it merges what the new rung
        // does not keep: the levels above a lowered cap at once, the rest by the raised
        // thresholds), no level above the cap steps a tet, and the deformation monitor sub-steps
        // no more than it did at this rung before; kControlWindow at most.
        if (settling) {
          bool settled = world.time() >= settle_until;
          if (!settled) {
            settled = world.substeps() <= settle_substeps;
            for (std::size_t k = 0; k < adaptive_bodies.size() && settled; ++k) {
              const BodyId b = adaptive_bodies[k];
              settled = world.adapt_stats(b).checks > settle_checks[k];
              for (int l = std::min(cap, world.level_count(b) - 1) + 1; l < world.level_count(b) && settled; ++l)
                settled = world.level_info(b, l).stepped_tets == 0;
            }
          }
          settling = !settled;
        }
        frame_settles = settling;
        frame_end = next_end;
      }
      const std::int64_t changes_before = realtime ? adapt_changes() : 0;
      const double step_start = realtime ? wall_now() : 0.0;
      world.step();
      const double step_end = realtime ? wall_now() : 0.0;
      if (realtime) {
        frame_busy += step_end - step_start;
        if (adapt_changes() != changes_before) frame_change_busy += step_end - step_start;
      }
      bool frame_heavy = false;  // a frame that used more than kBusy of its time (frames > 0 only)
      if (realtime && (frame <= 0 || world.time() + eps >= frame_end)) {  // the frame's last step
        frame_open = false;
        // Heavy: its stepping without the steps that changed the resolution used more than kBusy
        // of its time, or the whole frame more than its room (its time; more when it started
        // early, and then it is late only past that). A change is a one-off cost (a few
        // hundred us on the 50k-tet organ), and while a region refines every other frame has one:
        // counted in full, a frame at 0.5 of its time plus a change passed the mark and sent the
        // body back to its coarsest level. The window's mean load below counts the changes.
        frame_heavy = frame > 0 && (frame_busy - frame_change_busy > kBusy * frame || frame_busy > frame_room);
        if (frame_busy > (frame > 0 ? frame : world.dt())) ++s.frames_over;
        ++s.frames;
        frame_stats.add(frame_busy, 0);
        const double lag = (step_end - wall0) - (world.time() - sim0);  // > 0: ended after its wall-clock time
        if (lag > 0) {
          ++s.deadline_misses;
          if (lag <= frame_start_late) {  // on time, had it started on time
            ++s.late_behind;
          } else if (frame_change_busy > 0) {
            ++s.late_changing;
          }
          ++window_misses;
          lag_sum += lag;
          s.lag_max_s = std::max(s.lag_max_s, lag);
        }
      }
      if (realtime && !adaptive_bodies.empty()) {
        window_busy += step_end - step_start;
        rung_busy += step_end - step_start;
        const double window = world.time() - window_sim0;
        // A heavy frame ends the window at once (its rung has less room than the window's mean
        // shows: coarsen now rather than miss the frames left in the window).
        // What coarsening can help: a frame heavy by its own stepping. A frame late without being
        // heavy started late, behind the heavy frame before it (already acted on: counting it too
        // took a second rung down, the 50k organ's middle level abandoned because its finest
        // level had overrun) or behind a wait that woke up late, which no rung changes. With
        // frames of one step (realtime_frame 0) a miss is the only signal. A window behind the
        // clock is busy in any case (below).
        const bool overrun = frame_heavy || (frame <= 0 && window_misses > 0);
        if (window >= kControlWindow || (overrun && rung > 0)) {
          const double load = window_busy / window;
          // Behind the clock: no refining (late, it would never catch up), but no coarsening either
          // while the load lets it catch up (below kBusy, frames run back to back and gain on the
          // clock): after a try of its finest level had put it 39 ms behind, the 50k-tet organ
          // stepped down its middle rungs one window after another at loads of 0.35 (2026-11-28).
          const double behind = (wall_now() - wall0) - (world.time() - sim0);
          const int was = rung;
          if (load > kBusy || overrun) {
            if (rung > 0) {
              // The load the rung was found at: the heavy frame's own when a heavy frame ended the
              // window (the window's mean averages it with the light frames before it, and a rung
              // remembered at 0.8 of the clock was retried as soon as the load below it fell a
              // little: on the 50k organ, whose tries of the middle level began with frames of
              // 1.3-1.5 ms, the cheaper coarsest level brought 5 tries in 60 s instead of 3).
              // Not while settling: those frames carry the rung above, found busy already.
              // A frame heavy only by its change of resolution (its own stepping within kBusy, the
              // change taking it past its time) says nothing of the rung's load: the rung is tried
              // again after kRetryBackoff, then twice as long each time (the 50k-tet organ's middle level lost at
              // its first change of 0.7 ms was otherwise never tried again, its frames at 0.4 of
              // the clock; 2026-11-28). So does a spike (kSpikeBelow).
              const bool by_change = frame_heavy && frame_busy - frame_change_busy <= kBusy * frame;
              const double held = world.time() - rung_since - frame;  // s at this rung before the frame
              const bool spike = frame_heavy && held >= kControlWindow - eps && (rung_busy - frame_busy) / held < kSpikeBelow;
              if (!frame_settles && (by_change || spike)) {
                retry_at[std::size_t(rung)] = world.time() + retry_backoff[std::size_t(rung)];
                retry_backoff[std::size_t(rung)] *= 2;
              } else if (!frame_settles) {
                busy_load[std::size_t(rung)] = std::max({load, kBusy, frame_heavy ? frame_busy / frame : 0.0});
                retry_at[std::size_t(rung)] = world.time() + retry_backoff[std::size_t(rung)];
                retry_backoff[std::size_t(rung)] *= 2;
                overran[std::size_t(rung)] = frame_heavy ? frame_busy - frame_change_busy > frame : load > 1;
              }
              --rung;
            } else if (load > 1 && !coarsest_warned) {
              // Nothing left to coarsen: the scene cannot keep the clock even at its coarsest.
              coarsest_warned = true;
              const std::string w = fmt::format(
                  "real time cannot be kept even at the coarsest level: with every adaptive body on its level 0 and its "
                  "thresholds x{:.0f}, a simulated second costs {:.3g} s of wall time on {} thread(s) ({:.0f} steps of {:.3g} s, "
                  "{:.3g} us each); simulated time falls behind the clock from t = {:.3g} s",
                  kMaxScale, load, world.threads(), window / world.dt(), world.dt(), 1e6 * window_busy / (window / world.dt()),
                  world.time());
              s.notes.push_back(w);
              if (options.on_warning) options.on_warning(w);
            }
          } else if (load < kIdle && behind <= 0 && rung < top_rung && !frame_settles) {
            const auto up = std::size_t(rung) + 1;
            // Before its retry time, a rung found busy is entered again only if its load scaled
            // fits; after it, any rung is (its memory may be of a region it no longer has), unless
            // its own stepping overran a frame.
            const bool fits = busy_load[up] > 0 && busy_load[up] * load / entry_load[up] < kBusy;
            if ((world.time() >= retry_at[up] && !overran[up]) || fits) {
              entry_load[up] = std::max(load, 1e-9);
              ++rung;
            }
          }
          if (rung != was) {
            if (rung > was) {
              rung_substeps[std::size_t(was)] = world.substeps();
            } else if (!frame_settles) {  // (a step down while settling keeps the first one's clock)
              settling = true;
              settle_until = world.time() + kControlWindow;
              settle_substeps = rung_substeps[std::size_t(rung)];
              for (std::size_t k = 0; k < adaptive_bodies.size(); ++k) settle_checks[k] = world.adapt_stats(adaptive_bodies[k]).checks;
            }
            (rung < was ? s.controller_coarsened : s.controller_refined)++;
            apply_rung();
            rung_since = world.time();
            rung_busy = 0;
          }
          window_sim0 = world.time();
          window_busy = 0;
          window_misses = 0;
        }
      }
      clock.stepped(world.substeps());
      for (std::size_t t = 0; t < s.tools.size(); ++t) {
        const ToolReading r = world.tool_reading(ToolId(t));
        RunSummary::Tool& st = s.tools[t];
        st.max_force = std::max(st.max_force, std::sqrt(r.force[0] * r.force[0] + r.force[1] * r.force[1] + r.force[2] * r.force[2]));
        st.max_penetration = std::max(st.max_penetration, r.max_penetration);
        st.contact_steps += r.contacts > 0;
      }
      if (world.time() + eps >= next_probe) {  // probe_every = 0: every step
        write_probes(probes, world);
        write_tools(tools, world);
        write_levels(level_rows, world);
        if (scene.output.probe_every > 0) next_probe = next_due(scene.output.probe_every, world.time(), eps);
      }
      if (vtu.enabled() && world.time() + eps >= next_vtu) {
        vtu.write(world, s.files);
        next_vtu = next_due(scene.output.vtu_every, world.time(), eps);
      }
      if (frames && world.time() + eps >= next_frame) {
        options.on_frame(world);
        next_frame = next_due(options.frame_every, world.time(), eps);
      }
      if (options.on_progress && i + 1 < total_steps) {
        const double wall = clock.wall();
        if (!estimated && i >= 1 && wall >= options.estimate_after) {
          estimated = true;
          RunProgress p = clock.progress(total_steps, world.substeps(), world.time(), duration);
          p.estimate = true;
          options.on_progress(p);
          next_progress = wall + options.progress_every;
        } else if (estimated && options.progress_every > 0 && wall >= next_progress) {
          options.on_progress(clock.progress(total_steps, world.substeps(), world.time(), duration));
          next_progress = wall + options.progress_every;
        }
      }
    }
  } catch (const DivergenceError& e) {
    s.status = "diverged";
    s.message = e.what();
  }
  s.wall_time_s = realtime && options.wall_clock ? wall_now() - wall0 : clock.wall();
  s.realtime_factor = s.wall_time_s > 0 ? (world.time() - sim0) / s.wall_time_s : 0;
  if (realtime && frame_open) {  // a last frame cut short by the end of the run
    ++s.frames;
    frame_stats.add(frame_busy, 0);
    const double lag = (wall_now() - wall0) - (world.time() - sim0);
    if (lag > 0) {
      ++s.deadline_misses;
      lag_sum += lag;
      s.lag_max_s = std::max(s.lag_max_s, lag);
    }
  }
  if (realtime && s.frames > 0) {
    s.lag_mean_s = lag_sum / double(s.frames);
    s.frame_mean_us = 1e6 * frame_stats.mean_s();
    s.frame_p99_us = 1e6 * frame_stats.quantile_s(0.99);
    s.frame_max_us = 1e6 * frame_stats.max_s();
  }
  s.controller_final_scale = scale;  // over every step (0 for steps on time)
  s.steps = world.steps();
  s.max_substeps = world.max_substeps();
  s.adapted_steps = world.adapted_steps();
  s.max_stiffness_ratio = world.max_stiffness_ratio();
  s.simulated_time = world.time();
  s.steps_per_second = s.wall_time_s > 0 ? double(s.steps) / s.wall_time_s : 0;
  s.state_hash = hash_hex(world.state_hash());
  for (std::size_t b = 0; b < world.body_count(); ++b)
    for (int l = 0; l < world.level_count(BodyId(b)); ++l) {
      const LevelInfo i = world.level_info(BodyId(b), l);
      // A static split: the stepped set does not change during the run, so its mean is its size.
      s.levels.push_back({world.body_def(BodyId(b)).name, l, i.period, i.nodes, i.tets, double(i.stepped_tets),
                          double(i.ghost_nodes), i.dt});
    }
  for (std::size_t b = 0; b < world.body_count(); ++b) {
    const World::AdaptStats a = world.adapt_stats(BodyId(b));
    if (a.checks == 0) continue;
    s.adapt.push_back({world.body_def(BodyId(b)).name, a.splits, a.merges, a.changes,
                       a.changes > 0 ? 1e6 * a.apply_seconds / double(a.changes) : 0.0, a.checks,
                       1e6 * a.check_seconds / double(a.checks), 1e6 * a.check_max_seconds, a.undone});
  }
  const TickStats& ts = world.tick_stats();
  s.tet_updates = ts.tet_updates();
  s.tick_tet_updates_mean = ts.tets_mean();
  s.tick_tet_updates_max = ts.tets_max();
  s.tick_mean_us = 1e6 * ts.mean_s();
  s.tick_p50_us = 1e6 * ts.quantile_s(0.5);
  s.tick_p99_us = 1e6 * ts.quantile_s(0.99);
  s.tick_max_us = 1e6 * ts.max_s();
  if (s.status == "ok") {
    const Energies e = world.energies();
    s.kinetic_energy = e.kinetic;
    s.elastic_energy = e.elastic;
    s.potential_energy = e.potential;
    s.max_displacement = world.max_displacement();
  }
  if (options.write_files) {
    s.files.push_back("summary.json");
    write_summary(options.out_dir / "summary.json", s);
  }
  if (s.status != "ok") throw DivergenceError(s.message);
  return s;
}

}  // namespace pliant
