// What a run is about to do, said before it starts: `pliant run` prints it before stepping and
// `pliant run --dry-run` prints only it. Sizes, the time step and why, the number of steps, an
// estimate of the wall time from a short timed warm-up, the files the run will write, and
// warnings when the numbers look like a unit mistake (a mesh in mm read as metres, ...).
//
// Two stages, because meshing a surface can take minutes: preview_scene() reads only what the
// scene says (and a surface file's vertices), so that its warnings come before any meshing;
// plan_run() describes the built world.
#pragma once
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "pliant/defs.hpp"
#include "pliant/run.hpp"
#include "pliant/world.hpp"

namespace pliant {

// Thresholds of the unit-mistake warnings.
inline constexpr double kSmallestBody = 1e-3;      // m: a body whose largest side is below is suspect
inline constexpr double kLargestBody = 100;        // m: and above
inline constexpr double kMostSteps = 1e7;          // steps in a run
inline constexpr double kSmallestCellFraction = 0.01;  // cell size over the body's largest side

// A warning about one body ("" for the whole run), of one kind: "size", "cell_size", "steps".
struct PlanWarning {
  std::string kind, body, text;
};

// What the scene says of a body before its mesh is built.
struct BodyPreview {
  std::string name;
  std::string source;            // e.g. "box 40 x 4 x 4 cells of 6 tets", "surface liver.obj x 0.001, cell_size 0.005 m"
  bool needs_meshing = false;    // surface or implicit: building it runs the mesher
  bool bounds_known = false;     // box, implicit, and surface (read here; needs CGAL)
  Vec3d min{}, max{};            // m, after scale and translate
  double estimated_tets = 0;     // surface and implicit, when the volume is known; else 0
};
struct ScenePreview {
  std::vector<BodyPreview> bodies;
  std::vector<PlanWarning> warnings;
};
// Cheap: builds no mesh (a surface file is read for its bounding box and volume, with CGAL).
// Never throws for a surface it cannot read: the mesher will say what is wrong with it.
ScenePreview preview_scene(const SceneDef& scene);

struct BodyPlan {
  std::string name, source, model;
  Vec3d min{}, max{};             // m, rest bounding box
  std::size_t nodes = 0, tets = 0;
  int levels = 1;
  double h_min = 0;               // m, smallest tet altitude (finest level)
  double omega_geometric = 0;     // rad/s, 2 c_p / h_min
  double omega_measured = 0;      // rad/s, highest mode of M^-1 K at rest (Lanczos)
  double omega_max = 0;           // rad/s, the frequency the step is built for
  double stable_dt = 0;           // s
};

struct RunPlan {
  std::vector<BodyPlan> bodies;
  std::string precision;
  int threads = 1;
  double duration = 0;            // s
  double dt = 0, stable_dt = 0;   // s
  double courant = 0.5;
  bool dt_given = false;          // time_step.dt was a number (else "auto": the stable bound)
  int substeps = 1;               // sub-steps per step at load
  bool adapt = true;              // time_step.adapt: more sub-steps where the elements stiffen
  std::int64_t steps = 0;
  std::string limiting_body;      // the body whose bound sets stable_dt
  std::vector<std::string> outputs;  // what the run writes under its folder
  std::vector<PlanWarning> warnings;
  // From the warm-up (measure_warm_up or the run's first steps); 0 when not measured.
  std::int64_t warm_up_steps = 0;
  double warm_up_wall_s = 0, seconds_per_substep = 0, estimated_wall_s = 0;
};

// The plan of running `scene` on `world` (built from it by make_world) with `options`
// (duration, output). Warnings already in `preview` (same kind and body) are not repeated.
RunPlan plan_run(const World& world, const SceneDef& scene, const RunOptions& options,
                 const ScenePreview* preview = nullptr);

// Times the first steps of `world` (at least 2, until `seconds` of wall time have passed or the
// run's steps are done) and fills the plan's estimate. Steps the world: use it on a world that is
// then thrown away (`pliant run --dry-run`) or continued. Throws DivergenceError as step() does.
void measure_warm_up(World& world, RunPlan& plan, double seconds = kEstimateAfter);

// The plan as lines of text (no trailing newlines), warnings last, each starting "warning: ".
std::vector<std::string> plan_lines(const RunPlan& plan);
std::string preview_line(const BodyPreview& body);  // "body 'x': surface ... spans ..., about N tets"
std::string estimate_line(double estimated_wall_s, std::int64_t steps_timed, double seconds_per_substep);

}  // namespace pliant
