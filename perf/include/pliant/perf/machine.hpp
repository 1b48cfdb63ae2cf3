// The machine's limits, measured in the same run as the kernels they judge: a STREAM-like
// triad at a ladder of working-set sizes (in L2, in L3, in DRAM) on 1..N threads, and the peak
// FMA rate (and, since pliant builds with -ffp-contract=off, the separate multiply + add rate).
// Also: how busy the rest of the machine is, so that measurements on a shared machine can wait
// for quiet and say how quiet it was.
#pragma once
#include <cstddef>
#include <string>
#include <vector>

namespace pliant::perf {

struct TriadPoint {
  double footprint_bytes = 0;  // the three arrays together
  int threads = 1;
  double gb_per_s = 0;         // counted the STREAM way: 3 arrays x n x 8 B per sweep (no write-allocate)
};

struct PeakPoint {
  bool is_double = false;
  int threads = 1;
  bool fma = true;             // false: independent multiply and add chains (no contraction)
  double gflop_per_s = 0;
  std::string isa;             // "avx512", "avx2", "scalar"
};

struct MachineLimits {
  std::vector<TriadPoint> triad;
  std::vector<PeakPoint> peak;
  // Time for one cache line to go to another thread and back (ns, median of a few runs; 0 when
  // fewer than 2 threads are measured). What a phase barrier and every line across the cut
  // between two threads' halves of a body cost: on the 2-vCPU guests of docs/performance.md it was
  // 130-200 ns on some days and about 400 on others (the host placing the vCPUs further apart),
  // and small bodies' 2-thread steps moved with it.
  double round_trip_ns = 0;

  // Triad bandwidth (GB/s) for a working set of `footprint_bytes` on `threads` threads:
  // log-log interpolation along the measured ladder, clamped at its ends.
  double bandwidth(double footprint_bytes, int threads) const;
  // Peak GFLOP/s (FMA counted as 2 flops) for the precision and thread count.
  double peak_gflops(bool is_double, int threads, bool fma = true) const;
};

struct LimitOptions {
  std::vector<double> footprints_mib{1, 4, 24, 96, 512};
  std::vector<int> threads{1, 2};
  int samples = 5;               // best of this many per point (as STREAM)
  double seconds_per_sample = 0.01;
  double peak_seconds = 0.05;
};

MachineLimits measure_machine_limits(const LimitOptions& options);

// One triad point: best of `samples`, each sweeping the arrays often enough to last
// `seconds_per_sample`.
double measure_triad(std::size_t footprint_bytes, int threads, int samples, double seconds_per_sample);
// Peak rate of independent FMA (or multiply and add) chains held in registers, widest ISA built.
PeakPoint measure_peak(bool is_double, int threads, bool fma, double seconds);

// One cache line bounced between two threads `round_trips` times (release/acquire, no pinning:
// the threads where the scheduler puts them, as the engine's are): ns per round trip.
double measure_round_trip(int round_trips);

// The machine's own tail for work of one length: `samples` runs, timed one by one, of fixed
// arithmetic lasting about `seconds` (one dependent chain of multiply-adds, no memory traffic),
// on `threads` threads at once (at most the logical CPUs; each the same arithmetic, released
// together; a run ends when the last of them has finished; the threads spin between runs and never
// sleep). Whatever makes a run
// longer than its median is the machine's, not the code's: interrupts, the host's exits, other
// guests. A case's step p99 compares with the p99 of this at the step's median length
// (Record::floor_p99_us): on a 2-vCPU KVM guest, 28 us of arithmetic had a p99 of 50 us
// (docs/performance.md). Returns seconds per run.
std::vector<double> time_fixed_work(double seconds, int threads, std::size_t samples);

// CPU model, cores, caches (from /proc/cpuinfo and sysfs), compiler and ISA of this build.
std::string machine_description();
std::string build_description();

// Cores used by other processes (and the hypervisor: steal) between two samples.
struct CpuSample {
  double busy_s = 0;  // all CPUs, user + nice + system + irq + softirq + steal
  double self_s = 0;  // this process, user + system
  double wall_s = 0;
};
CpuSample cpu_sample();
double others_busy_cores(const CpuSample& from, const CpuSample& to);

// Waits (up to max_wait_s) until other processes use less than `threshold_cores`, sampling
// every 0.25 s. Returns the last measured load of the others (cores).
double wait_for_idle(double max_wait_s, double threshold_cores);

}  // namespace pliant::perf
