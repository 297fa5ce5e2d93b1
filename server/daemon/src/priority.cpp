#include "priority.hpp"

#include <sched.h>
#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

namespace arlight::daemon {

void lower_thread_priority(BackgroundWork work) {
  if (work == BackgroundWork::MapSet) {
    // SCHED_IDLE rather than nice 19: Linux's fair scheduler (EEVDF, 6.6 on) lets a niced
    // thread finish its slice before a woken frame thread gets the core, a few ms at each of a
    // frame's wake-ups (8 sessions with map sets: frame->update p99 ~50 ms against ~15 ms
    // without), while a thread of the idle policy is preempted at once.
    const sched_param param{};
    if (::sched_setscheduler(0, SCHED_IDLE, &param) == 0) return;  // 0: the calling thread
  }
  const int nice = work == BackgroundWork::MapSet ? 19 : 10;
  const auto tid = static_cast<id_t>(::syscall(SYS_gettid));
  if (::getpriority(PRIO_PROCESS, tid) < nice) ::setpriority(PRIO_PROCESS, tid, nice);
}

}  // namespace arlight::daemon
