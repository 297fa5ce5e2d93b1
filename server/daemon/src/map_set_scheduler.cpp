#include "map_set_scheduler.hpp"

namespace arlight::daemon {

MapSetScheduler::Decision MapSetScheduler::decide(const Now& now) {
  using Kind = Decision::Kind;
  if (state_ == State::Stopped || !now.can_compute) return {};
  // Frames paused after a preview: the full set of the map as it is now is due.
  const bool full_due =
      last_was_preview_ && !now.frames_waiting && now.time - last_frame_ >= kPreviewPause;
  if (!forced_ && now.frames_merged <= frames_at_start_ && !full_due) return {};  // nothing new
  if (state_ == State::Running || state_ == State::RunningAgain) {
    state_ = State::RunningAgain;
    return {};
  }
  // Deferred by the interval: it starts when the interval ends rather than with the next frame
  // or idle tick after it (those came ~20 ms late: sets every ~120 ms at a 100 ms interval).
  if (!forced_ && now.time - started_ < interval_)
    return {Kind::StartAt, false, started_ + interval_};
  const bool preview = now.time - last_frame_ < kPreviewPause;
  state_ = State::Running;
  forced_ = false;
  started_ = now.time;
  frames_at_start_ = now.frames_merged;
  last_was_preview_ = preview;
  return {Kind::StartNow, preview, {}};
}

bool MapSetScheduler::finished() {
  if (state_ == State::Stopped) return false;
  const bool again = state_ == State::RunningAgain;
  state_ = State::Idle;
  return again;
}

}  // namespace arlight::daemon
