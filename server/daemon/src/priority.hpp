// Background work (checkpoints, map computations) runs at a lower CPU priority than the live
// path, so a burst of it never delays a frame's LightingUpdate.
#pragma once

namespace arlight::daemon {

// Lowers the calling thread's scheduling priority to `nice` (Linux: nice values are per
// thread). It cannot be raised again without privileges, so call it only on threads that do
// background work for good. Best effort: a refusal is ignored.
void lower_thread_priority(int nice);

// Niceness of the two kinds of background work: checkpoints must keep up (a few ms per session
// every interval), map sets may wait for idle cycles.
constexpr int kCheckpointNice = 10;
constexpr int kMapNice = 19;

}  // namespace arlight::daemon
