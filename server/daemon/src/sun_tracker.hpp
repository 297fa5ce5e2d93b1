// A session's sun (issue 17; dissertation §5.3.3): the client's place and time, and the sun as
// last checked against the captured map — at most once a second (the sun moves 0.004 degrees a
// second), and at once after a new Location. No locks of its own: the Session calls it under
// its mutex. Tested on its own (tests/daemon/test_sun_tracker.cpp).
#pragma once

#include <chrono>
#include <functional>
#include <optional>

#include "arlight/capture/sun.hpp"
#include "arlight/protocol/wire.hpp"

namespace arlight::daemon {

class SunTracker {
 public:
  using Clock = std::chrono::steady_clock;
  static constexpr Clock::duration kCheckEvery = std::chrono::seconds(1);

  // Where and when the client is; the next check() re-estimates the sun at once.
  void set_location(const wire::Location& location, Clock::time_point received);
  bool located() const { return location_.has_value(); }

  // When a check is due: the sun where place and time (the client's clock, moved on by the
  // time since its Location came) put it, confirmed or not by the map's brightest compact light
  // (`brightest`, asked only then: it reads the measured map). Does nothing before a Location.
  void check(Clock::time_point now,
             const std::function<std::optional<capture::BrightRegion>()>& brightest);

  // Unknown before a Location; Confirmed: `direction()` is the sun's, exact where the SH's
  // bands 0-1 smear it with the sky.
  SunState state() const { return location_ ? estimate_.state : SunState::Unknown; }
  glm::dvec3 direction() const { return location_ ? estimate_.direction : glm::dvec3(0.0); }

 private:
  std::optional<wire::Location> location_;
  Clock::time_point received_{};
  std::optional<Clock::time_point> checked_;  // none: due at once
  capture::SunEstimate estimate_;
};

}  // namespace arlight::daemon
