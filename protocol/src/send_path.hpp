// What the kernel knows of a connection's way out (issue 36 §1/§3): how much it holds unacknowledged
// and its estimate of the path. A map set's tiles are written only while the bytes in flight stay
// within the path's bandwidth-delay product plus a little queue at its bottleneck: otherwise TCP
// fills the narrowest link's buffer with tiles (a 5 Mbit/s link: frame -> update p99 0.67 s with
// maps against 66 ms without, bench/RESULTS.md), and every LightingUpdate waits behind them.
#pragma once

#include <cstddef>
#include <optional>

namespace arlight::wire {

struct SendPath {
  std::size_t unacked = 0;   // written and not acknowledged yet, sent or not (SIOCOUTQ)
  double delivery_rate = 0;  // bytes a second, the kernel's newest sample (0: none yet)
  double min_rtt = 0;        // seconds
};

// A TCP socket's; nullopt for anything else (or a kernel that does not say).
std::optional<SendPath> send_path(int socket);

// Bulk data may go while `unacked` is at most this: delivery_rate x (min_rtt + kBulkQueueSeconds),
// and never less than kMinBulkInFlight (the first tiles, before the kernel has a sample). On
// loopback the rate is gigabytes a second: no bound in practice.
inline constexpr double kBulkQueueSeconds = 0.04;
inline constexpr std::size_t kMinBulkInFlight = 16 * 1024;
std::size_t bulk_in_flight_limit(const SendPath& path);

}  // namespace arlight::wire
