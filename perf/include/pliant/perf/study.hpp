// Parameter studies (`pliant study`, issue 3 §2): run one scene over a grid of settings, measure
// a quantity in every run, compare it with a reference (an analytic value, or the finest run) and
// with the run's cost, and mark the Pareto front of cost against error.
//
// The grid comes from sweeps `PATH=V1|V2|...` (PATH addresses any scene value, each V is JSON; see
// apply_scene_overrides in scene.hpp). What to measure and the analytic answer live in a reference
// file beside the scene, SCENE.reference.json (the scene format rejects unknown keys); its format
// is documented in docs/accuracy.md. Every run builds its own World from the edited scene, so runs
// are independent, and their measured values are deterministic (bitwise, for any thread count).
#pragma once
#include <array>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <limits>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "pliant/defs.hpp"

namespace pliant::study {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// ---- sweeps -------------------------------------------------------------------------------------

// One `--sweep PATH=V1|V2|...`. Values are split at `|` outside JSON strings and brackets, so
// `"a|b"` is one value. Each value must be JSON.
struct Sweep {
  std::string text;                 // as given
  std::string path;                 // e.g. "bodies[0].mesh.box.cells"
  std::vector<std::string> values;  // JSON texts, trimmed, e.g. "[20,2,2]", "\"linear\"", "0.3"
  std::string short_name() const;   // the last key of the path, e.g. "cells" (or "gravity[2]")
};

// Throws InputError naming the sweep ("--sweep 'x': ...") when it is malformed: no `=`, empty
// path, an empty value, a value that is not JSON, a repeated value.
Sweep parse_sweep(std::string_view text);
// A sweep's path as the scene edit reads it, for comparing two sweeps: indices without leading
// zeros ("bodies[00].model" -> "bodies[0].model").
std::string canonical_sweep_path(std::string_view path);

// The grid of runs: the cartesian product of the sweeps, the last sweep varying fastest. Each point
// is one override "PATH=VALUE" per sweep. No sweep: one point with no override.
std::vector<std::vector<std::string>> expand_grid(const std::vector<Sweep>& sweeps);

// ---- what is measured ---------------------------------------------------------------------------

enum class MeasureKind {
  probe_final,    // a displacement component of a probe at the end of the run (m)
  probe_mean,     // its time average: over [from, end], or over whole periods of its oscillation
  probe_period,   // the period of its oscillation (s), or 1/period (Hz), or distance/period (m/s)
  probe_arrival,  // when it first reaches `level` (s, minus `delay`), or distance/(time - delay) (m/s)
  // The RMS over [from, end] of the probe's distance to the same probe in the finest run (m), its
  // position sampled every `every` s (default 1 ms, linear between steps); its error is that RMS
  // over the finest run's largest displacement of the probe. Needs reference "finest". What the
  // adaptivity tables measure (docs/adaptivity.md), where a mean forgives a wrong trajectory.
  probe_rms,
  strain,         // mean engineering strain along `axis` of a body's nodes in `region` (slope of a fit)
  poisson_ratio,  // -(mean lateral strain)/(axial strain) of those nodes
  volume_change,  // V/V0 - 1 of a whole body
};
const char* to_string(MeasureKind k);

// MeasureDef::axis of a probe measure that takes the length of the displacement, |u| (m): what a
// study without a reference file measures at each probe.
constexpr int kDisplacementLength = 3;

struct MeasureDef {
  MeasureKind kind = MeasureKind::probe_final;
  std::string probe;                 // probe kinds: the probe's name
  std::string body;                  // body kinds: the body's name ("" = the first body)
  int axis = 0;                      // 0, 1, 2 for "x", "y", "z"; probe kinds: kDisplacementLength
  std::vector<int> lateral;          // poisson_ratio: the lateral axes (default: the other two)
  std::optional<std::array<Vec3d, 2>> region;  // body kinds: rest-position box (default: all nodes)
  std::string report;                // probe_period: period|frequency|speed; probe_arrival: time|speed
  double distance = 0;               // m, for report "speed"
  double level = 0;                  // probe_arrival: displacement to reach (m, signed)
  double delay = 0;                  // probe_arrival: subtracted from the arrival time (s)
  bool whole_periods = false;        // probe_mean: average over whole periods of the oscillation
  std::optional<double> from;        // s: ignore samples before; body kinds: average from there on
  double every = 0;                  // s: body kinds with `from`: sampling interval (0: 50 samples)
  double scale = 1;                  // the reported value is scale * measured
  // distance, level, delay and scale may be given as expressions of the reference file's
  // variables (strings); resolve_measure evaluates them for one run.
  std::map<std::string, std::string> expressions;
};

// A measure whose expression fields are evaluated with these variables.
MeasureDef resolve_measure(const MeasureDef& m, const std::map<std::string, double>& variables,
                           const std::string& where);

// A variable of reference expressions: a constant, or a value read from the (edited) scene.
struct VariableDef {
  std::optional<double> value;       // a constant
  std::string path;                  // a scene path, e.g. "bodies[0].material.young"
  std::optional<double> fallback;    // used when the path is absent from the scene
  std::string expression;            // or an expression of the variables defined before it
};

struct QuantityDef {
  std::string name = "value";
  std::string unit, formula, notes;
  MeasureDef measure;
  std::string reference;             // an expression (a number is one); empty: none
};

// A quantity named after what its measure is, with its unit, for a measure given alone
// (--measure, or the probes of a scene without a reference file): "tip_z" (m), "tip_z_period" (s),
// "tip_z_frequency" (Hz), "tip_displacement" (m, the length), "bar_strain_x", "bar_volume_change".
QuantityDef quantity_for_measure(const MeasureDef& m);

// SCENE.reference.json: {"description", "variables": {NAME: number | "scene.path" |
// {"path", "default"} | {"expr"}}, "quantities": [{"name", "unit", "measure": {...},
// "reference": number | "expression", "formula", "notes"}]} or, for one quantity, its keys at the
// top level. Unknown keys are errors; keys starting with `_` are comments.
struct ReferenceFile {
  std::string description;
  std::vector<std::pair<std::string, VariableDef>> variables;  // in file order
  std::vector<QuantityDef> quantities;
  std::string source;                // the file, for messages
};

ReferenceFile parse_reference(std::string_view json_text, const std::string& source);
ReferenceFile load_reference_file(const std::filesystem::path& path);
// scenes/validation/slender_bar.json -> scenes/validation/slender_bar.reference.json
std::filesystem::path reference_path_for(const std::filesystem::path& scene);
// A measure alone (the `measure` object of a quantity), for `pliant study --measure JSON`.
MeasureDef parse_measure(std::string_view json_text, const std::string& source);

// Arithmetic on numbers and variables: + - * / ^, parentheses, unary minus, pi, and the functions
// sqrt abs exp log sin cos tan pow min max. Throws InputError naming `where` on a syntax error or
// an unknown variable.
double evaluate_expression(std::string_view expr, const std::map<std::string, double>& variables,
                           const std::string& where);
// The variables of a reference file evaluated on a scene (JSON text after the overrides).
std::map<std::string, double> bind_variables(const ReferenceFile& ref, std::string_view scene_json);

// ---- signals ------------------------------------------------------------------------------------

// Times at which y crosses `level`, one per swing: a crossing counts once y has gone beyond
// level +- band on the other side (so ringing near the level is not counted twice); the time is
// the last raw crossing before that, interpolated linearly.
std::vector<double> level_crossings(const std::vector<double>& t, const std::vector<double>& y, double level,
                                    double band);

// An oscillation about an unknown mean: the mean (exact time average of the piecewise-linear
// signal over whole periods) and the period (from the crossings of that mean), refined from
// (max + min) / 2. NaN when fewer than one whole period was seen.
struct Oscillation {
  double mean = kNaN, period = kNaN, amplitude = kNaN;
  int periods = 0;
};
Oscillation analyse_oscillation(const std::vector<double>& t, const std::vector<double>& y,
                                double hysteresis = 0.25);

// ---- runs ---------------------------------------------------------------------------------------

struct RunRecord {
  std::vector<std::string> settings;   // one JSON value per sweep
  std::string status = "ok";           // "ok" | "diverged" | "invalid" (the world could not be built)
  std::string message;
  std::string model, precision;
  int threads = 1;
  std::size_t nodes = 0, tets = 0;     // of each body's mesh (a multiresolution body's finest level)
  std::int64_t steps = 0;
  int substeps = 1;
  double dt = 0, simulated_time = 0;
  double setup_s = 0;                  // building the world (s)
  double wall_s = 0;                   // stepping only, measurements excluded (s); the least over repeats
  int repeats = 1;                     // short runs are repeated to time them (StudyOptions::min_time)
  std::vector<double> values;          // per quantity (NaN: not measurable, e.g. no whole period)
  // Per quantity: a probe_rms quantity's track, the probe's displacement x y z (m) at each sample
  // time; empty for the other kinds. finish_study compares it with the finest run's.
  std::vector<std::vector<double>> tracks;
  std::vector<double> references;      // per quantity
  std::vector<double> errors;          // per quantity: value/reference - 1 (value - reference if reference = 0)
  double error = kNaN;                 // max |errors| (NaN if any is NaN)
  bool pareto = false;                 // on the front of cost against error
  bool is_reference = false;           // the finest run, when it is the reference
  // Tets computed over the run (World::tick_stats): tet_steps for a one-level body, the stepped
  // tets of every level at their own periods for a multiresolution one (adaptive or not).
  double tet_updates = 0;
  double wall_per_sim() const { return simulated_time > 0 ? wall_s / simulated_time : kNaN; }
  double tet_steps() const { return double(tets) * double(steps) * double(substeps); }
};

// Builds the scene's world, steps it for its duration and measures the quantities. A divergence
// gives status "diverged" and NaN values; an InputError from building the world, "invalid".
RunRecord run_measured(const SceneDef& scene, const std::vector<QuantityDef>& quantities,
                       std::optional<int> threads);

// Checks that the measures name probes and bodies of the scene (InputError naming both files).
void check_measures(const std::vector<QuantityDef>& quantities, const SceneDef& scene, const std::string& source);

// ---- studies ------------------------------------------------------------------------------------

// The cost of the Pareto front: wall s per simulated s, tets x steps, or tets computed (what a
// multiresolution body steps: tet-steps would count its finest mesh whatever level it runs).
enum class CostKind { wall, tet_steps, tet_updates };
std::string to_string(CostKind k);                  // "wall" | "tet-steps" | "tet-updates"
CostKind parse_cost(const std::string& text);       // the same; InputError naming the choices

struct StudyOptions {
  std::filesystem::path scene;
  std::string scene_label;             // how the reports name the scene ("" = `scene`)
  std::vector<std::string> sweeps;     // `PATH=V1|V2|...`
  // "" = the reference file beside the scene; "finest" = the measured value of the finest run;
  // a number = that reference (one quantity only); anything else = a reference file.
  std::string reference;
  std::string measure;                 // JSON of one measure, replacing the reference file's quantities
  std::filesystem::path out_dir = "study";
  bool write_files = true;             // DIR/study.csv and DIR/study.md
  std::optional<int> threads = 1;      // per run (empty: the scene's)
  CostKind cost = CostKind::wall;      // the cost of the Pareto front
  // A run whose stepping took less than this is run again (up to 5 times in all) and its least
  // wall time kept, so that the cost of small runs is not timer noise. The repeats must measure
  // bitwise the same values (else the run's message says so).
  double min_time = 0.3;               // s
  std::function<void(const std::string&)> progress;  // a line per run
};

struct StudyResult {
  std::string scene;                   // as given
  std::vector<std::string> notes;      // what the study chose for the user (e.g. no reference file)
  std::string description;
  std::vector<Sweep> sweeps;
  std::vector<QuantityDef> quantities;
  std::string reference_kind;          // "analytic" | "finest" | "value"
  CostKind cost = CostKind::wall;
  std::vector<RunRecord> runs;
  int finest = -1;                     // index of the reference run ("finest")
  double wall_total_s = 0;
  std::vector<std::string> files;      // written
};

// Runs the whole grid. Bad sweeps, references or scene values throw InputError before any run.
StudyResult run_study(const StudyOptions& options);

// run_study in its parts, for studies whose runs are separate processes (study_jobs.hpp).
// A point of the grid: its edited scene, its measures resolved with that scene's variables.
struct StudyPoint {
  SceneDef scene;
  std::vector<QuantityDef> quantities;
  std::vector<std::string> settings;   // one JSON value per sweep
  std::vector<double> references;      // per quantity (NaN with reference "finest")
};
struct PreparedStudy {
  StudyResult result;                  // everything but the runs
  std::vector<StudyPoint> points;      // in grid order (the last sweep fastest)
};
// Parses the sweeps, the reference and every scene of the grid (InputError before anything runs).
PreparedStudy prepare_study(const StudyOptions& options);
// Runs point i (repeated while shorter than options.min_time), with its settings and references.
RunRecord run_point(const PreparedStudy& prepared, std::size_t i, const StudyOptions& options);
// "[3/8] cells=[20,1,1]: tip_z = -0.0123 (ref -0.0125, -1.6%); 80 tets, 400 steps, ..."
std::string progress_line(const StudyResult& result, const RunRecord& run, std::size_t i, std::size_t n);
// DIR/study.csv and DIR/study.md (their paths appended to result.files).
void write_study_files(StudyResult& result, const std::filesystem::path& out_dir);

// Errors and the front for already measured runs (run_study calls it; exposed for tests): with
// reference "finest", takes the references from the run of most tet-steps.
void finish_study(StudyResult& result);

// Marks i when no other point is at most as costly and at most as wrong, and better in one of the
// two. Errors closer than `tolerance` times the larger count as equal (the 6th digit of an error is
// not "more accurate"). Points with a NaN or infinite cost or error are never on the front.
std::vector<bool> pareto_front(const std::vector<double>& cost, const std::vector<double>& error,
                               double tolerance = 0.01);

// DIR/study.csv: run, one column per sweep (its path), status, run_model, run_precision,
// run_threads (what the run used), nodes, tets, dt, steps, substeps, simulated_time, setup_s,
// wall_s, repeats, wall_per_sim_s, tet_steps, then NAME_value, NAME_reference, NAME_error per
// quantity, error, pareto, reference_run, message.
std::string study_csv(const StudyResult& result);
// DIR/study.md: the quantities and their references, a table per run, the convergence table of
// the first sweep against the others per quantity, and the Pareto front.
std::string study_markdown(const StudyResult& result);

// "cells=[20,2,2], model=linear"
std::string settings_label(const std::vector<Sweep>& sweeps, const std::vector<std::string>& settings);

}  // namespace pliant::study
