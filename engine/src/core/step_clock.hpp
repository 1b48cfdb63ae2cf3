// Private to pliant_core: times the steps of a run, for the progress lines and the wall-time
// estimate of `pliant run` (run_scene.cpp) and of its plan's warm-up (run_plan.cpp). The rate
// is per sub-step, so that the estimate holds when the adaptive step splits steps; the first
// step (threads waking, caches filling) is left out of it once there are others.
#pragma once
#include <chrono>
#include <cstdint>

#include "pliant/run.hpp"

namespace pliant::detail {

class StepClock {
 public:
  using Clock = std::chrono::steady_clock;
  void start() { start_ = after_first_ = Clock::now(); }
  // After each step, with the sub-steps it took.
  void stepped(int substeps) {
    ++steps_;
    substeps_ += substeps;
    if (steps_ == 1) {
      after_first_ = Clock::now();
      first_substeps_ = substeps;
      idle_at_first_ = idle_;
    }
  }
  // Wall time spent waiting rather than stepping (a real-time run's pacing): left out of the cost
  // per sub-step, so that the estimate says what stepping costs.
  void idle(double seconds) { idle_ += seconds; }
  double wall() const { return std::chrono::duration<double>(Clock::now() - start_).count(); }
  std::int64_t steps() const { return steps_; }
  // s of wall time per sub-step so far (0 before the first step).
  double seconds_per_substep() const {
    if (steps_ == 0) return 0;
    if (steps_ == 1) return (wall() - idle_) / double(substeps_);
    const double t = std::chrono::duration<double>(Clock::now() - after_first_).count() - (idle_ - idle_at_first_);
    return t / double(substeps_ - first_substeps_);
  }
  RunProgress progress(std::int64_t total_steps, int last_substeps, double time, double duration) const {
    RunProgress p;
    p.step = steps_;
    p.steps = total_steps;
    p.substeps_done = substeps_;
    p.substeps = last_substeps;
    p.time = time;
    p.duration = duration;
    p.wall_s = wall();
    p.seconds_per_substep = seconds_per_substep();
    p.eta_s = double(total_steps > steps_ ? total_steps - steps_ : 0) * last_substeps * p.seconds_per_substep;
    return p;
  }

 private:
  Clock::time_point start_, after_first_;
  std::int64_t steps_ = 0, substeps_ = 0;
  int first_substeps_ = 0;
  double idle_ = 0, idle_at_first_ = 0;  // s
};

}  // namespace pliant::detail
