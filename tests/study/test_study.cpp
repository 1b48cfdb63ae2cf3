// Parameter studies (pliant study): sweep parsing and the grid, overrides, reference files and
// their expressions, signal analysis, the Pareto front, the CSV, and small real studies on the
// shipped validation scenes.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "../support/special_files.hpp"
#include "pliant/error.hpp"
#include "pliant/perf/study.hpp"

namespace pliant::study {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

const fs::path kValidation = fs::path(PLIANT_SOURCE_DIR) / "scenes" / "validation";

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  return "(no InputError)";
}

std::string read(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

fs::path temp_dir(const std::string& name) {
  const fs::path d = fs::temp_directory_path() / ("pliant_test_study_" + name);
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

void write(const fs::path& p, const std::string& text) { std::ofstream(p) << text; }

// ---- sweeps -------------------------------------------------------------------------------------

TEST(Sweep, SplitsValuesOutsideStringsAndBrackets) {
  const Sweep s = parse_sweep("bodies[0].mesh.box.cells = [20,2,2] | [40,4,4]|[80,8,8]");
  EXPECT_EQ(s.path, "bodies[0].mesh.box.cells");
  EXPECT_THAT(s.values, ::testing::ElementsAre("[20,2,2]", "[40,4,4]", "[80,8,8]"));
  EXPECT_EQ(s.short_name(), "cells");
  const Sweep m = parse_sweep(R"(bodies[0].name="a|b"|"c")");
  EXPECT_THAT(m.values, ::testing::ElementsAre(R"("a|b")", R"("c")"));
  const Sweep k = parse_sweep(R"(bodies[0].prescribed[0].keyframes=[{"time":0,"offset":[0,0,0]}]|[{"time":1,"offset":[1,0,0]}])");
  EXPECT_EQ(k.values.size(), 2u);
  EXPECT_EQ(parse_sweep("gravity[2]=-1.62").short_name(), "gravity[2]");
  EXPECT_EQ(parse_sweep("precision=\"float\"").values.size(), 1u);
  // Values repeated as JSON (two runs of one scene, reported as two settings), and comment keys.
  EXPECT_THAT(error_of([] { parse_sweep("bodies[0].material.young=1e6|1000000"); }), HasSubstr("value 2 (1000000) is repeated (value 1 is 1e6)"));
  EXPECT_THAT(error_of([] { parse_sweep("_x=1|2"); }), HasSubstr("comment key"));
  EXPECT_THAT(error_of([] { parse_sweep("bodies[0]._note=1|2"); }), HasSubstr("comment key"));
  EXPECT_EQ(canonical_sweep_path("bodies[00].prescribed[010].keyframes[0]"), "bodies[0].prescribed[10].keyframes[0]");
}

TEST(Sweep, BadSyntaxIsAnInputErrorNamingTheSweep) {
  EXPECT_THAT(error_of([] { parse_sweep("bodies[0].model"); }),
              HasSubstr("--sweep 'bodies[0].model': expected PATH=V1|V2|..."));
  EXPECT_THAT(error_of([] { parse_sweep("bodies[0].model=linear|\"stvk\""); }),
              HasSubstr("--sweep 'bodies[0].model=linear|\"stvk\"': value 1 (linear) is not JSON"));
  EXPECT_THAT(error_of([] { parse_sweep("time_step.courant=0.3||0.9"); }), HasSubstr("value 2 is empty"));
  EXPECT_THAT(error_of([] { parse_sweep("=1|2"); }), HasSubstr("the path before '=' is empty"));
  EXPECT_THAT(error_of([] { parse_sweep("time_step.courant=0.3|0.3"); }), HasSubstr("value 2 (0.3) is repeated"));
  EXPECT_THAT(error_of([] { parse_sweep("bodies[0].mesh.box.cells=[20,2,2|[40,4,4]"); }), HasSubstr("is not JSON"));
}

TEST(Sweep, GridIsTheProductWithTheLastSweepFastest) {
  const std::vector<Sweep> sweeps = {parse_sweep("a=1|2"), parse_sweep("b=\"x\"|\"y\"|\"z\"")};
  const auto grid = expand_grid(sweeps);
  ASSERT_EQ(grid.size(), 6u);
  EXPECT_THAT(grid[0], ::testing::ElementsAre("a=1", "b=\"x\""));
  EXPECT_THAT(grid[1], ::testing::ElementsAre("a=1", "b=\"y\""));
  EXPECT_THAT(grid[3], ::testing::ElementsAre("a=2", "b=\"x\""));
  EXPECT_THAT(grid[5], ::testing::ElementsAre("a=2", "b=\"z\""));
  const auto none = expand_grid({});
  ASSERT_EQ(none.size(), 1u);
  EXPECT_TRUE(none[0].empty());
  EXPECT_EQ(settings_label(sweeps, {"2", "\"y\""}), "a=2, b=y");
}

// ---- expressions and reference files ------------------------------------------------------------

TEST(Expression, PrecedenceFunctionsAndVariables) {
  const std::map<std::string, double> v = {{"E", 1e6}, {"rho", 1000}, {"nu", 0.25}};
  EXPECT_DOUBLE_EQ(evaluate_expression("1 + 2 * 3", v, "t"), 7);
  EXPECT_DOUBLE_EQ(evaluate_expression("(1 + 2) * 3", v, "t"), 9);
  EXPECT_DOUBLE_EQ(evaluate_expression("2^3^2", v, "t"), 512);
  EXPECT_DOUBLE_EQ(evaluate_expression("-2^2", v, "t"), -4);
  EXPECT_DOUBLE_EQ(evaluate_expression("sqrt(E / rho)", v, "t"), std::sqrt(1000.0));
  EXPECT_DOUBLE_EQ(evaluate_expression("max(1, nu) - min(2, 3) + pow(2, 0.5)^2", v, "t"), 1 - 2 + 2.0000000000000004);
  EXPECT_DOUBLE_EQ(evaluate_expression("1.5e-3 * 2", v, "t"), 3e-3);
  EXPECT_NEAR(evaluate_expression("cos(pi)", v, "t"), -1, 1e-15);
  EXPECT_THAT(error_of([&] { evaluate_expression("E / rhoo", v, "f.json: reference"); }),
              HasSubstr("f.json: reference: expression \"E / rhoo\": unknown variable \"rhoo\""));
  EXPECT_THAT(error_of([&] { evaluate_expression("(1 + 2", v, "w"); }), HasSubstr("expected ')'"));
  EXPECT_THAT(error_of([&] { evaluate_expression("1 +", v, "w"); }), HasSubstr("unexpected end"));
  EXPECT_THAT(error_of([&] { evaluate_expression("foo(1)", v, "w"); }), HasSubstr("unknown function \"foo\""));
}

TEST(ReferenceFile, SingleQuantityAndVariablesFromTheScene) {
  const ReferenceFile r = parse_reference(R"J({
    "_comment": "ignored",
    "description": "bar",
    "variables": {"E": "bodies[0].material.young", "rho": {"path": "bodies[0].material.density", "default": 1000},
                  "c": {"expr": "sqrt(E / rho)"}, "L": 2},
    "name": "speed", "unit": "m/s",
    "measure": {"kind": "probe_period", "probe": "tip", "axis": "x", "report": "speed", "distance": "4 * L"},
    "reference": "c"
  })J", "r.json");
  ASSERT_EQ(r.quantities.size(), 1u);
  const QuantityDef& q = r.quantities[0];
  EXPECT_EQ(q.name, "speed");
  EXPECT_EQ(q.measure.kind, MeasureKind::probe_period);
  EXPECT_EQ(q.measure.axis, 0);
  EXPECT_EQ(q.measure.report, "speed");
  const auto vars = bind_variables(r, R"({"bodies": [{"material": {"young": 4e6}}]})");
  EXPECT_DOUBLE_EQ(vars.at("c"), std::sqrt(4e6 / 1000));
  EXPECT_DOUBLE_EQ(evaluate_expression(q.reference, vars, "t"), std::sqrt(4e3));
  EXPECT_DOUBLE_EQ(resolve_measure(q.measure, vars, "t").distance, 8);
  EXPECT_THAT(error_of([&] { bind_variables(r, R"({"bodies": [{"material": {}}]})"); }),
              HasSubstr("r.json: variables.E: the scene has no value at \"bodies[0].material.young\""));
}

TEST(ReferenceFile, SeveralQuantities) {
  const ReferenceFile r = parse_reference(R"({"quantities": [
      {"name": "deflection", "measure": {"kind": "probe_mean", "probe": "tip", "axis": "z", "whole_periods": true, "scale": -1},
       "reference": 0.01},
      {"name": "nu", "measure": {"kind": "poisson_ratio", "axis": "x", "region": {"min": [0, 0, 0], "max": [1, 1, 1]}}},
      {"name": "dv", "measure": {"kind": "volume_change", "body": "cube", "from": 0.1}}]})", "r.json");
  ASSERT_EQ(r.quantities.size(), 3u);
  EXPECT_TRUE(r.quantities[0].measure.whole_periods);
  EXPECT_EQ(r.quantities[0].measure.scale, -1);
  EXPECT_DOUBLE_EQ(std::stod(r.quantities[0].reference), 0.01);
  EXPECT_THAT(r.quantities[1].measure.lateral, ::testing::ElementsAre(1, 2));
  EXPECT_TRUE(r.quantities[1].reference.empty());
  EXPECT_EQ(r.quantities[2].measure.body, "cube");
  EXPECT_EQ(*r.quantities[2].measure.from, 0.1);
}

TEST(ReferenceFile, ErrorsNameTheFileAndTheField) {
  EXPECT_THAT(error_of([] { parse_reference(R"({"measure": {"kind": "probe_final", "probe": "tip", "axis": "z"}, "refrence": 1})", "r.json"); }),
              HasSubstr("r.json: refrence: unknown key"));
  EXPECT_THAT(error_of([] { parse_reference(R"({"measure": {"kind": "tip_speed"}})", "r.json"); }),
              HasSubstr("r.json: measure.kind: unknown measure \"tip_speed\""));
  EXPECT_THAT(error_of([] { parse_reference(R"({"measure": {"kind": "probe_final", "axis": "z"}})", "r.json"); }),
              HasSubstr("r.json: measure.probe: required"));
  EXPECT_THAT(error_of([] { parse_reference(R"({"measure": {"kind": "probe_final", "probe": "p", "axis": "w"}})", "r.json"); }),
              HasSubstr("r.json: measure.axis: expected \"x\", \"y\" or \"z\""));
  EXPECT_THAT(error_of([] { parse_reference(R"({"measure": {"kind": "probe_period", "probe": "p", "axis": "x", "report": "speed"}})", "r.json"); }),
              HasSubstr("measure.distance: required with report \"speed\""));
  EXPECT_THAT(error_of([] { parse_reference(R"({"measure": {"kind": "volume_change"}, "reference": "2 * x"})", "r.json"); }),
              HasSubstr("unknown variable \"x\""));
  EXPECT_THAT(error_of([] { parse_reference(R"({"measure": {"kind": "volume_change"},)", "r.json"); }),
              HasSubstr("r.json: invalid JSON"));
  EXPECT_THAT(error_of([] { load_reference_file("/nonexistent/x.reference.json"); }),
              HasSubstr("/nonexistent/x.reference.json: cannot open reference file"));
  // Only regular files: a link to /dev/zero was read until memory ran out.
  const fs::path zero = special::link_to_dev_zero(fs::temp_directory_path() /
                                                   ("pliant_test_zero_" + std::to_string(::getpid()) + ".json"));
  EXPECT_THAT(error_of([&] { load_reference_file(zero); }), HasSubstr(zero.string() + ": is a character device"));
  fs::remove(zero);
  EXPECT_EQ(reference_path_for("scenes/validation/slender_bar.json"),
            fs::path("scenes/validation/slender_bar.reference.json"));
}

TEST(ReferenceFile, ShippedReferenceFilesParse) {
  int n = 0;
  for (const auto& e : fs::directory_iterator(kValidation)) {
    const std::string name = e.path().filename().string();
    if (name.size() > 15 && name.substr(name.size() - 15) == ".reference.json") {
      SCOPED_TRACE(name);
      EXPECT_NO_THROW(load_reference_file(e.path()));
      ++n;
    }
  }
  EXPECT_GE(n, 5);
}

// ---- signals ------------------------------------------------------------------------------------

TEST(Signals, OscillationMeanAndPeriodOfASampledSine) {
  std::vector<double> t, y;
  const double period = 0.37, mean = -0.01, amp = 0.01;
  for (int i = 0; i <= 3000; ++i) {
    t.push_back(i * 1e-3);
    // A second, faster and weaker mode must not add crossings.
    y.push_back(mean + amp * std::cos(2 * M_PI * t.back() / period) + 0.1 * amp * std::sin(2 * M_PI * t.back() / 0.05));
  }
  const Oscillation o = analyse_oscillation(t, y);
  EXPECT_NEAR(o.period, period, 2e-3);
  EXPECT_NEAR(o.mean, mean, 2e-3 * amp);
  EXPECT_GE(o.periods, 7);
  // Too short for a whole period.
  const std::vector<double> t2(t.begin(), t.begin() + 200), y2(y.begin(), y.begin() + 200);
  EXPECT_TRUE(std::isnan(analyse_oscillation(t2, y2).period));
}

TEST(Signals, CrossingsIgnoreRingingNearTheLevel) {
  // A square wave 0 -> 2 -> 0 whose edges ring about the level 1.
  const std::vector<double> t = {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10};
  const std::vector<double> y = {0, 0, 0.9, 1.1, 0.95, 2, 2, 1.05, 0.9, 0, 0};
  const auto c = level_crossings(t, y, 1.0, 0.5);
  ASSERT_EQ(c.size(), 2u);
  EXPECT_NEAR(c[0], 4.0 + 0.05 / 1.05, 1e-12);  // the last raw crossing before the band was left
  // measured 8.9e-16
  EXPECT_NEAR(c[1], 7.0 + 0.05 / 0.15, 8e-15);
}

// ---- Pareto front and reports -------------------------------------------------------------------

TEST(Pareto, HandMadePoints) {
  //                        0    1    2    3    4    5     6
  const std::vector<double> cost = {1, 2, 3, 2, 5, NAN, 0.5};
  const std::vector<double> err = {0.5, 0.2, 0.2, 0.3, 0.01, 0.0, INFINITY};
  const auto f = pareto_front(cost, err);
  EXPECT_THAT(f, ::testing::ElementsAre(true, true, false, false, true, false, false));
  // Equal points do not dominate each other.
  EXPECT_THAT(pareto_front({1, 1}, {0.1, 0.1}), ::testing::ElementsAre(true, true));
  // Errors within 1% of each other are equal: the dearer of the two is not on the front...
  EXPECT_THAT(pareto_front({1, 2}, {0.5, 0.499}), ::testing::ElementsAre(true, false));
  // ... unless told otherwise.
  EXPECT_THAT(pareto_front({1, 2}, {0.5, 0.499}, 0.0), ::testing::ElementsAre(true, true));
}

StudyResult hand_made_study() {
  StudyResult s;
  s.scene = "s.json";
  s.sweeps = {parse_sweep("bodies[0].mesh.box.cells=[10,1,1]|[20,2,2]|[40,4,4]"), parse_sweep("bodies[0].model=\"linear\"")};
  QuantityDef q;
  q.name = "speed";
  s.quantities = {q};
  s.reference_kind = "analytic";
  const double values[] = {33, 32, 31.7};
  const double walls[] = {0.1, 1, 10};
  for (int i = 0; i < 3; ++i) {
    RunRecord r;
    r.settings = {s.sweeps[0].values[std::size_t(i)], "\"linear\""};
    r.tets = std::size_t(6 << (3 * i));
    r.steps = 100 << i;
    r.simulated_time = 0.5;
    r.wall_s = walls[i];
    r.values = {values[i]};
    r.references = {31.6};
    s.runs.push_back(r);
  }
  s.runs[1].status = "diverged";
  s.runs[1].message = "body 'bar', level 0, step 3: node 7 has a non-finite position, or velocity";
  s.runs[1].values = {NAN};
  finish_study(s);
  return s;
}

TEST(Report, CsvColumnsAndRows) {
  const StudyResult s = hand_made_study();
  const std::string csv = study_csv(s);
  std::istringstream in(csv);
  std::string header, row1, row2, row3, extra;
  std::getline(in, header);
  EXPECT_EQ(header,
            "run,bodies[0].mesh.box.cells,bodies[0].model,status,run_model,run_precision,run_threads,nodes,tets,dt,steps,substeps,"
            "simulated_time,setup_s,wall_s,repeats,wall_per_sim_s,tet_steps,tet_updates,speed,speed_reference,speed_error,"
            "error,pareto,reference_run,message");
  std::getline(in, row1);
  std::getline(in, row2);
  std::getline(in, row3);
  EXPECT_FALSE(std::getline(in, extra));
  EXPECT_THAT(row1, ::testing::StartsWith("1,\"[10,1,1]\",linear,ok,"));
  EXPECT_THAT(row1, HasSubstr(",0.1,1,0.2,600,0,33,31.6,"));  // wall, repeats, wall/sim, tet-steps, tet updates, value, reference
  EXPECT_THAT(row2, HasSubstr(",diverged,"));
  EXPECT_THAT(row2, HasSubstr(",nan,0,0,\"body 'bar', level 0, step 3: node 7 has a non-finite position, or velocity\""));
  EXPECT_THAT(row3, ::testing::EndsWith(",1,0,"));  // on the front, not the reference run, no message
  EXPECT_TRUE(s.runs[0].pareto);
  EXPECT_FALSE(s.runs[1].pareto);
  EXPECT_TRUE(s.runs[2].pareto);
  EXPECT_NEAR(s.runs[0].errors[0], 33 / 31.6 - 1, 1e-15);
  const std::string md = study_markdown(s);
  EXPECT_THAT(md, HasSubstr("| 1 | [10,1,1] | linear | 33 | +4.43% |"));
  EXPECT_THAT(md, HasSubstr("| [20,2,2] | diverged |"));
  EXPECT_THAT(md, HasSubstr("Pareto front"));
}

TEST(Report, FinestRunIsTheReference) {
  StudyResult s = hand_made_study();
  s.reference_kind = "finest";
  s.runs[1].status = "ok";
  s.runs[1].values = {32};
  finish_study(s);
  EXPECT_EQ(s.finest, 2);
  EXPECT_TRUE(s.runs[2].is_reference);
  EXPECT_DOUBLE_EQ(s.runs[0].references[0], 31.7);
  EXPECT_NEAR(s.runs[1].errors[0], 32 / 31.7 - 1, 1e-15);
  EXPECT_FALSE(s.runs[2].pareto);  // exact by construction: not a point of the trade
  EXPECT_TRUE(s.runs[0].pareto);
  EXPECT_TRUE(s.runs[1].pareto);
}

// probe_rms: each run's track against the finest run's, at the same sample times.
TEST(Report, ProbeRmsIsTheRmsDistanceToTheFinestRunsTrack) {
  StudyResult s = hand_made_study();
  s.quantities[0].name = "tip_rms";
  s.quantities[0].measure.kind = MeasureKind::probe_rms;
  s.reference_kind = "finest";
  s.runs[1].status = "ok";
  // Three samples each (x y z): the finest run's displacement reaches |(0, 3, 4)| = 5 m.
  s.runs[2].tracks = {{0, 0, 0, 0, 1, 0, 0, 3, 4}};
  s.runs[1].tracks = {{0, 0, 0, 0, 1, 0, 0, 3, 4}};  // the same track
  s.runs[0].tracks = {{1, 0, 0, 0, 1, 2, 0, 3, 4, 9, 9, 9}};  // off by 1, 2, 0 m; one sample more
  for (auto& r : s.runs) r.values = {123};  // each run's own RMS displacement: replaced
  finish_study(s);
  EXPECT_EQ(s.finest, 2);
  EXPECT_EQ(s.runs[2].values[0], 0);
  EXPECT_EQ(s.runs[2].errors[0], 0);
  EXPECT_EQ(s.runs[1].values[0], 0);
  EXPECT_EQ(s.runs[0].references[0], 5);
  EXPECT_DOUBLE_EQ(s.runs[0].values[0], std::sqrt((1.0 + 4.0 + 0.0) / 3));  // over the samples both have
  EXPECT_DOUBLE_EQ(s.runs[0].errors[0], std::sqrt(5.0 / 3) / 5);
  // Parsed: a probe and no axis (the whole displacement); from and every.
  const MeasureDef m = parse_measure(R"({"kind": "probe_rms", "probe": "tip", "every": 0.002, "from": 0.1})", "m");
  EXPECT_EQ(m.kind, MeasureKind::probe_rms);
  EXPECT_EQ(m.probe, "tip");
  EXPECT_EQ(m.every, 0.002);
  EXPECT_EQ(quantity_for_measure(m).name, "tip_rms");
  EXPECT_EQ(quantity_for_measure(m).unit, "m");
  EXPECT_THAT(error_of([] { parse_measure(R"({"kind": "probe_rms", "probe": "tip", "axis": "z"})", "m"); }),
              HasSubstr("axis"));
  EXPECT_THAT(error_of([] { parse_measure(R"({"kind": "probe_rms"})", "m"); }), HasSubstr("probe"));
}

// ---- studies ------------------------------------------------------------------------------------

TEST(Study, BadOverridesAndReferencesFailBeforeAnyRun) {
  const fs::path dir = temp_dir("bad");
  StudyOptions o;
  o.scene = kValidation / "slender_bar.json";
  o.write_files = false;
  o.sweeps = {"bodies[0].materail.young=1e6|2e6"};
  EXPECT_THAT(error_of([&] { run_study(o); }), HasSubstr("override \"bodies[0].materail.young=1e6\": bodies[0].materail: unknown key"));
  o.sweeps = {"bodies[0].material.poisson=0.3|0.7"};
  EXPECT_THAT(error_of([&] { run_study(o); }), HasSubstr("with poisson=0.7: "));
  o.sweeps = {"bodies[0].model=\"linear\"", "bodies[0].model=\"stvk\""};
  EXPECT_THAT(error_of([&] { run_study(o); }), HasSubstr("bodies[0].model is already swept"));
  // The same field written another way, and a field with its parent: the later edit overwrote the
  // earlier, whose values study.csv still reported.
  o.sweeps = {"bodies[0].model=\"linear\"", "bodies[00].model=\"stvk\""};
  EXPECT_THAT(error_of([&] { run_study(o); }), HasSubstr("bodies[00].model is already swept"));
  o.sweeps = {"bodies[0].material={\"young\": 1e6}|{\"young\": 2e6}", "bodies[0].material.young=3e6|4e6"};
  EXPECT_THAT(error_of([&] { run_study(o); }), HasSubstr("overlap: one sets part of the other"));
  o.sweeps = {"bodies[0].material.young=3e6|4e6", "bodies[0].material={\"young\": 1e6}|{\"young\": 2e6}"};
  EXPECT_THAT(error_of([&] { run_study(o); }), HasSubstr("overlap: one sets part of the other"));
  o.sweeps = {"bodies[0].model=\"linear\""};
  o.reference = "1.5";
  o.scene = kValidation / "cantilever_gravity.json";
  EXPECT_THAT(error_of([&] { run_study(o); }), HasSubstr("defines 2 quantities"));
  // A reference that is neither a finite number nor "finest" beside --measure was dropped, and the
  // error said that none was given.
  o.measure = R"({"kind": "probe_final", "probe": "tip", "axis": "z"})";
  for (const char* bad : {"bogus", "nan", "inf"}) {
    o.reference = bad;
    EXPECT_THAT(error_of([&] { run_study(o); }), HasSubstr(std::string("--reference ") + bad + ": with --measure, give a number or finest"));
  }
  o.reference = "";
  o.measure = R"({"kind": "probe_final", "probe": "nope", "axis": "z"})";
  o.reference = "finest";
  EXPECT_THAT(error_of([&] { run_study(o); }), HasSubstr("no probe named \"nope\"; probes: tip"));
  // A scene without a reference file beside it and without probes: nothing to measure.
  write(dir / "plain.json", R"({"bodies": [{"mesh": {"box": {"min": [0,0,0], "max": [1,0.1,0.1], "cells": [4,1,1]}}}]})");
  o.scene = dir / "plain.json";
  o.measure = "";
  o.reference = "";
  EXPECT_THAT(error_of([&] { run_study(o); }), HasSubstr("no reference file " + (dir / "plain.reference.json").string() +
                                                         " beside the scene and no probes to measure"));
  // A scene that is a FIFO: refused without being opened (its open waited for a writer).
  const special::Fifo fifo(dir / "fifo.json");
  o.scene = fifo.path();
  EXPECT_THAT(error_of([&] { run_study(o); }), HasSubstr("fifo.json: is a FIFO (named pipe), not a regular file"));
  EXPECT_FALSE(fifo.opened());
}

TEST(Study, TinySlenderBarStudy) {
  const fs::path dir = temp_dir("tiny");
  StudyOptions o;
  o.scene = kValidation / "slender_bar.json";
  o.sweeps = {"bodies[0].mesh.box.cells=[10,1,1]|[20,1,1]", "bodies[0].model=\"linear\"|\"corotational\""};
  o.out_dir = dir;
  o.min_time = 0;
  std::vector<std::string> lines;
  o.progress = [&](const std::string& l) { lines.push_back(l); };
  const StudyResult s = run_study(o);
  ASSERT_EQ(s.runs.size(), 4u);
  ASSERT_EQ(lines.size(), 4u);
  EXPECT_THAT(lines[0], ::testing::StartsWith("[1/4] cells=[10,1,1], model=linear: bar_speed = "));
  EXPECT_EQ(s.reference_kind, "analytic");
  for (const RunRecord& r : s.runs) {
    EXPECT_EQ(r.status, "ok");
    EXPECT_NEAR(r.references[0], std::sqrt(1e6 / 1000), 1e-12);
    EXPECT_LT(std::fabs(r.errors[0]), 0.03) << r.values[0];
    EXPECT_GT(r.tet_steps(), 0);
  }
  // Small strain: linear and corotational agree; runs are independent and deterministic.
  // measured 4.5e-6
  EXPECT_NEAR(s.runs[0].values[0], s.runs[1].values[0], 4e-5);
  StudyOptions again = o;
  again.sweeps = {"bodies[0].mesh.box.cells=[20,1,1]", "bodies[0].model=\"corotational\""};
  again.write_files = false;
  again.progress = nullptr;
  const StudyResult s2 = run_study(again);
  EXPECT_EQ(std::memcmp(&s2.runs[0].values[0], &s.runs[3].values[0], sizeof(double)), 0);
  // Files.
  const std::string csv = read(dir / "study.csv");
  EXPECT_THAT(csv, ::testing::StartsWith("run,bodies[0].mesh.box.cells,bodies[0].model,status,"));
  EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 5);
  const std::string md = read(dir / "study.md");
  EXPECT_THAT(md, HasSubstr("bar_speed against cells"));
  int front = 0;
  for (const RunRecord& r : s.runs) front += r.pareto;
  EXPECT_GE(front, 1);
}

TEST(Study, QuantitiesAreNamedAfterTheirMeasureWithUnits) {
  auto named = [](const std::string& json) {
    const QuantityDef q = quantity_for_measure(parse_measure(json, "--measure"));
    return q.name + " [" + q.unit + "]";
  };
  EXPECT_EQ(named(R"({"kind": "probe_final", "probe": "tip", "axis": "z"})"), "tip_z [m]");
  EXPECT_EQ(named(R"({"kind": "probe_mean", "probe": "tip", "axis": "x"})"), "tip_x_mean [m]");
  EXPECT_EQ(named(R"({"kind": "probe_period", "probe": "tip", "axis": "z"})"), "tip_z_period [s]");
  EXPECT_EQ(named(R"({"kind": "probe_period", "probe": "tip", "axis": "z", "report": "frequency"})"), "tip_z_frequency [Hz]");
  EXPECT_EQ(named(R"({"kind": "probe_arrival", "probe": "end", "axis": "x", "level": 1e-4, "report": "speed", "distance": 1})"),
            "end_x_speed [m/s]");
  EXPECT_EQ(named(R"({"kind": "strain", "body": "bar", "axis": "y"})"), "bar_strain_y []");
  EXPECT_EQ(named(R"({"kind": "volume_change"})"), "body_volume_change []");
  EXPECT_EQ(named(R"({"kind": "probe_final", "probe": "tip", "axis": "z", "scale": 1000})"), "tip_z_scaled []");
  // In study.csv: the value and the reference carry the unit, the relative error none.
  StudyResult s;
  s.quantities = {quantity_for_measure(parse_measure(R"({"kind": "probe_period", "probe": "end", "axis": "x", "report": "speed", "distance": 1})", "m"))};
  EXPECT_THAT(study_csv(s), HasSubstr(",tet_steps,tet_updates,end_x_speed_m_per_s,end_x_speed_reference_m_per_s,end_x_speed_error,error,"));
}

// A scene without a reference file runs anyway: the length of each probe's displacement at the
// end, against the finest run (issue 11 §5).
TEST(Study, WithoutAReferenceFileTheProbesAgainstTheFinestRun) {
  const fs::path dir = temp_dir("no_reference");
  write(dir / "bar.json", read(kValidation / "slender_bar.json"));
  StudyOptions o;
  o.scene = dir / "bar.json";
  o.sweeps = {"duration=0.05", "bodies[0].mesh.box.cells=[10,1,1]|[20,1,1]"};
  o.out_dir = dir / "study";
  o.min_time = 0;
  std::vector<std::string> lines;
  o.progress = [&](const std::string& l) { lines.push_back(l); };
  const StudyResult s = run_study(o);
  EXPECT_EQ(s.reference_kind, "finest");
  ASSERT_EQ(s.quantities.size(), 1u);
  EXPECT_EQ(s.quantities[0].name, "tip_displacement");
  EXPECT_EQ(s.quantities[0].unit, "m");
  ASSERT_EQ(s.notes.size(), 1u);
  EXPECT_THAT(s.notes[0], HasSubstr("no reference file " + (dir / "bar.reference.json").string() +
                                    ": measuring the displacement of probe tip at the end against the finest run"));
  ASSERT_FALSE(lines.empty());
  EXPECT_EQ(lines[0], "pliant: note: " + s.notes[0]);
  ASSERT_EQ(s.runs.size(), 2u);
  EXPECT_EQ(s.finest, 1);
  for (const RunRecord& r : s.runs) EXPECT_EQ(r.status, "ok");
  // The front (c = 31.6 m/s) reaches the free end of the 1 m bar at 0.032 s, which then jumps to
  // twice the 0.1 mm imposed at the other end (measured at 0.05 s: 1.936e-4 m on 20x1x1, 2.148e-4
  // m on 10x1x1, +11.0% from the finest).
  EXPECT_NEAR(s.runs[1].values[0], 2e-4, 0.2e-4);
  EXPECT_EQ(s.runs[1].errors[0], 0);
  EXPECT_NEAR(s.runs[0].errors[0], 0.11, 5e-4);  // measured 1.1e-4 from 0.11
  EXPECT_THAT(read(dir / "study" / "study.csv"), HasSubstr(",tip_displacement_m,tip_displacement_reference_m,tip_displacement_error,"));
}

TEST(Study, MeasureAndFinestReference) {
  StudyOptions o;
  o.scene = kValidation / "uniaxial_extension.json";
  o.sweeps = {"bodies[0].mesh.box.cells=[5,1,1]|[10,2,2]"};
  o.measure = R"({"kind": "strain", "axis": "y", "region": {"min": [0.2, -1, -1], "max": [0.3, 1, 1]}})";
  o.reference = "finest";
  o.write_files = false;
  o.min_time = 0;
  const StudyResult s = run_study(o);
  ASSERT_EQ(s.runs.size(), 2u);
  EXPECT_EQ(s.finest, 1);
  EXPECT_NEAR(s.runs[1].values[0], -0.3e-3, 4e-6);  // -nu F / (E A); measured 8.0e-7 from it
  EXPECT_EQ(s.runs[1].errors[0], 0);
  EXPECT_LT(std::fabs(s.runs[0].errors[0]), 0.02);
}

TEST(Study, ProbeRmsAgainstTheFinestRun) {
  // The cantilever under gravity at two resolutions: the finest run is the reference (0), the
  // coarse one a few per cent off over the run, its track sampled every 1 ms from 0 to the end.
  StudyOptions o;
  o.scene = kValidation / "cantilever_gravity.json";
  o.sweeps = {"bodies[0].mesh.box.cells=[10,1,1]|[20,2,2]", "duration=0.05"};
  o.measure = R"({"kind": "probe_rms", "probe": "tip"})";
  o.write_files = false;
  o.min_time = 0;
  o.reference = "0.01";
  EXPECT_THAT(error_of([&] { run_study(o); }), HasSubstr("use --reference finest"));
  o.reference = "finest";
  const StudyResult s = run_study(o);
  ASSERT_EQ(s.runs.size(), 2u);
  EXPECT_EQ(s.finest, 1);
  for (const RunRecord& r : s.runs) {
    ASSERT_EQ(r.tracks.size(), 1u);
    EXPECT_EQ(r.tracks[0].size(), 3u * 51);  // t = 0, 1 ms, ..., 50 ms
  }
  EXPECT_EQ(s.runs[1].errors[0], 0);
  EXPECT_GT(s.runs[0].references[0], 1e-4);  // the tip falls (m)
  std::printf("coarse cantilever: RMS distance %.3g m over %.3g m: %.2f%%\n", s.runs[0].values[0], s.runs[0].references[0],
              100 * s.runs[0].errors[0]);
  // Linear tets one cell thick lock in bending: 27.1% from the fine run over these 50 ms (measured;
  // the same bits on any thread count, so only the rounding of another build moves it).
  EXPECT_NEAR(s.runs[0].errors[0], 0.2707, 0.0005);
}

// Uniform levels and adaptive runs of one multiresolution body in one study (docs/adaptivity.md):
// a sweep of the whole multiresolution object, because "adapt" is refused beside a fixed level.
// Every run has the same mesh (tets, tet-steps), so the cost that tells them apart is the tets
// computed; the finest run is the uniform finest level.
TEST(Study, MultiresolutionLevelsAndAdaptiveRunsCostTheirTetUpdates) {
  const fs::path dir = temp_dir("multires");
  write(dir / "bar.json", R"({
    "duration": 0.02, "gravity": [0, 0, -9.81], "precision": "double", "threads": 1,
    "bodies": [{"name": "bar", "mesh": {"box": {"min": [0, 0, 0], "max": [0.4, 0.1, 0.1], "cells": [8, 2, 2], "tets_per_cell": 6}},
                "material": {"young": 1e5, "poisson": 0.3, "density": 1000},
                "fixed": [{"box": {"min": [-1, -1, -1], "max": [0, 1, 1]}}]}],
    "probes": [{"name": "tip", "body": "bar", "point": [0.4, 0.05, 0.05]}]})");
  StudyOptions o;
  o.scene = dir / "bar.json";
  o.sweeps = {R"(bodies[0].multiresolution={"levels":2,"active":0}|{"levels":2,"active":1}|)"
              R"({"levels":2,"active":"adaptive","adapt":{"measure":"absolute","refine_above":0.5,"coarsen_below":0.1}})"};
  o.measure = R"({"kind": "probe_mean", "probe": "tip", "axis": "z"})";
  o.reference = "finest";
  o.cost = parse_cost("tet-updates");
  o.out_dir = dir / "study";
  o.min_time = 0;
  const StudyResult s = run_study(o);
  ASSERT_EQ(s.runs.size(), 3u);
  for (const RunRecord& r : s.runs) {
    EXPECT_EQ(r.status, "ok") << r.message;
    EXPECT_EQ(r.tets, 8u * 2 * 2 * 6);  // the finest mesh, whatever level runs
    EXPECT_EQ(r.nodes, 9u * 3 * 3);
  }
  EXPECT_EQ(s.runs[0].tet_steps(), s.runs[1].tet_steps());
  // Level 0 (4x1x1 cells, 24 tets) steps at a period 4 times level 1's (96 tets): 1/16.
  EXPECT_NEAR(s.runs[0].tet_updates / s.runs[1].tet_updates, 1.0 / 16, 1e-12);
  EXPECT_EQ(s.finest, 1);  // ties in tet-steps go to the most tet updates
  // Adaptive with a high absolute threshold stays on level 0 (a 2 cm sag jumps far less than 0.5).
  EXPECT_EQ(s.runs[2].tet_updates, s.runs[0].tet_updates);
  EXPECT_NE(s.runs[0].values[0], s.runs[1].values[0]);
  EXPECT_THAT(read(dir / "study" / "study.csv"), HasSubstr(",tet_steps,tet_updates,"));
  EXPECT_THAT(read(dir / "study" / "study.md"), HasSubstr("tet updates"));
  EXPECT_THAT(error_of([] { parse_cost("tets"); }), HasSubstr("--cost must be wall, tet-steps or tet-updates, got 'tets'"));
  EXPECT_EQ(to_string(CostKind::tet_updates), "tet-updates");
}

}  // namespace
}  // namespace pliant::study
