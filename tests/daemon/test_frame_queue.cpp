// A session's frame queue (server/daemon/src/frame_queue.hpp), without a daemon: the newest
// frame wins, the advised frame stays, and one turn at a time is posted to the worker pool.
#include <gtest/gtest.h>

#include <vector>

#include "frame_queue.hpp"

using namespace arlight::daemon;

namespace {

FrameJob frame(std::uint64_t sequence) {
  FrameJob job;
  job.frame.sequence = sequence;
  return job;
}

std::vector<std::uint64_t> drain(FrameQueue& q) {
  std::vector<std::uint64_t> order;
  while (auto job = q.take()) order.push_back(job->frame.sequence);
  return order;
}

}  // namespace

TEST(FrameQueue, WhenFullTheOldestWaitingFrameIsDroppedAndTheNewestWins) {
  FrameQueue q(2);
  EXPECT_EQ(q.push(frame(1)), 0u);
  EXPECT_EQ(q.push(frame(2)), 0u);
  EXPECT_EQ(q.push(frame(3)), 1u);  // 1 goes
  EXPECT_EQ(q.push(frame(4)), 1u);  // 2 goes
  EXPECT_EQ(drain(q), (std::vector<std::uint64_t>{3, 4}));
  EXPECT_TRUE(q.empty());

  FrameQueue at_least_one(0);  // a depth below 1 still holds the newest frame
  at_least_one.push(frame(7));
  EXPECT_EQ(at_least_one.push(frame(8)), 1u);
  EXPECT_EQ(drain(at_least_one), (std::vector<std::uint64_t>{8}));
}

TEST(FrameQueue, TheFrameTheAdviceAskedForStaysAndTheOldestOtherGoes) {
  FrameQueue q(2);
  const auto advised = [](const FrameJob& j) { return j.frame.sequence == 1; };
  q.push(frame(1), advised);
  q.push(frame(2), advised);
  EXPECT_EQ(q.push(frame(3), advised), 1u);  // 2 goes, not the older advised 1
  EXPECT_EQ(drain(q), (std::vector<std::uint64_t>{1, 3}));

  // When every waiting frame is to be kept, the oldest goes all the same (the queue is bounded).
  FrameQueue all_kept(2);
  const auto keep_all = [](const FrameJob&) { return true; };
  all_kept.push(frame(1), keep_all);
  all_kept.push(frame(2), keep_all);
  EXPECT_EQ(all_kept.push(frame(3), keep_all), 1u);
  EXPECT_EQ(drain(all_kept), (std::vector<std::uint64_t>{2, 3}));
}

TEST(FrameQueue, OneTurnIsPostedUntilItEnds) {
  FrameQueue q(2);
  EXPECT_FALSE(q.active());
  q.push(frame(1));
  EXPECT_TRUE(q.active());      // a frame waits
  EXPECT_TRUE(q.begin_turn());  // post one
  q.push(frame(2));
  EXPECT_FALSE(q.begin_turn());  // one is posted already
  ASSERT_TRUE(q.take());
  ASSERT_TRUE(q.take());
  EXPECT_FALSE(q.take());
  EXPECT_TRUE(q.active());  // the turn is still running: frames are still coming
  q.end_turn();
  EXPECT_FALSE(q.active());
  q.push(frame(3));
  EXPECT_TRUE(q.begin_turn());  // a new turn for the next frame
}
