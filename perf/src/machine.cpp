// Machine limits (see machine.hpp). The triad and the peak kernels run on plain std::threads,
// one slice each, released together: the limit of the hardware, without a task scheduler's
// overhead in the way (the kernels pay that overhead, and the roofline fraction shows it).
#include "pliant/perf/machine.hpp"

#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstring>
#include <fstream>
#include <functional>
#include <memory>
#include <new>
#include <sstream>
#include <thread>
#include <type_traits>

#if defined(__x86_64__)
#include <immintrin.h>
#endif

namespace pliant::perf {
namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

// Runs body(i) on `threads` threads released at the same moment; returns the wall time from the
// release to the end of the slowest.
double run_parallel(int threads, const std::function<void(int)>& body) {
  std::atomic<int> ready{0};
  std::atomic<bool> go{false};
  std::vector<std::thread> pool;
  for (int i = 1; i < threads; ++i)
    pool.emplace_back([&, i] {
      ready.fetch_add(1);
      while (!go.load(std::memory_order_acquire)) {
      }
      body(i);
    });
  while (ready.load() < threads - 1) {
  }
  const auto t0 = Clock::now();
  go.store(true, std::memory_order_release);
  body(0);
  for (auto& t : pool) t.join();
  return seconds_since(t0);
}

struct AlignedDoubles {
  double* p = nullptr;
  explicit AlignedDoubles(std::size_t n) : p(static_cast<double*>(::operator new(n * sizeof(double), std::align_val_t{64}))) {}
  ~AlignedDoubles() { ::operator delete(p, std::align_val_t{64}); }
  AlignedDoubles(const AlignedDoubles&) = delete;
  AlignedDoubles& operator=(const AlignedDoubles&) = delete;
};

__attribute__((noinline)) void triad(double* __restrict a, const double* __restrict b, const double* __restrict c,
                                     std::size_t n, double s) {
  for (std::size_t i = 0; i < n; ++i) a[i] = b[i] + s * c[i];
}

// ---- peak kernels: 12 independent chains per thread -------------------------------------------
constexpr int kChains = 12;

#if defined(__AVX512F__)
constexpr const char* kIsa = "avx512";
template <bool Double, bool Fma>
double peak_kernel(long iterations) {
  if constexpr (Double) {
    __m512d acc[kChains], add[kChains];
    const __m512d x = _mm512_set1_pd(0.999999), xi = _mm512_set1_pd(1 / 0.999999), y = _mm512_set1_pd(1e-7);
    for (int j = 0; j < kChains; ++j) acc[j] = add[j] = _mm512_set1_pd(1.0 + j);
    for (long it = 0; it < iterations; ++it)
      for (int j = 0; j < kChains; ++j) {
        if constexpr (Fma) {
          acc[j] = _mm512_fmadd_pd(acc[j], x, y);
        } else {
          acc[j] = _mm512_mul_pd(acc[j], (it & 1) ? xi : x);  // x, 1/x, ...: no drift to denormals
          add[j] = _mm512_add_pd(add[j], y);
        }
      }
    __m512d s = _mm512_setzero_pd();
    for (int j = 0; j < kChains; ++j) s = _mm512_add_pd(s, _mm512_add_pd(acc[j], add[j]));
    double out[8];
    _mm512_storeu_pd(out, s);
    return out[0] + out[1] + out[2] + out[3] + out[4] + out[5] + out[6] + out[7];
  } else {
    __m512 acc[kChains], add[kChains];
    const __m512 x = _mm512_set1_ps(0.99999f), xi = _mm512_set1_ps(1 / 0.99999f), y = _mm512_set1_ps(1e-7f);
    for (int j = 0; j < kChains; ++j) acc[j] = add[j] = _mm512_set1_ps(1.0f + float(j));
    for (long it = 0; it < iterations; ++it)
      for (int j = 0; j < kChains; ++j) {
        if constexpr (Fma) {
          acc[j] = _mm512_fmadd_ps(acc[j], x, y);
        } else {
          acc[j] = _mm512_mul_ps(acc[j], (it & 1) ? xi : x);  // x, 1/x, ...: no drift to denormals
          add[j] = _mm512_add_ps(add[j], y);
        }
      }
    __m512 s = _mm512_setzero_ps();
    for (int j = 0; j < kChains; ++j) s = _mm512_add_ps(s, _mm512_add_ps(acc[j], add[j]));
    float out[16];
    _mm512_storeu_ps(out, s);
    double sum = 0;
    for (float o : out) sum += double(o);
    return sum;
  }
}
constexpr int kBytesPerVector = 64;
#elif defined(__AVX2__) && defined(__FMA__)
constexpr const char* kIsa = "avx2";
template <bool Double, bool Fma>
double peak_kernel(long iterations) {
  if constexpr (Double) {
    __m256d acc[kChains], add[kChains];
    const __m256d x = _mm256_set1_pd(0.999999), xi = _mm256_set1_pd(1 / 0.999999), y = _mm256_set1_pd(1e-7);
    for (int j = 0; j < kChains; ++j) acc[j] = add[j] = _mm256_set1_pd(1.0 + j);
    for (long it = 0; it < iterations; ++it)
      for (int j = 0; j < kChains; ++j) {
        if constexpr (Fma) {
          acc[j] = _mm256_fmadd_pd(acc[j], x, y);
        } else {
          acc[j] = _mm256_mul_pd(acc[j], (it & 1) ? xi : x);  // x, 1/x, ...: no drift to denormals
          add[j] = _mm256_add_pd(add[j], y);
        }
      }
    double out[4], s = 0;
    for (int j = 0; j < kChains; ++j) {
      _mm256_storeu_pd(out, _mm256_add_pd(acc[j], add[j]));
      s += out[0] + out[1] + out[2] + out[3];
    }
    return s;
  } else {
    __m256 acc[kChains], add[kChains];
    const __m256 x = _mm256_set1_ps(0.99999f), xi = _mm256_set1_ps(1 / 0.99999f), y = _mm256_set1_ps(1e-7f);
    for (int j = 0; j < kChains; ++j) acc[j] = add[j] = _mm256_set1_ps(1.0f + float(j));
    for (long it = 0; it < iterations; ++it)
      for (int j = 0; j < kChains; ++j) {
        if constexpr (Fma) {
          acc[j] = _mm256_fmadd_ps(acc[j], x, y);
        } else {
          acc[j] = _mm256_mul_ps(acc[j], (it & 1) ? xi : x);  // x, 1/x, ...: no drift to denormals
          add[j] = _mm256_add_ps(add[j], y);
        }
      }
    float out[8];
    double s = 0;
    for (int j = 0; j < kChains; ++j) {
      _mm256_storeu_ps(out, _mm256_add_ps(acc[j], add[j]));
      for (float o : out) s += double(o);
    }
    return s;
  }
}
constexpr int kBytesPerVector = 32;
#else
constexpr const char* kIsa = "scalar";
template <bool Double, bool Fma>
double peak_kernel(long iterations) {
  using T = std::conditional_t<Double, double, float>;
  T acc[kChains], add[kChains];
  const T x = T(0.99999), xi = T(1) / x, y = T(1e-7);
  for (int j = 0; j < kChains; ++j) acc[j] = add[j] = T(1 + j);
  for (long it = 0; it < iterations; ++it)
    for (int j = 0; j < kChains; ++j) {
      if constexpr (Fma) {
        acc[j] = std::fma(acc[j], x, y);
      } else {
        acc[j] = acc[j] * ((it & 1) ? xi : x);
        add[j] = add[j] + y;
      }
    }
  double s = 0;
  for (int j = 0; j < kChains; ++j) s += double(acc[j]) + double(add[j]);
  return s;
}
constexpr int kBytesPerVector = 0;
#endif

template <bool Double, bool Fma>
double flops_per_iteration() {
  const int lanes = kBytesPerVector ? kBytesPerVector / (Double ? 8 : 4) : 1;
  return double(kChains) * lanes * 2.0;  // FMA: 2 flops; mul + add chains: 1 + 1
}

std::string read_first_line(const std::string& path) {
  std::ifstream in(path);
  std::string line;
  std::getline(in, line);
  return line;
}

}  // namespace

double MachineLimits::bandwidth(double footprint, int threads) const {
  std::vector<const TriadPoint*> pts;
  for (const auto& p : triad)
    if (p.threads == threads) pts.push_back(&p);
  if (pts.empty()) {  // fall back to the nearest thread count, scaled
    int best = -1;
    for (const auto& p : triad)
      if (best < 0 || std::abs(p.threads - threads) < std::abs(best - threads)) best = p.threads;
    if (best < 0) return 0;
    return bandwidth(footprint, best) * double(threads) / double(best);
  }
  std::sort(pts.begin(), pts.end(), [](auto* a, auto* b) { return a->footprint_bytes < b->footprint_bytes; });
  if (footprint <= pts.front()->footprint_bytes) return pts.front()->gb_per_s;
  if (footprint >= pts.back()->footprint_bytes) return pts.back()->gb_per_s;
  for (std::size_t i = 1; i < pts.size(); ++i)
    if (footprint <= pts[i]->footprint_bytes) {
      const double x0 = std::log(pts[i - 1]->footprint_bytes), x1 = std::log(pts[i]->footprint_bytes);
      const double y0 = std::log(pts[i - 1]->gb_per_s), y1 = std::log(pts[i]->gb_per_s);
      const double s = (std::log(footprint) - x0) / (x1 - x0);
      return std::exp(y0 + s * (y1 - y0));
    }
  return pts.back()->gb_per_s;
}

double MachineLimits::peak_gflops(bool is_double, int threads, bool fma) const {
  double best = 0;
  int best_threads = 0;
  for (const auto& p : peak)
    if (p.is_double == is_double && p.fma == fma) {
      if (p.threads == threads) return p.gflop_per_s;
      if (p.threads <= threads && p.threads > best_threads) {
        best_threads = p.threads;
        best = p.gflop_per_s;
      }
    }
  return best_threads ? best * double(threads) / double(best_threads) : 0;
}

double measure_triad(std::size_t footprint_bytes, int threads, int samples, double seconds_per_sample) {
  const std::size_t n = std::max<std::size_t>(footprint_bytes / (3 * sizeof(double)), 64 * std::size_t(threads));
  AlignedDoubles a(n), b(n), c(n);
  auto slice = [&](int i) {
    const std::size_t per = (n / std::size_t(threads) + 7) & ~std::size_t(7);
    const std::size_t lo = std::min(n, per * std::size_t(i)), hi = std::min(n, lo + per);
    return std::pair<std::size_t, std::size_t>(lo, hi);
  };
  // First touch by the thread that will use the slice.
  run_parallel(threads, [&](int i) {
    const auto [lo, hi] = slice(i);
    for (std::size_t k = lo; k < hi; ++k) {
      a.p[k] = 0;
      b.p[k] = 1.0 + double(k % 7);
      c.p[k] = 2.0;
    }
  });
  // Sweeps per sample, from one timed sweep.
  const double one = std::max(1e-7, run_parallel(threads, [&](int i) {
    const auto [lo, hi] = slice(i);
    triad(a.p + lo, b.p + lo, c.p + lo, hi - lo, 3.0);
  }));
  const long reps = std::max(1L, long(seconds_per_sample / one));
  double best = 1e300;
  for (int s = 0; s < samples; ++s) {
    const double t = run_parallel(threads, [&](int i) {
      const auto [lo, hi] = slice(i);
      for (long r = 0; r < reps; ++r) triad(a.p + lo, b.p + lo, c.p + lo, hi - lo, 3.0 + double(r & 1));
    });
    best = std::min(best, t);
  }
  volatile double sink = a.p[n / 2];
  (void)sink;
  return 3.0 * double(n) * sizeof(double) * double(reps) / best * 1e-9;
}

PeakPoint measure_peak(bool is_double, int threads, bool fma, double seconds) {
  auto kernel = is_double ? (fma ? &peak_kernel<true, true> : &peak_kernel<true, false>)
                          : (fma ? &peak_kernel<false, true> : &peak_kernel<false, false>);
  const double per = is_double ? (fma ? flops_per_iteration<true, true>() : flops_per_iteration<true, false>())
                               : (fma ? flops_per_iteration<false, true>() : flops_per_iteration<false, false>());
  std::vector<double> sink(std::size_t(threads), 0.0);
  long iterations = 100000;
  double t = run_parallel(1, [&](int) { sink[0] += kernel(iterations); });
  iterations = std::max(1000L, long(double(iterations) * seconds / std::max(t, 1e-6)));
  double best = 1e300;
  for (int s = 0; s < 3; ++s) {
    t = run_parallel(threads, [&](int i) { sink[std::size_t(i)] += kernel(iterations); });
    best = std::min(best, t);
  }
  volatile double keep = sink[0];
  (void)keep;
  PeakPoint p;
  p.is_double = is_double;
  p.threads = threads;
  p.fma = fma;
  p.isa = kIsa;
  p.gflop_per_s = per * double(iterations) * double(threads) / best * 1e-9;
  return p;
}

double measure_round_trip(int round_trips) {
  // The line each thread waits on: the caller writes odd values, the other thread even ones.
  struct alignas(64) Line {
    std::atomic<int> value{0};
  } line;
  std::atomic<bool> ready{false};
  std::thread other([&] {
    ready.store(true, std::memory_order_release);
    for (int i = 0; i < round_trips; ++i) {
      while (line.value.load(std::memory_order_acquire) != 2 * i + 1) {
      }
      line.value.store(2 * i + 2, std::memory_order_release);
    }
  });
  while (!ready.load(std::memory_order_acquire)) {
  }
  const auto t0 = Clock::now();
  for (int i = 0; i < round_trips; ++i) {
    line.value.store(2 * i + 1, std::memory_order_release);
    while (line.value.load(std::memory_order_acquire) != 2 * i + 2) {
    }
  }
  const double s = seconds_since(t0);
  other.join();
  return s / double(round_trips) * 1e9;
}

namespace {

// A dependent chain of `iterations` multiply-adds (about 4 cycles each: the latency of one),
// which the compiler cannot shorten (-ffp-contract=off and no reassociation; the result is
// returned and kept).
__attribute__((noinline)) double fixed_chain(long iterations, double x) {
  for (long i = 0; i < iterations; ++i) x = x * 0.999999 + 1e-7;
  return x;
}

}  // namespace

std::vector<double> time_fixed_work(double seconds, int threads, std::size_t samples) {
  std::vector<double> out;
  if (!(seconds > 0) || samples == 0) return out;
  // No more threads than logical CPUs: spinning ones would wait for each other's time slices.
  threads = std::clamp(threads, 1, int(std::max(1u, std::thread::hardware_concurrency())));
  // Calibration: the fastest of a few runs of a chain long enough to time well (about 50 us).
  double sink = 0;
  long iterations = 1 << 14;
  double best = 0;
  for (int round = 0; round < 3; ++round) {
    best = 1e300;
    for (int i = 0; i < 5; ++i) {
      const auto t0 = Clock::now();
      sink += fixed_chain(iterations, 1.0);
      best = std::min(best, seconds_since(t0));
    }
    iterations = std::max(1L, long(double(iterations) * 5e-5 / std::max(best, 1e-9)));
  }
  iterations = std::max(1L, long(double(iterations) * seconds / 5e-5));
  // The other threads wait for each run's number, run the chain, and count themselves done.
  std::atomic<long> run{-1};
  std::atomic<int> done{0};
  std::atomic<bool> stop{false};
  std::vector<double> sinks(std::size_t(threads), 0.0);
  std::vector<std::thread> pool;
  for (int t = 1; t < threads; ++t)
    pool.emplace_back([&, t] {
      long seen = -1;
      while (true) {
        long now;
        while ((now = run.load(std::memory_order_acquire)) == seen && !stop.load(std::memory_order_relaxed)) {
        }
        if (now == seen) break;  // stopped
        seen = now;
        sinks[std::size_t(t)] += fixed_chain(iterations, 1.0);
        done.fetch_add(1, std::memory_order_release);
      }
    });
  const std::size_t warmup = 5;
  out.reserve(samples);
  for (std::size_t i = 0; i < warmup + samples; ++i) {
    done.store(0, std::memory_order_relaxed);
    const auto t0 = Clock::now();
    run.store(long(i), std::memory_order_release);
    sink += fixed_chain(iterations, 1.0);
    while (done.load(std::memory_order_acquire) < threads - 1) {
    }
    const double s = seconds_since(t0);
    if (i >= warmup) out.push_back(s);
  }
  stop.store(true, std::memory_order_relaxed);
  for (auto& t : pool) t.join();
  for (double s : sinks) sink += s;
  if (sink == 42.0) out.push_back(0);  // never true: keeps the chains' results alive
  return out;
}

MachineLimits measure_machine_limits(const LimitOptions& o) {
  MachineLimits m;
  if (std::find_if(o.threads.begin(), o.threads.end(), [](int t) { return t >= 2; }) != o.threads.end() &&
      std::thread::hardware_concurrency() >= 2) {
    std::vector<double> runs;
    for (int i = 0; i < 5; ++i) runs.push_back(measure_round_trip(20000));  // about 10 ms each
    std::sort(runs.begin(), runs.end());
    m.round_trip_ns = runs[runs.size() / 2];
  }
  for (int threads : o.threads) {
    for (double mib : o.footprints_mib) {
      TriadPoint p;
      p.footprint_bytes = mib * 1024.0 * 1024.0;
      p.threads = threads;
      p.gb_per_s = measure_triad(std::size_t(p.footprint_bytes), threads, o.samples, o.seconds_per_sample);
      m.triad.push_back(p);
    }
    for (bool is_double : {false, true})
      for (bool fma : {true, false}) m.peak.push_back(measure_peak(is_double, threads, fma, o.peak_seconds));
  }
  return m;
}

std::string machine_description() {
  std::string model;
  {
    std::ifstream in("/proc/cpuinfo");
    std::string line;
    while (std::getline(in, line))
      if (line.rfind("model name", 0) == 0) {
        model = line.substr(line.find(':') + 2);
        break;
      }
  }
  std::ostringstream out;
  out << (model.empty() ? "unknown CPU" : model) << ", " << std::thread::hardware_concurrency() << " logical CPUs";
  for (int i = 0; i < 6; ++i) {
    const std::string base = "/sys/devices/system/cpu/cpu0/cache/index" + std::to_string(i) + "/";
    const std::string level = read_first_line(base + "level"), type = read_first_line(base + "type"),
                      size = read_first_line(base + "size"), shared = read_first_line(base + "shared_cpu_list");
    if (level.empty() || type == "Instruction") continue;
    out << ", L" << level << " " << size << (shared.find_first_of(",-") != std::string::npos ? " shared" : "/core");
  }
  const long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGE_SIZE);
  if (pages > 0 && page > 0) out << ", " << std::lround(double(pages) * double(page) / (1024.0 * 1024.0 * 1024.0)) << " GiB";
  return out.str();
}

std::string build_description() {
  std::ostringstream out;
#if defined(__clang__)
  out << "clang " << __clang_major__ << "." << __clang_minor__;
#elif defined(__GNUC__)
  out << "g++ " << __GNUC__ << "." << __GNUC_MINOR__;
#endif
  out << ", kernels " << kIsa;
#if defined(__AVX512F__)
  out << " (512-bit vectors)";
#elif defined(__AVX__)
  out << " (256-bit vectors)";
#endif
  out << ", -ffp-contract=off";
#if defined(NDEBUG)
  out << ", NDEBUG";
#endif
  return out.str();
}

CpuSample cpu_sample() {
  CpuSample s;
  s.wall_s = std::chrono::duration<double>(Clock::now().time_since_epoch()).count();
  std::ifstream in("/proc/stat");
  std::string cpu;
  double v[8] = {};
  in >> cpu;
  for (double& x : v) in >> x;
  const double tick = double(sysconf(_SC_CLK_TCK));
  // user nice system idle iowait irq softirq steal
  s.busy_s = (v[0] + v[1] + v[2] + v[5] + v[6] + v[7]) / (tick > 0 ? tick : 100.0);
  rusage ru{};
  getrusage(RUSAGE_SELF, &ru);
  s.self_s = double(ru.ru_utime.tv_sec + ru.ru_stime.tv_sec) + 1e-6 * double(ru.ru_utime.tv_usec + ru.ru_stime.tv_usec);
  return s;
}

double others_busy_cores(const CpuSample& a, const CpuSample& b) {
  const double wall = b.wall_s - a.wall_s;
  if (!(wall > 0)) return 0;
  return std::max(0.0, ((b.busy_s - a.busy_s) - (b.self_s - a.self_s)) / wall);
}

double wait_for_idle(double max_wait_s, double threshold_cores) {
  const auto t0 = Clock::now();
  double load = 0;
  do {
    const CpuSample a = cpu_sample();
    std::this_thread::sleep_for(std::chrono::milliseconds(250));
    load = others_busy_cores(a, cpu_sample());
    if (load < threshold_cores) break;
  } while (seconds_since(t0) < max_wait_s);
  return load;
}

}  // namespace pliant::perf
