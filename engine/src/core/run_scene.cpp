// The scene runner: builds the world, steps it for the scene's duration, records probes and
// VTU frames at their own rates, prints a progress line, writes summary.json.
#include "pliant/run.hpp"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <fmt/format.h>
#include <fstream>
#include <nlohmann/json.hpp>

#include "pliant/vtu_writer.hpp"

namespace pliant {
namespace fs = std::filesystem;

std::string hash_hex(std::uint64_t h) { return fmt::format("{:016x}", h); }

World make_world(const SceneDef& scene, const RunOptions& options) {
  WorldDef wd = scene.world;
  if (options.threads) wd.threads = *options.threads;
  if (options.precision) wd.precision = *options.precision;
  World world(wd);
  for (const BodyDef& b : scene.bodies) world.add_body(b);
  for (const ProbeDef& p : scene.probes) world.add_probe(p);
  return world;
}

namespace {

class ProbeWriter {
 public:
  ProbeWriter(const fs::path& path, bool enabled) {
    if (!enabled) return;
    file_ = std::fopen(path.string().c_str(), "w");
    if (!file_) throw InputError(fmt::format("{}: cannot write", path.string()));
    std::fputs("time,probe,x,y,z\n", file_);
  }
  ~ProbeWriter() {
    if (file_) std::fclose(file_);
  }
  void write(const World& w) {
    if (!file_) return;
    for (std::size_t p = 0; p < w.probe_count(); ++p) {
      const Vec3d x = w.probe_position(int(p));
      fmt::print(file_, "{:.9g},{},{:.12g},{:.12g},{:.12g}\n", w.time(), w.probe_name(int(p)), x[0], x[1], x[2]);
    }
  }

 private:
  std::FILE* file_ = nullptr;
};

class VtuSeries {
 public:
  VtuSeries(const fs::path& dir, bool enabled) : dir_(dir), pvd_(dir / "series.pvd"), enabled_(enabled) {
    if (enabled_) fs::create_directories(dir_ / "vtu");
  }
  void write(const World& w, std::vector<std::string>& files) {
    if (!enabled_) return;
    for (std::size_t b = 0; b < w.body_count(); ++b) {
      const World::Snapshot s = w.snapshot(BodyId(b));
      const std::string name = fmt::format("vtu/{}_{:05d}.vtu", w.body_def(BodyId(b)).name, frame_);
      std::vector<VtuField> fields;
      fields.push_back({"displacement", 3, false, s.displacement});
      fields.push_back({"von_mises", 1, true, s.von_mises});
      fields.push_back({"stress", 9, true, s.stress});
      write_vtu(dir_ / name, s.points, s.tets, fields, VtuEncoding::base64_zlib);
      pvd_.add(w.time(), name, int(b));
      files.push_back(name);
    }
    pvd_.write();
    ++frame_;
  }
  bool enabled() const { return enabled_; }

 private:
  fs::path dir_;
  PvdSeries pvd_;
  bool enabled_;
  int frame_ = 0;
};

// When the next record is due after one at time t (s): the first multiple of `every` (s, > 0)
// past t + eps, in closed form. Adding `every` until past t cost t / every additions, a hang for
// intervals far below the step (and forever once `every` is below the rounding unit of t).
double next_due(double every, double t, double eps) {
  const double k = std::floor((t + eps) / every) + 1;
  const double next = k * every;
  return next > t + eps ? next : (k + 1) * every;  // (k + 1): k * every rounded down onto t
}

void write_summary(const fs::path& path, const RunSummary& s) {
  nlohmann::ordered_json j;
  j["status"] = s.status;
  if (!s.message.empty()) j["message"] = s.message;
  j["steps"] = s.steps;
  j["substeps"] = s.substeps;
  j["max_substeps"] = s.max_substeps;
  j["adapted_steps"] = s.adapted_steps;
  j["max_stiffness_ratio"] = s.max_stiffness_ratio;
  j["simulated_time"] = s.simulated_time;
  j["wall_time_s"] = s.wall_time_s;
  j["steps_per_second"] = s.steps_per_second;
  j["nodes"] = s.nodes;
  j["tets"] = s.tets;
  j["model"] = s.model;
  j["precision"] = s.precision;
  j["threads"] = s.threads;
  j["dt"] = s.dt;
  j["stable_dt"] = s.stable_dt;
  j["max_displacement"] = s.max_displacement;
  j["kinetic_energy"] = s.kinetic_energy;
  j["elastic_energy"] = s.elastic_energy;
  j["potential_energy"] = s.potential_energy;
  j["state_hash"] = s.state_hash;
  j["files"] = s.files;
  if (!s.notes.empty()) j["notes"] = s.notes;
  std::ofstream out(path);
  if (!out) throw InputError(fmt::format("{}: cannot write", path.string()));
  out << j.dump(2) << "\n";
}

}  // namespace

RunSummary run_scene(const SceneDef& scene, const RunOptions& options) {
  using Clock = std::chrono::steady_clock;
  const double duration = options.duration.value_or(scene.duration);
  if (!(duration > 0 && std::isfinite(duration)))
    throw InputError(fmt::format("duration must be a finite number > 0 (s), got {}", duration));
  if (options.write_files) fs::create_directories(options.out_dir);

  World world = make_world(scene, options);
  RunSummary s;
  s.precision = to_string(world.precision());
  s.threads = world.threads();
  const int asked = options.threads.value_or(scene.world.threads);
  if (asked > world.threads())
    s.notes.push_back(fmt::format("threads: {} threads asked, {} used (the cores this process may use)", asked,
                                  world.threads()));
  s.dt = world.dt();
  s.stable_dt = world.stable_dt();
  s.substeps = world.substeps();
  for (std::size_t b = 0; b < world.body_count(); ++b) {
    s.nodes += world.node_count(BodyId(b));
    s.tets += world.tet_count(BodyId(b));
    const MeshLoadReport& r = world.mesh_load_report(BodyId(b));
    if (r.skipped_cells || r.reoriented_tets || r.dropped_vertices)
      s.notes.push_back(fmt::format("body '{}': mesh loaded with {} non-tetrahedral cell(s) skipped, {} inverted tet(s) "
                                    "re-oriented, {} unused vertex(es) dropped",
                                    world.body_def(BodyId(b)).name, r.skipped_cells, r.reoriented_tets,
                                    r.dropped_vertices));
    const std::string m = to_string(world.body_def(BodyId(b)).model);
    if (s.model.find(m) == std::string::npos) s.model += (s.model.empty() ? "" : ",") + m;
  }
  // Whole steps up to the duration, at most 2^53: beyond that the simulated time (a double,
  // advanced by dt each step) no longer advances by whole steps. A count beyond int64 (1e30 s)
  // used to overflow and run 0 steps reporting "ok".
  const double step_count = std::ceil(duration / world.dt() - 1e-9);
  constexpr double kMaxSteps = 9007199254740992.0;  // 2^53
  if (!(step_count <= kMaxSteps))
    throw InputError(fmt::format(
        "duration {:g} s needs {:.3g} steps of {:.4g} s; at most 2^53 = {:.4g} steps can be run (the simulated time, "
        "a double, stops advancing by whole steps beyond that): give a shorter duration",
        duration, step_count, world.dt(), kMaxSteps));
  const std::int64_t total_steps = std::int64_t(step_count);

  ProbeWriter probes(options.out_dir / "probes.csv", options.write_files && world.probe_count() > 0);
  if (options.write_files && world.probe_count() > 0) s.files.push_back("probes.csv");
  VtuSeries vtu(options.out_dir, options.write_files && scene.output.vtu_every > 0);
  probes.write(world);
  vtu.write(world, s.files);
  const bool frames = options.on_frame && options.frame_every > 0;
  if (frames) options.on_frame(world);
  double next_probe = scene.output.probe_every, next_vtu = scene.output.vtu_every, next_frame = options.frame_every;
  const double eps = 1e-9 * world.dt();

  const auto start = Clock::now();
  auto last_print = start;
  try {
    for (std::int64_t i = 0; i < total_steps; ++i) {
      world.step();
      if (world.time() + eps >= next_probe) {  // probe_every = 0: every step
        probes.write(world);
        if (scene.output.probe_every > 0) next_probe = next_due(scene.output.probe_every, world.time(), eps);
      }
      if (vtu.enabled() && world.time() + eps >= next_vtu) {
        vtu.write(world, s.files);
        next_vtu = next_due(scene.output.vtu_every, world.time(), eps);
      }
      if (frames && world.time() + eps >= next_frame) {
        options.on_frame(world);
        next_frame = next_due(options.frame_every, world.time(), eps);
      }
      if (options.progress && (i & 63) == 0) {
        const auto now = Clock::now();
        if (now - last_print > std::chrono::milliseconds(200)) {
          last_print = now;
          const double wall = std::chrono::duration<double>(now - start).count();
          const double rate = double(i + 1) / wall;
          std::fprintf(stderr, "\r  %5.1f%%  t = %.4g / %.4g s  step %lld / %lld  %.0f steps/s  ETA %.0f s   ",
                       100.0 * double(i + 1) / double(total_steps), world.time(), duration, (long long)(i + 1),
                       (long long)total_steps, rate, double(total_steps - i - 1) / rate);
          std::fflush(stderr);
        }
      }
    }
  } catch (const DivergenceError& e) {
    s.status = "diverged";
    s.message = e.what();
  }
  if (options.progress) std::fprintf(stderr, "\r%100s\r", "");
  s.wall_time_s = std::chrono::duration<double>(Clock::now() - start).count();
  s.steps = world.steps();
  s.max_substeps = world.max_substeps();
  s.adapted_steps = world.adapted_steps();
  s.max_stiffness_ratio = world.max_stiffness_ratio();
  s.simulated_time = world.time();
  s.steps_per_second = s.wall_time_s > 0 ? double(s.steps) / s.wall_time_s : 0;
  s.state_hash = hash_hex(world.state_hash());
  if (s.status == "ok") {
    const Energies e = world.energies();
    s.kinetic_energy = e.kinetic;
    s.elastic_energy = e.elastic;
    s.potential_energy = e.potential;
    s.max_displacement = world.max_displacement();
  }
  if (options.write_files) {
    s.files.push_back("summary.json");
    write_summary(options.out_dir / "summary.json", s);
  }
  if (s.status != "ok") throw DivergenceError(s.message);
  return s;
}

}  // namespace pliant
