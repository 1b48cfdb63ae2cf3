// Studies beyond one process (issue 11 §4): the runs of a study are independent, so they can be
// written as a job list, run anywhere (GNU parallel on one host, a Slurm array on a cluster, or
// `pliant study --parallel N`), and collected afterwards into the same study.csv, study.md and
// plots as an in-process study of the same sweep.
//
//   DIR/study.json         what the study is (the options, absolute paths, a fingerprint of the
//                          scene and reference files), written with the job list
//   FILE                   one shell command per run, line K runs run K:
//                            '/abs/pliant' study --out '/abs/DIR' --run K   # cells=[20,1,1]
//   DIR/runs/000K/run.json the measured run K (written whole or not at all)
//
// Every run re-parses the scene and checks the fingerprint, so a scene edited after the job list
// was written is an error, not a silent mixture of two studies.
#pragma once
#include <cstddef>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "pliant/perf/study.hpp"

namespace pliant::study {

// Writes DIR/study.json (DIR = options.out_dir) and the job list `jobs_file`, one command per run
// calling `executable` (absolute paths everywhere: each line runs from any working directory).
// Checks the whole grid first (InputError as run_study). Returns the commands, in run order.
std::vector<std::string> write_study_jobs(const StudyOptions& options, const std::filesystem::path& executable,
                                          const std::filesystem::path& jobs_file);

// Runs run `k` (1-based) of the study in DIR/study.json and writes DIR/runs/<k>/run.json.
// `progress` gets the run's line. InputError when DIR holds no study, k is out of range or the
// scene changed since the job list was written.
RunRecord run_study_job(const std::filesystem::path& dir, std::size_t k,
                        const std::function<void(const std::string&)>& progress = {});

// Assembles the study of DIR from its run folders: errors, the Pareto front and DIR/study.csv,
// DIR/study.md (the plots are drawn by the caller, as after run_study). InputError listing the
// runs that have no run.json (and their job lines), or whose settings are not the study's.
StudyResult collect_study(const std::filesystem::path& dir);

// The study options stored in DIR/study.json (for --parallel and the tests).
StudyOptions load_study_spec(const std::filesystem::path& dir);

// Runs `commands` through /bin/sh, at most `parallel` at a time; `done(i, exit_status)` after each
// (exit_status as from the shell, -1 when it could not be started). Output goes where ours goes,
// or nowhere with `quiet`. Returns the number of commands that failed.
std::size_t run_commands(const std::vector<std::string>& commands, int parallel, bool quiet,
                         const std::function<void(std::size_t, int)>& done);

// A run as JSON and back, exactly (doubles round-trip; NaN as null, infinities as strings).
std::string run_record_json(const RunRecord& run);
RunRecord parse_run_record(const std::string& json_text, const std::string& source);

// DIR/runs/0007 for k = 7.
std::filesystem::path run_folder(const std::filesystem::path& dir, std::size_t k);

}  // namespace pliant::study
