// `pliant run SCENE`: runs a scene file to its end and writes its results; with --png-every,
// --sheet or --mp4 (or "output": {"sheet": true} in the scene) also pictures of the run, taken
// by raster::FrameRecorder through the runner's read-only frame callback.
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <fmt/format.h>
#include <optional>

#include "commands.hpp"
#include "pliant/raster/recorder.hpp"
#include "pliant/run.hpp"
#include "pliant/scene.hpp"

namespace pliant::cli {
namespace {
namespace fs = std::filesystem;

struct PictureOptions {
  std::optional<double> png_every;
  bool sheet = false, mp4 = false;
  std::string field = "displacement", size = "1280x720", camera = "scene";
};

void report_pictures(const raster::RecorderResult& r, const fs::path& out, bool quiet) {
  if (quiet) return;
  for (const auto& f : r.files) fmt::print("picture: {}\n", (out / f).string());
  for (const auto& n : r.notes) fmt::print(stderr, "pliant: note: {}\n", n);
}

int command_run(const std::string& scene_path, const std::string& out, std::optional<int> threads,
                const std::string& precision, std::optional<double> duration, bool quiet, const PictureOptions& pic,
                const std::string& schedule) {
  SceneDef scene = load_scene_file(scene_path);
  RunOptions opt;
  opt.out_dir = out;
  opt.threads = threads;
  if (precision == "float") opt.precision = Precision::float32;
  else if (precision == "double") opt.precision = Precision::float64;
  else if (!precision.empty()) throw InputError(fmt::format("--precision must be float or double, got '{}'", precision));
  opt.duration = duration;
  if (schedule == "staggered") opt.schedule = Schedule::staggered;
  else if (schedule == "naive") opt.schedule = Schedule::naive;
  else if (!schedule.empty()) throw InputError(fmt::format("--schedule must be staggered or naive, got '{}'", schedule));
  opt.progress = !quiet && isatty(STDERR_FILENO);

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
  std::optional<raster::FrameRecorder> recorder;
  if (ro.png_every > 0 || ro.sheet || ro.mp4) {
    recorder.emplace(scene, ro, duration.value_or(scene.duration));
    if (recorder->active()) {
      opt.frame_every = recorder->frame_every();
      opt.on_frame = [&recorder](const World& w) { recorder->capture(w); };
    }
  }

  if (!quiet) fmt::print(stderr, "pliant: running {} ...\n", scene_path);
  RunSummary s;
  try {
    s = run_scene(scene, opt);
  } catch (const DivergenceError&) {
    if (recorder && recorder->active()) {  // pictures up to the divergence help to see why
      if (!quiet) fmt::print(stderr, "pliant: rendering the pictures taken before the divergence ...\n");
      report_pictures(recorder->finish(), out, quiet);
    }
    throw;
  }
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
    fmt::print("results in {}/ (summary.json{}{})\n", fs::path(out).string(),
               s.files.size() > 1 && std::find(s.files.begin(), s.files.end(), "probes.csv") != s.files.end()
                   ? ", probes.csv" : "",
               scene.output.vtu_every > 0 ? ", series.pvd + vtu/" : "");
  }
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
    std::optional<double> duration;
    bool quiet = false;
    PictureOptions pic;
  };
  auto o = std::make_shared<Options>();
  auto* run = app.add_subcommand("run", "Run a scene file and write its results");
  run->add_option("SCENE", o->scene, "Scene file (JSON, see docs/scene-format.md)")->required();
  run->add_option("--out,-o", o->out, "Output folder")->capture_default_str();
  run->add_option("--threads", o->threads, "Worker threads (overrides the scene; 0 = all cores)");
  run->add_option("--precision", o->precision, "float or double (overrides the scene)");
  run->add_option("--duration", o->duration, "Simulated seconds (overrides the scene)");
  run->add_option("--schedule", o->schedule,
                  "How multiresolution levels share the ticks: staggered (coarse work in slices, every tick costs "
                  "about the same; the default) or naive (every coarse level on the same tick)");
  run->add_flag("--quiet,-q", o->quiet, "No progress line and no report");
  run->add_option("--png-every", o->pic.png_every, "Write a picture every S simulated seconds: OUT/frames/frame_NNNNN.png");
  run->add_flag("--sheet", o->pic.sheet, "Write OUT/sheet.png, a contact sheet of the run (pictures with their times)");
  run->add_flag("--mp4", o->pic.mp4, "Assemble OUT/movie.mp4 from the frames (needs ffmpeg; frames every duration/60 unless --png-every)");
  run->add_option("--field", o->pic.field, "Colour of the pictures: displacement, von_mises or none")->capture_default_str();
  run->add_option("--size", o->pic.size, "Picture size WIDTHxHEIGHT in pixels")->capture_default_str();
  run->add_option("--camera", o->pic.camera, "scene (the scene's camera block, else auto), auto, front, side or top")
      ->capture_default_str();
  return {run, [o] {
            return command_run(o->scene, o->out, o->threads, o->precision, o->duration, o->quiet, o->pic, o->schedule);
          }};
}

}  // namespace pliant::cli
