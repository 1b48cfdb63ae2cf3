// `pliant run SCENE`: runs a scene file to its end and writes its results; with --png-every,
// --sheet or --mp4 (or "output": {"sheet": true} in the scene) also pictures of the run, taken
// by raster::FrameRecorder through the runner's read-only frame callback. Before stepping it
// prints the plan (run_plan.hpp: sizes, the step and why, steps, files, warnings about likely
// unit mistakes, then the wall-time estimate once the first steps are timed); --dry-run prints
// the plan with a warm-up estimate and stops. Progress: a line rewritten in place on a terminal,
// else a line every few seconds on stderr; --quiet silences both (not the warnings).
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fmt/format.h>
#include <optional>

#include "commands.hpp"
#include "pliant/raster/plot.hpp"
#include "pliant/raster/recorder.hpp"
#include "pliant/run.hpp"
#include "pliant/run_plan.hpp"
#include "pliant/scene.hpp"

namespace pliant::cli {
namespace {
namespace fs = std::filesystem;

struct PictureOptions {
  std::optional<double> png_every;
  bool sheet = false, mp4 = false;
  std::string field = "displacement", size = "1280x720", camera = "scene", up;
  std::optional<double> azimuth, elevation;  // degrees
};

// OUT/tools.png: the force each tool felt over the run (its z component and magnitude), read
// back from OUT/tools.csv (time,tool,x,y,z,fx,fy,fz,...).
bool plot_tool_forces(const fs::path& csv, const fs::path& png) {
  std::FILE* f = std::fopen(csv.string().c_str(), "r");
  if (!f) return false;
  std::vector<std::string> names;
  std::vector<std::vector<double>> t, fz, fmag;
  char line[1024];
  bool header = true;
  while (std::fgets(line, sizeof line, f)) {
    if (header) {
      header = false;
      continue;
    }
    double time = 0, x, y, z, fx = 0, fy = 0, fzv = 0;
    char name[256] = {0};
    if (std::sscanf(line, "%lf,%255[^,],%lf,%lf,%lf,%lf,%lf,%lf", &time, name, &x, &y, &z, &fx, &fy, &fzv) != 8) continue;
    auto it = std::find(names.begin(), names.end(), std::string(name));
    std::size_t i = std::size_t(it - names.begin());
    if (it == names.end()) {
      names.push_back(name);
      t.emplace_back();
      fz.emplace_back();
      fmag.emplace_back();
    }
    t[i].push_back(time);
    fz[i].push_back(fzv);
    fmag[i].push_back(std::sqrt(fx * fx + fy * fy + fzv * fzv));
  }
  std::fclose(f);
  if (names.empty()) return false;
  raster::Plot p;
  p.title = "force of the bodies on the tool";
  p.x = {"time", "s"};
  p.y = {"force", "N"};
  for (std::size_t i = 0; i < names.size(); ++i) {
    p.series.push_back({names[i] + " |f|", t[i], fmag[i]});
    p.series.push_back({names[i] + " f_z", t[i], fz[i]});
  }
  raster::write_plot_png(p, png);
  return true;
}

void report_pictures(const raster::RecorderResult& r, const fs::path& out, bool quiet) {
  if (quiet) return;
  for (const auto& f : r.files) fmt::print("picture: {}\n", (out / f).string());
  for (const auto& n : r.notes) fmt::print(stderr, "pliant: note: {}\n", n);
}

std::string eta_text(double s) {
  if (s < 10) return fmt::format("{:.1f} s", s);
  if (s < 120) return fmt::format("{:.0f} s", s);
  if (s < 7200) return fmt::format("{:.1f} min", s / 60);
  return fmt::format("{:.1f} h", s / 3600);
}

std::string progress_text(const RunProgress& p) {
  return fmt::format("{:5.1f}%  t = {:.4g} / {:.4g} s  step {} / {}{}  {:.0f} steps/s  ETA {}",
                     100.0 * double(p.step) / double(p.steps), p.time, p.duration, p.step, p.steps,
                     p.substeps > 1 ? fmt::format(" ({} sub-steps each)", p.substeps) : "",
                     double(p.step) / std::max(p.wall_s, 1e-9), eta_text(p.eta_s));
}

int command_run(const std::string& scene_path, const std::string& out, std::optional<int> threads,
                const std::string& precision, std::optional<double> duration, bool quiet, bool dry_run, bool repair,
                double progress_every, const PictureOptions& pic, const std::string& schedule, bool realtime,
                std::optional<double> realtime_frame, bool realtime_priority) {
  SceneDef scene = load_scene_file(scene_path);
  if (repair)
    for (BodyDef& b : scene.bodies) b.mesh.repair = true;
  RunOptions opt;
  opt.out_dir = out;
  opt.threads = threads;
  if (precision == "float") opt.precision = Precision::float32;
  else if (precision == "double") opt.precision = Precision::float64;
  else if (!precision.empty()) throw InputError(fmt::format("--precision must be float or double, got '{}'", precision));
  opt.duration = duration;
  if (realtime) opt.realtime = true;
  if (realtime_priority && !realtime && !scene.realtime)
    throw InputError("--realtime-priority needs a real-time run (--realtime or \"realtime\": true in the scene)");
  opt.realtime_priority = realtime_priority;
  if (realtime_frame && !realtime && !scene.realtime)
    throw InputError("--realtime-frame needs a real-time run (--realtime or \"realtime\": true in the scene)");
  if (realtime_frame) {
    if (!(*realtime_frame >= 0 && std::isfinite(*realtime_frame)))
      throw InputError(fmt::format("--realtime-frame must be a finite number >= 0 (s), got {}", *realtime_frame));
    opt.realtime_frame = *realtime_frame;
  }
  const bool paced = realtime || scene.realtime;
  if (schedule == "staggered") opt.schedule = Schedule::staggered;
  else if (schedule == "naive") opt.schedule = Schedule::naive;
  else if (!schedule.empty()) throw InputError(fmt::format("--schedule must be staggered or naive, got '{}'", schedule));
  if (!(progress_every > 0 && std::isfinite(progress_every)))
    throw InputError(fmt::format("--progress-every must be a finite number > 0 (s), got {}", progress_every));
  if (duration && !(*duration > 0 && std::isfinite(*duration)))
    throw InputError(fmt::format("--duration must be a finite number > 0 (s), got {}", *duration));
  // Before the world is built (a file named by --out failed after minutes of meshing, as a
  // filesystem error naming neither the option nor the problem).
  if (!dry_run) {
    std::error_code ec;
    if (std::filesystem::exists(out, ec) && !std::filesystem::is_directory(out, ec))
      throw InputError(fmt::format("--out {}: exists and is not a folder", out));
  }

  // Pictures: options are checked before the run starts.
  raster::RecorderOptions ro;
  ro.out_dir = out;
  if (pic.png_every) {
    if (!(*pic.png_every > 0)) throw InputError(fmt::format("--png-every must be > 0 (s), got {}", *pic.png_every));
    ro.png_every = *pic.png_every;
  }
  ro.sheet = pic.sheet || scene.output.sheet;
  ro.mp4 = pic.mp4;
  ro.field = raster::parse_field(pic.field, "--field");
  const auto size = raster::parse_size(pic.size, "--size");
  ro.width = size[0];
  ro.height = size[1];
  ro.camera = raster::parse_camera_preset(pic.camera, "--camera");
  if (!pic.up.empty()) ro.up = raster::parse_direction(pic.up, "--up");
  set_view(ro.azimuth_deg, ro.elevation_deg, pic.azimuth, pic.elevation);
  std::optional<raster::FrameRecorder> recorder;
  if (!dry_run && (ro.png_every > 0 || ro.sheet || ro.mp4)) {
    recorder.emplace(scene, ro, duration.value_or(scene.duration));
    if (recorder->active()) {
      opt.frame_every = recorder->frame_every();
      opt.on_frame = [&recorder](const World& w) { recorder->capture(w); };
    }
  }

  // The plan: what the scene says (warnings before any meshing), then the built world.
  if (!quiet) fmt::print("pliant: {} {}\n", dry_run ? "plan of" : "running", scene_path);
  std::fflush(stdout);
  const ScenePreview preview = preview_scene(scene);
  for (const PlanWarning& w : preview.warnings) fmt::print(stderr, "pliant: warning: {}\n", w.text);
  if (!quiet)
    for (const BodyPreview& b : preview.bodies)
      if (b.needs_meshing) fmt::print("meshing {} ...\n", preview_line(b));
  std::fflush(stdout);
  World world = make_world(scene, opt);
  RunPlan plan = plan_run(world, scene, opt, &preview);
  if (ro.png_every > 0) plan.outputs.push_back(fmt::format("frames/ (a PNG every {:g} s)", ro.png_every));
  if (ro.sheet) plan.outputs.push_back("sheet.png");
  if (ro.mp4) plan.outputs.push_back("movie.mp4");
  if (dry_run) measure_warm_up(world, plan);
  const auto print_plan = [&](bool all) {
    for (const std::string& line : plan_lines(plan)) {
      if (line.starts_with("warning: ")) {
        const PlanWarning* seen = nullptr;
        for (const PlanWarning& w : preview.warnings)
          if ("warning: " + w.text == line) seen = &w;
        if (!seen) fmt::print(stderr, "pliant: {}\n", line);
      } else if (all) {
        fmt::print("{}\n", line);
      }
    }
    std::fflush(stdout);
  };
  print_plan(!quiet);
  if (dry_run) {
    if (!quiet) fmt::print("dry run: nothing was written (the files above are what the run would write under {}/)\n", out);
    return 0;
  }

  // Progress: rewritten in place on a terminal, else a line every few seconds; the first report
  // is the plan's estimate.
  const bool terminal = isatty(STDERR_FILENO);
  bool progress_shown = false;
  opt.on_warning = [&](const std::string& w) {  // printed even with --quiet, as every warning
    if (progress_shown) fmt::print(stderr, "\n");
    fmt::print(stderr, "pliant: warning: {}\n", w);
    progress_shown = false;
  };
  if (!quiet) {
    opt.progress_every = terminal ? 0.2 : progress_every;
    opt.on_progress = [&](const RunProgress& p) {
      if (p.estimate) {  // the plan's last line; not worth a line when the run is about to end
        if (p.eta_s >= 1) fmt::print("  {}\n", estimate_line(p.eta_s + p.wall_s, p.step, p.seconds_per_substep));
        // A real-time run that cannot keep up says so at once, with the numbers.
        const double wall_per_second = p.seconds_per_substep * world.substeps() / world.dt();
        if (paced && wall_per_second > 1)
          fmt::print(stderr,
                     "pliant: warning: this scene cannot run in real time on {} thread(s): a simulated second costs {:.3g} s "
                     "of wall time ({:.0f} sub-steps of {:.3g} us); simulated time will fall behind the clock by about {:.3g} s "
                     "by the end (coarser meshes, fewer tets stepped or more cores would help)\n",
                     world.threads(), wall_per_second, world.substeps() / world.dt(), 1e6 * p.seconds_per_substep,
                     (wall_per_second - 1) * p.duration);
        std::fflush(stdout);
        return;
      }
      if (terminal) {
        fmt::print(stderr, "\r  {}   ", progress_text(p));
        progress_shown = true;
      } else {
        fmt::print(stderr, "pliant: {}\n", progress_text(p));
      }
      std::fflush(stderr);
    };
  }
  RunSummary s;
  try {
    s = run_world(scene, world, opt);
  } catch (const DivergenceError&) {
    if (progress_shown) fmt::print(stderr, "\n");
    if (recorder && recorder->active()) {  // pictures up to the divergence help to see why
      if (!quiet) fmt::print(stderr, "pliant: rendering the pictures taken before the divergence ...\n");
      report_pictures(recorder->finish(), out, quiet);
    }
    throw;
  }
  if (progress_shown) fmt::print(stderr, "\r{:100}\r", "");
  if (!quiet) {
    for (const std::string& note : s.notes) fmt::print(stderr, "pliant: note: {}\n", note);
    fmt::print("{} nodes, {} tets ({}, {}), {} threads\n", s.nodes, s.tets, s.model, s.precision, s.threads);
    fmt::print("{} steps of {:.4g} s (stable bound {:.4g} s) to t = {:.4g} s in {:.2f} s wall: {:.0f} steps/s\n",
               s.steps, s.dt, s.stable_dt, s.simulated_time, s.wall_time_s, s.steps_per_second);
    if (s.adapted_steps > 0)
      fmt::print("adaptive step: the deformation stiffened the elements up to {:.3g}x; {} of {} steps were split, into up "
                 "to {} sub-steps\n",
                 s.max_stiffness_ratio, s.adapted_steps, s.steps, s.max_substeps);
    if (s.levels.size() > std::size_t(std::count_if(s.levels.begin(), s.levels.end(), [](const auto& l) { return l.level == 0; }))) {
      for (const auto& l : s.levels)
        fmt::print("  {} level {}: {} tets, {:.0f} stepped, {:.0f} ghost nodes, period {} ({:.4g} s)\n", l.body, l.level,
                   l.tets, l.active_tets_mean, l.ghost_nodes_mean, l.period, l.dt);
      fmt::print("ticks ({}): {:.0f} tets mean, {} max; {:.1f} us mean, p50 {:.1f}, p99 {:.1f}, max {:.1f}\n", s.schedule,
                 s.tick_tet_updates_mean, s.tick_tet_updates_max, s.tick_mean_us, s.tick_p50_us, s.tick_p99_us,
                 s.tick_max_us);
    }
    fmt::print("max displacement {:.4g} m, kinetic {:.4g} J, elastic {:.4g} J, state hash {}\n", s.max_displacement,
               s.kinetic_energy, s.elastic_energy, s.state_hash);
    if (s.realtime) {
      const bool framed = s.realtime_frame_s > 0;
      const std::string frames = framed ? fmt::format("frames of {:.3g} ms", 1e3 * s.realtime_frame_s) : "steps";
      fmt::print("real time: {:.3g} simulated s per wall s; {} of {} {} ended after their wall-clock time ({} took longer "
                 "than their time to step; of the late, {} only by starting late and {} holding a change of resolution; waits woke up to "
                 "{:.0f} us late; {} started early, ahead of a change of resolution); {} stepping {:.0f} us mean, p99 {:.0f}, "
                 "max {:.0f}; lag mean {:.3g} s, max {:.3g} s\n",
                 s.realtime_factor, s.deadline_misses, s.frames, frames, s.frames_over, s.late_behind, s.late_changing,
                 1e6 * s.wake_late_max_s, s.frames_early,
                 framed ? "frames" : "steps", s.frame_mean_us, s.frame_p99_us, s.frame_max_us, s.lag_mean_s, s.lag_max_s);
    }
    for (const auto& a : s.adapt)
      fmt::print("adaptivity of body '{}': {} splits, {} merges in {} changes ({} undone), {:.0f} us per change; {} decision "
                 "points, {:.0f} us each (mean), {:.0f} us at most\n",
                 a.body, a.splits, a.merges, a.changes, a.undone, a.apply_us_per_change, a.checks, a.check_us_mean,
                 a.check_us_max);
    for (const auto& t : s.tools)
      fmt::print("tool '{}': largest force {:.4g} N, in contact {} of {} steps, deepest penetration {:.3g} m\n", t.name,
                 t.max_force, t.contact_steps, s.steps, t.max_penetration);
    auto wrote = [&](const char* f) { return std::find(s.files.begin(), s.files.end(), f) != s.files.end(); };
    fmt::print("results in {}/ (summary.json{}{}{}{})\n", fs::path(out).string(), wrote("probes.csv") ? ", probes.csv" : "",
               wrote("tools.csv") ? ", tools.csv" : "", wrote("levels.csv") ? ", levels.csv" : "",
               scene.output.vtu_every > 0 ? ", series.pvd + vtu/" : "");
  }
  if (std::find(s.files.begin(), s.files.end(), "tools.csv") != s.files.end() &&
      plot_tool_forces(fs::path(out) / "tools.csv", fs::path(out) / "tools.png") && !quiet)
    fmt::print("tool forces: {}\n", (fs::path(out) / "tools.png").string());
  if (recorder && recorder->active()) {
    std::fflush(stdout);
    if (!quiet) fmt::print(stderr, "pliant: rendering pictures ...\n");
    report_pictures(recorder->finish(), out, quiet);
  }
  return 0;
}

}  // namespace

Command add_run_command(CLI::App& app) {
  struct Options {
    std::string scene, out = "out", precision, schedule;
    std::optional<int> threads;
    std::optional<double> duration, realtime_frame;
    bool quiet = false, dry_run = false, repair = false, realtime = false, realtime_priority = false;
    double progress_every = 5;  // s between progress lines when stderr is not a terminal (a log, a CI job)
    PictureOptions pic;
  };
  auto o = std::make_shared<Options>();
  auto* run = app.add_subcommand("run", "Run a scene file and write its results");
  run->add_option("SCENE", o->scene, "Scene file (JSON, see docs/scene-format.md)")->required();
  run->add_option("--out,-o", o->out, "Output folder")->capture_default_str();
  run->add_option("--threads", o->threads, "Worker threads (overrides the scene; 0 = all cores)");
  // An empty value ('--precision ""') read as the option not given.
  const auto not_empty = [](const std::string& v) { return v.empty() ? std::string("an empty value") : std::string(); };
  run->add_option("--precision", o->precision, "float or double (overrides the scene)")->check(not_empty);
  run->add_option("--duration", o->duration, "Simulated seconds (overrides the scene)")->check(not_empty);
  run->add_option("--schedule", o->schedule,
                  "How multiresolution levels share the ticks: staggered (coarse work in slices, every tick costs "
                  "about the same; the default) or naive (every coarse level on the same tick)")
      ->check(not_empty);
  run->add_flag("--realtime", o->realtime,
                "Simulated time follows the wall clock: steps wait for their time, and the report says how many ended late "
                "and how far simulated time lagged (also \"realtime\": true in the scene)");
  run->add_option("--realtime-frame", o->realtime_frame,
                  "Seconds of simulated time per real-time frame: each frame must be done by the wall-clock time of its "
                  "end (default 0.001, a 1 kHz haptic loop; 0: every step; also \"realtime_frame\" in the scene)");
  run->add_flag("--realtime-priority", o->realtime_priority,
                "With --realtime: step on a real-time thread (SCHED_FIFO) so that frames start on time when other processes "
                "hold the cores (needs root or CAP_SYS_NICE; otherwise the run says so and goes on)");
  run->add_flag("--quiet,-q", o->quiet, "No plan, no progress and no report (warnings and errors still print)");
  run->add_option("--progress-every", o->progress_every,
                  "Seconds between progress lines on stderr when it is not a terminal (on a terminal, one line is rewritten)")
      ->capture_default_str();
  run->add_flag("--dry-run", o->dry_run,
                "Print the plan (sizes, step, steps, files, warnings, and a wall-time estimate from a few timed steps) and stop: "
                "nothing is written");
  run->add_flag("--repair", o->repair,
                "Repair surface meshes that do not bound a volume (stitch, orient, fill holes, remove self-intersections) "
                "before meshing them");
  run->add_option("--png-every", o->pic.png_every, "Write a picture every S simulated seconds: OUT/frames/frame_NNNNN.png");
  run->add_flag("--sheet", o->pic.sheet, "Write OUT/sheet.png, a contact sheet of the run (pictures with their times)");
  run->add_flag("--mp4", o->pic.mp4, "Assemble OUT/movie.mp4 from the frames (needs ffmpeg; frames every duration/60 unless --png-every)");
  run->add_option("--field", o->pic.field, "Colour of the pictures: displacement, von_mises or none")->capture_default_str();
  run->add_option("--size", o->pic.size, "Picture size WIDTHxHEIGHT in pixels")->capture_default_str();
  run->add_option("--camera", o->pic.camera, "scene (the scene's camera block, else auto), auto, front, side or top")
      ->capture_default_str();
  add_view_options(run, o->pic.up, o->pic.azimuth, o->pic.elevation);
  return {run, [o] {
            return command_run(o->scene, o->out, o->threads, o->precision, o->duration, o->quiet, o->dry_run, o->repair,
                               o->progress_every, o->pic, o->schedule, o->realtime,
                               o->realtime_frame, o->realtime_priority);
          }};
}

}  // namespace pliant::cli
