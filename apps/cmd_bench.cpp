// `pliant bench`: speed of the kernels and of whole scenes against this machine's limits. Runs
// the standard set of perf/ (pliant_perf: machine limits, every model's element pass, the node
// passes and whole steps on 1k..1M-tet boxes, memory orders, scenes) with its own timing
// (warm-up, repeated timed calls, median / p99 / max), and prints a table, or with --json one
// JSON record per line and per case. docs/performance.md explains the figures.
#include <fmt/format.h>

#include <cmath>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "commands.hpp"
#include "pliant/error.hpp"
#include "pliant/scheduler/executor.hpp"

#ifdef PLIANT_HAS_BENCH_SUITE
#include <nlohmann/json.hpp>

#include "pliant/perf/suite.hpp"
#endif

namespace pliant::cli {
namespace {

struct Options {
  bool quick = false, json = false, no_scenes = false, scenes_only = false;
  std::optional<int> threads;
  std::string csv, scenes;
  double max_wait = 30;
};

#ifdef PLIANT_HAS_BENCH_SUITE
nlohmann::json to_json(const perf::Record& r) {
  auto n = [](double v) { return std::isnan(v) ? nlohmann::json(nullptr) : nlohmann::json(v); };
  auto s = [](const std::string& v) { return v.empty() ? nlohmann::json(nullptr) : nlohmann::json(v); };
  nlohmann::json j;
  j["case"] = r.case_name;
  j["kind"] = r.kind;
  j["model"] = s(r.model);
  j["precision"] = s(r.precision);
  j["order"] = s(r.order);
  j["size"] = s(r.size);
  j["tets"] = r.tets;
  j["nodes"] = r.nodes;
  j["threads"] = r.threads;
  j["ns_per_tet"] = n(r.ns_per_tet);
  j["mtets_per_s"] = n(r.mtets_per_s);
  j["bytes_per_tet"] = n(r.bytes_per_tet);
  j["gb_per_s"] = n(r.gb_per_s);
  j["flops_per_tet"] = n(r.flops_per_tet);
  j["gflop_per_s"] = n(r.gflop_per_s);
  j["footprint_mib"] = n(r.footprint_mib);
  j["roof_gb_per_s"] = n(r.roof_gb_per_s);
  j["roof_gflop_per_s"] = n(r.roof_gflop_per_s);
  j["roof_ns_per_tet"] = n(r.roof_ns_per_tet);
  j["roofline_fraction"] = n(r.roofline_fraction);
  j["bound"] = s(r.bound);
  j["steps_per_s"] = n(r.steps_per_s);
  j["step_p50_us"] = n(r.step_p50_us);
  j["step_p99_us"] = n(r.step_p99_us);
  j["step_max_us"] = n(r.step_max_us);
  j["realtime_factor"] = n(r.realtime_factor);
  j["samples"] = r.samples;
  j["others_busy"] = n(r.others_busy);
  j["round_trip_ns"] = n(r.round_trip_ns);
  j["floor_p99_us"] = n(r.floor_p99_us);
  j["value"] = n(r.value);
  j["unit"] = s(r.unit);
  j["note"] = s(r.note);
  return j;
}

int command_bench(const Options& o) {
  perf::SuiteOptions so;
  so.quick = o.quick;
  if (o.threads) {
    if (*o.threads < 1) throw InputError(fmt::format("--threads must be at least 1, got {}", *o.threads));
    so.threads = {std::min(*o.threads, Executor::default_threads())};
    if (so.threads[0] < *o.threads)  // the records must say what ran
      fmt::print(stderr, "pliant bench: note: --threads {}: this process may use {} cores, measuring on {} threads\n",
                 *o.threads, so.threads[0], so.threads[0]);
  }
  if (!(o.max_wait >= 0)) throw InputError(fmt::format("--max-wait must be >= 0 (s), got {}", o.max_wait));
  so.max_wait_s = o.max_wait;
  if (o.no_scenes && o.scenes_only) throw InputError("--no-scenes and --scenes-only exclude each other");
  so.scenes = !o.no_scenes;
  so.kernels = !o.scenes_only;
  so.scenes_dir = o.scenes;
  if (!o.scenes.empty() && !std::filesystem::exists(std::filesystem::path(o.scenes) / "cantilever.json"))
    throw InputError(fmt::format("--scenes {}: no cantilever.json there", o.scenes));
  so.progress = [&](const std::string& line) { fmt::print(stderr, "pliant bench: {}\n", line); };

  std::ofstream csv;
  if (!o.csv.empty()) {
    csv.open(o.csv);
    if (!csv) throw InputError(fmt::format("--csv {}: cannot write the file", o.csv));
    csv << perf::csv_header() << '\n';
  }
  const std::time_t now = std::time(nullptr);
  char date[32];
  std::strftime(date, sizeof(date), "%Y-%m-%d %H:%M:%S UTC", std::gmtime(&now));
  perf::Record info;
  info.case_name = "machine/info";
  info.kind = "machine";
  info.threads = so.threads.back();
  info.note = fmt::format("{} | {} | {} | {}", perf::machine_description(), perf::build_description(), date,
                          o.quick ? "quick set" : "full set");

  std::vector<perf::Record> all;
  auto emit = [&](const perf::Record& r) {
    all.push_back(r);
    if (o.json) {
      fmt::print("{}\n", to_json(r).dump());
      std::fflush(stdout);
    }
    if (csv) csv << perf::csv_row(r) << '\n';
  };
  emit(info);
  perf::run_suite(so, emit);
  if (!o.json) {
    fmt::print("{}\n{}\n\n", info.note, std::string(80, '-'));
    fmt::print("{}", perf::format_table(all));
    fmt::print("\nns/tet and Mtet/s are medians; B/tet is the compulsory traffic of the pass (docs/performance.md); "
               "roof% = roofline time / measured time; floor99 = p99 of fixed arithmetic lasting the median step, as many "
               "runs on as many threads (the machine's own tail for work of that length); busy = cores used by other "
               "processes meanwhile.\n");
  }
  return 0;
}
#endif

}  // namespace

Command add_bench_command(CLI::App& app) {
  auto o = std::make_shared<Options>();
  auto* sub = app.add_subcommand("bench", "Speed of kernels and scenes against this machine's limits");
  sub->add_flag("--quick", o->quick, "A small set (1k and 10k tets, short runs): well under a minute");
  sub->add_flag("--json", o->json, "One JSON record per line and per case instead of the table");
  sub->add_option("--threads", o->threads, "Run on this many threads only (default: 1 and 2)");
  sub->add_option("--csv", o->csv, "Also write every record to this CSV file");
  sub->add_option("--scenes", o->scenes, "Folder with default.json and cantilever.json (default: ./scenes, then the source tree's)");
  sub->add_option("--max-wait", o->max_wait, "Seconds to wait, at each stage, for other processes to go quiet")
      ->capture_default_str();
  sub->add_flag("--no-scenes", o->no_scenes, "Kernels and steps only");
  sub->add_flag("--scenes-only", o->scenes_only, "Machine limits and scenes only (the small bodies, the default scene): a few minutes");
#ifdef PLIANT_HAS_BENCH_SUITE
  return {sub, [o] { return command_bench(*o); }};
#else
  return {sub, []() -> int {
            throw InputError("pliant bench needs the perf/ module: configure with -DPLIANT_BUILD_PERF=ON");
          }};
#endif
}

}  // namespace pliant::cli
