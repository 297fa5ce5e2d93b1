#include "arlight/net/unsaved_frames.hpp"

namespace arlight::client {

void UnsavedFrames::keep(std::uint64_t sequence, const FrameInfo& info, int width, int height,
                         std::span<const std::uint8_t> jpeg, bool sent, std::size_t max_unsent) {
  Kept k{{sequence, info, width, height, {jpeg.begin(), jpeg.end()}}, sent};
  bytes_ += k.frame.jpeg.size();
  frames_.push_back(std::move(k));
  if (sent && next_ == frames_.size() - 1) ++next_;  // nothing waited before it
  if (!sent && max_unsent > 0 && waiting_unsent() > max_unsent) {
    // The oldest frame never sent goes (those sent once stay: a checkpoint lacks them).
    for (std::size_t i = next_; i < frames_.size(); ++i)
      if (!frames_[i].ever_sent) {
        bytes_ -= frames_[i].frame.jpeg.size();
        frames_.erase(frames_.begin() + std::ptrdiff_t(i));
        ++replaced_;
        break;
      }
  }
  while (bytes_ > max_bytes_ && !frames_.empty()) {
    ++given_up_;
    if (!frames_.front().ever_sent) ++given_up_unsent_;
    drop_front();
  }
}

void UnsavedFrames::drop_front() {
  bytes_ -= frames_.front().frame.jpeg.size();
  frames_.pop_front();
  if (next_ > 0) --next_;
}

void UnsavedFrames::saved(std::uint64_t sequence) {
  // Only frames already sent: one still waiting reached no checkpoint, whatever its number.
  while (!frames_.empty() && next_ > 0 && frames_.front().frame.sequence <= sequence)
    drop_front();
}

void UnsavedFrames::welcomed(std::uint64_t last_sequence) {
  while (!frames_.empty() && frames_.front().frame.sequence <= last_sequence) drop_front();
  next_ = 0;
}

const UnsavedFrames::Frame* UnsavedFrames::next_waiting() const {
  return waiting() ? &frames_[next_].frame : nullptr;
}

void UnsavedFrames::sent_next() {
  if (!waiting()) return;
  Kept& k = frames_[next_++];
  if (k.ever_sent) ++resent_;
  k.ever_sent = true;
}

std::uint64_t UnsavedFrames::waiting_unsent() const {
  std::uint64_t n = 0;
  for (std::size_t k = next_; k < frames_.size(); ++k) n += frames_[k].ever_sent ? 0 : 1;
  return n;
}

}  // namespace arlight::client
