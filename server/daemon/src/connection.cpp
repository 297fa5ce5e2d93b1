#include "connection.hpp"

#include <boost/asio/post.hpp>
#include <cmath>

namespace arlight::daemon {

namespace asio = boost::asio;

namespace {

using Clock = std::chrono::steady_clock;

Clock::duration to_clock(std::chrono::duration<double> d) {
  return std::chrono::duration_cast<Clock::duration>(d);
}

// A session's message onto a client's queue: a map set's as bulk data (issue 36 §1), which waits
// behind every other message and gives way to the next set.
void send_on(wire::MessageStream& stream, EncodedMessage envelope, std::optional<BulkGroup> bulk) {
  if (bulk) return stream.send_bulk(std::move(envelope), bulk->lane, bulk->group);
  stream.send(std::move(envelope));
}

}  // namespace

std::string peer_address(const std::string& peer) {
  const auto colon = peer.rfind(':');
  return colon == std::string::npos ? peer : peer.substr(0, colon);
}

ClientConnection::ClientConnection(std::unique_ptr<wire::Transport> transport, const ConnectionEnv& env)
    : stream_(std::make_shared<wire::MessageStream>(
          std::move(transport),
          wire::MessageStream::Options{env.limits, env.max_send_queue_bytes})),
      env_(env),
      address_(peer_address(stream_->peer())),
      deadline_(stream_->executor()) {}

// The stream's handlers hold this connection until the stream ends (MessageStream lets go of
// them then); the session only holds it weakly, through its sink.
void ClientConnection::start() {
  auto self = shared_from_this();
  wire::MessageStream::Handlers h;
  h.on_message = [self](wire::Message&& m) { self->handle(std::move(m)); };
  h.on_bad_message = [self](const wire::DecodeError& e) { self->fail(e.code(), e.what()); };
  h.on_start_failed = [self](const std::string& why) {
    // e.g. a plain-TCP client talking to a TLS port
    if (self->env_.log) self->env_.log(self->stream_->peer() + ": TLS handshake failed: " + why);
  };
  h.on_closed = [self](const std::string&) {
    self->deadline_.cancel();
    self->detach();
  };
  h.on_sent = [self](std::size_t) {
    if (self->watcher_) self->session_->watcher_drained(self->watcher_);
  };
  h.on_overflow = [self] {
    // A client that does not read would make us hold everything we send it.
    self->fail(wire::ErrorCode::Busy, "client reads too slowly; closing");
  };
  stream_->start(std::move(h));
  asio::post(stream_->executor(), [self] { self->arm_deadline(to_clock(self->env_.hello_timeout)); });
}

void ClientConnection::arm_deadline(Clock::duration after) {
  deadline_.expires_after(after);
  deadline_.async_wait([self = shared_from_this()](boost::system::error_code ec) {
    if (!ec) self->deadline_passed();
  });
}

void ClientConnection::deadline_passed() {
  if (closing_) return;
  if (!session_) {
    if (env_.hello_timeouts) env_.hello_timeouts->inc();
    return fail(wire::ErrorCode::Timeout, "no Hello within " +
                                              std::to_string(int(env_.hello_timeout.count())) +
                                              " s of connecting");
  }
  const Clock::time_point due = last_message_ + to_clock(env_.idle_timeout);
  if (Clock::now() < due) return arm_deadline(due - Clock::now());
  if (env_.idle_timeouts) env_.idle_timeouts->inc();
  fail(wire::ErrorCode::Timeout, "no message for " +
                                     std::to_string(int(env_.idle_timeout.count())) +
                                     " s; closing (the session stays for a resume)");
}

void ClientConnection::close() {
  asio::post(stream_->executor(), [self = shared_from_this()] {
    self->stream_->close();
    self->detach();
  });
}

void ClientConnection::detach() {
  if (!session_) return;
  if (contributing_) {
    if (contributor_) session_->leave(contributor_);
    contributor_ = 0;
    return;
  }
  if (!watching_) return session_->detach(attachment_);  // the session stays for a resume
  if (watcher_) session_->unwatch(watcher_);
  watcher_ = 0;
}

void ClientConnection::fail(wire::ErrorCode code, const std::string& message,
                            const std::string& address) {
  if (closing_) return;
  // A redirect is the fleet working, not bad input: counted on /metrics, not logged.
  if (env_.log && code != wire::ErrorCode::Moved) env_.log(stream_->peer() + ": " + message);
  stream_->send(wire::Error{code, message, address});
  closing_ = true;
  stream_->close_after_sending();  // once the Error is out
  detach();
}

void ClientConnection::handle(wire::Message&& message) {
  if (closing_) return;
  last_message_ = Clock::now();
  const char* name = wire::message_name(message);
  const bool hello = std::holds_alternative<wire::Hello>(message);
  if (!session_ && !hello && !std::holds_alternative<wire::Ping>(message))
    return fail(wire::ErrorCode::OutOfOrder, std::string(name) + " before Hello");
  if (hello) {
    if (session_) return fail(wire::ErrorCode::OutOfOrder, "a second Hello");
    return handle_hello(std::get<wire::Hello>(message));
  }
  const bool bye = std::holds_alternative<wire::Bye>(message);
  if (watching_ && !bye && !std::holds_alternative<wire::Ping>(message))
    return fail(wire::ErrorCode::Unauthorized,
                std::string(name) + ": this connection watches session " + session_->id() +
                    "; a watcher sends no frames, camera, location or map requests");
  const bool frames = std::holds_alternative<wire::CameraIntrinsicsMessage>(message) ||
                      std::holds_alternative<wire::CameraFrame>(message);
  if (contributing_ && !frames && !bye && !std::holds_alternative<wire::Ping>(message))
    return fail(wire::ErrorCode::Unauthorized,
                std::string(name) + ": this connection contributes to session " +
                    session_->id() + "; a contributor sends its camera and frames only");
  if (auto* k = std::get_if<wire::CameraIntrinsicsMessage>(&message))
    return handle_intrinsics(k->camera);
  if (auto* f = std::get_if<wire::CameraFrame>(&message)) return handle_frame(std::move(*f));
  if (auto* r = std::get_if<wire::RequestMaps>(&message)) {
    MapRequest req;
    req.kind = r->kind;
    req.levels = r->levels;
    req.specular_lights = r->specular_lights;
    req.shininess.assign(r->shininess.begin(), r->shininess.end());
    req.size = int(std::min<std::uint32_t>(r->size, 1u << 16));
    req.projection = r->projection;
    req.method = r->method.empty() ? "auto" : r->method;
    const std::string why = session_->request_maps(std::move(req));
    if (!why.empty()) return fail(wire::ErrorCode::BadMessage, why);
    return;
  }
  if (auto* l = std::get_if<wire::Location>(&message)) return session_->set_location(*l);
  if (std::holds_alternative<wire::RequestJoinToken>(message))
    return stream_->send(wire::JoinToken{session_->id(), session_->new_join_token(),
                                         float(Session::kJoinTokenSeconds)});
  if (auto* c = std::get_if<wire::CalibrationSet>(&message))
    return handle_calibration(std::move(*c));
  if (auto* p = std::get_if<wire::Ping>(&message)) return stream_->send(wire::Pong{p->nonce});
  if (bye) {
    // A failure is logged; the next retries. A contributor's Bye leaves the session as it is.
    if (!watching_ && !contributing_) env_.checkpoint_soon(session_);
    closing_ = true;
    detach();
    stream_->close_after_sending();
    return;
  }
  return fail(wire::ErrorCode::OutOfOrder, std::string(name) + " is a server-to-client message");
}

void ClientConnection::handle_hello(const wire::Hello& m) {
  if (m.protocol_version != wire::kProtocolVersion)
    return fail(wire::ErrorCode::Unsupported, "protocol version " +
                                                  std::to_string(m.protocol_version) +
                                                  " is not supported (this server speaks " +
                                                  std::to_string(wire::kProtocolVersion) + ")");
  wire::ErrorCode code = wire::ErrorCode::Unknown;
  std::string why, address;
  session_ = env_.open_session(m, env_.web, code, why, address);
  if (!session_) return fail(code, why, address);
  if (!m.watch_session.empty()) return watch(m);
  exposure_unknown_ = wire::has_capability(m.capabilities, wire::kCapabilityExposureUnknown);
  if (!m.join_session.empty()) return join(m);
  std::weak_ptr<wire::MessageStream> weak = stream_;
  std::weak_ptr<ClientConnection> weak_self = shared_from_this();
  Session::ClientLink client;
  client.send = [weak](EncodedMessage envelope, std::optional<BulkGroup> bulk) {
    if (auto stream = weak.lock()) send_on(*stream, std::move(envelope), bulk);
  };
  client.tile_coding = wire::choose_tile_coding(m.capabilities);
  client.disconnect = [weak_self] {
    if (auto self = weak_self.lock()) self->close();  // handed over to another daemon
  };
  client.exposure_advice = wire::has_capability(m.capabilities, wire::kCapabilityExposureAdvice);
  if (wire::has_capability(m.capabilities, wire::kCapabilityMapDeltas))
    client.bulk_begun = [weak](std::uint32_t lane) -> std::optional<std::uint64_t> {
      const auto stream = weak.lock();
      if (!stream) return std::nullopt;
      return stream->bulk_begun(lane, std::chrono::milliseconds(500));
    };
  attachment_ = session_->attach(std::move(client));
  stream_->send(welcome(!m.resume_session.empty()));
  authenticated_ = true;
  arm_deadline(to_clock(env_.idle_timeout));  // from the Hello deadline to the idle one
}

wire::Welcome ClientConnection::welcome(bool resumed) const {
  return {session_->id(),
          env_.server_version,
          resumed,
          session_->frames_processed(),
          env_.limits,
          {wire::kServerCapabilityLocation, wire::kServerCapabilityJoin},
          session_->newest_sequence()};
}

void ClientConnection::watch(const wire::Hello& m) {
  watching_ = true;
  std::weak_ptr<wire::MessageStream> weak = stream_;
  std::weak_ptr<ClientConnection> weak_self = shared_from_this();
  WatcherSet::Watcher w;
  w.send = [weak](EncodedMessage envelope, std::optional<BulkGroup> bulk) {
    if (auto stream = weak.lock()) send_on(*stream, std::move(envelope), bulk);
  };
  w.backlog = [weak] {
    const auto stream = weak.lock();
    return stream ? stream->queued_bytes() : std::size_t(0);
  };
  w.coding = wire::choose_tile_coding(m.capabilities);
  w.disconnect = [weak_self] {
    if (auto self = weak_self.lock()) self->close();  // the session ended or moved
  };
  // Admitted, it gets the Welcome, then the session's newest update and set.
  watcher_ = session_->watch(
      std::move(w), std::make_shared<const std::vector<std::uint8_t>>(wire::encode(welcome(false))));
  if (!watcher_) {
    if (env_.watchers_refused) env_.watchers_refused->inc();
    return fail(wire::ErrorCode::Busy, "session " + session_->id() +
                                           " has its maximum of watchers; try again later");
  }
  authenticated_ = true;
  arm_deadline(to_clock(env_.idle_timeout));
}

void ClientConnection::join(const wire::Hello& m) {
  contributing_ = true;
  std::weak_ptr<wire::MessageStream> weak = stream_;
  std::weak_ptr<ClientConnection> weak_self = shared_from_this();
  Session::ContributorLink link;
  link.device_id = m.device_id;
  link.exposure_advice = wire::has_capability(m.capabilities, wire::kCapabilityExposureAdvice) &&
                         !exposure_unknown_;
  link.send = [weak](EncodedMessage envelope, std::optional<BulkGroup> bulk) {
    if (auto stream = weak.lock()) send_on(*stream, std::move(envelope), bulk);
  };
  link.watcher.send = link.send;
  link.watcher.backlog = [weak] {
    const auto stream = weak.lock();
    return stream ? stream->queued_bytes() : std::size_t(0);
  };
  link.watcher.coding = wire::choose_tile_coding(m.capabilities);
  link.watcher.disconnect = [weak_self] {
    if (auto self = weak_self.lock()) self->close();  // the session ended or moved
  };
  contributor_ = session_->join(
      std::move(link), std::make_shared<const std::vector<std::uint8_t>>(wire::encode(welcome(false))));
  if (!contributor_)
    return fail(wire::ErrorCode::Busy, "session " + session_->id() +
                                           " has its maximum of contributors; try again later");
  authenticated_ = true;
  arm_deadline(to_clock(env_.idle_timeout));
}

void ClientConnection::handle_intrinsics(const CameraIntrinsics& c) {
  // The codec bounded the size by the pixel limit; the optics are checked here.
  const bool finite =
      std::isfinite(c.fx) && std::isfinite(c.fy) && std::isfinite(c.cx) && std::isfinite(c.cy);
  if (c.width < 1 || c.height < 1 || !finite || !(c.fx > 0) || !(c.fy > 0))
    return fail(wire::ErrorCode::BadMessage,
                "CameraIntrinsics: size or focal lengths out of range");
  const std::string why = contributing_
                              ? session_->set_contributor_camera(contributor_, c, exposure_unknown_)
                              : session_->set_camera(c, exposure_unknown_);
  if (!why.empty()) return fail(wire::ErrorCode::BadMessage, "CameraIntrinsics: " + why);
}

void ClientConnection::handle_calibration(wire::CalibrationSet&& set) {
  if (set.frames.size() < 2)
    return fail(wire::ErrorCode::BadMessage, "CalibrationSet: 2 to 16 frames");
  std::vector<std::vector<std::uint8_t>> jpegs;
  std::vector<double> times;
  for (std::size_t i = 0; i < set.frames.size(); ++i) {
    wire::CameraFrame& f = set.frames[i];
    const double t = f.info.exposure * f.info.gain;
    if (f.format != wire::PixelFormat::Jpeg || !std::isfinite(t) || !(t > 0.0))
      return fail(wire::ErrorCode::BadMessage,
                  "CalibrationSet: frame " + std::to_string(i) +
                      " needs JPEG data, a size within the limits and exposure x gain > 0");
    jpegs.push_back(std::move(f.data));
    times.push_back(t);
  }
  session_->calibrate(std::move(jpegs), std::move(times),
                      set.method.empty() ? "robertson" : set.method);
}

void ClientConnection::handle_frame(wire::CameraFrame&& m) {
  if (contributing_ ? !session_->contributor_has_camera(contributor_) : !session_->has_camera())
    return fail(wire::ErrorCode::OutOfOrder, "CameraFrame before CameraIntrinsics");
  // The codec checked the size against the limits and RGB8 data against the size.
  if (exposure_unknown_) {
    // Whatever the client wrote there: the first frame is taken at one locked exposure, which
    // sets the map's scale; the capture estimates every later frame's from its overlap with
    // the map (CaptureOptions::estimate_exposure).
    m.info.exposure = wire::kLockedExposureSeconds;
    m.info.gain = 1.0;
  }
  FrameJob job{std::move(m), Clock::now(), stream_->last_arrival()};
  if (contributing_) return session_->submit_contributed(contributor_, std::move(job));
  session_->submit(std::move(job));
}

}  // namespace arlight::daemon
