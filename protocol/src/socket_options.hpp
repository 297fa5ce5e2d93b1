// The socket options of every protocol connection (TCP, TLS, WebSocket; both ends).
#pragma once

#include <netinet/in.h>
#include <netinet/tcp.h>

#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/socket_base.hpp>

namespace arlight::wire {

// At most this many bytes written to a connection but not yet sent by the kernel
// (TCP_NOTSENT_LOWAT). What the kernel holds is sent in order: on a slow link a send buffer
// grown to megabytes would keep a LightingUpdate behind seconds of map tiles. Bounded, the
// rest waits in the MessageStream's queues, where the update goes first (issue 36 §1).
inline constexpr int kUnsentBytes = 32 * 1024;

// No Nagle delay (a LightingUpdate goes at once) and the bound above. Failures are ignored:
// both are about timing, not correctness.
template <class Socket>  // a tcp::socket, or an ssl::stream's lowest layer
void configure_socket(Socket& socket) {
  boost::system::error_code ec;
  socket.set_option(boost::asio::ip::tcp::no_delay(true), ec);
  socket.set_option(
      boost::asio::detail::socket_option::integer<IPPROTO_TCP, TCP_NOTSENT_LOWAT>(kUnsentBytes),
      ec);
}

}  // namespace arlight::wire
