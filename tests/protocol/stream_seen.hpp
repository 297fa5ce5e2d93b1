// What one end of a MessageStream saw, under a lock: the tests of every transport use it.
#pragma once

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
  std::optional<wire::DecodeError> bad;
  std::optional<std::string> closed;
  int overflows = 0;

  wire::MessageStream::Handlers handlers() {
    wire::MessageStream::Handlers h;
    h.on_message = [this](wire::Message&& m) { note([&] { messages.push_back(std::move(m)); }); };
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

}  // namespace arlight::test
