// Driving the protocol client (arlight_client_net) with a recording's frames, for the tests that
// start the real daemon.
#pragma once

#include <chrono>
#include <cstdint>

#include "arlight/net/client_net.hpp"
#include "arlight/protocol/recording.hpp"

namespace arlight::test {

// Sends frame `seq` (the recording's frames in turn) and waits up to 20 s for the LightingUpdate
// that answers it: whether it came.
inline bool frame_gets_update(client::Client& c, const recording::Recording& rec,
                              std::uint64_t seq) {
  const std::size_t i = std::size_t(seq % rec.frames.size());
  c.send_jpeg_frame(seq, rec.frames[i], rec.camera.width, rec.camera.height,
                    recording::read_frame_bytes(rec, i));
  return c.wait_for(
      [&] {
        const auto u = c.last_update();
        return u && u->frame_sequence >= seq;
      },
      std::chrono::seconds(20));
}

}  // namespace arlight::test
