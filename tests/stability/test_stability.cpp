// The stability harness (issue 3 §3, §5): the energy criterion, the cell outcomes, the ctest
// subset of the matrix and a short stress run with seed reproducibility.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fmt/format.h>

#include "pliant/meshing.hpp"
#include "pliant/perf/stability.hpp"

using namespace pliant;
using namespace pliant::stability;
using ::testing::HasSubstr;

namespace {

BodyDef beam(ForceModel m) {
  BodyDef b;
  b.name = "beam";
  b.model = m;
  b.material.young = 1e6;
  b.material.poisson = 0.3;
  RegionDef fixed;
  fixed.min = {0, -1, -1};
  fixed.max = {0, 1, 1};
  b.fixed.push_back(fixed);
  b.mesh.min = {0, 0, 0};
  b.mesh.max = {0.1, 0.02, 0.02};
  b.mesh.cells = {5, 1, 1};
  return b;
}

CellSpec cell(ForceModel m, double factor, bool substep = false) {
  CellSpec c;
  c.model = m;
  c.dt_factor = factor;
  c.substep = substep;
  c.steps = 300;
  return c;
}

}  // namespace

TEST(EnergyMonitor, ConservativeRunIsBounded) {
  World w;
  w.add_body(beam(ForceModel::corotational));
  EnergyMonitor m;
  m.start(w);
  for (int i = 1; i <= 400; ++i) {
    w.step();
    m.after_step(w);
    if (i % 10 == 0) ASSERT_TRUE(m.sample(w)) << m.why();
  }
  EXPECT_TRUE(m.finish()) << m.why();
  EXPECT_LT(m.peak_ratio(), 2.0);
}

TEST(EnergyMonitor, EnergyFromNowhereIsCaught) {
  World w;
  w.add_body(beam(ForceModel::linear));
  EnergyMonitor m;
  m.start(w);
  for (int i = 0; i < 20; ++i) w.step();
  ASSERT_TRUE(m.sample(w));
  auto& L = w.level<double>(0);
  for (std::size_t n = 0; n < L.node_count; ++n)
    if (L.inv_mass[n] > 0) L.v[2][n] += 10.0;  // 10 m/s out of nothing
  w.step();
  EXPECT_FALSE(m.sample(w));
  EXPECT_THAT(m.why(), HasSubstr("energy unbounded"));
}

TEST(EnergyMonitor, TwiceTheBudgetIsNotBounded) {
  // A conservative run keeps M within (omega dt)^2 / 8 of its budget S (a third at most at the
  // default step); doubling it is an energy gain the criterion must report, not a "stable" run.
  World w;
  w.add_body(beam(ForceModel::linear));
  EnergyMonitor m;
  m.start(w);
  for (int i = 1; i <= 40; ++i) {
    w.step();
    m.after_step(w);
  }
  ASSERT_TRUE(m.sample(w)) << m.why();
  const double s = m.scale(), before = w.energies().kinetic + w.energies().elastic;
  ASSERT_GT(s, 0);
  auto& L = w.level<double>(0);
  double free_mass = 0;
  for (std::size_t n = 0; n < L.node_count; ++n)
    if (L.inv_mass[n] > 0) free_mass += L.mass[n];
  // A uniform velocity along y carrying 2 S - M of kinetic energy: M becomes about 2 S.
  const double vy = std::sqrt(2 * std::max(0.0, 2 * s - before) / free_mass);
  for (std::size_t n = 0; n < L.node_count; ++n)
    if (L.inv_mass[n] > 0) L.v[1][n] += vy;
  w.step();
  m.after_step(w);
  EXPECT_FALSE(m.sample(w)) << "peak " << m.peak_ratio();
  EXPECT_THAT(m.why(), HasSubstr("energy unbounded"));
}

TEST(EnergyMonitor, StagnantFloatPositionsAreNotAnEnergyGain) {
  // A free body falling in float with a tiny step: dt v stays below half the float spacing of
  // the coordinates (0.15 m: 7.5e-9 m), so x + dt v rounds back to x. The velocities gain the
  // energy gravity gives, the positions (and the potential computed from them) do not move: the
  // criterion must count the work of gravity from the velocities (docs/stress.md, scene 14874).
  WorldDef wd;
  wd.precision = Precision::float32;
  wd.time_step.dt = 1e-7;
  World w(wd);
  BodyDef b = beam(ForceModel::corotational);
  b.fixed.clear();
  b.material.young = 1e3;
  b.mesh.min = {0.1, 0.1, 0.1};
  b.mesh.max = {0.2, 0.12, 0.12};
  w.add_body(b);
  EnergyMonitor m;
  m.start(w);
  for (int i = 1; i <= 1000; ++i) {
    w.step();
    m.after_step(w);
    if (i % 20 == 0) ASSERT_TRUE(m.sample(w)) << "step " << i << ": " << m.why();
  }
  EXPECT_TRUE(m.finish()) << m.why();
  const Energies e = w.energies();
  EXPECT_GT(e.kinetic, 1e-8);                        // 1/2 M (g t)^2 = 1.9e-8 J, t = 1e-4 s
  EXPECT_LT(std::abs(e.potential), 1e-12 * e.kinetic);  // a uniform fall strains nothing (measured 0)
}

TEST(EnergyMonitor, GhostsAndSplitsAreNotDrivenWork) {
  // A free adaptive block (no fixed or prescribed node) with a kink: its half x > 0 (body frame)
  // starts 5% wider, so the coarse tets across x = 0 jump in F by 0.05 and split there, with
  // ghosts around the split part; then everything is forced coarse, and the kink splits again.
  // The nodes change roles (free, ghost, inactive) and their counts with them. Nothing drives
  // the block, so the monitor's work of driven nodes must stay 0: a ghost's force is internal
  // (handed to the coarse nodes it follows), and counting it would widen the energy budget.
  WorldDef wd;
  wd.gravity = {0, 0, 0};
  World w(wd);
  BodyDef b;
  b.name = "block";
  b.mesh.max = {0.1, 0.04, 0.04};
  b.mesh.cells = {10, 4, 4};
  b.mesh.tets_per_cell = 6;
  b.material.young = 1e5;
  b.material.damping.mass = 20;
  b.multiresolution.levels = 2;
  b.multiresolution.active.kind = ActiveDef::Kind::adaptive;
  b.multiresolution.active.adapt.measure = AdaptDef::Measure::absolute;  // a 1% jump: a partial split
  b.multiresolution.active.adapt.refine_above = 0.01;
  b.multiresolution.active.adapt.coarsen_below = 0;  // no merge but the forced one
  w.add_body(b);
  for (int l = 0; l < w.level_count(0); ++l) {
    Level<double>& L = w.level<double>(0, l);
    for (std::size_t n = 0; n < L.node_count; ++n)
      if (L.X[0][n] > 1e-9) L.x[1][n] = 1.05 * L.X[1][n];
  }
  EnergyMonitor m;
  m.start(w);
  std::size_t ghosts = 0;
  for (int phase = 0; phase < 3; ++phase) {
    if (phase == 1) w.force_level(0, 0);
    for (int i = 1; i <= 30; ++i) {
      w.step();
      m.after_step(w);
      ghosts = std::max(ghosts, w.level_info(0, 1).ghost_nodes);
      if (i % 10 == 0) ASSERT_TRUE(m.sample(w)) << m.why();
    }
  }
  EXPECT_TRUE(m.finish()) << m.why();
  const World::AdaptStats a = w.adapt_stats(0);
  std::printf("%lld splits, %lld merges, %lld changes, up to %zu ghosts; work of driven nodes %g J\n",
              static_cast<long long>(a.splits), static_cast<long long>(a.merges), static_cast<long long>(a.changes),
              ghosts, m.work());
  EXPECT_GE(a.changes, 3);  // split, forced merge, split again
  EXPECT_GT(a.merges, 0);
  EXPECT_GT(ghosts, 0u);
  EXPECT_EQ(m.work(), 0.0);
}

TEST(Cells, AdaptiveChangesGiveBackTheEnergyTheyAdd) {
  // The 3-level beam pushed 2 cm and released, at the loosest threshold of the matrix's adaptive
  // rows: a change of level is not energy-neutral (the coarser tets lock in bending), and before
  // each change's excess was taken back from the body's motion these cells diverged at 0.9x the
  // bound (kinetic + elastic 0.70-1.1 J against a budget of about 0.5 J, after 5-6 merges).
  for (ForceModel m : {ForceModel::linear, ForceModel::stvk, ForceModel::corotational}) {
    CellSpec c = cell(m, 0.9);
    c.scenario = "adaptive_push";
    c.young = 1e6;
    c.poisson = 0.3;
    c.refine_above = 1.0;
    c.steps = 2000;
    const CellResult r = run_cell(c);
    std::printf("%s: %s, peak %.3g of the budget, %lld splits, %lld merges\n", std::string(to_string(m)).c_str(), to_string(r.outcome),
                r.peak_ratio, static_cast<long long>(r.splits), static_cast<long long>(r.merges));
    EXPECT_EQ(r.outcome, Outcome::stable) << r.message;
    EXPECT_GT(r.merges, 0);
  }
}

TEST(Cells, OutcomesFollowTheTimeStep) {
  const CellResult s = run_cell(cell(ForceModel::corotational, 0.9));
  EXPECT_EQ(s.outcome, Outcome::stable) << s.message;
  EXPECT_EQ(s.steps_run, 300);
  EXPECT_NEAR(s.dt, 0.9 * s.bound, 1e-15);

  const CellResult r = run_cell(cell(ForceModel::corotational, 1.2));
  EXPECT_EQ(r.outcome, Outcome::refused);
  EXPECT_THAT(r.message, HasSubstr("above the stable bound"));
  EXPECT_EQ(r.steps_run, 0);

  const CellResult c = run_cell(cell(ForceModel::corotational, 1.2, true));
  EXPECT_EQ(c.outcome, Outcome::clamped) << c.message;
  EXPECT_EQ(c.substeps, 2);
  EXPECT_TRUE(s.acceptable() && r.acceptable() && c.acceptable());
}

TEST(Cells, AnAdaptiveSplitAtAPushedFaceStaysWithinTheBudget) {
  // The 3-level beam pushed at its free end: the first splits there move most of the face nodes'
  // mass into free fine nodes, which take the face's velocity. That kinetic energy was given by
  // the driven nodes; before the budget counted it, every such cell was "unbounded" at its first
  // split (1.7x at step 60 of 1000).
  CellSpec c = cell(ForceModel::corotational, 0.9);
  c.scenario = "adaptive_push";
  c.refine_above = 0.5;  // the default (relative to the peak strain)
  const CellResult r = run_cell(c);
  EXPECT_EQ(r.outcome, Outcome::stable) << r.message;
  EXPECT_GT(r.splits, 0);
  EXPECT_LT(r.peak_ratio, 1.2);  // 1.09 measured at 1000 steps (0.89 with the absolute threshold 0.01 and the
                                 // momentum correction of held bodies, both gone)
  EXPECT_LE(r.mass_error, kAdaptMassToleranceDouble);
  EXPECT_TRUE(r.acceptable());
}

TEST(Cells, ADivergenceIsNeverAcceptable) {
  // 1.0x is the default step ("dt": "auto"), and 1.2x runs only sub-stepped (below the bound):
  // no cell that runs may diverge.
  for (auto [factor, substep] : {std::pair{0.5, false}, {0.9, false}, {1.0, false}, {1.2, true}}) {
    CellResult r;
    r.spec = cell(ForceModel::stvk, factor, substep);
    r.outcome = Outcome::diverged;
    EXPECT_FALSE(r.acceptable()) << r.spec.label();
  }
}

TEST(Cells, EveryScenarioBuildsAndRunsAtTheBound) {
  for (const auto& name : scenarios()) {
    CellSpec c = cell(ForceModel::linear, 0.9);
    c.scenario = name;
    c.steps = 100;
    const CellResult r = run_cell(c);
    EXPECT_EQ(r.outcome, Outcome::stable) << name << ": " << r.message;
  }
}

// The ctest subset of `pliant stability`: the corners of the matrix (E 1e2 and 1e9, nu 0 and
// 0.499, dt 0.9x / 1.0x / 1.2x refused / 1.2x sub-stepped, every model and precision) and every
// extreme scenario at E = 1e6, nu = 0.49, 0.9x. Nothing may diverge (1.0x is the default step), and no
// cell may need known_issue(): the collapsing E = 100 Pa cantilever of stvk and corotational
// (which diverged at 0.5x before the adaptive step) must come out stable or clamped.
// `rotated_state` corotational is in the subset: it diverged while the rotation extraction
// stopped at the 180-degree saddle.
TEST(Matrix, SubsetHasNoUnexpectedOutcome) {
  MatrixOptions o;
  o.full = false;
  o.steps = 1000;
  const auto results = run_matrix(o);
  ASSERT_EQ(results.size(), 128u + 7u * 8u + 8u);
  int counts[4] = {0, 0, 0, 0}, known = 0;
  for (const auto& r : results) {
    ++counts[int(r.outcome)];
    if (r.acceptable()) continue;
    if (known_issue(r.spec)) ++known;
    ADD_FAILURE() << r.spec.label() << ": " << to_string(r.outcome) << " - " << r.message;
  }
  fmt::print("subset: {} stable, {} clamped, {} refused, {} diverged ({} of them known engine issues)\n", counts[0],
             counts[1], counts[2], counts[3], known);
  EXPECT_EQ(known, 0);
  EXPECT_EQ(counts[2], 32);  // every 1.2x cell without sub-stepping, and only those
  for (const auto& r : results)  // sub-stepped cells are clamped
    if (r.spec.substep) EXPECT_EQ(r.outcome, Outcome::clamped) << r.spec.label() << ": " << r.message;
  // The collapsing soft cantilever at 0.9x: where its elements stiffen past the trigger (2x) the
  // adaptive step sub-steps it (clamped) and says so; near-incompressible stvk (nu = 0.499) stiffens
  // less than that against its large bulk mode and runs stable at its rest step.
  int collapsing = 0, adapted = 0;
  for (const auto& r : results)
    if (r.spec.young <= 1e2 && r.spec.dt_factor == 0.9 &&
        (r.spec.model == ForceModel::stvk || r.spec.model == ForceModel::corotational)) {
      ++collapsing;
      const bool stiffened = r.max_stiffness_ratio > 2.0;
      EXPECT_EQ(r.outcome, stiffened ? Outcome::clamped : Outcome::stable) << r.spec.label() << ": " << r.message;
      EXPECT_EQ(r.adapted_steps > 0, stiffened) << r.spec.label();
      adapted += stiffened;
    }
  EXPECT_EQ(collapsing, 8);  // 2 models x 2 nu x 2 precisions
  EXPECT_GE(adapted, 6);     // all but stvk at nu = 0.499
  // The adaptive rows (3-level beam pushed and released, refine_above 0.01, 1.0x, every model
  // and precision): as expected above (no divergence, mass kept), and adaptivity at work:
  // each splits while pushed and merges after the release.
  int adaptive = 0;
  for (const auto& r : results)
    if (r.spec.scenario == "adaptive_push") {
      ++adaptive;
      EXPECT_GT(r.splits, 0) << r.spec.label();
      EXPECT_GT(r.merges, 0) << r.spec.label();
      EXPECT_GT(r.max_fine_tets, 0u) << r.spec.label();
    }
  EXPECT_EQ(adaptive, 8);
}

TEST(Stress, TheScenesOnceOpenPass) {
  // The three scenes left open by the 30-minute run of docs/stress.md (energy 12-15x the input):
  // two were the half-step kinetic energy at a turning point, one float positions stagnating.
  StressOptions o;
  o.threads = 2;
  o.mesh_dirs = {PLIANT_DATA_MESHES};
  const std::pair<std::uint64_t, const char*> scenes[] = {
      {0x7fcd6356b52f6d40ull, "msh4_cube.msh"}, {0xc52140097f6b5b63ull, "box 0.066x0.083x0.090"},
      {0xe111f992aded751eull, "raptorTetra_8418.vtu"}};
  for (const auto& [seed, what] : scenes) {
    const StressScene s = run_stress_scene(seed, 0, o);
    // The seed picks the scene from the shipped mesh set: a different scene means the set or the
    // generator changed, and the seed list must be renewed.
    ASSERT_EQ(s.description.rfind(what, 0), 0u) << "seed " << seed << " now gives: " << s.description;
    EXPECT_EQ(s.status, "ok") << s.description << ": " << s.message;
  }
}

TEST(Stress, AdaptiveScenesSplitMergeAndKeepTheirMass) {
  // The first adaptive scenes among the seeds 1, 2, 3, ... (one in five is): each must pass the
  // stress checks, its body must weigh rho x its finest volume at every sample, and together
  // they must split and merge (the pulse pushes the free end and lets it go). The first one is
  // re-run on the other thread count: the same bits.
  StressOptions o;
  o.threads = 2;
  o.mesh_dirs = {PLIANT_DATA_MESHES};
  int found = 0, both = 0;
  std::int64_t splits = 0, merges = 0;
  double worst_mass = 0;
  for (std::uint64_t seed = 1; found < 6; ++seed) {
    if (!adaptive_scene_seed(seed)) continue;
    ++found;
    const StressScene s = run_stress_scene(seed, 0, o);
    fmt::print("seed {}: {} [{}], {} splits, {} merges, mass to {:.2g}, {:.2f} s\n", seed, s.status, s.description,
               s.splits, s.merges, s.mass_error, s.wall_s);
    ASSERT_TRUE(s.adaptive) << s.description;
    // Seed 5 (undamped, 12 merges) ended 1.73x its energy budget until each change gave back the
    // energy it added.
    EXPECT_EQ(s.status, "ok") << s.description << ": " << s.message;
    splits += s.splits;
    merges += s.merges;
    both += s.splits > 0 && s.merges > 0;
    worst_mass = std::max(worst_mass, s.mass_error);
    if (found == 1) {
      const StressScene again = run_stress_scene(seed, 0, o, s.threads == 1 ? 2 : 1);
      EXPECT_EQ(again.hash, s.hash) << "threads " << s.threads << " vs " << again.threads;
      EXPECT_EQ(again.splits, s.splits);
    }
  }
  EXPECT_GE(both, 3);  // the same on every machine: no clock involved
  EXPECT_GT(splits, 0);
  EXPECT_GT(merges, 0);
  EXPECT_LE(worst_mass, kAdaptMassToleranceFloat);
}

// Runs stress scenes by seed, each checked to still be the scene named (a prefix of its
// description: the generator may not drift under a regression test) and to pass.
std::vector<StressScene> run_named_scenes(const std::vector<std::pair<std::uint64_t, const char*>>& scenes,
                                         bool tools = false, bool capsules = false) {
  StressOptions o;
  o.threads = 2;
  o.mesh_dirs = {PLIANT_DATA_MESHES};
  o.tools = tools;
  o.capsules = capsules;  // the named tool scenes before 2026-11-28 were spheres
  std::vector<StressScene> out;
  for (const auto& [seed, what] : scenes) {
    StressScene s = run_stress_scene(seed, 0, o);
    fmt::print("{:#x}: {} after {} steps, {} splits, {} merges\n", seed, s.status, s.steps, s.splits, s.merges);
    EXPECT_EQ(s.description.rfind(what, 0), 0u) << "seed " << seed << " now gives: " << s.description;
    EXPECT_EQ(s.status, "ok") << s.description << ": " << s.message;
    out.push_back(std::move(s));
  }
  return out;
}

TEST(Stress, TheStvkCantileverOnceUnboundedPasses) {
  // Scene 5726 of `pliant stress --seed 19` (docs/stress.md): a stvk box fixed at one end, 2.9 times
  // longer than thick, E = 21 kPa. The generator kept rho g D / E (0.06) under stvk's 0.1, but a
  // cantilever bends under its weight with a strain of 3 rho g L^2 / (E h) (0.45 here): its edges
  // swung between 26 % and 135 % of their length, where stvk softens and the explicit step gains
  // energy (0.3 % of the swing per second, in double as in float, at dt 1x and at 0.5x), 2.5x the
  // budget at the turn of the fifth swing.
  for (const StressScene& s : run_named_scenes({{0xd327d1aa66ac608full, "box 0.141x0.069x0.049"}}))
    EXPECT_GT(s.energy_peak, 0.5) << "the load and the weight must still strain it: " << s.description;
}

TEST(Stress, AdaptiveScenesOnceUnboundedPass) {
  // Two adaptive scenes of seed 7 (indices 30 and 37) that the criterion called unbounded (1.5x
  // their budget by step 320-340) while the same bodies all fine or all coarse passed: their
  // pushed face feeds fine ghosts, whose forces go to the driven coarse nodes as part of their
  // reaction without being in their f, so the work of the push was missed (0.070 J of 0.127 J).
  for (const StressScene& s : run_named_scenes({{0xf89c5aca8c448a78ull, "adaptive nested box 0.147x0.031x0.030"},
                                                {0xef6841424a61a275ull, "adaptive nested box 0.293x0.164x0.161"}}))
    EXPECT_GT(s.splits, 0);
}

TEST(Stress, ToolScenesThatFailedPass) {
  // Adaptive scenes of `pliant stress --tools --seed 11` (docs/stress.md) that failed under their
  // tool, each passing since its fix of the contact response (docs/tool.md). Four exploded (10x to
  // 10^13x their energy budget):
  //  - a 0.128 m sphere on a 0.2 m block: the side faces' top edges touched it with its centre
  //    behind their plane, and the deep push sent them a radius into the block (now radial);
  //  - a 0.095 m sphere 38% deep into a 0.12 m block with refine_near 0 (coarser surfaces made
  //    active under the tool): 2.1e4 J with the response before, 1.2e5 J with the corners' move
  //    capped at 2 |d| instead of the triangle left alone;
  //  - a 2.8 cm sphere on a 3 cm bar (springs, non-nested) and a 2.6 cm one 37% deep (stvk): 185x
  //    and 10x their budget, a top triangle that the tool had turned over taking the deep push,
  //    2r through the bar (now only an axis that crossed the triangle in the step is pushed
  //    through).
  // Three gained 1.7-1.9x their budget, bodies driven into a resting tool: triangles next to a
  // held corner whose free corners moved up to 2x the point's push overshot the tool's surface at
  // every step (now such a triangle is left alone beyond the all-free bound, 1.37x). And one,
  // refine_near 0, merged the region under the tool back to its coarsest level with the tool 3 cm
  // inside that surface; the split back put fine nodes deep inside the tool: 7 J to 114 J, 2.8x
  // (now nodes inside or touching a tool do not merge, whatever refine_near).
  // From `--seed 7` (900 s, 2026-11-26): a 3.7 cm sphere over a coarse triangle with a driven
  // corner (refine_near 0; the triangle left alone, 6.8 mm deep); a split then made the finer
  // surface active there and the response pushed it out in one step: 0.7 J, 1.04 J against a limit
  // of 0.96 J (now a penetration the window's motion does not explain comes out at 5% of the P-wave
  // speed). Five of `--seed 3` (1200 s, all with refine_near 0) failed (1.05-1.32x their
  // criterion) with the corner bound raised to 2.5x (f8e9d41, reverted); the two traced are bodies
  // driven into a resting tool, where a lever triangle's corner nearest the point went out further
  // than it came in at every step. Two (0x6ede..., 0xedea...) also failed before the gradual push-out.
  // Four more, all refine_near 0, failed until 2026-11-28 (docs/tool.md, "Levers"; energy peaks,
  // kinetic + elastic over the budget, failing above 1.5): 0xbe0a... (seed 7; 3.30) and
  // 0xfff2... (seed 3; 1.84), spheres sinking through a coarse triangle with a fixed corner, left
  // alone by the response, until a split put a finer surface inside the tool (now such a contact
  // refines, at once: 0x9f74..., seed 5, 2.34 before, 1.67 when it waited for the next check,
  // 0.94 now); and 0x763e... (seed 5; 1.55). With the refinement alone 0x9b64... above went from
  // 1.00 to 2.04: a corner pushed out by its approach plus the recovery at every window, further
  // than its point had come in (now the recovery replaces the approach where larger, bounded by
  // the point's depth).
  for (const StressScene& s : run_named_scenes({{0xd11bdab429871e87ull, "adaptive nested box 0.199x0.169x0.191"},
                                                {0x7bef6633f8a2c52ull, "adaptive nested box 0.159x0.100x0.123"},
                                                {0x4cc8b51c7c16b23dull, "adaptive non-nested box 0.182x0.033x0.029"},
                                                {0x6754da3a0e15dfbull, "adaptive nested box 0.250x0.070x0.136"},
                                                {0xa1682368d4769fbbull, "adaptive nested box 0.202x0.063x0.108"},
                                                {0xa1140cb71dc00c31ull, "adaptive nested box 0.224x0.083x0.090"},
                                                {0x29d667d39001c802ull, "adaptive nested box 0.229x0.060x0.181"},
                                                {0x1737c22123264ff8ull, "adaptive nested box 0.199x0.071x0.115"},
                                                {0x6966cda70374db28ull, "adaptive non-nested box 0.280x0.060x0.069"},
                                                {0x6edefdd746f5f13full, "adaptive nested box 0.195x0.051x0.043"},
                                                {0x13b3adbcacf399ccull, "adaptive non-nested box 0.142x0.058x0.028"},
                                                {0xedea30cf613d3514ull, "adaptive nested box 0.178x0.045x0.061"},
                                                {0x5a6a8d5d42369db8ull, "adaptive nested box 0.236x0.079x0.071"},
                                                {0x9b6466689abb5ec3ull, "adaptive nested box 0.105x0.114x0.047"},
                                                {0xbe0a425e9b998b6full, "adaptive nested box 0.198x0.118x0.069"},
                                                {0xfff2b230f6845b2eull, "adaptive nested box 0.105x0.037x0.029"},
                                                {0x9f74bf79269c36f1ull, "adaptive non-nested box 0.182x0.037x0.049"},
                                                {0x763e604202317178ull, "adaptive non-nested box 0.144x0.041x0.055"}},
                                               true)) {
    EXPECT_NE(s.description.find(", tool r "), std::string::npos) << s.description;
    EXPECT_GT(s.splits, 0);
  }
}

TEST(Stress, AnAdaptiveSwingWhoseMergesCouldNotPayPasses) {
  // Scene 4238 of `pliant stress --seed 30` (docs/stress.md): a 3-level box clamped at one end,
  // swinging under its weight (a capsule tool beside it never touches it). At two decisions near
  // the bottom of its swing, merges added 6.4e-05 and 7.9e-05 J of kinetic + elastic energy while
  // its motion about its mean velocity held almost none to give back; what stayed (3.5 % and 2.8 %
  // of the body's energy) was under kUnpaidShare, so the merges went ahead, and the body rose to
  // 2.23x its energy budget. What a change cannot take back at once is now owed, and taken from
  // the body's motion at the next decision points that have it.
  for (const StressScene& s : run_named_scenes({{0x7ef10c66d965d906ull, "adaptive nested box 0.121x0.044x0.037"}}, true, true)) {
    EXPECT_GT(s.merges, 0);
    EXPECT_LT(s.energy_peak, 1.5) << s.description;
  }
}

TEST(Stress, AFinestLevelFedByTheCoarsestStaysBounded) {
  // Scene 1745 of `pliant stress --seed 36` (docs/stress.md): a 3-level linear box whose change at
  // 0.165 s left the finest level's ghosts sourced from the coarsest level, two levels apart. A
  // coarse receiver then took about 4x its own tets' stiffness at the coarse level's step; the
  // energy grew 1.75x every 3 ms, to 1.85x the budget. The coarse level's period is now halved
  // while it feeds a level two finer (Simulation::shorten_far_sources).
  for (const StressScene& s : run_named_scenes({{0x236e38a6695cca71ull, "adaptive nested box 0.223x0.121x0.075"}}, true, true)) {
    EXPECT_GT(s.splits, 0);
    EXPECT_LT(s.energy_peak, 1.1) << s.description;  // 1.015 measured (1.853 before)
  }
}

TEST(Stress, APeriodGrowsOnlyWhereItsWindowsStart) {
  // Scenes 70 and 204 of `pliant stress --seed 38`: a change ended the coarsest level's feeding the
  // finest level directly at a tick of 2 mod 4, and its period went back from 2 to 4 there, so its
  // first window began halfway (half its staggered slices skipped, their forces left from the
  // window before). The runner now checks at every step that a period grows only at a multiple
  // of itself (status "misaligned"), and Simulation::align_periods keeps it so.
  for (const StressScene& s : run_named_scenes({{0x888d78f1c1f3c5f3ull, "adaptive nested box 0.144x0.035x0.040"},
                                                {0x7cf1ac656ae879b7ull, "adaptive nested box 0.278x0.049x0.070"}},
                                               true, true))
    EXPECT_GT(s.merges, 0);
}

TEST(Stress, CapsuleToolScenesPass) {
  // The first six adaptive scenes (seeds 1, 2, 3, ...) whose tool is a capsule (StressOptions::
  // capsules, on with tools: half the tools, 1-3 radii long, leaning 0-80 degrees, pressing with
  // the lower cap) pass, on 1 and 2 threads with the same state hash.
  StressOptions o;
  o.threads = 2;
  o.mesh_dirs = {PLIANT_DATA_MESHES};
  o.tools = true;
  int found = 0, touched = 0;
  for (std::uint64_t seed = 1; found < 6 && seed < 2000; ++seed) {
    if (!adaptive_scene_seed(seed) || stress_scene_description(seed, o).find(" capsule ") == std::string::npos) continue;
    ++found;
    const StressScene s = run_stress_scene(seed, 0, o);
    fmt::print("seed {}: {} [{}], {} splits, {} merges, the tool touching for {} of {} steps\n", seed, s.status,
               s.description, s.splits, s.merges, s.tool_steps, s.steps);
    EXPECT_EQ(s.status, "ok") << s.description << ": " << s.message;
    touched += s.tool_steps > 0 ? 1 : 0;
    const StressScene again = run_stress_scene(seed, 0, o, s.threads == 1 ? 2 : 1);
    EXPECT_EQ(again.hash, s.hash) << s.description;
  }
  EXPECT_EQ(found, 6);
  // The capsules reach the bodies: 5 of the 6 (seed 32's does not: its path, slowed to 5% of the
  // P-wave speed of a stiff light bar by shrinking it towards its start, comes down 1.4 mm of the
  // 4.8 mm above the top it starts from, as a sphere's would).
  EXPECT_GE(touched, 5);
}

TEST(Stress, ThreeLevelScenesThatGainedEnergyAtTheirChangesPass) {
  // Three of the 14 three-level scenes of docs/stress.md's 5-minute run (seed 1) that ended
  // "energy unbounded", each at a change of level, not between changes:
  //  - 1808: a split from the coarsest level to the finest left finest nodes whose middle-level
  //    tets were inactive at their last simulated state: 0.63 J of strain became 100.7 J in one tick
  //    (now they take the field carried through the middle level);
  //  - 121 and 617: the last split coarse node of a bent bar merged, and with it the tets of its
  //    never-split neighbours, whose region nobody measured: the 752 finest tets gave way to the 12
  //    coarsest at once, 0.10 J -> 0.28 J (now a node inside a refined region is split where its own
  //    merge would be refused).
  for (const StressScene& s :
       run_named_scenes({{0xf6ffa77d86f2490bull, "adaptive nested box 0.217x0.045x0.053 16x4x4x6, 3 levels"},
                         {0xbd7de8f23cff78deull, "adaptive nested box 0.106x0.045x0.049 8x4x4x6, 3 levels"},
                         {0x9109d84f8a322878ull, "adaptive nested box 0.120x0.068x0.037 8x4x4x6, 3 levels"}}))
    EXPECT_GT(s.merges, 0);
}

TEST(Stress, AdaptiveScenesWhoseMergesGainedEnergyPass) {
  // Five of the 11 adaptive scenes of docs/stress.md's 15-minute run (seed 7) that ended "energy
  // unbounded", each at a decision that merged while the body's motion had little to give back (a
  // bent bar at the end of its swing): 39% to 141% of the body's energy added at once. Such a change
  // is now undone and applied again without its merges (undo_change). Of the other six, five gained
  // through splits of non-nested levels (NonNestedScenesThatGainedEnergyAtSplitsPass); the sixth is
  // AnAdaptiveSceneChangedWhileSubSteppedPasses.
  std::int64_t undone = 0;
  for (const StressScene& s :
       run_named_scenes({{0xd1e38a197d1a4b6bull, "adaptive nested box 0.143x0.026x0.028 8x2x2x6, 2 levels"},
                         {0x4ee6791418a0138dull, "adaptive nested box 0.108x0.038x0.025 12x4x4x6, 3 levels"},
                         {0x483ca96c4745be41ull, "adaptive nested box 0.262x0.076x0.042 16x4x4x6, 3 levels"},
                         {0xb38007d166536f35ull, "adaptive non-nested box 0.179x0.088x0.098 5x4x4x6, 2 levels"},
                         {0xacef5b1a1e2fd5a0ull, "adaptive non-nested box 0.110x0.056x0.026 5x4x2x6, 2 levels"}})) {
    EXPECT_GT(s.merges, 0);
    EXPECT_GE(s.undone, 1) << s.description;  // each had a change undone
    undone += s.undone;
  }
  fmt::print("{} changes undone\n", undone);
}

TEST(Stress, AnAdaptiveSceneChangedWhileSubSteppedPasses) {
  // Scene 10460 of seed 7 (docs/stress.md) gained energy between its changes, none of which added
  // any: the deformation monitor sub-stepped it, a change of resolution meanwhile prepared the
  // levels' periods for the sub-step's tick, and its levels then stepped beyond their stable steps
  // (AdaptiveStep.AnAdaptiveBodyChangedWhileSubSteppedKeepsItsSubSteps). Ended "energy unbounded"
  // at 6.98 J for a budget of 1.5 x 4.28 J.
  for (const StressScene& s :
       run_named_scenes({{0x85643c1c6fd42171ull, "adaptive nested box 0.138x0.023x0.037 16x4x4x6, 3 levels"}}))
    EXPECT_GT(s.splits, 0);
}

TEST(Stress, NonNestedScenesThatGainedEnergyAtSplitsPass) {
  // The last five failures of docs/stress.md's seed-7 run (scenes 826, 4732, 6804, 7270 and 12268):
  // 2- and 3-level bars whose levels do not nest, "energy unbounded" through splits. A finer tet
  // was stepped only when its centroid lay in a refined coarser tet, so at an interface that cut
  // across the finer cells most tets around the active nodes were missing: the two sides parted
  // like a hinge (a bar split in half sagged 1.8x its fine level's sag:
  // MultilevelStep.NonNestedBarSplitInPartSagsBetweenItsLevels), and a split that filled the joint
  // with tets found it strained (12268: 0.047 J became 0.70 J). Now an active node has all its tets.
  for (const StressScene& s :
       run_named_scenes({{0x49f9bc7d5a0681b2ull, "adaptive non-nested box 0.214x0.103x0.162 5x4x4x6, 2 levels"},
                         {0xef80ad5b27f79e33ull, "adaptive non-nested box 0.176x0.069x0.048 7x4x2x6, 2 levels"},
                         {0x90d5355002726ffbull, "adaptive non-nested box 0.170x0.057x0.114 5x2x4x6, 2 levels"},
                         {0xcc6aae6c6da3d7dcull, "adaptive non-nested box 0.287x0.149x0.125 7x4x4x6, 3 levels"},
                         {0xd70109226ff7a6a9ull, "adaptive non-nested box 0.166x0.040x0.065 5x2x2x6, 2 levels"}}))
    EXPECT_GT(s.splits, 0);
}

TEST(Stress, ShortRunIsCleanAndReproducible) {
  StressOptions o;
  o.seconds = 4;
  o.max_scenes = 80;  // on a fast machine too: the first 80 scenes of seed 7 are checked to pass
                      // (a fast machine reaches further: the scenes past them are checked by the long runs, docs/stress.md)
  o.threads = 2;
  o.seed = 7;
  o.repeat_every = 2;
  o.mesh_dirs = {PLIANT_DATA_MESHES};
  const StressReport a = run_stress(o);
  fmt::print("{}", stress_text(a, o));
  // The scenes are drawn from the shipped meshes: without them the run would still pass, on
  // boxes only. data/meshes has 10 volume meshes of at most 25000 tets (stress.cpp).
  EXPECT_EQ(a.mesh_files, 10u) << PLIANT_DATA_MESHES;
  EXPECT_EQ(a.implicit_shapes, meshing_available() ? 3u : 0u);
  EXPECT_GT(a.scenes, 3);
  EXPECT_EQ(a.failures, 0);
  EXPECT_EQ(a.repeat_mismatches, 0);
  EXPECT_GT(a.repeats, 0);
  EXPECT_TRUE(a.memory_flat);
  EXPECT_GT(a.rss_peak, 0u);
  EXPECT_GT(a.adaptive_scenes, 0);  // scene 4 of seed 7 is the first (7 of 27 scenes measured in 4 s)
  // The same seed again: the same scenes, the same state hashes.
  o.seconds = 1e9;
  o.max_scenes = a.digest_scenes;
  const StressReport b = run_stress(o);
  EXPECT_EQ(b.digest_scenes, a.digest_scenes);
  EXPECT_EQ(b.digest, a.digest);
}
