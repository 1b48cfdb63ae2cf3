// Benchmark workloads and cost models (see workload.hpp).
#include "pliant/perf/workload.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numeric>
#include <random>

#include "pliant/level_passes.hpp"

namespace pliant::perf {
namespace {

using Clock = std::chrono::steady_clock;

double seconds_between(Clock::time_point a, Clock::time_point b) { return std::chrono::duration<double>(b - a).count(); }

}  // namespace

struct StepRunner::Impl {
  virtual ~Impl() = default;
  virtual void element() = 0;
  virtual void gather() = 0;
  virtual void integrate() = 0;
  virtual void gather_integrate() = 0;
};

namespace {

template <class T>
struct Runner final : StepRunner::Impl {
  Executor& ex;
  ElementContext<T> ec;
  PackContext<T> pk;
  bool packed = false;  // the step packs positions before this element pass (pack_pays)
  void (*pass)(const ElementContext<T>&, Range);
  GatherContext<T> gc;
  IntegrateContext<T> ic;
  std::size_t nt, nn;

  Runner(World& w, Executor& e) : ex(e) {
    Level<T>& L = w.level<T>(0);
    ec = element_context(L);
    pk = pack_context(L);
    packed = pack_pays(L, L.tet_count);
    use_packed(ec, pk, packed);
    pass = force_kernel<T>(L.model);
    gc = gather_context(L);
    ic = integrate_context(L, std::array<double, 3>{0, 0, -9.81}, w.dt());  // the box world's gravity
    nt = L.tet_count;
    nn = L.node_count;
  }
  // The pack, when the step does it, is timed as part of the element pass.
  void element() override {
    if (packed) ex.parallel_for(nn, pass_grain(nn, kNodeGrain), [&](Range r) { pack_positions(pk, r); });
    ex.parallel_for(nt, pass_grain(nt, kTetGrain), [&](Range r) { pass(ec, r); });
  }
  void gather() override { ex.parallel_for(nn, pass_grain(nn, kNodeGrain), [&](Range r) { gather_forces(gc, r); }); }
  void integrate() override {
    ex.parallel_all(nn, pass_grain(nn, kNodeGrain), [&](Range r) { return integrate_symplectic_euler(ic, r); });
  }
  void gather_integrate() override {
    ex.parallel_all(nn, pass_grain(nn, kNodeGrain), [&](Range r) { return gather_integrate_symplectic_euler(gc, ic, r); });
  }
};

PartTimes parts(World& w, Executor& ex, const TimingOptions& o) {
  StepRunner run(w, ex);
  auto element = [&] { run.element(); };
  auto gather = [&] { run.gather(); };
  auto integrate = [&] { run.integrate(); };
  auto fused = [&] { run.gather_integrate(); };
  for (int i = 0; i < o.warmup; ++i) {
    element();
    fused();
  }
  PartTimes out;
  double total = 0;
  for (int i = 0; (total < o.min_seconds || i < o.min_samples) && i < o.max_samples; ++i) {
    const auto t0 = Clock::now();
    element();
    const auto t1 = Clock::now();
    out.element.push_back(seconds_between(t0, t1));
    if (i % 2 == 0) {
      gather();
      const auto t2 = Clock::now();
      integrate();
      const auto t3 = Clock::now();
      out.gather.push_back(seconds_between(t1, t2));
      out.integrate.push_back(seconds_between(t2, t3));
      total += seconds_between(t0, t3);
    } else {
      fused();
      const auto t2 = Clock::now();
      out.gather_integrate.push_back(seconds_between(t1, t2));
      total += seconds_between(t0, t2);
    }
  }
  return out;
}

// Flops per tet of each element kernel (hand count of the source: + - * / sqrt each 1).
// rayleigh (viscosities beta times the moduli, ElementContext::rayleigh): the damped pass takes
// one Hooke law of eps + beta eps_dot, F_dot 54 and F + beta F_dot 18 (9 fused multiply-adds) in
// place of the damped terms below, for every continuum model: + 72.
double element_flops(ForceModel m, bool damped, bool rayleigh) {
  if (damped && rayleigh && m != ForceModel::springs) return element_flops(m, false, false) + 72;
  switch (m) {
    // F 54, sym 18, -I 3, Hooke 23, corner forces 63; damped: F_dot 54, sym 18, Hooke 23, add 9.
    case ForceModel::linear: return 161 + (damped ? 104 : 0);
    // F 54, F^T F 45, sym 18, -I 3, /2 9, Hooke 23, F S 45, corner forces 63; damped + 149.
    case ForceModel::stvk: return 260 + (damped ? 149 : 0);
    // F 54; rotation: quaternion -> R 39, one step of 112 and one update of 83 (the check after
    // the update is skipped when the update is known to be final, tet_local.hpp; before issue 15
    // a second step of 112 was always computed: 597); R^T F 45, sym 18, -I 3, Hooke 23,
    // R sigma 45, corner forces 63; damped + 149. Counted as before FMA: a fused multiply-add
    // is 2 flops.
    case ForceModel::corotational: return 485 + (damped ? 149 : 0);
    // 6 edges of 35 (two lengths, stiffness, tension, forces); damped + 13 per edge.
    case ForceModel::springs: return 210 + (damped ? 78 : 0);
  }
  return 0;
}

template <class T>
PassCost cost(const Level<T>& L, Pass p) {
  const double S = sizeof(T), I = sizeof(std::int32_t), nt = double(L.tet_count), nn = double(L.node_count);
  const bool coro = L.model == ForceModel::corotational, springs = L.model == ForceModel::springs;
  const bool damped = springs ? L.stiffness_damping != T(0) : (L.bulk_viscosity != T(0) || L.shear_viscosity != T(0));
  const bool ext = !L.external[0].empty();
  double free_nodes = 0;
  for (auto s : L.state) free_nodes += s == kNodeFree ? 1 : 0;

  // Element pass: tets' indices, rest data, rotation (read + write), corner forces (write);
  // node positions (and rest positions for springs, velocities when damped) read once. With the
  // pack (pack_pays), x is read by it, and 4 values per node written by it and read by the pass.
  PassCost e;
  const double tet_rest = springs ? S : 10 * S;
  const double pack = pack_pays(L, L.tet_count) ? 4 * S : 0;
  const double node_reads = 3 * S * (1 + (springs ? 1 : 0) + (damped ? 1 : 0)) + 2 * pack;
  e.bytes = nt * (4 * I + tet_rest + (coro ? 8 * S : 0) + 12 * S) + nn * node_reads;
  e.footprint = nt * (4 * I + tet_rest + (coro ? 4 * S : 0) + 12 * S) + nn * (node_reads - pack);
  e.flops = nt * element_flops(L.model, damped, rayleigh_factor(L.lambda, L.mu, L.bulk_viscosity, L.shear_viscosity) != T(0));

  // Gather: offsets, incidence, corner forces, loads; f written.
  PassCost g;
  g.bytes = g.footprint = nn * I + nt * (4 * I + 12 * S) + nn * (ext ? 3 * S : 0) + nn * 3 * S;
  g.flops = nt * 12 + (ext ? 3 * nn : 0);

  // Integrate: x, v read and written, f, 1/m and state read.
  PassCost in;
  in.bytes = nn * (12 * S + 3 * S + S + 1);
  in.footprint = nn * (9 * S + S + 1);
  in.flops = 24 * free_nodes;

  // Fused: the gather's reads, f written, x and v read and written, 1/m and state read.
  PassCost f;
  f.bytes = nn * I + nt * (4 * I + 12 * S) + nn * (ext ? 3 * S : 0) + nn * (3 * S + 12 * S + S + 1);
  f.footprint = nn * I + nt * (4 * I + 12 * S) + nn * (ext ? 3 * S : 0) + nn * (9 * S + S + 1);
  f.flops = g.flops + in.flops;

  switch (p) {
    case Pass::element: return e;
    case Pass::gather: return g;
    case Pass::integrate: return in;
    case Pass::gather_integrate: return f;
    case Pass::step: {
      PassCost s;
      s.bytes = e.bytes + f.bytes;
      s.flops = e.flops + f.flops;
      // x (and v when damped) are in both working sets.
      s.footprint = e.footprint + f.footprint - nn * 3 * S * (1 + (damped ? 1 : 0));
      return s;
    }
  }
  return e;
}

}  // namespace

const char* to_string(Order o) {
  switch (o) {
    case Order::grid: return "grid";
    case Order::random: return "random";
    case Order::renumbered: return "renumbered";
  }
  return "?";
}

const char* to_string(Pass p) {
  switch (p) {
    case Pass::element: return "element";
    case Pass::gather: return "gather";
    case Pass::integrate: return "integrate";
    case Pass::gather_integrate: return "gather_integrate";
    case Pass::step: return "step";
  }
  return "?";
}

BodyDef box_body(ForceModel model, const std::array<int, 3>& cells) {
  BodyDef b;
  b.name = "box";
  b.model = model;
  b.mesh.min = {0, 0, 0};
  b.mesh.max = {1, 0.25, 0.25};
  b.mesh.cells = cells;
  b.mesh.tets_per_cell = 6;
  RegionDef clamp;
  clamp.min = {-1, -1, -1};
  clamp.max = {1e-6, 1, 1};
  b.fixed.push_back(clamp);
  return b;
}

TetMesh box_mesh(const std::array<int, 3>& cells, Order order) {
  TetMesh grid = make_box_mesh({0, 0, 0}, {1, 0.25, 0.25}, cells, 6);
  if (order == Order::grid) return grid;
  TetMesh m = shuffled_order(grid, 20261122);
  if (order == Order::renumbered) renumber_for_locality(m);
  return m;
}

World make_box_world(ForceModel model, Precision precision, int threads, const std::array<int, 3>& cells, Order order,
                     int warm_steps) {
  WorldDef wd;
  wd.precision = precision;
  wd.threads = threads;
  World w(wd);
  w.add_body(box_body(model, cells), box_mesh(cells, order));
  for (int i = 0; i < warm_steps; ++i) w.step();
  return w;
}

const std::vector<BoxSize>& standard_sizes() {
  static const std::vector<BoxSize> sizes = {
      {"1k", {12, 4, 4}},        // 1,152 tets
      {"10k", {28, 8, 8}},       // 10,752
      {"100k", {64, 16, 16}},    // 98,304
      {"1M", {140, 35, 35}},     // 1,029,000
  };
  return sizes;
}

PassCost pass_cost(const World& w, BodyId body, Pass p) {
  if (w.precision() == Precision::float32) return cost(w.level<float>(body), p);
  return cost(w.level<double>(body), p);
}

StepRunner::StepRunner(World& w, Executor& ex) {
  if (w.precision() == Precision::float32)
    impl_ = std::make_unique<Runner<float>>(w, ex);
  else
    impl_ = std::make_unique<Runner<double>>(w, ex);
}
StepRunner::~StepRunner() = default;
void StepRunner::element() { impl_->element(); }
void StepRunner::gather() { impl_->gather(); }
void StepRunner::integrate() { impl_->integrate(); }
void StepRunner::gather_integrate() { impl_->gather_integrate(); }

PartTimes time_step_parts(World& w, Executor& ex, const TimingOptions& o) { return parts(w, ex, o); }

std::vector<double> time_calls(const std::function<void()>& fn, const TimingOptions& o) {
  for (int i = 0; i < o.warmup; ++i) fn();
  std::vector<double> out;
  double total = 0;
  for (int i = 0; (total < o.min_seconds || i < o.min_samples) && i < o.max_samples; ++i) {
    const auto t0 = Clock::now();
    fn();
    const double s = seconds_between(t0, Clock::now());
    out.push_back(s);
    total += s;
  }
  return out;
}

Stats stats_of(std::vector<double> s) {
  Stats st;
  st.n = s.size();
  if (s.empty()) return st;
  std::sort(s.begin(), s.end());
  auto rank = [&](double q) { return s[std::min(s.size() - 1, std::size_t(std::ceil(q * double(s.size()))) - (q > 0 ? 1 : 0))]; };
  st.min = s.front();
  st.max = s.back();
  st.median = s.size() % 2 ? s[s.size() / 2] : 0.5 * (s[s.size() / 2 - 1] + s[s.size() / 2]);
  st.p99 = rank(0.99);
  st.mean = std::accumulate(s.begin(), s.end(), 0.0) / double(s.size());
  return st;
}

}  // namespace pliant::perf
