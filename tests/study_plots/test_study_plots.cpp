// Plots of parameter studies (raster/study): which runs make the Pareto front and the convergence
// curves, their axes and units, and the PNG files of a small real study (size, not blank).
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>

#include "pliant/error.hpp"
#include "pliant/raster/colormap.hpp"
#include "pliant/raster/image.hpp"
#include "pliant/perf/study_plots.hpp"
#include "pliant/perf/study.hpp"

namespace pliant::raster {
namespace {

namespace fs = std::filesystem;
using ::testing::ElementsAre;
using ::testing::HasSubstr;
using study::RunRecord;
using study::StudyResult;

fs::path temp_dir(const std::string& name) {
  const fs::path d = fs::temp_directory_path() / ("pliant_test_study_plots_" + std::to_string(::getpid())) / name;
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

struct Cleanup : ::testing::Environment {
  void TearDown() override {
    std::error_code ec;
    fs::remove_all(fs::temp_directory_path() / ("pliant_test_study_plots_" + std::to_string(::getpid())), ec);
  }
};
const auto* const kCleanup = ::testing::AddGlobalTestEnvironment(new Cleanup);

// Pixels that differ from white, and whether a colour is present.
std::size_t ink(const Image& img) {
  std::size_t n = 0;
  for (int y = 0; y < img.height(); ++y)
    for (int x = 0; x < img.width(); ++x) n += !(img.get(x, y) == Rgba{255, 255, 255, 255});
  return n;
}
bool has(const Image& img, Rgba c) {
  for (int y = 0; y < img.height(); ++y)
    for (int x = 0; x < img.width(); ++x)
      if (img.get(x, y) == c) return true;
  return false;
}

// Three meshes x two models, one or two quantities of reference 31.6; run 3 ([20,2,2], linear)
// diverged. Costs grow 10x per mesh; springs cost 1.5x and are less accurate than the coarsest
// linear run, so the front is runs 1 and 5.
StudyResult hand_made(int quantities = 1) {
  StudyResult s;
  s.scene = "scenes/validation/bar.json";
  s.sweeps = {study::parse_sweep("bodies[0].mesh.box.cells=[10,1,1]|[20,2,2]|[40,4,4]"),
              study::parse_sweep("bodies[0].model=\"linear\"|\"springs\"")};
  for (int q = 0; q < quantities; ++q) {
    study::QuantityDef d;
    d.name = q ? "period" : "speed";
    s.quantities.push_back(d);
  }
  s.reference_kind = "analytic";
  const double linear[] = {33, 32, 31.7}, springs[] = {34, 33.5, 33.2};
  for (int m = 0; m < 3; ++m)
    for (int model = 0; model < 2; ++model) {
      RunRecord r;
      r.settings = {s.sweeps[0].values[std::size_t(m)], s.sweeps[1].values[std::size_t(model)]};
      r.tets = std::size_t(6 << (3 * m));
      r.steps = 100 << m;
      r.simulated_time = 0.5;
      r.wall_s = 0.01 * std::pow(10.0, m) * (model ? 1.5 : 1);
      r.values.assign(std::size_t(quantities), model ? springs[m] : linear[m]);
      r.references.assign(std::size_t(quantities), 31.6);
      s.runs.push_back(r);
    }
  s.runs[2].status = "diverged";  // [20,2,2], linear
  s.runs[2].values.assign(std::size_t(quantities), NAN);
  study::finish_study(s);
  return s;
}

TEST(StudyPlots, ParetoFrontCheapestFirstWithRunNumbers) {
  const StudyResult s = hand_made();
  const Plot p = study_pareto_plot(s);
  EXPECT_EQ(p.x.label, "cost: wall time per simulated time");
  EXPECT_EQ(p.x.unit, "s/s");
  EXPECT_TRUE(p.x.log);  // 0.02 to 30 s/s
  EXPECT_EQ(p.y.label, "|relative error| of speed");
  EXPECT_EQ(p.y.unit, "%");
  ASSERT_EQ(p.series.size(), 2u);
  EXPECT_EQ(p.series[0].label, "other runs (3)");
  EXPECT_EQ(p.series[1].label, "Pareto front (2 runs)");
  // Front: run 1 (cheapest), run 5 (linear, finest: 0.3%); the springs runs are dominated.
  EXPECT_THAT(p.series[1].point_labels, ElementsAre("#1", "#5"));
  EXPECT_LT(p.series[1].x[0], p.series[1].x[1]);  // an ordering of two costs, not a tolerance (audit ratio 0.01)
  EXPECT_NEAR(p.series[1].y[1], 100 * (31.7 / 31.6 - 1), 1e-14);  // measured 0
  EXPECT_EQ(p.series[0].x.size(), 3u);  // 2, 4, 6; 3 diverged
  EXPECT_THAT(p.title, ::testing::Eq("bar: cost against error (not drawn: 1 diverged or invalid)"));

  EXPECT_EQ(study_pareto_plot(hand_made(2)).y.label, "largest |relative error|");  // the front's error

  StudyResult tets = hand_made();
  tets.cost = study::CostKind::tet_steps;
  study::finish_study(tets);
  const Plot t = study_pareto_plot(tets);
  EXPECT_EQ(t.x.label, "cost: tet-steps (tets × steps)");
  EXPECT_EQ(t.x.unit, "");
}

TEST(StudyPlots, ConvergenceAgainstTetsOneSeriesPerModel) {
  const StudyResult s = hand_made(2);
  const ConvergencePlots c = study_convergence_plots(s);
  EXPECT_TRUE(c.x_is_tets);
  EXPECT_EQ(c.sweep, "bodies[0].mesh.box.cells");
  ASSERT_EQ(c.panels.size(), 2u);  // one per quantity
  const Plot& p = c.panels[1];
  EXPECT_EQ(p.x.label, "mesh: number of tets");
  EXPECT_TRUE(p.x.log);
  EXPECT_EQ(p.y.label, "|relative error| of period");
  EXPECT_EQ(p.y.unit, "%");
  EXPECT_THAT(p.title, ::testing::Eq("bar: convergence of period (vs analytic)"));
  ASSERT_EQ(p.series.size(), 2u);
  EXPECT_EQ(p.series[0].label, "model=linear");
  EXPECT_EQ(p.series[1].label, "model=springs");
  EXPECT_THAT(p.series[0].x, ElementsAre(6, 48, 384));
  EXPECT_TRUE(std::isnan(p.series[0].y[1]));  // the diverged run: a gap
  EXPECT_NEAR(p.series[1].y[0], 100 * (34 / 31.6 - 1), 1e-14);  // measured 0

  // Sweeps in the other order: the mesh sweep is still the x axis.
  StudyResult swapped = s;
  std::swap(swapped.sweeps[0], swapped.sweeps[1]);
  for (RunRecord& r : swapped.runs) std::swap(r.settings[0], r.settings[1]);
  const ConvergencePlots c2 = study_convergence_plots(swapped);
  EXPECT_EQ(c2.sweep, "bodies[0].mesh.box.cells");
  EXPECT_EQ(c2.panels[0].series[0].label, "model=linear");
}

TEST(StudyPlots, ConvergenceAgainstANumberOrNone) {
  StudyResult s = hand_made();
  // Same mesh everywhere, Young's modulus swept: x is E in Pa.
  s.sweeps[0] = study::parse_sweep("bodies[0].material.young=1e5|1e6|1e7");
  for (std::size_t i = 0; i < s.runs.size(); ++i) {
    s.runs[i].settings[0] = s.sweeps[0].values[i / 2];
    s.runs[i].tets = 48;
  }
  ConvergencePlots c = study_convergence_plots(s);
  ASSERT_EQ(c.panels.size(), 1u);
  EXPECT_FALSE(c.x_is_tets);
  EXPECT_EQ(c.panels[0].x.label, "young");
  EXPECT_EQ(c.panels[0].x.unit, "Pa");
  EXPECT_TRUE(c.panels[0].x.log);
  EXPECT_THAT(c.panels[0].series[1].x, ElementsAre(1e5, 1e6, 1e7));

  // Only strings: no convergence; the Pareto plot is still written, with a note for the other.
  StudyResult models = hand_made();
  models.sweeps = {models.sweeps[1]};
  for (RunRecord& r : models.runs) {
    r.settings = {r.settings[1]};
    r.tets = 48;
  }
  c = study_convergence_plots(models);
  EXPECT_TRUE(c.panels.empty());
  EXPECT_THAT(c.why_none, HasSubstr("no sweep changes the mesh or takes two numbers"));
  const fs::path dir = temp_dir("models");
  const StudyPlotFiles f = write_study_plots(models, dir);
  EXPECT_THAT(f.files, ElementsAre((dir / "pareto.png").string()));
  ASSERT_EQ(f.notes.size(), 1u);
  EXPECT_THAT(f.notes[0], HasSubstr("no convergence.png"));
  EXPECT_FALSE(fs::exists(dir / "convergence.png"));

  StudyResult none;
  none.scene = "x.json";
  EXPECT_THAT(study_convergence_plots(none).why_none, HasSubstr("no sweep"));
}

TEST(StudyPlots, PanelsSideBySideAndErrorsNameTheFile) {
  const fs::path dir = temp_dir("panels");
  const StudyPlotFiles f = write_study_plots(hand_made(2), dir);
  ASSERT_EQ(f.files.size(), 2u);
  const Image conv = read_png(dir / "convergence.png");
  EXPECT_EQ(conv.width(), 1600);
  EXPECT_EQ(conv.height(), 600);
  EXPECT_GT(ink(conv), 10000u);
  try {
    write_study_plots(hand_made(), dir / "absent" / "folder");
    ADD_FAILURE() << "no InputError";
  } catch (const InputError& e) {
    EXPECT_THAT(std::string(e.what()), HasSubstr("pareto.png"));
  }
}

// A small real study, as `pliant study` runs it: both PNGs exist, 800x600, with ink in the plot
// area, the front's colour, and the labels of both axes.
TEST(StudyPlots, TinySlenderBarStudyWritesBothPlots) {
  const fs::path dir = temp_dir("tiny");
  study::StudyOptions o;
  o.scene = fs::path(PLIANT_SOURCE_DIR) / "scenes" / "validation" / "slender_bar.json";
  o.sweeps = {"bodies[0].mesh.box.cells=[10,1,1]|[20,1,1]|[40,2,2]", "bodies[0].model=\"linear\"|\"corotational\""};
  o.out_dir = dir;
  o.min_time = 0;
  const StudyResult s = study::run_study(o);
  const StudyPlotFiles f = write_study_plots(s, dir);
  EXPECT_THAT(f.files, ElementsAre((dir / "pareto.png").string(), (dir / "convergence.png").string()));
  EXPECT_TRUE(f.notes.empty());
  for (const char* name : {"pareto.png", "convergence.png"}) {
    SCOPED_TRACE(name);
    const Image img = read_png(dir / name);
    ASSERT_EQ(img.width(), 800);
    ASSERT_EQ(img.height(), 600);
    EXPECT_GT(ink(img), 5000u);
    // Axis labels: at the bottom, and along the left edge.
    std::size_t bottom = 0, left = 0;
    for (int y = 575; y < 600; ++y)
      for (int x = 200; x < 600; ++x) bottom += !(img.get(x, y) == Rgba{255, 255, 255, 255});
    for (int y = 150; y < 450; ++y)
      for (int x = 0; x < 20; ++x) left += !(img.get(x, y) == Rgba{255, 255, 255, 255});
    EXPECT_GT(bottom, 100u);
    EXPECT_GT(left, 100u);
  }
  EXPECT_TRUE(has(read_png(dir / "pareto.png"), palette(3)));    // the front
  EXPECT_TRUE(has(read_png(dir / "convergence.png"), palette(0)));  // model=linear
  // Both models are named: each in its own colour, or, when the two curves coincide at this size
  // (a slender bar barely rotates: their errors differ in the 5th digit), drawn once in the first
  // one's colour under a joint name, so that the legend names no line that cannot be seen.
  PlotLayout layout;
  const Image conv = render_plot(study_convergence_plots(s).panels.at(0), &layout);
  if (layout.legend_labels.size() == 2) {
    EXPECT_THAT(layout.legend_labels, ElementsAre("model=linear", "model=corotational"));
    EXPECT_TRUE(has(conv, palette(1)));  // model=corotational
  } else {
    EXPECT_THAT(layout.legend_labels, ElementsAre(::testing::AnyOf("model=linear\u2248corotational",
                                                                   "model=linear|corotational")));
    EXPECT_FALSE(has(conv, palette(1)));
  }
}

}  // namespace
}  // namespace pliant::raster
