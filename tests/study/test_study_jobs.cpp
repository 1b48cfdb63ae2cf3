// Studies as job lists (study_jobs.hpp): run records round-trip exactly, a study run job by job
// and collected gives the same study.csv as the same study run in one process (but for the timing
// columns), and what can go wrong between the two says so. The CLI test (cli_study_jobs.sh) runs
// the job lines as separate processes from another directory and with --parallel.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>

#include "pliant/error.hpp"
#include "pliant/perf/study.hpp"
#include "pliant/perf/study_jobs.hpp"

namespace pliant::study {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

const fs::path kValidation = fs::path(PLIANT_SOURCE_DIR) / "scenes" / "validation";

std::string read(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

fs::path temp_dir(const std::string& name) {
  const fs::path d = fs::temp_directory_path() / ("pliant_test_study_jobs_" + name);
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  return "(no InputError)";
}

// The timing of a run is the machine's, not the study's: zeroed before comparing two studies.
StudyResult untimed(StudyResult s) {
  for (RunRecord& r : s.runs) r.setup_s = r.wall_s = 0, r.repeats = 1;
  s.wall_total_s = 0;
  return s;
}

bool same_bits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

TEST(StudyJobs, RunRecordRoundTripsExactly) {
  RunRecord r;
  r.settings = {"[10,1,1]", "\"linear\""};
  r.status = "diverged";
  r.message = "a \"quoted\" message,\nwith a newline";
  r.model = "corotational";
  r.precision = "double";
  r.threads = 2;
  r.nodes = 44;
  r.tets = 60;
  r.steps = 1234567890123;
  r.substeps = 3;
  r.dt = 1.0 / 3.0;
  r.simulated_time = 0.1 + 0.2;
  r.setup_s = 4.9406564584124654e-324;  // the smallest denormal
  r.wall_s = 1e300;
  r.repeats = 5;
  r.values = {std::nextafter(1.0, 2.0), kNaN, std::numeric_limits<double>::infinity(), -0.0};
  r.references = {-std::numeric_limits<double>::infinity(), 2.5};
  r.tracks = {{}, {0.1, -0.0, 1e-300, 2.0 / 3.0}, {}, {}};
  const RunRecord back = parse_run_record(run_record_json(r), "test");
  ASSERT_EQ(back.tracks.size(), 4u);
  ASSERT_EQ(back.tracks[1].size(), 4u);
  for (std::size_t i = 0; i < 4; ++i) EXPECT_TRUE(same_bits(back.tracks[1][i], r.tracks[1][i]));
  EXPECT_TRUE(back.tracks[0].empty());
  EXPECT_EQ(back.settings, r.settings);
  EXPECT_EQ(back.status, r.status);
  EXPECT_EQ(back.message, r.message);
  EXPECT_EQ(back.model, r.model);
  EXPECT_EQ(back.precision, r.precision);
  EXPECT_EQ(back.threads, 2);
  EXPECT_EQ(back.nodes, 44u);
  EXPECT_EQ(back.tets, 60u);
  EXPECT_EQ(back.steps, r.steps);
  EXPECT_EQ(back.substeps, 3);
  EXPECT_EQ(back.repeats, 5);
  for (auto [a, b] : {std::pair{back.dt, r.dt}, {back.simulated_time, r.simulated_time}, {back.setup_s, r.setup_s},
                      {back.wall_s, r.wall_s}})
    EXPECT_TRUE(same_bits(a, b)) << a << " != " << b;
  ASSERT_EQ(back.values.size(), 4u);
  EXPECT_TRUE(same_bits(back.values[0], r.values[0]));
  EXPECT_TRUE(std::isnan(back.values[1]));
  EXPECT_TRUE(same_bits(back.values[2], r.values[2]));
  EXPECT_TRUE(same_bits(back.values[3], -0.0));
  ASSERT_EQ(back.references.size(), 2u);
  EXPECT_TRUE(same_bits(back.references[0], r.references[0]));
  EXPECT_THAT(error_of([] { parse_run_record("{\"status\": \"ok\"}", "runs/0001/run.json"); }),
              HasSubstr("runs/0001/run.json: not a run record"));
}

// The same sweep in one process and as four jobs collected: the same study, to the bit.
TEST(StudyJobs, CollectedStudyIsTheInProcessStudy) {
  const fs::path dir = temp_dir("same");
  StudyOptions o;
  o.scene = kValidation / "slender_bar.json";
  o.sweeps = {"bodies[0].mesh.box.cells=[10,1,1]|[20,1,1]", "bodies[0].model=\"linear\"|\"corotational\""};
  o.cost = CostKind::tet_steps;  // a front of counts: the same in both (wall times are not)
  o.min_time = 0;
  o.out_dir = dir / "in_process";
  const StudyResult direct = run_study(o);

  StudyOptions jobs = o;
  jobs.out_dir = dir / "jobs";
  const std::vector<std::string> commands = write_study_jobs(jobs, "/usr/bin/pliant", dir / "jobs.txt");
  ASSERT_EQ(commands.size(), 4u);
  EXPECT_EQ(commands[2], "'/usr/bin/pliant' study --out '" + (dir / "jobs").string() + "' --run 3");
  const std::string list = read(dir / "jobs.txt");
  EXPECT_THAT(list, HasSubstr("--run 3  # cells=[20,1,1], model=linear\n"));
  EXPECT_EQ(std::count(list.begin(), list.end(), '\n'), 4);
  // Not all runs yet: the collection names the missing ones.
  for (std::size_t k : {4, 1}) run_study_job(dir / "jobs", k);
  EXPECT_THAT(error_of([&] { collect_study(dir / "jobs"); }), HasSubstr("2 of 4 runs have no run.json (runs 2, 3)"));
  for (std::size_t k : {3, 2}) run_study_job(dir / "jobs", k);
  const StudyResult collected = collect_study(dir / "jobs");

  EXPECT_EQ(collected.scene, direct.scene);
  EXPECT_EQ(study_csv(untimed(collected)), study_csv(untimed(direct)));
  EXPECT_EQ(study_markdown(untimed(collected)), study_markdown(untimed(direct)));
  ASSERT_EQ(collected.runs.size(), 4u);
  int front = 0;
  for (std::size_t i = 0; i < 4; ++i) {
    EXPECT_TRUE(same_bits(collected.runs[i].values[0], direct.runs[i].values[0])) << i;
    EXPECT_EQ(collected.runs[i].pareto, direct.runs[i].pareto) << i;
    front += collected.runs[i].pareto;
  }
  EXPECT_GE(front, 1);
  EXPECT_TRUE(fs::exists(dir / "jobs" / "study.csv"));
  EXPECT_TRUE(fs::exists(dir / "jobs" / "study.md"));
  EXPECT_FALSE(fs::exists(run_folder(dir / "jobs", 1) / "run.json.part"));
}

TEST(StudyJobs, ErrorsSayWhatToDo) {
  const fs::path dir = temp_dir("errors");
  EXPECT_THAT(error_of([&] { collect_study(dir); }), HasSubstr("no study here"));
  EXPECT_THAT(error_of([&] { run_study_job(dir, 1); }), HasSubstr("study.json is missing"));

  // A scene copied beside its reference file, so that the test can edit it.
  fs::copy_file(kValidation / "slender_bar.json", dir / "bar.json");
  fs::copy_file(kValidation / "slender_bar.reference.json", dir / "bar.reference.json");
  StudyOptions o;
  o.scene = dir / "bar.json";
  o.sweeps = {"bodies[0].mesh.box.cells=[10,1,1]|[20,1,1]"};
  o.out_dir = dir / "study";
  // The whole grid is checked when the list is written, as run_study does before running.
  StudyOptions bad = o;
  bad.sweeps = {"bodies[0].material.poisson=0.3|0.7"};
  EXPECT_THAT(error_of([&] { write_study_jobs(bad, "/bin/pliant", dir / "bad.txt"); }), HasSubstr("poisson"));

  write_study_jobs(o, "/bin/pliant", dir / "jobs.txt");
  EXPECT_THAT(error_of([&] { run_study_job(dir / "study", 3); }), HasSubstr("--run 3: the study in"));
  EXPECT_THAT(error_of([&] { run_study_job(dir / "study", 0); }), HasSubstr("runs 1 to 2"));
  // A scene edited after the list was written: refused, not mixed into the study.
  std::ofstream(dir / "bar.json", std::ios::app) << "\n";
  EXPECT_THAT(error_of([&] { run_study_job(dir / "study", 1); }), HasSubstr("changed since the job list was written"));
  EXPECT_THAT(error_of([&] { collect_study(dir / "study"); }), HasSubstr("changed since the job list was written"));
  // The same folder cannot take a second list once runs are in it.
  fs::create_directories(dir / "study" / "runs");
  EXPECT_THAT(error_of([&] { write_study_jobs(o, "/bin/pliant", dir / "jobs.txt"); }), HasSubstr("earlier study"));
}

TEST(StudyJobs, RunCommandsRunsEachOnceAtMostNAtATime) {
  const fs::path dir = temp_dir("commands");
  std::vector<std::string> commands;
  // Each command records itself and how many were running with it (a lock-free count through
  // files: the number of *.running files while it ran).
  for (int i = 0; i < 6; ++i)
    commands.push_back("cd '" + dir.string() + "' && touch " + std::to_string(i) + ".running && sleep 0.2 && ls *.running | wc -l > " +
                       std::to_string(i) + ".seen && rm " + std::to_string(i) + ".running" + (i == 4 ? " && exit 7" : ""));
  std::vector<int> codes(6, -2);
  const std::size_t failed = run_commands(commands, 2, false, [&](std::size_t i, int code) { codes[i] = code; });
  EXPECT_EQ(failed, 1u);
  for (int i = 0; i < 6; ++i) {
    EXPECT_EQ(codes[std::size_t(i)], i == 4 ? 7 : 0) << i;
    const int seen = std::stoi(read(dir / (std::to_string(i) + ".seen")));
    EXPECT_GE(seen, 1) << i;
    EXPECT_LE(seen, 2) << i;  // never more than 2 at once
  }
}

}  // namespace
}  // namespace pliant::study
