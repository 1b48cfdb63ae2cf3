// Rendering speed: time per frame of the OSMesa renderer (llvmpipe) for body surfaces of about
// 5k, 50k and 500k triangles at 1280x720, coloured by a field, with 4x multisampling, grid,
// marks and overlays, i.e. what `pliant run --png-every` pays per frame before the PNG; and
// the PNG encoding of such a frame separately. Results go to docs/performance.md ("Rendering").
//
// The surface is a bumpy torus (smooth, with creases nowhere), made directly as a Frame so that
// no simulation runs here; the field is a smooth function of position.
//
// Every benchmark reports the same counters (triangles, frames/s), because Google Benchmark's CSV
// output (--benchmark_out_format=csv) requires it; the PNG size goes in the label. Times are real
// (wall) time: llvmpipe renders in its own threads (LP_NUM_THREADS, default one per core), which
// the CPU-time column, that of the calling thread only, does not see.
#include <benchmark/benchmark.h>

#include <cmath>
#include <filesystem>
#include <memory>
#include <string>

#include "pliant/raster/image.hpp"
#include "pliant/raster/render.hpp"

namespace {
using namespace pliant;
using namespace pliant::raster;

// A torus of nu x nv quads (2 nu nv triangles), radii 0.1 and 0.035 m, with ripples.
Frame torus_frame(int nu, int nv) {
  auto topo = std::make_shared<SurfaceTopology>();
  topo->name = "torus";
  SurfaceBody body;
  const double pi = std::acos(-1.0);
  for (int i = 0; i < nu; ++i)
    for (int j = 0; j < nv; ++j) {
      const double u = 2 * pi * i / nu, v = 2 * pi * j / nv;
      const double r = 0.035 * (1 + 0.08 * std::sin(7 * u) * std::sin(5 * v));
      const double x = (0.1 + r * std::cos(v)) * std::cos(u), y = (0.1 + r * std::cos(v)) * std::sin(u),
                   z = r * std::sin(v) + 0.05;
      body.points.insert(body.points.end(), {float(x), float(y), float(z)});
      body.values.push_back(float(0.01 * (1 + std::sin(3 * u + v))));
      topo->source_node.push_back(i * nv + j);
      if (j == 0 && i % 8 == 0) topo->fixed.push_back(i * nv + j);
      const int a = i * nv + j, b = ((i + 1) % nu) * nv + j, c = ((i + 1) % nu) * nv + (j + 1) % nv,
                d = i * nv + (j + 1) % nv;
      topo->triangles.push_back({a, b, c});
      topo->triangles.push_back({a, c, d});
    }
  body.topology = topo;
  Frame f;
  f.time = 0.25;
  f.field = Field::displacement;
  if (nu > 0) f.bodies.push_back(std::move(body));
  f.probes.push_back({"probe", {0.1, 0, 0.05}});
  return f;
}

Renderer& renderer() {
  static Renderer r;
  return r;
}

// Arguments: nu, nv (triangles = 2 nu nv; 0: no body, the fixed cost of a frame).
void BM_RenderFrame(benchmark::State& state) {
  const Frame f = torus_frame(int(state.range(0)), int(state.range(1)));
  RenderOptions o;
  o.width = 1280;
  o.height = 720;
  Image img;
  for (auto _ : state) {
    img = renderer().render(f, o);
    benchmark::DoNotOptimize(img.data());
  }
  state.counters["triangles"] = f.bodies.empty() ? 0.0 : double(f.bodies[0].topology->triangles.size());
  state.counters["frames/s"] = benchmark::Counter(double(state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_RenderFrame)->Args({0, 0})->Args({50, 50})->Args({158, 158})->Args({500, 500})->Unit(benchmark::kMillisecond)->UseRealTime();

// The same frame without multisampling, to show what anti-aliasing costs.
void BM_RenderFrameNoMsaa(benchmark::State& state) {
  const Frame f = torus_frame(int(state.range(0)), int(state.range(1)));
  RenderOptions o;
  o.samples = 1;
  Image img;
  for (auto _ : state) {
    img = renderer().render(f, o);
    benchmark::DoNotOptimize(img.data());
  }
  state.counters["triangles"] = f.bodies.empty() ? 0.0 : double(f.bodies[0].topology->triangles.size());
  state.counters["frames/s"] = benchmark::Counter(double(state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_RenderFrameNoMsaa)->Args({0, 0})->Args({50, 50})->Args({158, 158})->Args({500, 500})->Unit(benchmark::kMillisecond)->UseRealTime();

// Encoding a 1280x720 frame as PNG (zlib level 3, as frames are written) to a temp file.
void BM_WritePng(benchmark::State& state) {
  const Frame f = torus_frame(158, 158);
  RenderOptions o;
  const Image img = renderer().render(f, o);
  const auto path = std::filesystem::temp_directory_path() / "pliant_bench_raster.png";
  for (auto _ : state) write_png(img, path, int(state.range(0)));
  state.counters["triangles"] = double(f.bodies[0].topology->triangles.size());  // of the frame encoded
  state.counters["frames/s"] = benchmark::Counter(double(state.iterations()), benchmark::Counter::kIsRate);
  state.SetLabel("png_bytes=" + std::to_string(std::filesystem::file_size(path)));
  std::filesystem::remove(path);
}
BENCHMARK(BM_WritePng)->Arg(3)->Arg(6)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
