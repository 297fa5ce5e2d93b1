// A session's frames waiting for a worker: a bounded queue where the newest frame wins, and the
// turn a session holds on the worker pool (one frame a turn). No threads or locks of its own:
// the Session calls it under its mutex. Tested on its own (tests/daemon/test_frame_queue.cpp).
#pragma once

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <functional>
#include <optional>

#include "arlight/protocol/arrival.hpp"
#include "arlight/protocol/wire.hpp"

namespace arlight::daemon {

// A frame as it waits for a worker: the message as it arrived, and when.
struct FrameJob {
  wire::CameraFrame frame;
  std::chrono::steady_clock::time_point received;
  wire::Arrival arrival;  // how its message's bytes came (UplinkRate)
};

class FrameQueue {
 public:
  // At most `depth` frames wait (at least 1). Two absorb the jitter of a shared worker pool
  // without letting a session fall more than a frame behind.
  explicit FrameQueue(int depth) : depth_(depth < 1 ? 1 : std::size_t(depth)) {}

  // Queues a frame. When the queue is full the oldest waiting frame is stale and dropped,
  // unless `keep` says it must stay (the darker frame the exposure advice asked for: dropping
  // it would read as a client that cannot go that dark): then the oldest other one. Returns how
  // many frames were dropped (0 or 1).
  std::size_t push(FrameJob job, const std::function<bool(const FrameJob&)>& keep = {});

  // Whether the caller must post a turn to the worker pool: none is posted or running. From
  // here until end_turn() the queue counts as busy.
  bool begin_turn();
  // The frame this turn processes, the oldest waiting; nullopt when none waits.
  std::optional<FrameJob> take();
  // The turn is over with nothing left to take: the next push() begins a new one.
  void end_turn() { busy_ = false; }

  bool empty() const { return waiting_.empty(); }
  std::size_t size() const { return waiting_.size(); }
  // The sequence of the oldest frame waiting (every older frame was processed or dropped).
  std::optional<std::uint64_t> oldest_sequence() const {
    if (waiting_.empty()) return std::nullopt;
    return waiting_.front().frame.sequence;
  }
  // A frame waits, or a turn is posted or running (a map set's scheduler reads "frames are
  // still coming").
  bool active() const { return busy_ || !waiting_.empty(); }

 private:
  std::size_t depth_;
  std::deque<FrameJob> waiting_;
  bool busy_ = false;
};

}  // namespace arlight::daemon
