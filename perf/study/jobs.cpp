// A study as a job list, its runs as separate processes, and their collection (study_jobs.hpp).
#include <fcntl.h>
#include <fmt/format.h>
#include <fmt/ranges.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>

#include "pliant/error.hpp"
#include "pliant/input_file.hpp"
#include "pliant/perf/study_jobs.hpp"

extern char** environ;

namespace pliant::study {
namespace fs = std::filesystem;
using Json = nlohmann::ordered_json;

namespace {

constexpr const char* kFormat = "pliant study jobs 1";

// 'text' for /bin/sh: single quotes, a quote inside as '\''.
std::string shell_quote(const std::string& text) {
  std::string out = "'";
  for (char c : text) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

// FNV-1a, 64 bits: enough to notice that a file changed between the job list and a run.
std::uint64_t fnv1a(std::string_view text, std::uint64_t h = 1469598103934665603ull) {
  for (unsigned char c : text) h = (h ^ c) * 1099511628211ull;
  return h;
}

// As run_study reads --reference: a number (the whole text), "finest", or else a file.
bool reference_is_file(const StudyOptions& o) {
  if (!o.measure.empty() || o.reference.empty() || o.reference == "finest") return false;
  char* end = nullptr;
  const double v = std::strtod(o.reference.c_str(), &end);
  return !(end == o.reference.c_str() + o.reference.size() && std::isfinite(v));
}

// The files a study's results depend on: the scene, and the reference file when there is one.
std::string fingerprint(const StudyOptions& o) {
  std::uint64_t h = fnv1a(read_input_file(o.scene, "scene file"));
  const fs::path ref = reference_is_file(o) ? fs::path(o.reference) : reference_path_for(o.scene);
  if (o.measure.empty() && fs::exists(ref)) h = fnv1a(read_input_file(ref, "reference file"), h ^ 0x9e3779b97f4a7c15ull);
  return fmt::format("{:016x}", h);
}

Json number(double v) {
  if (std::isnan(v)) return "nan";
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  return v;
}

double number_of(const Json& j, const std::string& source, const char* key) {
  if (j.is_number()) return j.get<double>();
  if (j.is_string()) {
    const std::string s = j.get<std::string>();
    if (s == "nan") return kNaN;
    if (s == "inf") return std::numeric_limits<double>::infinity();
    if (s == "-inf") return -std::numeric_limits<double>::infinity();
  }
  throw InputError(fmt::format("{}: {} is not a number: {}", source, key, j.dump()));
}

fs::path spec_path(const fs::path& dir) { return dir / "study.json"; }

Json read_json(const fs::path& path, std::string_view what) {
  const std::string text = read_input_file(path, what);
  try {
    return Json::parse(text);
  } catch (const Json::exception& e) {
    throw InputError(fmt::format("{}: not JSON: {}", path.string(), e.what()));
  }
}

void write_atomically(const fs::path& path, const std::string& text) {
  const fs::path tmp = path.string() + ".part";
  {
    std::ofstream out(tmp);
    out << text;
    if (!out.flush()) throw InputError(fmt::format("{}: cannot write", tmp.string()));
  }
  fs::rename(tmp, path);  // whole or not at all: a run killed mid-write leaves no run.json
}

// The spec's fingerprint against the files now: a scene edited after the job list is an error.
void check_fingerprint(const StudyOptions& o, const std::string& stored, const fs::path& dir) {
  const std::string now = fingerprint(o);
  if (now != stored)
    throw InputError(fmt::format("{}: {} (or its reference file) changed since the job list was written "
                                 "(fingerprint {} then, {} now): write the job list again",
                                 spec_path(dir).string(), o.scene.string(), stored, now));
}

struct Spec {
  StudyOptions options;
  std::size_t runs = 0;
  std::string fingerprint;
};

Spec load_spec(const fs::path& dir) {
  const fs::path path = spec_path(dir);
  if (!fs::exists(path))
    throw InputError(fmt::format("{}: no study here ({} is missing: write it with pliant study SCENE ... --out {} --jobs FILE)",
                                 dir.string(), path.string(), dir.string()));
  const Json j = read_json(path, "study file");
  const std::string source = path.string();
  try {
    if (j.value("format", "") != kFormat)
      throw InputError(fmt::format("{}: format is not \"{}\"", source, kFormat));
    Spec s;
    StudyOptions& o = s.options;
    o.scene = j.at("scene").get<std::string>();
    o.scene_label = j.at("scene_label").get<std::string>();
    o.sweeps = j.at("sweeps").get<std::vector<std::string>>();
    o.reference = j.at("reference").get<std::string>();
    o.measure = j.at("measure").get<std::string>();
    if (j.at("threads").is_null()) o.threads.reset();
    else o.threads = j.at("threads").get<int>();
    const std::string cost = j.at("cost").get<std::string>();
    try {
      o.cost = parse_cost(cost);
    } catch (const InputError&) {
      throw InputError(fmt::format("{}: cost '{}'", source, cost));
    }
    o.min_time = j.at("min_time").get<double>();
    o.out_dir = dir;
    s.runs = j.at("runs").get<std::size_t>();
    s.fingerprint = j.at("fingerprint").get<std::string>();
    return s;
  } catch (const Json::exception& e) {
    throw InputError(fmt::format("{}: {}", source, e.what()));
  }
}

}  // namespace

fs::path run_folder(const fs::path& dir, std::size_t k) { return dir / "runs" / fmt::format("{:04d}", k); }

std::string run_record_json(const RunRecord& r) {
  Json j;
  j["settings"] = r.settings;
  j["status"] = r.status;
  j["message"] = r.message;
  j["model"] = r.model;
  j["precision"] = r.precision;
  j["threads"] = r.threads;
  j["nodes"] = r.nodes;
  j["tets"] = r.tets;
  j["steps"] = r.steps;
  j["tet_updates"] = number(r.tet_updates);
  j["substeps"] = r.substeps;
  j["dt"] = number(r.dt);
  j["simulated_time"] = number(r.simulated_time);
  j["setup_s"] = number(r.setup_s);
  j["wall_s"] = number(r.wall_s);
  j["repeats"] = r.repeats;
  Json values = Json::array(), references = Json::array();
  for (double v : r.values) values.push_back(number(v));
  for (double v : r.references) references.push_back(number(v));
  j["values"] = values;
  j["references"] = references;
  // probe_rms tracks (per quantity, empty for the others): finish_study needs them all.
  Json tracks = Json::array();
  for (const auto& track : r.tracks) {
    Json t = Json::array();
    for (double v : track) t.push_back(number(v));
    tracks.push_back(t);
  }
  j["tracks"] = tracks;
  return j.dump(2) + "\n";
}

RunRecord parse_run_record(const std::string& text, const std::string& source) {
  try {
    const Json j = Json::parse(text);
    RunRecord r;
    r.settings = j.at("settings").get<std::vector<std::string>>();
    r.status = j.at("status").get<std::string>();
    r.message = j.at("message").get<std::string>();
    r.model = j.at("model").get<std::string>();
    r.precision = j.at("precision").get<std::string>();
    r.threads = j.at("threads").get<int>();
    r.nodes = j.at("nodes").get<std::size_t>();
    r.tets = j.at("tets").get<std::size_t>();
    r.steps = j.at("steps").get<std::int64_t>();
    r.substeps = j.at("substeps").get<int>();
    r.tet_updates = number_of(j.at("tet_updates"), source, "tet_updates");
    r.dt = number_of(j.at("dt"), source, "dt");
    r.simulated_time = number_of(j.at("simulated_time"), source, "simulated_time");
    r.setup_s = number_of(j.at("setup_s"), source, "setup_s");
    r.wall_s = number_of(j.at("wall_s"), source, "wall_s");
    r.repeats = j.at("repeats").get<int>();
    for (const Json& v : j.at("values")) r.values.push_back(number_of(v, source, "values"));
    for (const Json& v : j.at("references")) r.references.push_back(number_of(v, source, "references"));
    if (j.contains("tracks"))
      for (const Json& t : j.at("tracks")) {
        r.tracks.emplace_back();
        for (const Json& v : t) r.tracks.back().push_back(number_of(v, source, "tracks"));
      }
    return r;
  } catch (const Json::exception& e) {
    throw InputError(fmt::format("{}: not a run record: {}", source, e.what()));
  }
}

std::vector<std::string> write_study_jobs(const StudyOptions& given, const fs::path& executable, const fs::path& jobs_file) {
  StudyOptions o = given;
  o.scene_label = given.scene_label.empty() ? given.scene.string() : given.scene_label;
  o.scene = fs::absolute(given.scene).lexically_normal();
  if (reference_is_file(o)) o.reference = fs::absolute(o.reference).lexically_normal().string();
  const fs::path dir = fs::absolute(given.out_dir).lexically_normal();
  const PreparedStudy prepared = prepare_study(o);  // every scene of the grid checked now

  fs::create_directories(dir);
  if (fs::exists(dir / "runs"))
    throw InputError(fmt::format("{}: holds runs of an earlier study; give an empty --out folder", (dir / "runs").string()));
  Json j;
  j["format"] = kFormat;
  j["scene"] = o.scene.string();
  j["scene_label"] = o.scene_label;
  j["sweeps"] = o.sweeps;
  j["reference"] = o.reference;
  j["measure"] = o.measure;
  j["threads"] = o.threads ? Json(*o.threads) : Json();
  j["cost"] = to_string(o.cost);
  j["min_time"] = o.min_time;
  j["runs"] = prepared.points.size();
  j["fingerprint"] = fingerprint(o);
  write_atomically(spec_path(dir), j.dump(2) + "\n");

  const std::string exe = fs::absolute(executable).lexically_normal().string();
  std::vector<std::string> commands;
  std::string list;
  for (std::size_t i = 0; i < prepared.points.size(); ++i) {
    std::string label = prepared.result.sweeps.empty() ? "the scene"
                                                       : settings_label(prepared.result.sweeps, prepared.points[i].settings);
    for (char& c : label)
      if (c == '\n' || c == '\r') c = ' ';
    commands.push_back(fmt::format("{} study --out {} --run {}", shell_quote(exe), shell_quote(dir.string()), i + 1));
    list += commands.back() + "  # " + label + "\n";
  }
  if (!jobs_file.parent_path().empty()) fs::create_directories(jobs_file.parent_path());
  std::ofstream out(jobs_file);
  out << list;
  if (!out.flush()) throw InputError(fmt::format("{}: cannot write", jobs_file.string()));
  return commands;
}

StudyOptions load_study_spec(const fs::path& dir) { return load_spec(dir).options; }

RunRecord run_study_job(const fs::path& dir, std::size_t k, const std::function<void(const std::string&)>& progress) {
  const Spec spec = load_spec(dir);
  if (k < 1 || k > spec.runs)
    throw InputError(fmt::format("--run {}: the study in {} has runs 1 to {}", k, dir.string(), spec.runs));
  check_fingerprint(spec.options, spec.fingerprint, dir);
  const PreparedStudy prepared = prepare_study(spec.options);
  if (prepared.points.size() != spec.runs)
    throw InputError(fmt::format("{}: {} runs listed, the sweeps give {}", spec_path(dir).string(), spec.runs,
                                 prepared.points.size()));
  const auto t0 = std::chrono::steady_clock::now();
  const RunRecord r = run_point(prepared, k - 1, spec.options);
  const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  Json j = Json::parse(run_record_json(r));
  j["run"] = k;
  j["elapsed_s"] = elapsed;  // the whole run with its repeats: what an in-process study's total adds up
  const fs::path folder = run_folder(dir, k);
  fs::create_directories(folder);
  write_atomically(folder / "run.json", j.dump(2) + "\n");
  if (progress) progress(progress_line(prepared.result, r, k - 1, spec.runs));
  return r;
}

StudyResult collect_study(const fs::path& dir) {
  const Spec spec = load_spec(dir);
  check_fingerprint(spec.options, spec.fingerprint, dir);
  PreparedStudy prepared = prepare_study(spec.options);
  StudyResult& s = prepared.result;
  std::vector<std::string> missing;
  for (std::size_t k = 1; k <= prepared.points.size(); ++k) {
    const fs::path file = run_folder(dir, k) / "run.json";
    if (!fs::exists(file)) {
      missing.push_back(std::to_string(k));
      continue;
    }
    const std::string text = read_input_file(file, "run record");
    RunRecord r = parse_run_record(text, file.string());
    if (r.settings != prepared.points[k - 1].settings)
      throw InputError(fmt::format("{}: settings {} are not those of run {} of the study ({})", file.string(),
                                   fmt::join(r.settings, ", "), k, fmt::join(prepared.points[k - 1].settings, ", ")));
    r.references = prepared.points[k - 1].references;
    try {
      s.wall_total_s += Json::parse(text).value("elapsed_s", r.wall_s);
    } catch (const Json::exception&) {
    }
    s.runs.push_back(std::move(r));
  }
  if (!missing.empty())
    throw InputError(fmt::format("{}: {} of {} runs have no run.json (runs {}): run those lines of the job list "
                                 "(line K is run K) and collect again",
                                 dir.string(), missing.size(), prepared.points.size(), fmt::join(missing, ", ")));
  finish_study(s);
  write_study_files(s, dir);
  return std::move(s);
}

std::size_t run_commands(const std::vector<std::string>& commands, int parallel, bool quiet,
                         const std::function<void(std::size_t, int)>& done) {
  if (parallel < 1) parallel = 1;
  std::map<pid_t, std::size_t> running;
  std::size_t next = 0, failed = 0;
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  if (quiet) {
    posix_spawn_file_actions_addopen(&actions, 1, "/dev/null", O_WRONLY, 0);
    posix_spawn_file_actions_addopen(&actions, 2, "/dev/null", O_WRONLY, 0);
  }
  while (next < commands.size() || !running.empty()) {
    while (next < commands.size() && running.size() < std::size_t(parallel)) {
      const std::string& cmd = commands[next];
      char sh[] = "/bin/sh", dash_c[] = "-c";
      std::vector<char> text(cmd.begin(), cmd.end());
      text.push_back('\0');
      char* argv[] = {sh, dash_c, text.data(), nullptr};
      pid_t pid = 0;
      if (posix_spawn(&pid, "/bin/sh", &actions, nullptr, argv, environ) != 0) {
        ++failed;
        if (done) done(next, -1);
      } else {
        running[pid] = next;
      }
      ++next;
    }
    if (running.empty()) continue;
    int status = 0;
    const pid_t pid = waitpid(-1, &status, 0);
    if (pid < 0) {
      if (errno == EINTR) continue;
      break;  // no child left that we know of
    }
    const auto it = running.find(pid);
    if (it == running.end()) continue;  // not one of ours
    const int code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
    failed += code != 0;
    if (done) done(it->second, code);
    running.erase(it);
  }
  posix_spawn_file_actions_destroy(&actions);
  return failed;
}

}  // namespace pliant::study
