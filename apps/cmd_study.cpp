// `pliant study SCENE --sweep 'PATH=V1|V2|...' [--sweep ...] [--reference VALUE|finest|FILE] [--out DIR]`:
// runs a scene over the grid of settings, measures a quantity per run (the reference file beside
// the scene, SCENE.reference.json, says which and gives its analytic value), and writes
// DIR/study.csv and DIR/study.md with the error, the cost and the Pareto front, and draws them:
// DIR/pareto.png (cost against error) and DIR/convergence.png (error against the mesh). See docs/accuracy.md.
#include <fmt/format.h>
#include <fmt/ranges.h>

#include <cstdio>

#include "commands.hpp"
#include "pliant/error.hpp"
#include "pliant/perf/study_plots.hpp"
#include "pliant/perf/study.hpp"

namespace pliant::cli {

Command add_study_command(CLI::App& app) {
  struct Options {
    std::string scene, reference, measure, out = "study", cost = "wall";
    std::vector<std::string> sweeps;
    int threads = 1;
    bool quiet = false;
  };
  auto o = std::make_shared<Options>();
  auto* sub = app.add_subcommand("study", "Run a scene over a grid of settings: accuracy against cost");
  sub->add_option("SCENE", o->scene, "Scene file; its measure and analytic answer are read from SCENE.reference.json")
      ->required();
  sub->add_option("--sweep,-s", o->sweeps,
                  "PATH=V1|V2|... (repeatable): a scene value and the JSON values it takes, e.g. "
                  "'bodies[0].mesh.box.cells=[20,2,2]|[40,4,4]' or 'precision=\"float\"|\"double\"'")
      ->expected(1)
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
  sub->add_option("--reference,-r", o->reference,
                  "VALUE, 'finest' (the run of most tet-steps) or a reference FILE; default: SCENE.reference.json");
  sub->add_option("--measure", o->measure,
                  "One measure as JSON instead of the reference file's, e.g. "
                  "'{\"kind\":\"probe_final\",\"probe\":\"tip\",\"axis\":\"z\"}' (with --reference VALUE|finest)");
  sub->add_option("--out,-o", o->out, "Output folder (study.csv, study.md, pareto.png, convergence.png)")
      ->capture_default_str();
  sub->add_option("--threads", o->threads, "Worker threads per run (0: all cores); runs go one after the other")
      ->capture_default_str();
  sub->add_option("--cost", o->cost, "Cost of the Pareto front: wall (s per simulated s) or tet-steps")
      ->capture_default_str();
  sub->add_flag("--quiet,-q", o->quiet, "No progress lines");
  return {sub, [o]() -> int {
            study::StudyOptions so;
            so.scene = o->scene;
            so.sweeps = o->sweeps;
            so.reference = o->reference;
            so.measure = o->measure;
            so.out_dir = o->out;
            if (o->threads < 0) throw InputError(fmt::format("--threads must be >= 0, got {}", o->threads));
            so.threads = o->threads;
            if (o->cost == "wall") so.cost = study::CostKind::wall;
            else if (o->cost == "tet-steps") so.cost = study::CostKind::tet_steps;
            else throw InputError(fmt::format("--cost must be wall or tet-steps, got '{}'", o->cost));
            if (!o->quiet)
              so.progress = [](const std::string& line) {
                fmt::print(stderr, "{}\n", line);
                std::fflush(stderr);
              };
            study::StudyResult r = study::run_study(so);
            const raster::StudyPlotFiles plots = raster::write_study_plots(r, so.out_dir);
            r.files.insert(r.files.end(), plots.files.begin(), plots.files.end());
            int front = 0, bad = 0;
            for (const auto& run : r.runs) {
              front += run.pareto;
              bad += run.status == "invalid";
            }
            if (!o->quiet) {
              fmt::print("{} runs in {:.1f} s, {} on the Pareto front; results in {}\n", r.runs.size(), r.wall_total_s,
                         front, fmt::join(r.files, ", "));
              for (const std::string& note : plots.notes) fmt::print(stderr, "pliant: note: {}\n", note);
            }
            return bad ? 2 : 0;
          }};
}

}  // namespace pliant::cli
