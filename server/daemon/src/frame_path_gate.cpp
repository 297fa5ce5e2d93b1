#include "frame_path_gate.hpp"

#include <algorithm>

namespace arlight::daemon {

void FramePathGate::frames_began() { busy_.fetch_add(1, std::memory_order_relaxed); }

void FramePathGate::frames_ended() {
  if (busy_.fetch_sub(1, std::memory_order_relaxed) == 1) {
    std::lock_guard lock(mutex_);  // a waiter between its check and its wait sees the change
    quiet_.notify_all();
  }
}

FramePathGate::Clock::duration FramePathGate::step_aside() {
  // When this thread last went on: its allowance is kWaitPerRun times what it ran since.
  thread_local Clock::time_point resumed = Clock::now();
  const auto now = Clock::now();
  if (busy() == 0) return {};
  const auto allowance = std::min<Clock::duration>(kWaitPerRun * (now - resumed), kMaxWait);
  {
    std::unique_lock lock(mutex_);
    quiet_.wait_for(lock, allowance, [&] { return busy() == 0; });
  }
  resumed = Clock::now();
  return resumed - now;
}

}  // namespace arlight::daemon
