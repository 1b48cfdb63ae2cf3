// The force of a tool, handed from the simulation to a haptic device thread (thesis ch. 6: the
// hand feels forces at a rate far above the simulation's frames; today's devices poll at 1 kHz).
//
// One writer (the thread that steps the World: World::step publishes each tool's reading) and
// any number of readers that never wait for it: a sequence lock over the last two readings. A
// reader copies them and retries only if a publish overlapped its copy (a publish writes 8
// numbers, so a retry costs nanoseconds; the writer never waits at all). Every shared number is
// a std::atomic accessed with relaxed order between the fences of the sequence counter, so
// that the exchange is race-free under the C++ memory model (and ThreadSanitizer agrees).
//
// Smoothing: the simulation publishes a reading per step, the device reads at its own rate.
// force_at(t) interpolates linearly between the last two readings, one reading interval late:
// at time t it shows the force of time t - (t1 - t0). Holding the latest reading would jump by a
// whole reading's change at once (a buzz the hand feels at the simulation's rate); extrapolating
// ahead would overshoot on every contact onset. The delay is one simulation step (about 0.1-1 ms
// in the shipped scenes), below what a hand resolves; docs/tool.md measures what it costs in
// passivity.
#pragma once
#include <algorithm>
#include <atomic>
#include <cstdint>

#include "pliant/defs.hpp"

namespace pliant {

class HapticLink {
 public:
  struct Readings {
    double t0 = 0, t1 = 0;  // s, simulated times of the previous and the last reading (t0 <= t1)
    Vec3d f0{}, f1{};       // N, the tool's force at those times
    std::uint64_t count = 0;  // readings published so far
  };

  // Writer side: a new reading (simulated time t, force f). Wait-free.
  void publish(double t, const Vec3d& f) noexcept {
    const std::uint64_t s = seq_.load(std::memory_order_relaxed);
    seq_.store(s + 1, std::memory_order_relaxed);  // odd: a write is under way
    std::atomic_thread_fence(std::memory_order_release);
    const int newest = int((count_.load(std::memory_order_relaxed) + 1) & 1);
    t_[newest].store(t, std::memory_order_relaxed);
    for (int k = 0; k < 3; ++k) f_[newest][k].store(f[std::size_t(k)], std::memory_order_relaxed);
    count_.store(count_.load(std::memory_order_relaxed) + 1, std::memory_order_relaxed);
    seq_.store(s + 2, std::memory_order_release);
  }

  // Reader side, any thread: the last two readings (before the first publish: zeros; after one:
  // both equal to it). Lock-free: retries only while a publish overlaps the copy.
  Readings readings() const noexcept {
    Readings r;
    for (;;) {
      const std::uint64_t s1 = seq_.load(std::memory_order_acquire);
      if (s1 & 1) continue;
      const std::uint64_t c = count_.load(std::memory_order_relaxed);
      const int last = int(c & 1), prev = c >= 2 ? 1 - last : last;
      r.count = c;
      r.t1 = t_[last].load(std::memory_order_relaxed);
      r.t0 = t_[prev].load(std::memory_order_relaxed);
      for (int k = 0; k < 3; ++k) {
        r.f1[std::size_t(k)] = f_[last][k].load(std::memory_order_relaxed);
        r.f0[std::size_t(k)] = f_[prev][k].load(std::memory_order_relaxed);
      }
      std::atomic_thread_fence(std::memory_order_acquire);
      if (seq_.load(std::memory_order_relaxed) == s1) break;
    }
    if (r.count == 0) r = Readings{};
    return r;
  }

  // The smoothed force at simulated time t (s): the readings interpolated one interval late
  // (see the top of this file), held at the last reading beyond it.
  Vec3d force_at(double t) const noexcept { return interpolate(readings(), t); }

  static Vec3d interpolate(const Readings& r, double t) noexcept {
    const double span = r.t1 - r.t0;
    if (!(span > 0)) return r.f1;
    const double s = std::clamp((t - span - r.t0) / span, 0.0, 1.0);
    Vec3d f;
    for (int k = 0; k < 3; ++k) f[std::size_t(k)] = r.f0[std::size_t(k)] + s * (r.f1[std::size_t(k)] - r.f0[std::size_t(k)]);
    return f;
  }

 private:
  std::atomic<std::uint64_t> seq_{0};
  std::atomic<std::uint64_t> count_{0};
  std::atomic<double> t_[2] = {0.0, 0.0};
  std::atomic<double> f_[2][3] = {{0.0, 0.0, 0.0}, {0.0, 0.0, 0.0}};
};

}  // namespace pliant
