// Background work (checkpoints, map computations) runs at a lower CPU priority than the live
// path, so a burst of it delays a frame's LightingUpdate little, yet it still gets a share of
// the cores when other programs keep them busy.
#pragma once

namespace arlight::daemon {

// The nice value of background threads. Not SCHED_IDLE, which gets no time at all while any
// other thread can run: beside two CPU-bound processes of normal priority a session got no map
// set in 10 s (issue 37 §2). At nice 7 (CFS weight 244 against a normal thread's 1024) map
// sets get about a fifth of a core a busy program also wants (a set every ~0.3 s beside two busy
// loops), and inside arlightd frames still come first (FramePathGate): bench/RESULTS.md
// "Issue 37 §2" (with the gate, nice 5 dropped frames at 8 sessions, nice 10 gave sets only
// every 0.8-1.3 s beside the busy loops).
inline constexpr int kBackgroundNice = 7;

// Lowers the calling thread's scheduling priority to kBackgroundNice (Linux: the nice value is
// per thread). It cannot be raised again without privileges, so call it only on threads that
// do background work for good. Best effort: a refusal is ignored.
void lower_thread_priority();

}  // namespace arlight::daemon
