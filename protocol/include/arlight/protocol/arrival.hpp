// How a received message's bytes came (issue 36 §1: the rate of the sender's uplink, for the
// frame advice's byte budget): those read after the message's first read, and the seconds from
// that read to its last (MessageStream::last_arrival). 0 bytes: the message was there whole at
// its first read (a fast link, or a reader that came late), which tells nothing of the link.
#pragma once

#include <cstddef>

namespace arlight::wire {

struct Arrival {
  std::size_t bytes_after_first = 0;
  double seconds = 0;
};

}  // namespace arlight::wire
