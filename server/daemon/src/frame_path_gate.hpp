// Frames first, inside arlightd (issue 37 §2). The OS orders arlightd's threads against other
// programs (background threads at kBackgroundNice, priority.hpp); this orders its own work:
// map computations step aside between tiles while any session has a frame waiting or being
// processed, and go on as soon as none has. So a niced map thread, which the kernel lets finish
// its slice before a woken frame thread gets the core, no longer sits in a frame's way.
//
// Stepping aside is bounded: a background thread waits at most kWaitPerRun times as long as it
// ran since it last stepped aside (and at most kMaxWait at a time), so when frames keep the
// cores busy all the time map sets slow down to about 1 / (1 + kWaitPerRun) of a thread each
// and never stop. No threads of its own; tested on its own (tests/daemon/test_frame_path_gate.cpp).
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <mutex>

namespace arlight::daemon {

class FramePathGate {
 public:
  using Clock = std::chrono::steady_clock;
  static constexpr int kWaitPerRun = 3;
  static constexpr Clock::duration kMaxWait = std::chrono::milliseconds(50);

  // A session's turn on the worker pool began (FrameQueue::begin_turn) / ended (end_turn).
  void frames_began();
  void frames_ended();
  // Sessions with a turn now.
  int busy() const { return busy_.load(std::memory_order_relaxed); }

  // From a background thread between two steps of its work: returns at once when no session
  // has frames; else blocks until none has or the thread's wait allowance is spent. Returns
  // how long it waited.
  Clock::duration step_aside();

 private:
  std::atomic<int> busy_{0};
  std::mutex mutex_;
  std::condition_variable quiet_;
};

}  // namespace arlight::daemon
