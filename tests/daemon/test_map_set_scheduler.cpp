// When a session's map sets start (server/daemon/src/map_set_scheduler.hpp), without a daemon:
// the clock and the session's state are given, and each rule of issue 16 §3 is checked.
#include <gtest/gtest.h>

#include "map_set_scheduler.hpp"

using namespace arlight::daemon;
using namespace std::chrono_literals;
using Kind = MapSetScheduler::Decision::Kind;
using State = MapSetScheduler::State;

namespace {

const MapSetScheduler::Clock::time_point t0 = MapSetScheduler::Clock::now();

MapSetScheduler::Now at(std::chrono::milliseconds ms, std::uint64_t frames, bool waiting = false) {
  return {.time = t0 + ms, .frames_merged = frames, .frames_waiting = waiting, .can_compute = true};
}

}  // namespace

TEST(MapSetScheduler, ANewRequestStartsAtOnceThenSetsFollowTheMapAtTheInterval) {
  MapSetScheduler s(90ms);
  s.frame_arrived(t0);
  MapSetScheduler::Now nothing = at(0ms, 1);
  nothing.can_compute = false;  // no request or an empty map: nothing, whatever else
  EXPECT_EQ(s.decide(nothing).kind, Kind::None);
  const auto first = s.decide(at(10ms, 1));
  EXPECT_EQ(first.kind, Kind::StartNow);
  EXPECT_TRUE(first.preview);  // a frame 10 ms ago: frames are arriving
  EXPECT_EQ(s.state(), State::Running);
  // A change while it runs: the next follows it, not a second one beside it.
  EXPECT_EQ(s.decide(at(20ms, 2)).kind, Kind::None);
  EXPECT_EQ(s.state(), State::RunningAgain);
  EXPECT_TRUE(s.finished());
  EXPECT_EQ(s.state(), State::Idle);
  // Done 30 ms after it started: the interval defers the next to 10 + 90 ms.
  const auto deferred = s.decide(at(40ms, 2));
  EXPECT_EQ(deferred.kind, Kind::StartAt);
  EXPECT_EQ(deferred.at, t0 + 100ms);
  EXPECT_EQ(s.decide(at(100ms, 2)).kind, Kind::StartNow);
  // Nothing new since: no set, however long one waits while frames keep coming.
  EXPECT_FALSE(s.finished());
  s.frame_arrived(t0 + 300ms);
  EXPECT_EQ(s.decide(at(400ms, 2)).kind, Kind::None);
}

TEST(MapSetScheduler, WhenFramesPauseAfterAPreviewTheFullSetFollows) {
  MapSetScheduler s(90ms);
  s.frame_arrived(t0);
  ASSERT_TRUE(s.decide(at(0ms, 1)).preview);
  s.finished();
  // No new frame merged, but the frames stopped 500 ms ago: the full set, once none waits.
  EXPECT_EQ(s.decide(at(400ms, 1)).kind, Kind::None);
  EXPECT_EQ(s.decide(at(600ms, 1, /*waiting=*/true)).kind, Kind::None);
  const auto full = s.decide(at(600ms, 1));
  EXPECT_EQ(full.kind, Kind::StartNow);
  EXPECT_FALSE(full.preview);
  s.finished();
  EXPECT_EQ(s.decide(at(2000ms, 1)).kind, Kind::None);  // and only one
}

TEST(MapSetScheduler, AfterShutdownNothingStartsUntilAClientAttaches) {
  MapSetScheduler s(90ms);
  s.frame_arrived(t0);
  ASSERT_EQ(s.decide(at(0ms, 1)).kind, Kind::StartNow);
  EXPECT_EQ(s.decide(at(10ms, 2)).kind, Kind::None);  // again after it
  s.stop();
  EXPECT_FALSE(s.finished());  // the stopped set's follow-up does not start
  EXPECT_EQ(s.decide(at(500ms, 3)).kind, Kind::None);
  s.resume();
  s.request_changed();
  EXPECT_EQ(s.decide(at(510ms, 3)).kind, Kind::StartNow);  // a new request: at once
}
