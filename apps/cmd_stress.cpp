// `pliant stress --seconds S --threads 2 [--seed K]`: random valid scenes back to back (issue 3
// §5), checked for divergence, non-finite or unbounded energy, thread-count reproducibility of
// the state hash and flat resident memory. Exit 0 when all checks pass, 3 otherwise.
#include <fmt/format.h>
#include <cmath>
#include <filesystem>
#include <fstream>

#include "commands.hpp"
#include "pliant/error.hpp"
#include "pliant/perf/stability.hpp"

namespace pliant::cli {

Command add_stress_command(CLI::App& app) {
  struct Options {
    double seconds = 10;
    int threads = 2, repeat_every = 5;
    std::uint64_t seed = 1;
    std::int64_t max_scenes = -1;
    std::vector<std::string> meshes;
    std::string report, scene;
    bool tools = true, capsules = true;
  };
  auto o = std::make_shared<Options>();
  auto* sub = app.add_subcommand("stress", "Random scenes back to back: NaN, energy, memory and reproducibility checks");
  sub->add_option("--seconds", o->seconds, "Wall-clock seconds to run")->capture_default_str();
  sub->add_option("--threads", o->threads, "Largest thread count a scene may use")->capture_default_str();
  sub->add_option("--seed", o->seed, "Seed of the scene sequence")->capture_default_str();
  sub->add_option("--max-scenes", o->max_scenes, "Stop after this many scenes");
  sub->add_option("--repeat-every", o->repeat_every, "Re-run every Nth scene with another thread count (0: never)")
      ->capture_default_str();
  sub->add_option("--meshes", o->meshes, "Folders of meshes to draw scenes from (default: the shipped data/meshes; env PLIANT_MESHES)");
  sub->add_option("--report", o->report, "Also write the final report to this file");
  sub->add_flag("--tools,!--no-tools", o->tools,
                "Press a tool into one adaptive scene in three (random size, depth, path and refine_near); on by "
                "default since 2026-11-28: --no-tools gives the scenes (and digests) of the runs before (docs/stress.md)");
  sub->add_flag("--capsules,!--no-capsules", o->capsules,
                "With --tools: make half the tools capsules (random length, leaning 0-80 degrees); on by default: "
                "--no-capsules keeps every tool a sphere, as they all were before 2026-11-26");
  sub->add_option("--scene", o->scene, "Run only the scene of this seed (as printed for a failure), e.g. 0x71c1...");
  return {sub, [o]() -> int {
            if (!(o->seconds >= 0 && std::isfinite(o->seconds)))
              throw InputError(fmt::format("--seconds must be a finite number >= 0, got {}", o->seconds));
            if (o->threads < 1) throw InputError("--threads must be >= 1");
            if (o->max_scenes < 0 && o->max_scenes != -1)  // -1: the default, no limit
              throw InputError(fmt::format("--max-scenes must be >= 0, got {}", o->max_scenes));
            if (o->repeat_every < 0)
              throw InputError(fmt::format("--repeat-every must be >= 0 (0: never), got {}", o->repeat_every));
            // A folder that is not there drew no mesh and said "0 shipped meshes".
            for (const auto& m : o->meshes)
              if (std::error_code ec; !std::filesystem::is_directory(m, ec))
                throw InputError(fmt::format("--meshes {}: not a folder", m));
            // The seed of one scene, as a failure prints it (0x...): "abc" was an internal error.
            std::uint64_t scene_seed = 0;
            if (!o->scene.empty()) {
              std::size_t used = 0;
              try {
                scene_seed = std::stoull(o->scene, &used, 0);
              } catch (const std::exception&) {
                used = 0;
              }
              if (used == 0 || used != o->scene.size())
                throw InputError(fmt::format("--scene {}: expected a scene's seed as a failure prints it, e.g. 0x71c1...", o->scene));
            }
            stability::StressOptions so;
            so.seconds = o->seconds;
            so.threads = o->threads;
            so.seed = o->seed;
            so.max_scenes = o->max_scenes;
            so.repeat_every = o->repeat_every;
            so.tools = o->tools;
            so.capsules = o->capsules;
            if (o->meshes.empty()) {
              if (const char* env = std::getenv("PLIANT_MESHES"))
                so.mesh_dirs = {env};
              else
                so.mesh_dirs = {PLIANT_DATA_MESHES};
            } else {
              for (const auto& m : o->meshes) so.mesh_dirs.emplace_back(m);
            }
            so.log = [](const std::string& s) {
              fmt::print("{}\n", s);
              std::fflush(stdout);
            };
            if (!o->scene.empty()) {
              const auto s = stability::run_stress_scene(scene_seed, 0, so);
              fmt::print("{}\n{}: {} steps, hash {:016x}, {:.2f} s, energy peak {:.3f} of {} x{}{}\n", s.description, s.status,
                         s.steps, s.hash, s.wall_s, s.energy_peak, stability::kBoundFactor,
                         s.adaptive ? fmt::format(", {} splits, {} merges, {} undone, mass to {:.2g}", s.splits, s.merges, s.undone, s.mass_error)
                                    : std::string(),
                         s.message.empty() ? "" : "\n" + s.message);
              return s.status == "ok" ? 0 : 3;
            }
            const auto rep = stability::run_stress(so);
            const std::string text = stability::stress_text(rep, so);
            fmt::print("{}", text);
            if (!o->report.empty()) {
              std::ofstream f(o->report);
              if (!f) throw InputError(fmt::format("cannot write {}", o->report));
              f << text;
            }
            return rep.ok() ? 0 : 3;
          }};
}

}  // namespace pliant::cli
