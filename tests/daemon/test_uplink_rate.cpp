// The uplink's rate from frames' arrivals and the frame advice's byte budget
// (server/daemon/src/uplink_rate.hpp, issue 36 §1), without a daemon.
#include <gtest/gtest.h>

#include "uplink_rate.hpp"

using arlight::daemon::UplinkRate;
using namespace std::chrono_literals;

TEST(UplinkRate, TheMedianArrivalRateGivesWhatCrossesInACameraFrame) {
  UplinkRate up;
  UplinkRate::Clock::time_point t{};
  const auto next = [&] { return t += 33ms; };
  EXPECT_EQ(up.frame_bytes(t), 0u);  // nothing measured: no advice
  // 2 Mbit/s: 250 kB/s, 8.3 kB in 1/30 s.
  for (int i = 0; i < 8; ++i) up.arrived({20000, 20000 / 250e3}, next());
  EXPECT_NEAR(up.bytes_per_second(t), 250e3, 1.0);
  EXPECT_NEAR(up.frame_bytes(t), 8333, 1);
  // Outliers either way stay outliers: frames a retransmission held up (2 % loss), and one whose
  // segments came bunched.
  up.arrived({20000, 0.5}, next());
  up.arrived({16000, 0.0}, next());
  up.arrived({20000, 0.3}, next());
  EXPECT_NEAR(up.frame_bytes(t), 8333, 1);
  // Too few bytes after the first read tell nothing; a message there whole tells nothing.
  for (int i = 0; i < 8; ++i) up.arrived({UplinkRate::kMinBytes - 1, 0.001}, next());
  up.arrived({}, next());
  EXPECT_NEAR(up.frame_bytes(t), 8333, 1);
  // The link narrows to 1 Mbit/s: within a window's worth of frames the advice follows it.
  for (std::size_t i = 0; i < UplinkRate::kWindow / 2 + 1; ++i)
    up.arrived({20000, 20000 / 125e3}, next());
  EXPECT_NEAR(up.frame_bytes(t), 4166, 1);
  // Frames too small to measure for kMaxAge: the advice lapses (the client's frames grow back
  // and are measured again).
  t += UplinkRate::kMaxAge;
  EXPECT_NEAR(up.frame_bytes(t), 4166, 1);  // the newest sample is just kMaxAge old
  t += 1ms;
  EXPECT_EQ(up.frame_bytes(t), 0u);
  // A new connection starts over.
  up.arrived({20000, 20000 / 250e3}, next());
  up.reset();
  EXPECT_EQ(up.frame_bytes(t), 0u);
}

TEST(UplinkRate, AFastLinkGetsNoLimit) {
  UplinkRate up;
  UplinkRate::Clock::time_point t{};
  // Loopback or a LAN: a 40 kB frame's rest arrives within a millisecond (counted as one).
  for (int i = 0; i < 8; ++i) up.arrived({40000, 0.0002}, t += 33ms);
  EXPECT_NEAR(up.bytes_per_second(t), 40e6, 1.0);
  EXPECT_EQ(up.frame_bytes(t), 0u);  // 1.3 MB in a frame's time: no frame is that large
  // 50 Mbit/s still advises (208 kB: a 1280x720 frame at quality 90 fits).
  for (int i = 0; i < 8; ++i) up.arrived({40000, 40000 / 6.25e6}, t += 33ms);
  EXPECT_NEAR(up.frame_bytes(t), 208333, 1);
}
