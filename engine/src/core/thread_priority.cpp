// ThreadPriority (thread_priority.hpp): pthread scheduling on POSIX systems; elsewhere it says it
// cannot.
#include "thread_priority.hpp"

#include <cstring>

#if defined(__unix__) || defined(__APPLE__)
#include <pthread.h>
#include <sched.h>
#define PLIANT_HAS_PTHREAD_SCHED 1
#endif

namespace pliant::detail {

bool ThreadPriority::raise(std::string& why) {
#ifdef PLIANT_HAS_PTHREAD_SCHED
  sched_param old{};
  int policy = 0;
  if (const int e = pthread_getschedparam(pthread_self(), &policy, &old); e != 0) {
    why = std::string("pthread_getschedparam: ") + std::strerror(e);
    return false;
  }
  sched_param fifo{};
  fifo.sched_priority = 1;
  if (const int e = pthread_setschedparam(pthread_self(), SCHED_FIFO, &fifo); e != 0) {
    why = std::string("SCHED_FIFO refused (") + std::strerror(e) + "): needs root, CAP_SYS_NICE or an rtprio limit";
    return false;
  }
  raised_ = true;
  policy_ = policy;
  priority_ = old.sched_priority;
  return true;
#else
  why = "real-time priority is not supported on this system";
  return false;
#endif
}

void ThreadPriority::restore() {
#ifdef PLIANT_HAS_PTHREAD_SCHED
  if (!raised_) return;
  sched_param p{};
  p.sched_priority = priority_;
  pthread_setschedparam(pthread_self(), policy_, &p);
  raised_ = false;
#endif
}

}  // namespace pliant::detail
