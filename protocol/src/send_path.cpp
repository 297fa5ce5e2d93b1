#include "send_path.hpp"

// linux/tcp.h's tcp_info has the rate and minimum RTT fields glibc's netinet/tcp.h lacks; the
// two headers cannot meet in one file.
#include <linux/sockios.h>
#include <netinet/in.h>
#include <linux/tcp.h>
#include <sys/ioctl.h>
#include <sys/socket.h>

#include <algorithm>
#include <cstddef>

namespace arlight::wire {

std::optional<SendPath> send_path(int socket) {
  if (socket < 0) return std::nullopt;
  int queued = 0;
  tcp_info info{};
  socklen_t length = sizeof(info);
  if (ioctl(socket, SIOCOUTQ, &queued) != 0 || queued < 0 ||
      getsockopt(socket, IPPROTO_TCP, TCP_INFO, &info, &length) != 0 ||
      length < offsetof(tcp_info, tcpi_delivery_rate) + sizeof(info.tcpi_delivery_rate))
    return std::nullopt;
  return SendPath{std::size_t(queued), double(info.tcpi_delivery_rate),
                  double(info.tcpi_min_rtt) * 1e-6};
}

std::size_t bulk_in_flight_limit(const SendPath& path) {
  const double bytes = path.delivery_rate * (path.min_rtt + kBulkQueueSeconds);
  return std::max(kMinBulkInFlight, std::size_t(std::min(bytes, 1e12)));
}

}  // namespace arlight::wire
