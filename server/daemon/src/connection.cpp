#include "connection.hpp"

#include <boost/asio/bind_executor.hpp>
#include <boost/asio/post.hpp>
#include <boost/asio/read.hpp>
#include <boost/asio/write.hpp>
#include <cmath>

namespace arlight::daemon {

namespace asio = boost::asio;

Connection::Connection(ClientStream stream, const ConnectionEnv& env)
    : stream_(std::move(stream)), strand_(asio::make_strand(socket().get_executor())), env_(env) {
  boost::system::error_code ec;
  const auto ep = socket().remote_endpoint(ec);
  peer_ = ec ? "?" : ep.address().to_string() + ":" + std::to_string(ep.port());
  socket().set_option(asio::ip::tcp::no_delay(true), ec);
}

asio::ip::tcp::socket::lowest_layer_type& Connection::socket() {
  return std::visit(
      [](auto& s) -> asio::ip::tcp::socket::lowest_layer_type& { return s.lowest_layer(); },
      stream_);
}

// Closes the TCP connection under the stream (a TLS peer sees the end of the stream without a
// close_notify: nothing we send after an Error or a Bye needs the truncation protection).
void Connection::shutdown() {
  boost::system::error_code ec;
  socket().shutdown(asio::ip::tcp::socket::shutdown_both, ec);
  socket().close(ec);
}

void Connection::start() {
  asio::post(strand_, [self = shared_from_this()] {
    auto* tls = std::get_if<TlsStream>(&self->stream_);
    if (!tls) return self->read_header();
    tls->async_handshake(
        asio::ssl::stream_base::server,
        asio::bind_executor(self->strand_, [self](boost::system::error_code ec) {
          if (ec) {  // e.g. a plain-TCP client talking to a TLS port
            if (self->env_.log)
              self->env_.log(self->peer_ + ": TLS handshake failed: " + ec.message());
            return self->shutdown();
          }
          self->read_header();
        }));
  });
}

void Connection::close() {
  asio::post(strand_, [self = shared_from_this()] {
    self->shutdown();
    if (self->session_) self->session_->detach();
  });
}

void Connection::read_header() {
  if (closing_) return;
  std::visit(
      [&](auto& stream) {
        asio::async_read(
            stream, asio::buffer(header_),
            asio::bind_executor(
                strand_, [self = shared_from_this()](boost::system::error_code ec, std::size_t) {
                  if (ec) {  // the peer went away: the session stays for a resume
                    if (self->session_) self->session_->detach();
                    return;
                  }
                  std::string why;
                  const auto size = wire::read_header(
                      std::span<const std::uint8_t, wire::kHeaderBytes>(self->header_),
                      self->env_.limits.max_message_bytes, why);
                  if (!size)
                    return self->fail(why.starts_with("message of") ? wire::ErrorCode::TooLarge
                                                                    : wire::ErrorCode::BadMessage,
                                      why);
                  self->read_payload(*size);
                }));
      },
      stream_);
}

void Connection::read_payload(std::uint32_t size) {
  payload_.resize(size);  // bounded by the limit checked in the header
  std::visit(
      [&](auto& stream) {
        asio::async_read(
            stream, asio::buffer(payload_),
            asio::bind_executor(
                strand_, [self = shared_from_this()](boost::system::error_code ec, std::size_t) {
                  if (ec) {
                    if (self->session_) self->session_->detach();
                    return;
                  }
                  std::string why;
                  const wire::Envelope* e = wire::verify_envelope(self->payload_, why);
                  if (!e) return self->fail(wire::ErrorCode::BadMessage, why);
                  self->handle(*e);
                  self->read_header();
                }));
      },
      stream_);
}

void Connection::fail(wire::ErrorCode code, const std::string& message) {
  if (closing_) return;
  if (env_.log) env_.log(peer_ + ": " + message);
  send(wire::make_error(code, message));
  closing_ = true;  // write_next() closes once the Error is out
  if (session_) session_->detach();
}

void Connection::send(std::vector<std::uint8_t> message) {
  asio::post(strand_, [self = shared_from_this(), m = std::move(message)]() mutable {
    if (!self->socket().is_open()) return;
    self->out_bytes_ += m.size();
    self->out_.push_back(std::move(m));
    if (self->out_bytes_ > self->env_.max_send_queue_bytes && !self->closing_) {
      // A client that does not read would make us hold everything we send it. The message
      // being written (the front, while writing_) must stay alive until its write ends.
      const std::size_t keep = self->writing_ ? 1 : 0;
      while (self->out_.size() > keep) {
        self->out_bytes_ -= self->out_.back().size();
        self->out_.pop_back();
      }
      self->fail(wire::ErrorCode::Busy, "client reads too slowly; closing");
      return;
    }
    if (!self->writing_) self->write_next();
  });
}

void Connection::write_next() {
  if (out_.empty()) {
    writing_ = false;
    if (closing_) shutdown();
    return;
  }
  writing_ = true;
  std::visit(
      [&](auto& stream) {
        asio::async_write(
            stream, asio::buffer(out_.front()),
            asio::bind_executor(
                strand_, [self = shared_from_this()](boost::system::error_code ec, std::size_t) {
                  if (ec) {
                    self->out_.clear();
                    self->writing_ = false;
                    if (self->session_) self->session_->detach();
                    return;
                  }
                  self->out_bytes_ -= self->out_.front().size();
                  self->out_.pop_front();
                  self->write_next();
                }));
      },
      stream_);
}

void Connection::handle(const wire::Envelope& e) {
  using M = wire::Message;
  const M type = e.message_type();
  if (!session_ && type != M::Hello && type != M::Ping)
    return fail(wire::ErrorCode::OutOfOrder,
                std::string(wire::message_name(type)) + " before Hello");
  switch (type) {
    case M::Hello:
      if (session_) return fail(wire::ErrorCode::OutOfOrder, "a second Hello");
      return handle_hello(*e.message_as_Hello());
    case M::CameraIntrinsics: {
      const wire::CameraIntrinsics& k = *e.message_as_CameraIntrinsics();
      CameraIntrinsics c;
      c.width = int(std::min<std::uint32_t>(k.width(), 1u << 20));
      c.height = int(std::min<std::uint32_t>(k.height(), 1u << 20));
      c.fx = k.fx(), c.fy = k.fy(), c.cx = k.cx(), c.cy = k.cy();
      if (k.distortion()) {
        if (k.distortion()->size() > 5)
          return fail(wire::ErrorCode::BadMessage,
                      "CameraIntrinsics: more than 5 distortion terms");
        for (flatbuffers::uoffset_t i = 0; i < k.distortion()->size(); ++i)
          c.distortion[i] = k.distortion()->Get(i);
      }
      const bool finite =
          std::isfinite(c.fx) && std::isfinite(c.fy) && std::isfinite(c.cx) && std::isfinite(c.cy);
      if (c.width < 1 || c.height < 1 || !finite || !(c.fx > 0) || !(c.fy > 0) ||
          std::uint64_t(c.width) * std::uint64_t(c.height) > env_.limits.max_frame_pixels)
        return fail(wire::ErrorCode::BadMessage,
                    "CameraIntrinsics: size or focal lengths out of range");
      const std::string why = session_->set_camera(c);
      if (!why.empty()) return fail(wire::ErrorCode::BadMessage, "CameraIntrinsics: " + why);
      return;
    }
    case M::CameraFrame:
      return handle_frame(*e.message_as_CameraFrame());
    case M::RequestMaps: {
      const wire::RequestMaps& r = *e.message_as_RequestMaps();
      MapRequest req;
      if (r.shininess())
        for (float s : *r.shininess()) req.shininess.push_back(s);
      req.size = int(std::min<std::uint32_t>(r.size(), 1u << 16));
      if (int(r.projection()) < 0 || int(r.projection()) > 2)
        return fail(wire::ErrorCode::Unsupported, "RequestMaps: unknown projection");
      req.projection = Projection(int(r.projection()));
      req.method = r.method() ? r.method()->str() : "auto";
      const std::string why = session_->request_maps(std::move(req));
      if (!why.empty()) return fail(wire::ErrorCode::BadMessage, why);
      return;
    }
    case M::CalibrationSet: {
      const wire::CalibrationSet& set = *e.message_as_CalibrationSet();
      const auto* frames = set.frames();
      if (!frames || frames->size() < 2 || frames->size() > 16)
        return fail(wire::ErrorCode::BadMessage, "CalibrationSet: 2 to 16 frames");
      std::vector<std::vector<std::uint8_t>> jpegs;
      std::vector<double> times;
      for (flatbuffers::uoffset_t i = 0; i < frames->size(); ++i) {
        const wire::CameraFrame* f = frames->Get(i);
        const double t = f->exposure() * f->gain();
        const std::uint64_t pixels = std::uint64_t(f->width()) * f->height();
        if (!f->data() || f->data()->size() == 0 || f->format() != wire::PixelFormat::Jpeg ||
            pixels == 0 || pixels > env_.limits.max_frame_pixels || !std::isfinite(t) || !(t > 0.0))
          return fail(wire::ErrorCode::BadMessage,
                      "CalibrationSet: frame " + std::to_string(i) +
                          " needs JPEG data, a size within the limits and exposure x gain > 0");
        jpegs.emplace_back(f->data()->begin(), f->data()->end());
        times.push_back(t);
      }
      session_->calibrate(std::move(jpegs), std::move(times),
                          set.method() ? set.method()->str() : "robertson");
      return;
    }
    case M::Ping:
      return send(wire::make_pong(e.message_as_Ping()->nonce()));
    case M::Bye:
      try {
        session_->checkpoint();
      } catch (const std::exception& ex) {  // still in memory; the next checkpoint retries
        if (env_.log) env_.log(peer_ + ": checkpoint at Bye failed: " + ex.what());
      }
      closing_ = true;
      session_->detach();
      if (!writing_) write_next();
      return;
    default:
      return fail(wire::ErrorCode::OutOfOrder,
                  std::string(wire::message_name(type)) + " is a server-to-client message");
  }
}

void Connection::handle_hello(const wire::Hello& m) {
  if (m.protocol_version() != wire::kProtocolVersion)
    return fail(wire::ErrorCode::Unsupported, "protocol version " +
                                                  std::to_string(m.protocol_version()) +
                                                  " is not supported (this server speaks " +
                                                  std::to_string(wire::kProtocolVersion) + ")");
  wire::ErrorCode code = wire::ErrorCode::Unknown;
  std::string why;
  session_ = env_.open_session(m, code, why);
  if (!session_) return fail(code, why);
  const bool resumed = m.resume_session() && m.resume_session()->size() > 0;
  std::weak_ptr<Connection> weak = weak_from_this();
  session_->attach([weak](std::vector<std::uint8_t> message) {
    if (auto self = weak.lock()) self->send(std::move(message));
  });
  flatbuffers::FlatBufferBuilder b(256);
  const auto limits =
      wire::CreateLimits(b, env_.limits.max_message_bytes, env_.limits.max_frame_pixels,
                         env_.limits.max_map_size, env_.limits.max_maps);
  const auto welcome =
      wire::CreateWelcome(b, b.CreateString(session_->id()), b.CreateString(env_.server_version),
                          resumed, session_->frames_processed(), limits);
  b.Finish(wire::CreateEnvelope(b, wire::Message::Welcome, welcome.Union()),
           wire::EnvelopeIdentifier());
  send(wire::frame_message(b));
}

void Connection::handle_frame(const wire::CameraFrame& m) {
  if (!session_->has_camera())
    return fail(wire::ErrorCode::OutOfOrder, "CameraFrame before CameraIntrinsics");
  if (!m.data() || m.data()->size() == 0)
    return fail(wire::ErrorCode::BadMessage,
                "CameraFrame " + std::to_string(m.sequence()) + ": no image data");
  const std::uint64_t pixels = std::uint64_t(m.width()) * m.height();
  if (pixels == 0 || pixels > env_.limits.max_frame_pixels)
    return fail(wire::ErrorCode::TooLarge, "CameraFrame " + std::to_string(m.sequence()) + ": " +
                                               std::to_string(m.width()) + "x" +
                                               std::to_string(m.height()) + " pixels");
  if (m.format() == wire::PixelFormat::Rgb8 && m.data()->size() != pixels * 3)
    return fail(wire::ErrorCode::BadMessage, "CameraFrame " + std::to_string(m.sequence()) +
                                                 ": RGB8 data of " +
                                                 std::to_string(m.data()->size()) + " bytes for " +
                                                 std::to_string(pixels) + " pixels");
  if (m.format() != wire::PixelFormat::Jpeg && m.format() != wire::PixelFormat::Rgb8)
    return fail(wire::ErrorCode::Unsupported, "CameraFrame: unknown pixel format");
  FrameJob job;
  job.sequence = m.sequence();
  job.info.timestamp = m.timestamp();
  job.info.exposure = m.exposure();
  job.info.gain = m.gain();
  if (const wire::Quat* q = m.orientation())
    job.info.orientation = glm::dquat(q->w(), q->x(), q->y(), q->z());
  else
    job.info.orientation = glm::dquat(0, 0, 0, 0);  // the capture library refuses it with a reason
  job.format = m.format();
  job.width = int(m.width()), job.height = int(m.height());
  job.data.assign(m.data()->begin(), m.data()->end());
  job.received = Clock::now();
  session_->submit(std::move(job));
}

}  // namespace arlight::daemon
