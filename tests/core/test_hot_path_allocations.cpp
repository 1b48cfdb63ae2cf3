// The hot path does not allocate (the project's standard, DESIGN.md): once a world has stepped a
// while, a step makes no heap allocation through operator new, on 1 thread or 2 — with a tool
// pressing the body, a table under it, Rayleigh damping, and for an adaptive multiresolution body
// at every step that did not split or merge (its decision points included: most decide nothing).
// A change of resolution allocates (the jobs are prepared again: docs/multiresolution.md) and is
// left out. Counted by replacing the global operator new in this test program; an allocation
// made inside Embree (its refit of a tool's BVH, rtcCommitScene, when a surface vertex has left
// its box's margin: a few in hundreds of steps) is counted apart, by the library on its stack.
#include <dlfcn.h>
#include <execinfo.h>
#include <gtest/gtest.h>

#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <new>
#include <sstream>
#include <string>

#include "pliant/run.hpp"
#include "pliant/scene.hpp"
#include "pliant/world.hpp"

namespace {
std::atomic<bool> g_counting{false};
std::atomic<long> g_ours{0}, g_embree{0};  // operator new calls while counting: ours, and Embree's
thread_local bool g_in_hook = false;        // backtrace() may allocate: not counted

// Whether a frame of the calling stack lies in Embree's library.
bool called_from_embree() {
  void* frames[32];
  const int n = backtrace(frames, 32);
  for (int i = 0; i < n; ++i) {
    Dl_info info{};
    if (dladdr(frames[i], &info) && info.dli_fname && std::strstr(info.dli_fname, "libembree")) return true;
  }
  return false;
}

void* counted(std::size_t n, std::size_t align) {
  if (g_counting.load(std::memory_order_relaxed) && !g_in_hook) {
    g_in_hook = true;
    (called_from_embree() ? g_embree : g_ours).fetch_add(1, std::memory_order_relaxed);
    g_in_hook = false;
  }
  if (n == 0) n = 1;
  void* p = align > alignof(std::max_align_t) ? std::aligned_alloc(align, (n + align - 1) / align * align) : std::malloc(n);
  if (!p) throw std::bad_alloc();
  return p;
}
}  // namespace

void* operator new(std::size_t n) { return counted(n, 0); }
void* operator new[](std::size_t n) { return counted(n, 0); }
void* operator new(std::size_t n, std::align_val_t a) { return counted(n, std::size_t(a)); }
void* operator new[](std::size_t n, std::align_val_t a) { return counted(n, std::size_t(a)); }
void* operator new(std::size_t n, const std::nothrow_t&) noexcept {
  try {
    return counted(n, 0);
  } catch (...) {
    return nullptr;
  }
}
void* operator new[](std::size_t n, const std::nothrow_t&) noexcept {
  try {
    return counted(n, 0);
  } catch (...) {
    return nullptr;
  }
}
void operator delete(void* p) noexcept { std::free(p); }
void operator delete[](void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t) noexcept { std::free(p); }
void operator delete(void* p, std::align_val_t) noexcept { std::free(p); }
void operator delete[](void* p, std::align_val_t) noexcept { std::free(p); }
void operator delete(void* p, std::size_t, std::align_val_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t, std::align_val_t) noexcept { std::free(p); }

namespace pliant {
namespace {

SceneDef scene_file(const std::string& name, const std::vector<std::string>& overrides = {}) {
  const std::filesystem::path path = std::filesystem::path(PLIANT_SOURCE_DIR) / "scenes" / name;
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return parse_scene(apply_scene_overrides(text.str(), overrides, path.string()), path.string(), path.parent_path());
}

struct Counted {
  long steps = 0;           // steps counted
  long allocations = 0;     // operator new calls during them, ours
  long embree = 0;          // and Embree's (its BVH refits)
  long refits = 0;          // the tools' BVH refits during them
  long touching = 0;        // steps at whose end a tool touched the body
  long changing_steps = 0;  // steps left out: they changed a body's resolution, or its targets
};

// Steps `warm` steps, then `count` more, counting the allocations of each step that changed no
// body's resolution. A decision that split or merged a node is left out even when what is stepped
// stayed the same (a split inside a region already refined): it re-activates as a change does.
Counted count_allocations(const SceneDef& scene, int threads, int warm, int count) {
  RunOptions o;
  o.write_files = false;
  o.threads = threads;
  World w = make_world(scene, o);
  for (int i = 0; i < warm; ++i) w.step();
  auto changes = [&] {
    std::int64_t n = 0;
    for (std::size_t b = 0; b < w.body_count(); ++b)
      if (w.level_count(BodyId(b)) > 1 && w.body_def(BodyId(b)).multiresolution.active.kind == ActiveDef::Kind::adaptive)
      {
        const World::AdaptStats a = w.adapt_stats(BodyId(b));
        n += a.changes + a.splits + a.merges + a.undone;
      }
    return n;
  };
  auto refits = [&] {
    long n = 0;
    for (std::size_t t = 0; t < w.tool_count(); ++t) n += long(w.tool_reading(ToolId(t)).refits);
    return n;
  };
  Counted c;
  const long refits_before = refits();
  for (int i = 0; i < count; ++i) {
    const std::int64_t before = changes();
    const long ours = g_ours.load(), embree = g_embree.load();
    g_counting = true;
    w.step();
    g_counting = false;
    if (changes() != before) {
      ++c.changing_steps;
      continue;
    }
    ++c.steps;
    for (std::size_t t = 0; t < w.tool_count(); ++t) c.touching += w.tool_reading(ToolId(t)).contacts > 0;
    c.allocations += g_ours.load() - ours;
    c.embree += g_embree.load() - embree;
  }
  c.refits = refits() - refits_before;
  return c;
}

// A box held at one end, pressed by a sphere that comes down onto it, over a table, with Rayleigh
// damping: the default scene's passes on a mesh that needs no CGAL.
SceneDef pressed_box() {
  return parse_scene(R"({"duration": 1, "precision": "float",
      "bodies": [{"name": "box", "mesh": {"box": {"min": [0,0,0], "max": [0.1,0.04,0.04], "cells": [10,4,4]}},
                  "material": {"young": 2e4, "poisson": 0.45, "density": 1000, "damping": {"mass": 3.0, "stiffness": 1e-4}},
                  "fixed": [{"box": {"min": [-1,-1,-1], "max": [1e-9,1,1]}}]}],
      "obstacles": [{"plane": {"point": [0,0,-0.002], "normal": [0,0,1]}, "friction": 0.3}],
      "tools": [{"name": "probe", "shape": {"sphere": {"radius": 0.01}},
                 "path": {"keyframes": [{"time": 0, "position": [0.07,0.02,0.055]},
                                        {"time": 0.05, "position": [0.07,0.02,0.045]}]}}]})",
                     "pressed_box.json", ".");
}

TEST(HotPath, AStepOfABodyPressedByAToolAllocatesNothing) {
  for (int threads : {1, 2}) {
    const Counted c = count_allocations(pressed_box(), threads, 200, 400);
    std::printf("%d thread(s): %ld allocations in %ld steps; inside Embree %ld, for %ld BVH refits\n", threads,
                c.allocations, c.steps, c.embree, c.refits);
    EXPECT_EQ(c.steps, 400);
    EXPECT_EQ(c.touching, 400);  // the tool presses the box in every counted step
    EXPECT_EQ(c.allocations, 0) << threads << " thread(s)";
  }
}

TEST(HotPath, AStepOfTheDefaultSceneAllocatesNothing) {
#if PLIANT_HAS_CGAL
  for (int threads : {1, 2}) {
    const Counted c = count_allocations(scene_file("default.json"), threads, 3000, 1500);
    std::printf("%d thread(s): %ld allocations in %ld steps; inside Embree %ld, for %ld BVH refits\n", threads,
                c.allocations, c.steps, c.embree, c.refits);
    EXPECT_GT(c.touching, 0);  // the tool presses the organ in these steps
    EXPECT_GT(c.refits, 0);
    EXPECT_EQ(c.allocations, 0) << threads << " thread(s)";
  }
#else
  GTEST_SKIP() << "SKIPPED: the default scene's organ is meshed with CGAL (PLIANT_WITH_CGAL=OFF)";
#endif
}

// The adaptive bar (scenes/adaptive_bar.json, its mesh 3/4 as long in cells): decision points every
// 2 ms, most of them changing nothing, a prescribed motion that refines by distance.
TEST(HotPath, AStepOfAnAdaptiveBodyThatKeepsItsResolutionAllocatesNothing) {
  const SceneDef scene = scene_file("adaptive_bar.json", {"bodies[0].mesh.box.cells=[48,8,8]"});
  for (int threads : {1, 2}) {
    const Counted c = count_allocations(scene, threads, 100, 1500);
    std::printf("%d thread(s): %ld allocations in %ld steps (%ld steps that split or merged left out)\n", threads,
                c.allocations, c.steps, c.changing_steps);
    EXPECT_GT(c.steps, 1000);  // the decisions that changed nothing are among them
    EXPECT_EQ(c.allocations, 0) << threads << " thread(s)";
  }
}

}  // namespace
}  // namespace pliant
