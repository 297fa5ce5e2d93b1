// A session's sun (server/daemon/src/sun_tracker.hpp), without a daemon: nothing before a
// Location, the map read at most once a second, at once after a new Location, and the sun
// confirmed only where place and time put it.
#include <gtest/gtest.h>

#include <cmath>
#include <glm/geometric.hpp>

#include "sun_tracker.hpp"

using namespace arlight;
using namespace arlight::daemon;
using namespace std::chrono_literals;

namespace {

// Golden, Colorado, 2003-10-17 19:30:30 UTC (SPA's example: the sun ~40° up, south-west).
wire::Location golden() {
  return {.where = {39.742476, -105.1786, 1830.14},
          .utc_seconds = 1066419030.0,
          .north_referenced = true,
          .north_offset_deg = 0};
}

}  // namespace

TEST(SunTracker, ChecksTheMapOnceASecondAndAtOnceAfterALocation) {
  SunTracker sun;
  const auto t0 = SunTracker::Clock::now();
  int reads = 0;
  const capture::SunPosition where = capture::sun_position(golden().where, golden().utc_seconds);
  const glm::dvec3 predicted = capture::sun_direction_world(where);
  // The map's brightest compact light exactly where the sun is, 1000x the mean.
  const auto bright_at_the_sun = [&]() -> std::optional<capture::BrightRegion> {
    ++reads;
    return capture::BrightRegion{predicted, 0.001, 1000.0};
  };
  sun.check(t0, bright_at_the_sun);
  EXPECT_EQ(reads, 0);  // no Location: the map is not read
  EXPECT_EQ(sun.state(), SunState::Unknown);
  EXPECT_EQ(sun.direction(), glm::dvec3(0.0));

  sun.set_location(golden(), t0);
  sun.check(t0, bright_at_the_sun);
  EXPECT_EQ(reads, 1);
  EXPECT_EQ(sun.state(), SunState::Confirmed);
  EXPECT_GT(glm::dot(sun.direction(), predicted), std::cos(1.0 * M_PI / 180.0));

  sun.check(t0 + 999ms, bright_at_the_sun);
  EXPECT_EQ(reads, 1);  // within the second: the last estimate stands
  sun.check(t0 + 1000ms, bright_at_the_sun);
  EXPECT_EQ(reads, 2);

  // A new Location is checked at once, whatever the last check's time.
  sun.set_location(golden(), t0 + 1100ms);
  sun.check(t0 + 1100ms, [&]() -> std::optional<capture::BrightRegion> {
    ++reads;
    return std::nullopt;  // nothing seen that could be the sun
  });
  EXPECT_EQ(reads, 3);
  EXPECT_EQ(sun.state(), SunState::Predicted);  // day, but nothing compact there
}

TEST(SunTracker, ABrightLightWhereTheSunIsNotIsNotTheSun) {
  SunTracker sun;
  const auto t0 = SunTracker::Clock::now();
  sun.set_location(golden(), t0);
  const glm::dvec3 predicted =
      capture::sun_direction_world(capture::sun_position(golden().where, golden().utc_seconds));
  // A lamp straight overhead, 40° off the sun's elevation.
  sun.check(t0, [] {
    return std::optional(capture::BrightRegion{{0.0, 1.0, 0.0}, 0.001, 1000.0});
  });
  EXPECT_EQ(sun.state(), SunState::Predicted);  // day, but nothing compact there
  EXPECT_LT(glm::dot(glm::dvec3(0.0, 1.0, 0.0), predicted), 0.9);
}
