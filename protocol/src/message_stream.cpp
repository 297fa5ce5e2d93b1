#include "arlight/protocol/message_stream.hpp"

#include <boost/asio/bind_executor.hpp>
#include <boost/asio/post.hpp>
#include <boost/asio/read.hpp>
#include <boost/asio/ssl.hpp>
#include <boost/asio/strand.hpp>
#include <boost/asio/write.hpp>
#include <future>
#include <variant>

#include "arrival_timer.hpp"
#include "send_path.hpp"
#include "socket_options.hpp"

namespace arlight::wire {

namespace asio = boost::asio;
using asio::ip::tcp;

namespace {

// TCP and TLS: each Envelope behind a 4-byte little-endian length (wire::frame_header).
template <class Stream>
class FramedTransport final : public Transport {
 public:
  FramedTransport(Stream stream, bool server_handshake)
      : stream_(std::move(stream)),
        strand_(asio::make_strand(stream_.lowest_layer().get_executor())),
        server_handshake_(server_handshake) {
    boost::system::error_code ec;
    const auto ep = stream_.lowest_layer().remote_endpoint(ec);
    peer_ = ec ? "?" : ep.address().to_string() + ":" + std::to_string(ep.port());
    configure_socket(stream_.lowest_layer());
    if constexpr (kTls) time_tls_reads(stream_.native_handle(), &arrival_);
  }
  ~FramedTransport() override {
    if constexpr (kTls) time_tls_reads(stream_.native_handle(), nullptr);
  }

  asio::any_io_executor executor() override { return strand_; }
  std::string peer() const override { return peer_; }
  int native_socket() override { return stream_.lowest_layer().native_handle(); }

  void async_start(Done done) override {
    if constexpr (std::is_same_v<Stream, TlsSocket>) {
      if (server_handshake_)
        return stream_.async_handshake(asio::ssl::stream_base::server,
                                       asio::bind_executor(strand_, std::move(done)));
    }
    asio::post(strand_, [done = std::move(done)] { done({}); });
  }

  void async_read(std::vector<std::uint8_t>& envelope, std::uint32_t max_bytes,
                  ReadDone done) override {
    if constexpr (kTls) arrival_.start();  // the header's record is the first read beneath
    asio::async_read(
        stream_, asio::buffer(header_),
        asio::bind_executor(strand_, [this, &envelope, max_bytes, done = std::move(done)](
                                         boost::system::error_code ec, std::size_t) mutable {
          if (ec) return done(ec, nullptr);
          std::uint32_t size = 0;
          try {
            size = read_header(header_, max_bytes);
          } catch (const DecodeError& e) {
            return done({}, &e);
          }
          envelope.resize(size);  // bounded by the limit checked in the header
          if constexpr (!kTls) arrival_.start();
          read_body(envelope, 0, std::move(done));
        }));
  }

  Arrival last_arrival() const override { return arrival_.arrival(); }

  void async_write(std::span<const std::uint8_t> bytes, bool framed, Done done) override {
    out_header_ = frame_header(bytes.size());
    const std::array<asio::const_buffer, 2> buffers{
        asio::buffer(out_header_, framed ? kHeaderBytes : 0),
        asio::buffer(bytes.data(), bytes.size())};
    asio::async_write(
        stream_, buffers,
        asio::bind_executor(strand_, [done = std::move(done)](boost::system::error_code ec,
                                                              std::size_t) { done(ec); }));
  }

  void close() override {
    boost::system::error_code ec;
    stream_.lowest_layer().shutdown(tcp::socket::shutdown_both, ec);
    stream_.lowest_layer().close(ec);
  }

 private:
  static constexpr bool kTls = std::is_same_v<Stream, TlsSocket>;

  // The Envelope after `have` of its bytes, a read at a time (each timed: ArrivalTimer; the
  // header's read is not, as the bytes behind it had arrived with it; over TLS the reads
  // beneath are timed instead).
  void read_body(std::vector<std::uint8_t>& envelope, std::size_t have, ReadDone done) {
    stream_.async_read_some(
        asio::buffer(envelope.data() + have, envelope.size() - have),
        asio::bind_executor(strand_, [this, &envelope, have, done = std::move(done)](
                                         boost::system::error_code ec, std::size_t n) mutable {
          if (ec) return done(ec, nullptr);
          if constexpr (!kTls) arrival_.read(n);
          if (have + n < envelope.size()) return read_body(envelope, have + n, std::move(done));
          arrival_.stop();
          done({}, nullptr);
        }));
  }

  Stream stream_;
  asio::strand<asio::any_io_executor> strand_;
  bool server_handshake_;
  std::string peer_;
  std::array<std::uint8_t, kHeaderBytes> header_{}, out_header_{};
  ArrivalTimer arrival_;
};

}  // namespace

std::unique_ptr<Transport> make_tcp_transport(tcp::socket socket) {
  return std::make_unique<FramedTransport<tcp::socket>>(std::move(socket), false);
}

std::unique_ptr<Transport> make_tls_transport(TlsSocket stream, TlsRole role) {
  return std::make_unique<FramedTransport<TlsSocket>>(std::move(stream),
                                                      role == TlsRole::AcceptAsServer);
}

MessageStream::MessageStream(std::unique_ptr<Transport> transport, Options options)
    : transport_(std::move(transport)),
      options_(options),
      executor_(transport_->executor()),
      peer_(transport_->peer()),
      bulk_retry_(executor_) {}

MessageStream::~MessageStream() = default;

void MessageStream::start(Handlers handlers) {
  asio::post(executor_, [self = shared_from_this(), h = std::move(handlers)]() mutable {
    self->handlers_ = std::move(h);
    self->transport_->async_start([self](const boost::system::error_code& ec) {
      if (ec) {
        if (self->handlers_.on_start_failed) self->handlers_.on_start_failed(ec.message());
        return self->end("handshake failed: " + ec.message());
      }
      self->read_next();
    });
  });
}

void MessageStream::read_next() {
  if (closing_ || ended_) return;
  transport_->async_read(
      in_, options_.limits.max_message_bytes,
      [self = shared_from_this()](const boost::system::error_code& ec, const DecodeError* refused) {
        if (self->ended_) return;
        if (ec) return self->end("connection closed: " + ec.message());
        if (refused) {
          if (self->handlers_.on_bad_message) self->handlers_.on_bad_message(*refused);
          return;
        }
        self->bytes_received_ += self->in_.size() + 4;  // the Envelope and its length
        std::optional<Message> message;
        try {
          message = decode(self->in_, self->options_.limits);
        } catch (const DecodeError& e) {
          if (self->handlers_.on_bad_message) self->handlers_.on_bad_message(e);
          return;
        }
        if (self->handlers_.on_message) self->handlers_.on_message(std::move(*message));
        self->read_next();
      });
}

void MessageStream::send(std::vector<std::uint8_t> envelope) {
  send(std::make_shared<const std::vector<std::uint8_t>>(std::move(envelope)));
}

void MessageStream::send(std::shared_ptr<const std::vector<std::uint8_t>> envelope) {
  enqueue({std::move(envelope), true});
}

void MessageStream::send_bulk(std::shared_ptr<const std::vector<std::uint8_t>> envelope,
                              std::uint32_t lane, std::uint64_t group) {
  enqueue({std::move(envelope), true, true, lane, group});
}

void MessageStream::send_unframed(std::vector<std::uint8_t> bytes) {
  enqueue({std::make_shared<const std::vector<std::uint8_t>>(std::move(bytes)), false});
}

void MessageStream::enqueue(Outgoing message) {
  queued_bytes_ += message.bytes->size();
  asio::post(executor_, [self = shared_from_this(), m = std::move(message)]() mutable {
    if (self->ended_) {
      self->queued_bytes_ -= m.bytes->size();
      return;
    }
    if (m.bulk) {
      // A newer group of the lane (a newer map set) replaces the older ones still waiting whole:
      // a client that reads slowly gets the newest set, not a queue of stale ones; the one
      // being written is finished first.
      const auto begun = self->begun_.find(m.lane);
      const auto stale = [&](const Outgoing& o) {
        return o.lane == m.lane && o.group < m.group &&
               !(begun != self->begun_.end() && begun->second == o.group);
      };
      for (const Outgoing& o : self->bulk_)
        if (stale(o)) self->queued_bytes_ -= o.bytes->size(), ++self->bulk_replaced_;
      std::erase_if(self->bulk_, stale);
      self->bulk_.push_back(std::move(m));
    } else {
      self->out_.push_back(std::move(m));
    }
    if (self->options_.max_queued_bytes && self->queued_bytes_ > self->options_.max_queued_bytes &&
        !self->closing_) {
      // A peer that does not read would make us hold everything we send it (the message being
      // written stays alive in writing_ until its write ends).
      self->drop_queued();
      if (self->handlers_.on_overflow) self->handlers_.on_overflow();
    }
    if (!self->writing_) self->write_next();
  });
}

std::optional<std::uint64_t> MessageStream::bulk_begun(std::uint32_t lane,
                                                       std::chrono::milliseconds timeout) {
  // Posted behind the messages sent before it (the executor is a strand: in order), so what it
  // reads counts their replacements.
  auto answer = std::make_shared<std::promise<std::optional<std::uint64_t>>>();
  auto result = answer->get_future();
  asio::post(executor_, [self = shared_from_this(), lane, answer] {
    if (self->ended_) return answer->set_value(std::nullopt);
    const auto it = self->begun_.find(lane);
    answer->set_value(it == self->begun_.end() ? 0 : it->second);
  });
  if (result.wait_for(timeout) != std::future_status::ready) return std::nullopt;
  try {
    return result.get();
  } catch (const std::future_error&) {  // the executor was destroyed with the post in it
    return std::nullopt;
  }
}

bool MessageStream::bulk_has_room() {
  const auto path = send_path(transport_->native_socket());
  return !path || path->unacked <= bulk_in_flight_limit(*path);
}

void MessageStream::drop_queued() {
  for (const auto* q : {&out_, &bulk_})
    for (const Outgoing& o : *q) queued_bytes_ -= o.bytes->size();
  out_.clear();
  bulk_.clear();
}

// Control messages first (a LightingUpdate never waits behind a map set's tiles); bulk ones
// when none waits, one at a time, so a control message waits for at most one tile.
void MessageStream::write_next() {
  std::deque<Outgoing>& q = out_.empty() ? bulk_ : out_;
  if (q.empty()) {
    writing_.reset();
    if (closing_) end("closed after sending");
    return;
  }
  if (&q == &bulk_ && !closing_ && !bulk_has_room()) {
    writing_.reset();  // a control message sent meanwhile is written at once
    if (bulk_waiting_) return;
    bulk_waiting_ = true;
    bulk_retry_.expires_after(std::chrono::milliseconds(5));
    bulk_retry_.async_wait([self = shared_from_this()](const boost::system::error_code& ec) {
      self->bulk_waiting_ = false;
      if (!ec && !self->ended_ && !self->writing_) self->write_next();
    });
    return;
  }
  writing_ = std::move(q.front());
  q.pop_front();
  if (writing_->bulk) begun_[writing_->lane] = writing_->group;
  transport_->async_write(*writing_->bytes, writing_->framed,
                          [self = shared_from_this()](const boost::system::error_code& ec) {
                            const std::size_t n = self->writing_->bytes->size();
                            self->queued_bytes_ -= n;
                            self->writing_.reset();
                            if (ec) {
                              self->drop_queued();
                              return self->end("send failed: " + ec.message());
                            }
                            if (self->handlers_.on_sent) self->handlers_.on_sent(n);
                            self->write_next();
                          });
}

void MessageStream::close_after_sending() {
  asio::post(executor_, [self = shared_from_this()] {
    self->closing_ = true;
    if (!self->writing_) self->write_next();
  });
}

void MessageStream::close() {
  asio::post(executor_, [self = shared_from_this()] { self->end("closed"); });
}

void MessageStream::end(const std::string& why) {
  if (ended_) return;
  ended_ = true;
  bulk_retry_.cancel();
  transport_->close();  // pending reads and writes complete with an error
  // The handlers usually hold their owner, which holds this stream: let go of them here.
  Handlers h = std::move(handlers_);
  handlers_ = {};
  if (h.on_closed) h.on_closed(why);
}

}  // namespace arlight::wire
