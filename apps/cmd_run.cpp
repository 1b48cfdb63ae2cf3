// `pliant run SCENE`: runs a scene file to its end and writes its results.
#include <unistd.h>

#include <algorithm>
#include <fmt/format.h>

#include "commands.hpp"
#include "pliant/run.hpp"
#include "pliant/scene.hpp"

namespace pliant::cli {
namespace {
namespace fs = std::filesystem;

int command_run(const std::string& scene_path, const std::string& out, std::optional<int> threads,
                const std::string& precision, std::optional<double> duration, bool quiet) {
  SceneDef scene = load_scene_file(scene_path);
  RunOptions opt;
  opt.out_dir = out;
  opt.threads = threads;
  if (precision == "float") opt.precision = Precision::float32;
  else if (precision == "double") opt.precision = Precision::float64;
  else if (!precision.empty()) throw InputError(fmt::format("--precision must be float or double, got '{}'", precision));
  opt.duration = duration;
  opt.progress = !quiet && isatty(STDERR_FILENO);
  if (!quiet) fmt::print(stderr, "pliant: running {} ...\n", scene_path);
  const RunSummary s = run_scene(scene, opt);
  if (!quiet) {
    fmt::print("{} nodes, {} tets ({}, {}), {} threads\n", s.nodes, s.tets, s.model, s.precision, s.threads);
    fmt::print("{} steps of {:.4g} s (stable bound {:.4g} s) to t = {:.4g} s in {:.2f} s wall: {:.0f} steps/s\n",
               s.steps, s.dt, s.stable_dt, s.simulated_time, s.wall_time_s, s.steps_per_second);
    fmt::print("max displacement {:.4g} m, kinetic {:.4g} J, elastic {:.4g} J, state hash {}\n", s.max_displacement,
               s.kinetic_energy, s.elastic_energy, s.state_hash);
    fmt::print("results in {}/ (summary.json{}{})\n", fs::path(out).string(),
               s.files.size() > 1 && std::find(s.files.begin(), s.files.end(), "probes.csv") != s.files.end()
                   ? ", probes.csv" : "",
               scene.output.vtu_every > 0 ? ", series.pvd + vtu/" : "");
  }
  return 0;
}

}  // namespace

Command add_run_command(CLI::App& app) {
  struct Options {
    std::string scene, out = "out", precision;
    std::optional<int> threads;
    std::optional<double> duration;
    bool quiet = false;
  };
  auto o = std::make_shared<Options>();
  auto* run = app.add_subcommand("run", "Run a scene file and write its results");
  run->add_option("SCENE", o->scene, "Scene file (JSON, see docs/scene-format.md)")->required();
  run->add_option("--out,-o", o->out, "Output folder")->capture_default_str();
  run->add_option("--threads", o->threads, "Worker threads (overrides the scene; 0 = all cores)");
  run->add_option("--precision", o->precision, "float or double (overrides the scene)");
  run->add_option("--duration", o->duration, "Simulated seconds (overrides the scene)");
  run->add_flag("--quiet,-q", o->quiet, "No progress line and no report");
  return {run, [o] { return command_run(o->scene, o->out, o->threads, o->precision, o->duration, o->quiet); }};
}

}  // namespace pliant::cli
