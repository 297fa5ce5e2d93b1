#include "frame_queue.hpp"

#include <utility>

namespace arlight::daemon {

std::size_t FrameQueue::push(FrameJob job, const std::function<bool(const FrameJob&)>& keep) {
  std::size_t dropped = 0;
  while (waiting_.size() >= depth_) {
    auto victim = waiting_.begin();
    if (keep)
      for (auto it = waiting_.begin(); it != waiting_.end(); ++it)
        if (!keep(*it)) {
          victim = it;
          break;
        }
    waiting_.erase(victim);
    ++dropped;
  }
  waiting_.push_back(std::move(job));
  return dropped;
}

bool FrameQueue::begin_turn() {
  if (busy_) return false;
  busy_ = true;
  return true;
}

std::optional<FrameJob> FrameQueue::take() {
  if (waiting_.empty()) return std::nullopt;
  FrameJob job = std::move(waiting_.front());
  waiting_.pop_front();
  return job;
}

}  // namespace arlight::daemon
