// What one end of a MessageStream saw, under a lock: the tests of every transport use it.
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "arlight/protocol/message_stream.hpp"

namespace arlight::test {

struct Seen {
  std::mutex mutex;
  std::condition_variable cv;
  std::vector<wire::Message> messages;
  // Set: each message's arrival as this stream reports it (MessageStream::last_arrival).
  std::atomic<const wire::MessageStream*> stream{nullptr};
  std::vector<wire::Arrival> arrivals;
  std::optional<wire::DecodeError> bad;
  std::optional<std::string> closed;
  int overflows = 0;

  wire::MessageStream::Handlers handlers() {
    wire::MessageStream::Handlers h;
    h.on_message = [this](wire::Message&& m) {
      const wire::MessageStream* s = stream.load();
      const wire::Arrival a = s ? s->last_arrival() : wire::Arrival{};
      note([&] { messages.push_back(std::move(m)), arrivals.push_back(a); });
    };
    h.on_bad_message = [this](const wire::DecodeError& e) { note([&] { bad = e; }); };
    h.on_closed = [this](const std::string& why) { note([&] { closed = why; }); };
    h.on_overflow = [this] { note([&] { ++overflows; }); };
    return h;
  }
  template <class F>
  void note(F f) {
    std::lock_guard lock(mutex);
    f();
    cv.notify_all();
  }
  template <class P>
  bool wait(P pred) {
    std::unique_lock lock(mutex);
    return cv.wait_for(lock, std::chrono::seconds(10), pred);
  }
};

// A frame message of about `bytes` (random-looking data), encoded.
inline std::vector<std::uint8_t> encoded_frame(std::size_t bytes) {
  wire::CameraFrame frame;
  frame.sequence = 1, frame.width = 320, frame.height = 240;
  for (std::size_t i = 0; i < bytes; ++i) frame.data.push_back(std::uint8_t(i * 7919 >> 5));
  return wire::encode(frame);
}

}  // namespace arlight::test
