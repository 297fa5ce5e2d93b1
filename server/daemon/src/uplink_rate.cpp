#include "uplink_rate.hpp"

#include <algorithm>
#include <vector>

namespace arlight::daemon {

void UplinkRate::arrived(const wire::Arrival& a, Clock::time_point now) {
  if (a.bytes_after_first < kMinBytes) return;
  samples_.emplace_back(now, double(a.bytes_after_first) / std::max(a.seconds, kMinSeconds));
  if (samples_.size() > kWindow) samples_.pop_front();
}

double UplinkRate::bytes_per_second(Clock::time_point now) {
  while (!samples_.empty() && now - samples_.front().first > kMaxAge) samples_.pop_front();
  if (samples_.empty()) return 0.0;
  std::vector<double> s;
  for (const auto& [when, rate] : samples_) s.push_back(rate);
  const auto upper = s.begin() + std::ptrdiff_t(s.size() / 2);
  std::nth_element(s.begin(), upper, s.end());
  if (s.size() % 2 == 1) return *upper;
  return (*upper + *std::max_element(s.begin(), upper)) / 2;  // the two middle ones' mean
}

std::uint32_t UplinkRate::frame_bytes(Clock::time_point now) {
  const double bytes = bytes_per_second(now) * kFrameSeconds;
  return bytes > kNoLimitBytes ? 0u : std::uint32_t(bytes);
}

}  // namespace arlight::daemon
