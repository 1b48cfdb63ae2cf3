// The plan `pliant run` prints before stepping (run_plan.hpp): sizes, the step and why, the number
// of steps and files, the warm-up estimate, and the warnings that catch unit mistakes (a body in
// mm read as metres, a cell size in the wrong unit, a run of more than 10 million steps) before
// any meshing or stepping.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <string>

#include <fmt/format.h>

#include "pliant/run.hpp"
#include "pliant/run_plan.hpp"
#include "pliant/scene.hpp"

namespace pliant {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;

SceneDef box_scene(Vec3d max, double duration = 0.01) {
  SceneDef s;
  s.duration = duration;
  BodyDef b;
  b.name = "block";
  b.mesh.max = max;
  b.mesh.cells = {8, 2, 2};
  RegionDef clamp;
  clamp.min = {-1e9, -1e9, -1e9};
  clamp.max = {1e-9, 1e9, 1e9};
  b.fixed.push_back(clamp);
  s.bodies.push_back(b);
  s.world.threads = 1;
  return s;
}

std::string all_text(const std::vector<std::string>& lines) {
  std::string s;
  for (const auto& l : lines) s += l + "\n";
  return s;
}

std::vector<std::string> kinds(const std::vector<PlanWarning>& w) {
  std::vector<std::string> k;
  for (const auto& x : w) k.push_back(x.kind);
  return k;
}

TEST(RunPlan, ABodyInMillimetresReadAsMetresIsWarnedAboutBeforeAnyMeshing) {
  // A 200 x 50 x 50 mm block written in mm, without a scale: 200 m.
  const SceneDef mm = box_scene({200, 50, 50});
  const ScenePreview preview = preview_scene(mm);
  ASSERT_EQ(preview.warnings.size(), 1u);
  EXPECT_EQ(preview.warnings[0].kind, "size");
  EXPECT_EQ(preview.warnings[0].body, "block");
  EXPECT_THAT(preview.warnings[0].text, HasSubstr("body 'block' is 200 m across"));
  EXPECT_THAT(preview.warnings[0].text, HasSubstr("\"scale\": 0.001"));
  // The same block in metres: no warning.
  EXPECT_TRUE(preview_scene(box_scene({0.2, 0.05, 0.05})).warnings.empty());
  // And a body under 1 mm.
  const ScenePreview tiny = preview_scene(box_scene({0.0008, 0.0002, 0.0002}));
  ASSERT_EQ(tiny.warnings.size(), 1u);
  EXPECT_THAT(tiny.warnings[0].text, HasSubstr("body 'block' is only 800 um across"));
}

TEST(RunPlan, TheBuiltWorldGivesTheSameWarningOnceAndThePlanSaysWhy) {
  const SceneDef mm = box_scene({200, 50, 50});
  const ScenePreview preview = preview_scene(mm);
  World w = make_world(mm);
  const RunPlan plan = plan_run(w, mm, {}, &preview);
  EXPECT_EQ(kinds(plan.warnings), std::vector<std::string>{"size"});  // not twice
  // Without the preview, the world alone finds it.
  EXPECT_EQ(kinds(plan_run(w, mm, {}).warnings), std::vector<std::string>{"size"});
  const std::string text = all_text(plan_lines(plan));
  EXPECT_THAT(text, HasSubstr("plan: 1 body, 81 nodes, 192 tets, double precision, 1 thread\n"));
  EXPECT_THAT(text, HasSubstr("body 'block': box of 8 x 2 x 2 cells, 6 tets each; 81 nodes, 192 tets, 1 level, 200 m x 50 m x 50 m"));
  EXPECT_THAT(text, HasSubstr("the stable bound (Courant 0.5 x 2/omega_max"));
  EXPECT_THAT(text, HasSubstr("warning: body 'block' is 200 m across"));
}

TEST(RunPlan, CountsStepsAndFilesAndEstimatesTheWallTime) {
  SceneDef s = box_scene({0.2, 0.05, 0.05}, 0.05);
  ProbeDef p;
  p.name = "tip";
  p.body = "block";
  p.point = {0.2, 0.025, 0.025};
  s.probes.push_back(p);
  s.output.vtu_every = 0.01;
  World w = make_world(s);
  RunPlan plan = plan_run(w, s, {});
  EXPECT_EQ(plan.steps, steps_for(0.05, w.dt()));
  EXPECT_GE(double(plan.steps) * w.dt(), 0.05 - 1e-12);
  EXPECT_EQ(plan.dt, w.dt());
  EXPECT_FALSE(plan.dt_given);
  EXPECT_EQ(plan.limiting_body, "block");
  EXPECT_EQ(plan.outputs, (std::vector<std::string>{"summary.json", "probes.csv", "series.pvd + vtu/ (6 frames x 1 body)"}));
  EXPECT_EQ(plan.warm_up_steps, 0);
  const std::int64_t steps_before = w.steps();
  measure_warm_up(w, plan, 0.05);
  EXPECT_GE(plan.warm_up_steps, 2);
  EXPECT_EQ(w.steps() - steps_before, plan.warm_up_steps);  // it stepped the world it was given
  EXPECT_GT(plan.seconds_per_substep, 0);
  EXPECT_NEAR(plan.estimated_wall_s, double(plan.steps) * plan.seconds_per_substep, 1e-12 * plan.estimated_wall_s);
  EXPECT_THAT(all_text(plan_lines(plan)), HasSubstr("estimate: "));
  // A duration override counts.
  RunOptions longer;
  longer.duration = 0.1;
  EXPECT_EQ(plan_run(w, s, longer).steps, steps_for(0.1, w.dt()));
}

TEST(RunPlan, AnExplicitStepAboveTheBoundSaysItIsSplit) {
  SceneDef s = box_scene({0.2, 0.05, 0.05});
  s.world.time_step.dt = 1e-3;
  s.world.time_step.substep = true;
  World w = make_world(s);
  const RunPlan plan = plan_run(w, s, {});
  ASSERT_GT(plan.substeps, 1);
  EXPECT_THAT(all_text(plan_lines(plan)),
              HasSubstr("dt 0.001 s as given, above the stable bound"));
  EXPECT_THAT(all_text(plan_lines(plan)), HasSubstr(fmt::format("each step split into {} sub-steps", plan.substeps)));
}

TEST(RunPlan, ProgressCountsSubStepsAndStartsWithTheEstimate) {
  // An explicit step above the bound split into sub-steps: the progress reports count them (the
  // ETA is per sub-step), the first report is the estimate, then reports follow every
  // progress_every seconds of wall time (both shortened here: 1k tets, about 0.1 s of stepping).
  SceneDef s = box_scene({0.2, 0.05, 0.05}, 0.1);
  s.bodies[0].mesh.cells = {16, 4, 4};
  s.world.time_step.substep = true;
  s.world.time_step.adapt = false;
  World probe = make_world(s);
  s.world.time_step.dt = 3.5 * probe.stable_dt();  // 4 sub-steps per step
  World w = make_world(s);
  ASSERT_EQ(w.substeps(), 4);
  std::vector<RunProgress> reports;
  RunOptions o;
  o.write_files = false;
  o.progress_every = 0.002;
  o.estimate_after = 0.005;
  o.on_progress = [&](const RunProgress& p) { reports.push_back(p); };
  const RunSummary r = run_world(s, w, o);
  ASSERT_GE(reports.size(), 2u) << "stepping took " << r.wall_time_s << " s";  // measured: 0.03 s, 14 reports
  EXPECT_TRUE(reports[0].estimate);
  EXPECT_GE(reports[0].wall_s, o.estimate_after);
  for (std::size_t i = 0; i < reports.size(); ++i) {
    const RunProgress& p = reports[i];
    EXPECT_EQ(p.estimate, i == 0);
    EXPECT_EQ(p.substeps, 4);
    EXPECT_EQ(p.substeps_done, 4 * p.step);
    EXPECT_EQ(p.steps, r.steps);
    EXPECT_LT(p.step, p.steps);
    EXPECT_GT(p.eta_s, 0);
    if (i > 0) {
      EXPECT_GT(p.step, reports[i - 1].step);
    }
  }
}

TEST(RunPlan, MoreThanTenMillionStepsIsWarnedAbout) {
  const SceneDef s = box_scene({0.2, 0.05, 0.05}, 1e4);  // 10^4 s at dt ~ 2e-4 s: 4.5e7 steps
  World w = make_world(s);
  const RunPlan plan = plan_run(w, s, {});
  ASSERT_EQ(kinds(plan.warnings), std::vector<std::string>{"steps"});
  EXPECT_THAT(plan.warnings[0].text, HasSubstr("more than 10 million"));
  EXPECT_TRUE(plan_run(w, box_scene({0.2, 0.05, 0.05}, 1.0), {}).warnings.empty());
}

TEST(RunPlan, ACellSizeUnderOnePercentOfTheBodyIsWarnedAboutBeforeMeshing) {
  // The shipped organ is 20 cm long; 1 mm cells would be 0.5% of it (about 4 million tets).
  SceneDef s;
  BodyDef b;
  b.name = "organ";
  b.mesh.kind = MeshSourceDef::Kind::implicit;
  b.mesh.shape = "organ";
  b.mesh.cell_size = 0.001;
  s.bodies.push_back(b);
  const ScenePreview p = preview_scene(s);
  ASSERT_EQ(kinds(p.warnings), std::vector<std::string>{"cell_size"});
  EXPECT_THAT(p.warnings[0].text, HasSubstr("body 'organ': cell_size 1 mm is"));
  ASSERT_EQ(p.bodies.size(), 1u);
  EXPECT_TRUE(p.bodies[0].needs_meshing);
  // Mesh_3 gives about 4.3 V / s^3: 3.9 million for the organ's 0.9 litre at 1 mm.
  EXPECT_GT(p.bodies[0].estimated_tets, 3.5e6);
  EXPECT_LT(p.bodies[0].estimated_tets, 4.3e6);
  EXPECT_THAT(preview_line(p.bodies[0]), HasSubstr("body 'organ': implicit shape 'organ', cell_size 0.001 m"));
  b.mesh.cell_size = 0.01;
  s.bodies[0] = b;
  EXPECT_TRUE(preview_scene(s).warnings.empty());
}

}  // namespace
}  // namespace pliant
