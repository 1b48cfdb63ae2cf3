// `pliant study SCENE --sweep 'PATH=V1|V2|...' [--sweep ...] [--reference VALUE|finest|FILE] [--out DIR]`:
// runs a scene over the grid of settings, measures a quantity per run (the reference file beside
// the scene, SCENE.reference.json, says which and gives its analytic value), and writes
// DIR/study.csv and DIR/study.md with the error, the cost and the Pareto front, and draws them:
// DIR/pareto.png (cost against error) and DIR/convergence.png (error against the mesh). See docs/accuracy.md.
//
// Beyond one process (study_jobs.hpp): `--jobs FILE` writes one shell command per run instead of
// running (GNU parallel, a Slurm array: scripts/study-slurm.sh), `--run K --out DIR` is one such
// command, `--collect DIR` assembles the study from the run folders, and `--parallel N` does the
// three with N processes on this machine.
#include <fmt/format.h>
#include <fmt/ranges.h>

#include <cstdio>
#include <filesystem>

#include "commands.hpp"
#include "pliant/error.hpp"
#include "pliant/perf/study_plots.hpp"
#include "pliant/perf/study.hpp"
#include "pliant/perf/study_jobs.hpp"

namespace pliant::cli {
namespace {

// The plots of a finished study, and the closing line (with the study's notes when they were not
// printed before the runs: a collected study).
int report(study::StudyResult& r, const std::filesystem::path& out, bool quiet, bool notes) {
  const raster::StudyPlotFiles plots = raster::write_study_plots(r, out);
  r.files.insert(r.files.end(), plots.files.begin(), plots.files.end());
  int front = 0, bad = 0;
  for (const auto& run : r.runs) {
    front += run.pareto;
    bad += run.status == "invalid";
  }
  if (!quiet) {
    if (notes)
      for (const std::string& note : r.notes) fmt::print(stderr, "pliant: note: {}\n", note);
    fmt::print("{} runs in {:.1f} s, {} on the Pareto front; results in {}\n", r.runs.size(), r.wall_total_s, front,
               fmt::join(r.files, ", "));
    for (const std::string& note : plots.notes) fmt::print(stderr, "pliant: note: {}\n", note);
  }
  return bad ? 2 : 0;
}

void print_line(const std::string& line) {
  fmt::print(stderr, "{}\n", line);
  std::fflush(stderr);
}

}  // namespace

Command add_study_command(CLI::App& app) {
  struct Options {
    std::string scene, reference, measure, out = "study", cost = "wall", jobs, collect;
    std::vector<std::string> sweeps;
    int threads = 1, parallel = 0;
    std::size_t run = 0;
    bool quiet = false;
  };
  auto o = std::make_shared<Options>();
  auto* sub = app.add_subcommand("study", "Run a scene over a grid of settings: accuracy against cost");
  sub->add_option("SCENE", o->scene, "Scene file; its measure and analytic answer are read from SCENE.reference.json");
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
  sub->add_option("--cost", o->cost,
                  "Cost of the Pareto front: wall (s per simulated s), tet-steps (tets x steps) or tet-updates "
                  "(tets computed: what a multiresolution body steps)")
      ->capture_default_str();
  sub->add_flag("--quiet,-q", o->quiet, "No progress lines");
  sub->add_option("--jobs", o->jobs,
                  "Write one shell command per run to FILE instead of running (each writes OUT/runs/K/); run them "
                  "with `parallel < FILE` or a Slurm array (scripts/study-slurm.sh), then --collect OUT");
  sub->add_option("--parallel", o->parallel,
                  "Run the grid as N processes on this machine (a job list in OUT/jobs.txt, then --collect)");
  sub->add_option("--run", o->run, "Run K of the job list of the study in --out DIR (what a line of --jobs does)");
  sub->add_option("--collect", o->collect, "Assemble study.csv, study.md and the plots of DIR from its run folders");
  return {sub, [o, sub]() -> int {
            namespace fs = std::filesystem;
            const bool distributed = o->run > 0 || !o->collect.empty();
            if (distributed) {
              // A run of a job list, or the collection: everything else comes from DIR/study.json.
              for (const char* other : {"SCENE", "--sweep", "--reference", "--measure", "--threads", "--cost", "--jobs",
                                        "--parallel"})
                if (sub->count(other))
                  throw InputError(fmt::format("{} takes no {}: the study's settings are in its study.json",
                                               o->run > 0 ? "--run" : "--collect", other));
              if (o->run > 0 && !o->collect.empty()) throw InputError("--run and --collect go in separate commands");
              if (o->run > 0) {
                if (!sub->count("--out")) throw InputError("--run K needs --out DIR, the study's folder");
                study::run_study_job(o->out, o->run, o->quiet ? std::function<void(const std::string&)>{} : print_line);
                return 0;
              }
              study::StudyResult r = study::collect_study(o->collect);
              return report(r, o->collect, o->quiet, true);
            }
            if (sub->count("--run")) throw InputError("--run counts from 1");
            if (o->scene.empty()) throw InputError("study: SCENE is required (or --collect DIR, or --run K --out DIR)");
            study::StudyOptions so;
            so.scene = o->scene;
            so.sweeps = o->sweeps;
            so.reference = o->reference;
            so.measure = o->measure;
            so.out_dir = o->out;
            if (o->threads < 0) throw InputError(fmt::format("--threads must be >= 0, got {}", o->threads));
            so.threads = o->threads;
            so.cost = study::parse_cost(o->cost);
            if (!o->quiet) so.progress = print_line;
            if (sub->count("--parallel") && o->parallel < 1)
              throw InputError(fmt::format("--parallel must be >= 1, got {}", o->parallel));
            if (!o->jobs.empty() || o->parallel > 0) {
              // The runs as separate processes: this program, wherever it is, runs each line.
              const fs::path exe = fs::read_symlink("/proc/self/exe");
              const fs::path jobs = o->jobs.empty() ? fs::path(o->out) / "jobs.txt" : fs::path(o->jobs);
              const std::vector<std::string> commands = study::write_study_jobs(so, exe, jobs);
              if (o->parallel == 0) {
                if (!o->quiet)
                  fmt::print("{} runs written to {} (one command per line, line K runs run K). Run them with\n"
                             "  parallel < {}          # GNU parallel, this machine\n"
                             "  sbatch --array=1-{} scripts/study-slurm.sh {}   # a Slurm cluster\n"
                             "then assemble the study with\n  pliant study --collect {}\n",
                             commands.size(), jobs.string(), jobs.string(), commands.size(), jobs.string(), o->out);
                return 0;
              }
              std::size_t finished = 0;
              const std::size_t failed = study::run_commands(commands, o->parallel, o->quiet, [&](std::size_t i, int code) {
                ++finished;
                if (code != 0)
                  fmt::print(stderr, "pliant: run {} failed (exit {}): {}\n", i + 1, code, commands[i]);
              });
              if (failed)
                throw InputError(fmt::format("{} of {} runs failed; run their lines of {} again, then pliant study --collect {}",
                                             failed, commands.size(), jobs.string(), o->out));
              study::StudyResult r = study::collect_study(o->out);
              return report(r, o->out, o->quiet, true);
            }
            study::StudyResult r = study::run_study(so);
            return report(r, so.out_dir, o->quiet, false);
          }};
}

}  // namespace pliant::cli
