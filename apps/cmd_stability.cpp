// `pliant stability`: the stability matrix of issue 3 §3 (materials x time steps x models x
// precisions, plus the extreme scenarios). Prints a line per cell that is not as expected (a
// divergence at once), progress, the counts; writes the markdown table if asked. Exit 0 when every
// cell is as expected, 3 when any cell is not (a divergence at any step that runs, among others).
#include <chrono>
#include <fmt/format.h>
#include <fstream>

#include "commands.hpp"
#include "pliant/error.hpp"
#include "pliant/perf/machine.hpp"
#include "pliant/perf/stability.hpp"

namespace pliant::cli {

Command add_stability_command(CLI::App& app) {
  struct Options {
    bool subset = false, verbose = false;
    int steps = 0, threads = 1;
    std::string markdown, filter;
  };
  auto o = std::make_shared<Options>();
  auto* sub = app.add_subcommand("stability", "The stability matrix: materials x time steps x models x precisions");
  sub->add_flag("--subset", o->subset, "Only the corners of the matrix and one material per extreme (the ctest subset)");
  sub->add_option("--steps", o->steps, "Steps per cell (default 2000, 1000 with --subset)");
  sub->add_option("--threads", o->threads, "Worker threads per cell")->capture_default_str();
  sub->add_option("--markdown", o->markdown, "Write the generated table (docs/stability.md)");
  sub->add_flag("--verbose,-v", o->verbose, "One line per cell");
  sub->add_option("--filter", o->filter,
                  "Run only the cells whose label contains this text (as printed, e.g. \"adaptive_push linear double\")");
  return {sub, [o]() -> int {
            if (o->threads < 1) throw InputError("--threads must be >= 1");
            if (o->steps < 0) throw InputError(fmt::format("--steps must be > 0, got {}", o->steps));  // (0: the default)
            stability::MatrixOptions mo;
            mo.full = !o->subset;
            mo.steps = o->steps > 0 ? o->steps : (o->subset ? 1000 : 2000);
            mo.threads = o->threads;
            mo.machine = perf::machine_description();
            mo.filter = o->filter;
            if (!o->filter.empty() && !o->markdown.empty())
              throw InputError("--filter runs part of the matrix: it cannot write --markdown (the whole table)");
            const auto t0 = std::chrono::steady_clock::now();
            int unexpected = 0;
            mo.progress = [&](const stability::CellResult& r, std::size_t i, std::size_t n) {
              const bool ok = r.acceptable();
              if (!ok) ++unexpected;
              const char* known = ok ? nullptr : stability::known_issue(r.spec);
              if (!ok || r.outcome == stability::Outcome::diverged || o->verbose)
                fmt::print("[{}/{}] {}: {}{}{}{}\n", i + 1, n, r.spec.label(), stability::to_string(r.outcome),
                           ok ? "" : known ? " (UNEXPECTED, known engine issue)" : " (UNEXPECTED)",
                           r.spec.scenario == "adaptive_push"
                               ? fmt::format(" ({} splits, {} merges, up to {} finest tets, peak {:.2f}, mass to {:.2g})",
                                             r.splits, r.merges, r.max_fine_tets, r.peak_ratio, r.mass_error)
                               : std::string(),
                           r.message.empty() ? "" : " - " + r.message);
              else if ((i + 1) % 50 == 0 || i + 1 == n)
                fmt::print("[{}/{}] {:.0f} s, {} unexpected so far\n", i + 1, n,
                           std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), unexpected);
              std::fflush(stdout);
            };
            const auto results = stability::run_matrix(mo);
            // A filter that matches nothing ran 0 cells and passed ("0 unexpected"): a typo in a CI job.
            if (results.empty() && !o->filter.empty())
              throw InputError(fmt::format("--filter \"{}\": no cell of the {} matrix has it in its label", o->filter,
                                           o->subset ? "subset" : "full"));
            const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
            int counts[4] = {0, 0, 0, 0};
            for (const auto& r : results) ++counts[int(r.outcome)];
            fmt::print("{} cells in {:.0f} s: {} stable, {} clamped, {} refused, {} diverged; {} unexpected\n",
                       results.size(), wall, counts[0], counts[1], counts[2], counts[3], unexpected);
            if (!o->markdown.empty()) {
              std::ofstream f(o->markdown);
              if (!f) throw InputError(fmt::format("cannot write {}", o->markdown));
              f << stability::markdown_report(results, mo, wall);
              fmt::print("table written to {}\n", o->markdown);
            }
            return unexpected == 0 ? 0 : 3;
          }};
}

}  // namespace pliant::cli
