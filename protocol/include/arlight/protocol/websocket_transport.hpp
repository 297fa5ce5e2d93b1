// The WebSocket transport (Boost.Beast): one binary WebSocket message per Envelope, no length
// header (the WebSocket frames carry the length), permessage-deflate accepted from browsers. It is
// a MessageStream Transport like TCP and TLS, so a browser on arlightd's /ws endpoint gets the
// same handshake, limits, back-pressure and sessions as a native client.
//
// Reads are bounded by the limit as the payload arrives (and after inflation), so neither an
// oversized message nor a deflate bomb is ever held whole; such a message, a text message or an
// empty one is refused like a bad length header on TCP: the stream stays open for the Error the
// server answers with. close() sends a WebSocket close frame before the socket goes.
#pragma once

#include <boost/beast/core/tcp_stream.hpp>
#include <boost/beast/http/message.hpp>
#include <boost/beast/http/string_body.hpp>
#include <boost/beast/ssl/ssl_stream.hpp>
#include <boost/beast/websocket/stream.hpp>
#include <memory>

#include "arlight/protocol/message_stream.hpp"

namespace arlight::wire {

using WebSocket = boost::beast::websocket::stream<boost::beast::tcp_stream>;
using SecureWebSocket =
    boost::beast::websocket::stream<boost::beast::ssl_stream<boost::beast::tcp_stream>>;
using UpgradeRequest = boost::beast::http::request<boost::beast::http::string_body>;

// Server side: async_start answers `upgrade` (an HTTP request that is a WebSocket upgrade, read
// by the web listener, TLS done) with 101 Switching Protocols.
std::unique_ptr<Transport> make_websocket_transport(SecureWebSocket ws, UpgradeRequest upgrade);
std::unique_ptr<Transport> make_websocket_transport(WebSocket ws, UpgradeRequest upgrade);
// Client side: the WebSocket handshake is done.
std::unique_ptr<Transport> make_websocket_transport(SecureWebSocket ws);
std::unique_ptr<Transport> make_websocket_transport(WebSocket ws);

// The options both sides set before their handshake: permessage-deflate (the server accepts it,
// a native client does not offer it), timeouts for the
// opening and closing handshakes (no idle timeout: the daemon's sessions have their own), no
// message size limit of Beast's own (the transport bounds each read itself).
void configure_websocket(WebSocket& ws, bool server);
void configure_websocket(SecureWebSocket& ws, bool server);

}  // namespace arlight::wire
