// MessageStream: wire messages over a byte stream, the one implementation both arlightd and the
// protocol client use. A Transport carries whole Envelopes and owns the framing: plain TCP and
// TLS frame each as a 4-byte length then the bytes (the length checked against the limit before
// anything is allocated); a WebSocket transport carries one binary message per Envelope and
// plugs in beside them. MessageStream adds what every connection needs on top: one read loop
// that decodes and verifies every message, a write queue with a byte bound, orderly and abrupt
// closing. Everything runs on the transport's strand; send() and close() may be called from any
// thread.
#pragma once

#include <atomic>
#include <chrono>
#include <boost/asio/any_io_executor.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/asio/ssl/stream.hpp>
#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "arlight/protocol/arrival.hpp"
#include "arlight/protocol/wire.hpp"

namespace arlight::wire {

// One way of carrying Envelopes. Completion handlers run on executor() (a strand); MessageStream
// never has two reads or two writes outstanding.
class Transport {
 public:
  virtual ~Transport() = default;
  using Done = std::function<void(const boost::system::error_code&)>;
  // `refused` is set (and ec clear) when the framing announced a message that cannot be
  // accepted (over max_bytes, empty).
  using ReadDone =
      std::function<void(const boost::system::error_code& ec, const DecodeError* refused)>;

  virtual boost::asio::any_io_executor executor() = 0;
  // Whatever must happen before the first message (a TLS server handshake); may complete at once.
  virtual void async_start(Done done) = 0;
  virtual void async_read(std::vector<std::uint8_t>& envelope, std::uint32_t max_bytes,
                          ReadDone done) = 0;
  // How the message the last async_read completed arrived.
  virtual Arrival last_arrival() const = 0;
  // `bytes` stay alive until `done` runs. Unframed: written as they are, header and all (tests
  // of what a misbehaving peer can send).
  virtual void async_write(std::span<const std::uint8_t> bytes, bool framed, Done done) = 0;
  virtual void close() = 0;              // ends the connection at once (no TLS close_notify)
  // The TCP socket underneath (the kernel's view of the path: send_path.hpp); -1: none.
  virtual int native_socket() { return -1; }
  virtual std::string peer() const = 0;  // "address:port"
};

using TlsSocket = boost::asio::ssl::stream<boost::asio::ip::tcp::socket>;
enum class TlsRole { AcceptAsServer, Established };

std::unique_ptr<Transport> make_tcp_transport(boost::asio::ip::tcp::socket socket);
// AcceptAsServer: async_start runs the server handshake. Established: the caller has done it.
std::unique_ptr<Transport> make_tls_transport(TlsSocket stream, TlsRole role);

class MessageStream : public std::enable_shared_from_this<MessageStream> {
 public:
  struct Options {
    WireLimits limits;                 // what a received message may be
    std::size_t max_queued_bytes = 0;  // over this, on_overflow; 0: no bound here
  };
  // Called on the strand. After on_bad_message reading has stopped: the handler closes.
  struct Handlers {
    std::function<void(Message&&)> on_message;
    std::function<void(const DecodeError&)> on_bad_message;
    std::function<void(const std::string& why)> on_start_failed;  // e.g. the TLS handshake
    // The connection ended (peer gone, I/O error, close()); called once, after which the
    // stream lets go of the handlers.
    std::function<void(const std::string& why)> on_closed;
    // The send queue went over max_queued_bytes: everything not yet being written was dropped.
    std::function<void()> on_overflow;
    std::function<void(std::size_t bytes)> on_sent;  // one message written
  };

  MessageStream(std::unique_ptr<Transport> transport, Options options);
  ~MessageStream();
  MessageStream(const MessageStream&) = delete;
  MessageStream& operator=(const MessageStream&) = delete;

  void start(Handlers handlers);

  // Any thread. Messages are written in the order sent; after the end they are dropped.
  void send(std::vector<std::uint8_t> envelope);
  void send(const Message& message) { send(encode(message)); }
  // The same bytes to several streams (a session's watchers) without a copy each.
  void send(std::shared_ptr<const std::vector<std::uint8_t>> envelope);
  // Bulk data (a map set's tiles, progress and completion): written only while no other message
  // waits, and replaced while it waits by a newer `group` of the same `lane` (a newer map set of
  // the same kind), which drops the older groups not begun yet. A group whose writing has begun
  // is finished: on a link slower than the groups come, dropping it too would leave the client
  // with halves of sets and never a whole one (issue 36 §3).
  void send_bulk(std::shared_ptr<const std::vector<std::uint8_t>> envelope, std::uint32_t lane,
                 std::uint64_t group);
  // Any thread: bytes onto the connection as they are, bypassing the framing (tests only).
  void send_unframed(std::vector<std::uint8_t> bytes);
  // Any thread: read nothing more, close once everything queued is written.
  void close_after_sending();
  // Any thread: close now.
  void close();

  std::size_t queued_bytes() const { return queued_bytes_.load(); }
  // The messages read so far, in bytes (each Envelope and its 4-byte length).
  std::uint64_t bytes_received() const { return bytes_received_.load(); }
  // In on_message (on the strand): how the message being handled arrived.
  Arrival last_arrival() const { return transport_->last_arrival(); }
  // Any thread but the stream's own: the newest group of `lane` whose writing has begun, after
  // every message sent before this call was queued (so a group sent before it and not begun
  // yet will be replaced by the next group sent). 0 when none began; nullopt when the stream
  // has ended or did not answer within `timeout`. A group begun is written whole, so the peer
  // will have it (issue 36 §2: the set a map set's change is sent against).
  std::optional<std::uint64_t> bulk_begun(std::uint32_t lane, std::chrono::milliseconds timeout);
  // Bulk messages dropped unwritten because a newer group of their lane came (send_bulk).
  std::uint64_t bulk_replaced() const { return bulk_replaced_.load(); }
  const std::string& peer() const { return peer_; }
  boost::asio::any_io_executor executor() const { return executor_; }

 private:
  struct Outgoing {
    std::shared_ptr<const std::vector<std::uint8_t>> bytes;
    bool framed = true;
    bool bulk = false;  // send_bulk's, with its lane and group
    std::uint32_t lane = 0;
    std::uint64_t group = 0;
  };
  void enqueue(Outgoing message);
  void drop_queued();  // on the strand: everything not being written
  void read_next();
  void write_next();
  // Whether bulk data may be written now: the bytes in flight are within the path's bound
  // (send_path.hpp). When not, a timer tries again shortly; control messages go meanwhile.
  bool bulk_has_room();
  void end(const std::string& why);  // on the strand; idempotent

  std::unique_ptr<Transport> transport_;
  Options options_;
  boost::asio::any_io_executor executor_;
  std::string peer_;
  Handlers handlers_;
  std::vector<std::uint8_t> in_;
  std::deque<Outgoing> out_, bulk_;  // control messages first, then bulk ones
  std::optional<Outgoing> writing_;   // the message being written
  boost::asio::steady_timer bulk_retry_;  // bulk waiting for the path to have room
  bool bulk_waiting_ = false;
  std::atomic<std::size_t> queued_bytes_{0};  // of all three
  std::atomic<std::uint64_t> bulk_replaced_{0};
  std::atomic<std::uint64_t> bytes_received_{0};
  std::map<std::uint32_t, std::uint64_t> begun_;  // the newest group begun of each lane
  bool closing_ = false, ended_ = false;
};

}  // namespace arlight::wire
