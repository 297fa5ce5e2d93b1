#include "sun_tracker.hpp"

namespace arlight::daemon {

void SunTracker::set_location(const wire::Location& location, Clock::time_point received) {
  location_ = location;
  received_ = received;
  checked_.reset();
}

void SunTracker::check(Clock::time_point now,
                       const std::function<std::optional<capture::BrightRegion>()>& brightest) {
  if (!location_ || (checked_ && now - *checked_ < kCheckEvery)) return;
  checked_ = now;
  const double utc =
      location_->utc_seconds + std::chrono::duration<double>(now - received_).count();
  // A sun prior for the dominant light: the map's brightest compact light, if it is where place
  // and time put the sun. Only what was measured counts (not the fill).
  estimate_ = capture::estimate_sun(capture::sun_position(location_->where, utc), brightest(),
                                    location_->north_referenced, location_->north_offset_deg);
}

}  // namespace arlight::daemon
