// Raising the calling thread to a real-time scheduling class for a paced run
// (RunOptions::realtime_priority), and putting it back. A thread of the normal class that waits for
// its next frame can wake up milliseconds late when other processes hold the cores (5.2 ms on the
// 2-vCPU machine of docs/adaptivity.md); a SCHED_FIFO thread preempts them. It needs the privilege
// (root, CAP_SYS_NICE or an rtprio limit): without it the run goes on at normal priority and says so.
#pragma once
#include <string>

namespace pliant::detail {

class ThreadPriority {
 public:
  ThreadPriority() = default;
  ThreadPriority(const ThreadPriority&) = delete;
  ThreadPriority& operator=(const ThreadPriority&) = delete;
  ~ThreadPriority() { restore(); }
  // Raises the calling thread to SCHED_FIFO at a low real-time priority (1: above every normal
  // thread, below the kernel's own). Returns false with the reason if it may not.
  bool raise(std::string& why);
  void restore();

 private:
  bool raised_ = false;
  int policy_ = 0;
  int priority_ = 0;
};

}  // namespace pliant::detail
