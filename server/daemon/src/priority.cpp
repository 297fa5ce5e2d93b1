#include "priority.hpp"

#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

namespace arlight::daemon {

void lower_thread_priority(int nice) {
  const auto tid = static_cast<id_t>(::syscall(SYS_gettid));
  if (::getpriority(PRIO_PROCESS, tid) < nice) ::setpriority(PRIO_PROCESS, tid, nice);
}

}  // namespace arlight::daemon
