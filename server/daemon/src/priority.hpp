// Background work (checkpoints, map computations) runs at a lower CPU priority than the live
// path, so a burst of it never delays a frame's LightingUpdate.
#pragma once

namespace arlight::daemon {

enum class BackgroundWork {
  Checkpoint,  // nice 10: checkpoints must keep up (a few ms per session every interval)
  MapSet,      // SCHED_IDLE: map sets run on idle cycles, and a frame's thread preempts them
};

// Lowers the calling thread's scheduling priority for `work` (Linux: policy and nice value are
// per thread). It cannot be raised again without privileges, so call it only on threads that
// do background work for good. Best effort: a refusal is ignored (a map set's thread then
// falls back to nice 19).
void lower_thread_priority(BackgroundWork work);

}  // namespace arlight::daemon
