// The frames a client sent that the session's newest checkpoint may not hold yet (issue 36 §5,
// PROTOCOL.md "Fail-over"): kept, up to a size, so that after a fail-over the client sends them
// again to whichever daemon resumed the session, and so that frames due while it had no daemon
// wait here instead of being lost. A LightingUpdate's saved_sequence lets it forget the frames a
// checkpoint holds; a Welcome's last_sequence says which ones the resumed session lacks.
// Part of the client core (the native link and arlight-load); no clock, threads or networking.
#pragma once

#include <cstddef>
#include <cstdint>
#include <deque>
#include <span>
#include <vector>

#include "arlight/common/frame.hpp"

namespace arlight::client {

class UnsavedFrames {
 public:
  struct Frame {
    std::uint64_t sequence = 0;
    FrameInfo info;
    int width = 0, height = 0;
    std::vector<std::uint8_t> jpeg;
  };

  // At most `max_bytes` of JPEGs kept (32 MiB: ~10 s of 640x480 frames at 30 a second); past
  // it the oldest go (given_up()).
  explicit UnsavedFrames(std::size_t max_bytes = std::size_t(32) << 20) : max_bytes_(max_bytes) {}

  // A frame in sequence order: sent now (`sent`), or waiting to be sent (no daemon, or frames
  // before it still wait: a frame never goes before an older one, or the session would take
  // the older as a duplicate). `max_unsent` > 0 (a live camera): at most that many frames
  // never sent wait, the newest; an older one is replaced (replaced()), as a live camera's
  // newest frame wins everywhere else, so a long outage costs neither memory nor, once the link
  // is back, seconds of stale frames.
  void keep(std::uint64_t sequence, const FrameInfo& info, int width, int height,
            std::span<const std::uint8_t> jpeg, bool sent, std::size_t max_unsent = 0);
  // LightingUpdate.saved_sequence: the frames up to it are in a checkpoint.
  void saved(std::uint64_t sequence);
  // A Welcome (after any handshake): the session holds the frames up to `last_sequence`; every
  // frame kept after it waits to be sent (again), oldest first.
  void welcomed(std::uint64_t last_sequence);

  // The oldest frame waiting to be sent, nullptr when none does; sent_next() once it went.
  const Frame* next_waiting() const;
  void sent_next();
  bool waiting() const { return next_ < frames_.size(); }

  std::size_t size() const { return frames_.size(); }
  std::size_t bytes() const { return bytes_; }
  // Frames sent a second time (after a fail-over), and frames dropped for the size limit
  // before a checkpoint held them (of them: never sent at all).
  std::uint64_t resent() const { return resent_; }
  std::uint64_t given_up() const { return given_up_; }
  std::uint64_t given_up_unsent() const { return given_up_unsent_; }
  std::uint64_t waiting_unsent() const;  // waiting, never sent
  std::uint64_t replaced() const { return replaced_; }  // by a newer one (keep's max_unsent)

 private:
  struct Kept {
    Frame frame;
    bool ever_sent = false;
  };
  void drop_front();

  std::size_t max_bytes_;
  std::deque<Kept> frames_;  // in sequence order; [next_, end) wait to be sent
  std::size_t next_ = 0;
  std::size_t bytes_ = 0;
  std::uint64_t resent_ = 0, given_up_ = 0, given_up_unsent_ = 0, replaced_ = 0;
};

}  // namespace arlight::client
