// When a session's next map set starts (issue 16 §3), as a state machine with no threads, timers
// or locks: the Session tells it what happened (a frame, a request, a set done, shutdown,
// attach) and asks decide() whether a set starts now, later or not, and does what it says.
// Tested on its own (tests/daemon/test_map_set_scheduler.cpp).
//
// Sets follow the map: one starts when a frame has changed the map since the last one started,
// once that one is done and at least `interval` after it started. A change while a set runs
// starts the next when it ends; one deferred by the interval starts then (the Session arms a
// timer). While frames arrive, sets are previews; once they pause for kPreviewPause, a full one
// follows.
#pragma once

#include <chrono>
#include <cstdint>

namespace arlight::daemon {

class MapSetScheduler {
 public:
  using Clock = std::chrono::steady_clock;
  // Frames that stopped this long ago have stopped: the next set is a full one.
  static constexpr Clock::duration kPreviewPause = std::chrono::milliseconds(500);

  enum class State {
    Idle,          // no set running
    Running,       // a set runs
    RunningAgain,  // a set runs, and the map changed since it started: another follows it
    Stopped,       // the session shut down: no set starts until a client attaches
  };

  // What the session knows when it asks.
  struct Now {
    Clock::time_point time;
    std::uint64_t frames_merged = 0;  // frames in the map now
    bool frames_waiting = false;      // a frame is queued or being merged
    bool can_compute = false;         // a map request, and a map with something in it
  };
  struct Decision {
    enum class Kind { None, StartNow, StartAt } kind = Kind::None;
    bool preview = false;    // StartNow: a preview (frames are arriving) or the full set
    Clock::time_point at{};  // StartAt: when the interval ends
  };

  explicit MapSetScheduler(Clock::duration interval) : interval_(interval) {}

  // The one question: does a set start? StartNow counts it as started (Running).
  Decision decide(const Now& now);

  void frame_arrived(Clock::time_point t) { last_frame_ = t; }
  // A new map request: its first set starts at once, whatever changed.
  void request_changed() { forced_ = true; }
  // The running set ended; true when another is due now (the map changed while it ran).
  bool finished();
  void stop() { state_ = State::Stopped; }
  // A client attached: sets may start again.
  void resume() {
    if (state_ == State::Stopped) state_ = State::Idle;
  }
  State state() const { return state_; }

 private:
  Clock::duration interval_;
  State state_ = State::Idle;
  bool forced_ = true;                 // the next set starts whatever changed
  std::uint64_t frames_at_start_ = 0;  // frames in the map when the last set started
  Clock::time_point started_{};        // when the last set started
  bool last_was_preview_ = false;      // the last set was a preview (frames were arriving)
  Clock::time_point last_frame_ = Clock::now();
};

}  // namespace arlight::daemon
