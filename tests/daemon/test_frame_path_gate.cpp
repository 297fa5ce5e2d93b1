// Frames first inside arlightd (issue 37 §2): background work steps aside while a session has
// frames, goes on when none has, and is never held for good.
#include <gtest/gtest.h>

#include <chrono>
#include <thread>

#include "frame_path_gate.hpp"

using namespace arlight::daemon;
using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;

TEST(FramePathGate, WithoutFramesBackgroundWorkGoesOnAtOnce) {
  FramePathGate gate;
  EXPECT_EQ(gate.busy(), 0);
  std::this_thread::sleep_for(20ms);  // "ran": an allowance it must not use
  EXPECT_EQ(gate.step_aside(), Clock::duration::zero());
  gate.frames_began();
  gate.frames_ended();
  EXPECT_EQ(gate.step_aside(), Clock::duration::zero());
}

// Frames of two sessions: the thread waits until the last session's turn ends, not for its whole
// allowance.
TEST(FramePathGate, BackgroundWorkWaitsUntilNoSessionHasFrames) {
  FramePathGate gate;
  Clock::duration waited{};
  gate.frames_began();
  gate.frames_began();
  std::thread background([&] {
    gate.step_aside();                  // starts this thread's count of what it ran
    std::this_thread::sleep_for(40ms);  // ran 40 ms: may wait min(120, kMaxWait = 50) ms
    waited = gate.step_aside();
  });
  std::this_thread::sleep_for(50ms);
  gate.frames_ended();
  EXPECT_EQ(gate.busy(), 1);
  std::this_thread::sleep_for(5ms);
  gate.frames_ended();  // ~15 ms into its wait
  background.join();
  EXPECT_GT(waited, 5ms);
  EXPECT_LT(waited, 45ms);  // woken when the last turn ended, before its allowance ran out
}

// Frames that never stop: the background thread still gets about 1 / (1 + kWaitPerRun) of its
// time (it waits at most kWaitPerRun times what it ran), not none.
TEST(FramePathGate, FramesThatNeverStopStillLeaveBackgroundWorkItsShare) {
  FramePathGate gate;
  gate.frames_began();
  Clock::duration waited{}, worked{};
  std::thread([&] {
    gate.step_aside();
    const auto end = Clock::now() + 600ms;
    while (Clock::now() < end) {
      const auto t = Clock::now();
      while (Clock::now() - t < 2ms) {
      }  // a step of work
      worked += Clock::now() - t;
      waited += gate.step_aside();
    }
  }).join();
  gate.frames_ended();
  const double share = std::chrono::duration<double>(worked) /
                       std::chrono::duration<double>(worked + waited);
  EXPECT_GT(share, 0.15);  // 0.25 exactly on an idle machine
  EXPECT_LT(share, 0.5);   // it did step aside
}
