#include "priority.hpp"

#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

namespace arlight::daemon {

void lower_thread_priority() {
  const auto tid = static_cast<id_t>(::syscall(SYS_gettid));  // the calling thread, not the process
  if (::getpriority(PRIO_PROCESS, tid) < kBackgroundNice)
    ::setpriority(PRIO_PROCESS, tid, kBackgroundNice);
}

}  // namespace arlight::daemon
