// The standard benchmark set of `pliant bench`: the machine's limits, every force model's
// element pass and the node passes on box meshes of about 1k..1M tets in float and double on
// 1 and 2 threads, whole steps, grid vs random vs renumbered memory order, and whole scenes
// (the default scene, the cantilever, a 100k-tet body). Each case becomes a Record with its
// speed, its cost model and its fraction of the roofline; summary records give the ratios the
// performance targets talk about (2-thread speed-up, float/double, random/grid order).
#pragma once
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "pliant/perf/machine.hpp"

namespace pliant::perf {

inline constexpr double kNone = std::numeric_limits<double>::quiet_NaN();

struct Record {
  std::string case_name;  // "element", "gather", "integrate", "gather_integrate", "step", "scene/<name>",
                          // "machine/triad", "machine/peak_fma", "machine/peak_mul_add", "summary/<what>"
  std::string kind;       // "machine" | "kernel" | "step" | "scene" | "summary"
  std::string model, precision, order, size;  // size: "1k".."1M" for box cases
  std::size_t tets = 0, nodes = 0;
  int threads = 1;
  double ns_per_tet = kNone, mtets_per_s = kNone;
  double bytes_per_tet = kNone, gb_per_s = kNone;         // compulsory traffic model, and its rate
  double flops_per_tet = kNone, gflop_per_s = kNone;
  double footprint_mib = kNone;                            // working set of the case
  double roof_gb_per_s = kNone, roof_gflop_per_s = kNone;  // triad at that working set, FMA peak
  double roof_ns_per_tet = kNone, roofline_fraction = kNone;
  std::string bound;                                       // "memory" | "compute": the lower roof
  double steps_per_s = kNone, step_p50_us = kNone, step_p99_us = kNone, step_max_us = kNone;
  double realtime_factor = kNone;                          // scenes: simulated s per wall s
  std::size_t samples = 0;
  double others_busy = kNone;                              // cores used by other processes meanwhile
  // Cases on 2 threads or more: the cache-line round trip between two threads (ns,
  // measure_round_trip) just before and just after the case, the larger. On 2-vCPU guests it went
  // from about 90 to about 450 ns and back within minutes (the host moving the vCPUs apart), and
  // small bodies' 2-thread steps with it (the default scene 53 against 87 us): figures compare
  // only at like round trips.
  double round_trip_ns = kNone;
  // Step and scene cases: the p99 of fixed arithmetic lasting the case's median step, timed as
  // many times (up to 20 000) on as many threads right after it (time_fixed_work, machine.hpp):
  // the tail the machine alone gives work of that length. A step p99 near it is the machine's.
  double floor_p99_us = kNone;
  double value = kNone;                                    // machine and summary records
  std::string unit, note;
};

struct SuiteOptions {
  bool quick = false;
  std::vector<int> threads{1, 2};
  std::string scenes_dir;       // holding default.json and cantilever.json; "" = search
  double max_wait_s = 30;       // waiting for the machine to be idle, per gate
  double idle_threshold = 0.2;  // cores used by others below which the machine counts as idle
  bool scenes = true;
  bool kernels = true;           // machine limits are always measured; false skips the boxes' kernels, steps and orders
  std::function<void(const std::string&)> progress;  // one line per stage, or empty
};

// Runs the set, passing each record to `emit` as soon as it is measured.
void run_suite(const SuiteOptions& options, const std::function<void(const Record&)>& emit);

// Where the shipped scenes are: `dir` if given, else ./scenes, else the source tree's.
std::string find_scenes_dir(const std::string& dir);

std::string csv_header();
std::string csv_row(const Record& r);
// A human-readable table of the records (machine, kernels, steps, scenes, summary).
std::string format_table(const std::vector<Record>& records);

}  // namespace pliant::perf
