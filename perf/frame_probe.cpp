// What each step and each frame of a scene costs with an adaptive body's settings held fixed (the
// real-time controller's rungs, measured apart from it): steps back to back, unpaced, timed one by
// one; frames are runs of steps covering `--frame` seconds of simulated time (1 ms: a 1 kHz host).
// Prints the step and frame percentiles, how many frames took longer than a frame, the slowest
// steps (with their index modulo the coarsest level's period: the ticks where windows end), and
// each level's stepped tets at the end. docs/adaptivity.md quotes it for the middle level's cost.
//   frame_probe SCENE [--set PATH=VALUE]... [--duration S] [--threads N] [--scale X] [--cap LEVEL]
//               [--budget SPLITS] [--frame S] [--paced 1] [--touch PAGES] [--lift-at S] [--lift-to LEVEL]
//               [--change-interval S]
// --budget and --change-interval set what the real-time controller sets (2 splits a decision, one
// change a frame: World::set_adapt_split_budget and set_adapt_change_interval).
// --paced 1 waits for each frame's wall-clock time as `pliant run --realtime` does (then memory
// the idle levels leave untouched ages as in a real-time run), but always for the frame's own
// time: the runner starts a frame that may change the resolution up to a frame early; --touch reads that many pages of
// the bodies' arrays in each wait (World::touch_pages; the runner reads up to 64); --lift-at lifts
// the cap at that simulated time (to the finest level, or to --lift-to LEVEL) and prints the frames
// that follow it (what a try of the finer levels costs after they sat idle).
// --set edits the scene as `pliant study --sweep` does, e.g. the 50k-tet organ of docs/adaptivity.md:
//   frame_probe scenes/adaptive_organ.json --set bodies[0].mesh.cell_size=0.0043 --threads 2 --scale 4 --cap 1 --budget 2
#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "pliant/error.hpp"
#include "pliant/run.hpp"
#include "pliant/scene.hpp"
#include "pliant/world.hpp"

namespace {
using namespace pliant;

double quantile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, std::size_t(q * double(v.size())))];
}

int usage() {
  std::fprintf(stderr,
               "usage: frame_probe SCENE [--set PATH=VALUE]... [--duration S] [--threads N] [--scale X] [--cap LEVEL] "
               "[--budget SPLITS] [--frame S] [--paced 1] [--touch PAGES] [--lift-at S] [--lift-to LEVEL] [--change-interval S]\n");
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) return usage();
  double duration = 1, scale = 1, frame = 1e-3, lift_at = -1, change_interval = 0;
  int threads = 0, cap = -1, budget = 0, paced = 0, touch = 0, lift_to = -1;
  std::vector<std::string> overrides;
  for (int i = 2; i < argc; ++i) {
    const std::string a = argv[i];
    if (i + 1 >= argc) return usage();
    if (a == "--set") {
      overrides.push_back(argv[++i]);
      continue;
    }
    const double v = std::atof(argv[++i]);
    if (a == "--duration") duration = v;
    else if (a == "--threads") threads = int(v);
    else if (a == "--scale") scale = v;
    else if (a == "--cap") cap = int(v);
    else if (a == "--budget") budget = int(v);
    else if (a == "--change-interval") change_interval = v;
    else if (a == "--frame") frame = v;
    else if (a == "--paced") paced = int(v);
    else if (a == "--touch") touch = int(v);
    else if (a == "--lift-at") lift_at = v;
    else if (a == "--lift-to") lift_to = int(v);
    else return usage();
  }
  if (!(duration > 0) || !(frame > 0)) return usage();
  try {
    const std::filesystem::path path = argv[1];
    std::ifstream in(path);
    if (!in) throw InputError(fmt::format("{}: cannot read the scene file", path.string()));
    std::stringstream text;
    text << in.rdbuf();
    const SceneDef scene = parse_scene(apply_scene_overrides(text.str(), overrides, path.string()), path.string(),
                                       path.parent_path());
    RunOptions ro;
    ro.threads = threads;
    ro.write_files = false;
    World w = make_world(scene, ro);
    for (std::size_t b = 0; b < w.body_count(); ++b) {
      const auto id = BodyId(b);
      if (w.body_def(id).multiresolution.active.kind != ActiveDef::Kind::adaptive) continue;
      w.set_adapt_scale(id, scale);
      if (cap >= 0) w.set_adapt_cap(id, std::min(cap, w.level_count(id) - 1));
      if (budget > 0) w.set_adapt_split_budget(id, budget);
      if (change_interval != 0) w.set_adapt_change_interval(id, change_interval);  // (World rejects < 0, NaN)
    }
    const auto steps = std::int64_t(std::llround(duration / w.dt()));
    const auto per_frame = std::max<std::int64_t>(1, std::llround(frame / w.dt()));
    std::vector<double> step_us;
    step_us.reserve(std::size_t(steps));
    const auto wall0 = std::chrono::steady_clock::now();
    const double sim0 = w.time();
    std::int64_t lift_step = -1;
    // Decision points and changes of resolution so far, over the adaptive bodies.
    auto adapt_counts = [&] {
      std::pair<std::int64_t, std::int64_t> n{0, 0};
      for (std::size_t b = 0; b < w.body_count(); ++b) {
        const World::AdaptStats st = w.adapt_stats(BodyId(b));
        n.first += st.checks;
        n.second += st.changes;
      }
      return n;
    };
    std::vector<double> change_us, check_us, other_us;  // step times (us) by what the step's decision point did
    for (std::int64_t i = 0; i < steps; ++i) {
      if (paced && i % per_frame == 0) {  // a frame starts: wait for its wall-clock time
        const auto due = wall0 + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                     std::chrono::duration<double>(w.time() - sim0));
        for (int done = 0; done < touch && std::chrono::steady_clock::now() + std::chrono::microseconds(300) < due; done += 8)
          if (w.touch_pages(8) == 0) break;
        if (std::chrono::steady_clock::now() + std::chrono::microseconds(150) < due)
          std::this_thread::sleep_until(due - std::chrono::microseconds(150));
        while (std::chrono::steady_clock::now() < due) {
        }
      }
      if (lift_at >= 0 && lift_step < 0 && w.time() >= lift_at) {
        lift_step = i;
        for (std::size_t b = 0; b < w.body_count(); ++b)
          if (w.body_def(BodyId(b)).multiresolution.active.kind == ActiveDef::Kind::adaptive)
            w.set_adapt_cap(BodyId(b), lift_to >= 0 ? std::min(lift_to, w.level_count(BodyId(b)) - 1) : w.level_count(BodyId(b)) - 1);
      }
      const auto [checks0, changes0] = adapt_counts();
      const auto a = std::chrono::steady_clock::now();
      w.step();
      step_us.push_back(1e6 * std::chrono::duration<double>(std::chrono::steady_clock::now() - a).count());
      const auto [checks1, changes1] = adapt_counts();
      (changes1 != changes0 ? change_us : checks1 != checks0 ? check_us : other_us).push_back(step_us.back());
    }
    // What a decision point costs: its step against the steps without one (the difference is the
    // decision's, or the change's, own cost, give or take what the tick's position adds).
    auto summary = [](const char* what, std::vector<double> us) {
      double sum = 0;
      for (double u : us) sum += u;
      fmt::print("  {}: {}, mean {:.1f} us, p50 {:.1f}, p99 {:.1f}, max {:.1f}\n", what, us.size(),
                 us.empty() ? 0.0 : sum / double(us.size()), quantile(us, 0.5), quantile(us, 0.99),
                 us.empty() ? 0.0 : *std::max_element(us.begin(), us.end()));
    };
    if (!change_us.empty() || !check_us.empty()) {
      fmt::print("steps by their decision point (adaptive bodies):\n");
      summary("steps that changed the resolution", change_us);
      summary("steps that decided without a change", check_us);
      summary("steps without a decision", other_us);
    }
    std::vector<double> frame_us;
    for (std::size_t i = 0; i + std::size_t(per_frame) <= step_us.size(); i += std::size_t(per_frame)) {
      double f = 0;
      for (std::size_t j = i; j < i + std::size_t(per_frame); ++j) f += step_us[j];
      frame_us.push_back(f);
    }
    double sum = 0, frame_sum = 0;
    for (double x : step_us) sum += x;
    for (double f : frame_us) frame_sum += f;
    const std::size_t over = std::size_t(std::count_if(frame_us.begin(), frame_us.end(), [&](double f) { return f > 1e6 * frame; }));
    fmt::print("{} steps of {:.3g} s on {} thread(s), thresholds x{:g}, cap {}, split budget {}, change interval {:g} s\n", steps, w.dt(), w.threads(),
               scale, cap < 0 ? std::string("none") : std::to_string(cap), budget > 0 ? std::to_string(budget) : std::string("none"),
               change_interval);
    fmt::print("steps (us): mean {:.2f}, p50 {:.2f}, p99 {:.2f}, max {:.1f}\n", sum / double(std::max<std::int64_t>(steps, 1)),
               quantile(step_us, 0.5), quantile(step_us, 0.99), step_us.empty() ? 0.0 : *std::max_element(step_us.begin(), step_us.end()));
    fmt::print("frames of {} steps ({:.3g} s): {}, stepping mean {:.1f} us, p50 {:.1f}, p99 {:.1f}, max {:.1f}; {} took longer than a frame\n",
               per_frame, double(per_frame) * w.dt(), frame_us.size(), frame_sum / double(std::max<std::size_t>(frame_us.size(), 1)),
               quantile(frame_us, 0.5), quantile(frame_us, 0.99),
               frame_us.empty() ? 0.0 : *std::max_element(frame_us.begin(), frame_us.end()), over);
    if (lift_step >= 0) {  // the frames after the lift: their stepping, and the slowest step among them
      const auto first = std::size_t(lift_step) / std::size_t(per_frame);
      for (std::size_t f = first; f < std::min(frame_us.size(), first + 12); ++f) {
        double slowest = 0;
        for (std::size_t j = f * std::size_t(per_frame); j < (f + 1) * std::size_t(per_frame); ++j) slowest = std::max(slowest, step_us[j]);
        fmt::print("  frame {} after the lift: {:.1f} us (slowest step {:.1f})\n", f - first, frame_us[f], slowest);
      }
    }
    std::vector<std::size_t> order(step_us.size());
    for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
    const std::size_t top = std::min<std::size_t>(5, order.size());
    std::partial_sort(order.begin(), order.begin() + std::ptrdiff_t(top), order.end(),
                      [&](std::size_t a, std::size_t b) { return step_us[a] > step_us[b]; });
    const int period = w.body_count() > 0 ? w.level_info(0, 0).period : 1;
    for (std::size_t k = 0; k < top; ++k)
      fmt::print("  slow step {} (t = {:.5f} s, index mod {} = {}): {:.1f} us\n", order[k], double(order[k] + 1) * w.dt(), period,
                 order[k] % std::size_t(period), step_us[order[k]]);
    for (std::size_t b = 0; b < w.body_count(); ++b)
      for (int l = 0; l < w.level_count(BodyId(b)); ++l) {
        const LevelInfo li = w.level_info(BodyId(b), l);
        // Runs of consecutive stepped tets: by runs, the element kernels fill their vector lanes
        // within a run; a level of short runs is stepped from a list instead (LevelInfo::listed).
        const std::size_t runs = w.precision() == Precision::float32 ? w.level<float>(BodyId(b), l).stepped_runs.size()
                                                                     : w.level<double>(BodyId(b), l).stepped_runs.size();
        fmt::print("body {} level {}: {} tets, {} stepped at the end in {} runs ({}), period {}\n", b, l, li.tets,
                   li.stepped_tets, runs, li.listed ? "from a list" : "by runs", li.period);
      }
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "frame_probe: %s\n", e.what());
    return 1;
  }
}
