#include "arlight/daemon/daemon.hpp"

#include <spdlog/spdlog.h>

#include <atomic>
#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/ssl/context.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/asio/strand.hpp>
#include <boost/asio/thread_pool.hpp>
#include <condition_variable>
#include <map>
#include <mutex>
#include <opencv2/core/utility.hpp>
#include <thread>

#include "arlight/admin/admin_http.hpp"
#include "arlight/admin/metrics.hpp"
#include "arlight/common/error.hpp"
#include "connection.hpp"
#include "frame_path_gate.hpp"
#include "phone_link.hpp"
#include "priority.hpp"
#include "session_lease.hpp"
#include "session_opener.hpp"
#include "tokens.hpp"
#include "web_server.hpp"

namespace arlight::daemon {

namespace asio = boost::asio;
using asio::ip::tcp;

namespace {

constexpr const char* kServerVersion = "arlightd 0.1.0";

unsigned hardware_threads() { return std::max(1u, std::thread::hardware_concurrency()); }

// The server's TLS context: TLS 1.2 or newer, the certificate chain and key from PEM files.
// A file that cannot be used is an InputError naming it and what OpenSSL said.
std::unique_ptr<asio::ssl::context> make_tls_context(const std::filesystem::path& cert,
                                                     const std::filesystem::path& key) {
  auto ctx = std::make_unique<asio::ssl::context>(asio::ssl::context::tls_server);
  ctx->set_options(asio::ssl::context::default_workarounds | asio::ssl::context::no_sslv2 |
                   asio::ssl::context::no_sslv3 | asio::ssl::context::no_tlsv1 |
                   asio::ssl::context::no_tlsv1_1 | asio::ssl::context::single_dh_use);
  boost::system::error_code ec;
  ctx->use_certificate_chain_file(cert.string(), ec);
  if (ec) throw InputError(cert.string() + ": not a usable PEM certificate: " + ec.message());
  ctx->use_private_key_file(key.string(), asio::ssl::context::pem, ec);
  if (ec) throw InputError(key.string() + ": not a usable PEM private key: " + ec.message());
  if (SSL_CTX_check_private_key(ctx->native_handle()) != 1)
    throw InputError(key.string() + ": does not match the certificate " + cert.string());
  return ctx;
}

// The client port's TLS context (--tls-cert/--tls-key), or null for plain TCP.
std::unique_ptr<asio::ssl::context> make_tls_context(const DaemonConfig& c) {
  if (c.tls_cert.empty() && c.tls_key.empty()) return nullptr;
  if (c.tls_cert.empty() || c.tls_key.empty())
    throw InputError("TLS needs both a certificate (--tls-cert) and its key (--tls-key)");
  return make_tls_context(c.tls_cert, c.tls_key);
}

// Where the browser client's files are when no --web-root is given: beside the executable (the
// build tree), or in the installed share folder.
std::filesystem::path default_web_root() {
  std::error_code ec;
  const auto exe_dir = std::filesystem::read_symlink("/proc/self/exe", ec).parent_path();
  for (const auto& dir : {exe_dir / "web", exe_dir.parent_path() / "share" / "arlight" / "web"})
    if (std::filesystem::exists(dir / "index.html", ec)) return dir;
  return exe_dir / "web";
}

}  // namespace

struct Daemon::Impl {
  DaemonConfig config;
  TokenStore tokens;
  asio::io_context io;
  std::optional<asio::executor_work_guard<asio::io_context::executor_type>> work;
  // Before the sessions and their map threads, which use it, so it goes after them.
  FramePathGate frame_path;
  asio::thread_pool workers;
  asio::thread_pool disk{1};  // checkpoints (fsync) stay off the frame workers
  // On a strand of its own, where its accept handler runs and stop() closes it.
  tcp::acceptor acceptor{asio::make_strand(io)};
  std::unique_ptr<asio::ssl::context> tls;  // null: plain TCP
  std::unique_ptr<asio::ssl::context> web_tls;
  std::unique_ptr<WebServer> web_server;
  std::filesystem::path web_certificate;
  std::string phone_url;
  admin::Registry metrics;
  SessionEnv session_env;
  ConnectionEnv connection_env;
  std::unique_ptr<admin::AdminServer> admin_server;
  std::filesystem::path admin_token_file;
  asio::steady_timer housekeeping{io};
  std::vector<std::thread> threads;
  std::uint16_t bound_port = 0;
  std::atomic<bool> accepting{true};  // /healthz, read from the admin threads

  std::mutex sessions_mutex;
  std::map<std::string, std::shared_ptr<Session>> sessions;
  std::mutex connections_mutex;
  std::vector<std::weak_ptr<ClientConnection>> connections;

  std::mutex stop_mutex;
  std::condition_variable stopped_cv;
  bool stopping = false;  // stop() has begun (it runs once)
  bool stopped = false;   // and has ended: wait() returns

  // Logging of bad input is rate-limited: a flood of garbage must not flood the log.
  std::mutex log_mutex;
  Clock::time_point log_window = Clock::now();
  int log_lines = 0, log_suppressed = 0;

  admin::Gauge& sessions_gauge;
  admin::Counter* refused_total = nullptr;
  admin::Counter* refused_unauthenticated = nullptr;
  admin::Counter* refused_per_address = nullptr;
  admin::Counter* sessions_handed_over = nullptr;
  admin::Counter* sessions_lost = nullptr;

  // Written into every lease this daemon takes: who, and where clients reach it (its
  // addresses once its ports are bound: advertise()).
  LeaseHolder lease_holder{lease_owner_name()};
  std::optional<SessionOpener> opener;  // Hellos' sessions (made once the metrics exist)

  explicit Impl(DaemonConfig c)
      : config(std::move(c)),
        tokens(TokenStore::load(config.tokens_file)),
        workers(config.workers > 0 ? unsigned(config.workers) : hardware_threads()),
        tls(make_tls_context(config)),
        sessions_gauge(metrics.gauge("arlight_sessions", "live sessions (connected or idle)")) {
    asio::post(disk, [] { lower_thread_priority(); });
    session_env.data_dir = config.data_dir;
    session_env.map_size = config.map_size;
    session_env.fill = config.fill;
    session_env.align_every = config.align_every;
    session_env.align_max_width = config.align_max_width;
    session_env.queue_depth = config.queue_depth;
    session_env.map_interval_s = config.map_interval_s;
    session_env.max_watchers = std::size_t(config.max_watchers);
    session_env.max_contributors = std::size_t(config.max_contributors);
    session_env.watchers = &metrics.gauge("arlight_watchers", "devices watching a session");
    session_env.limits = config.limits;
    session_env.workers = &workers;
    session_env.frame_path = &frame_path;
    session_env.frames_received =
        &metrics.counter("arlight_frames_received_total", "camera frames received");
    session_env.frames_processed =
        &metrics.counter("arlight_frames_processed_total", "frames merged into a session's map");
    session_env.frames_dropped = &metrics.counter(
        "arlight_frames_dropped_total", "frames replaced by a newer one before processing");
    session_env.frames_duplicate = &metrics.counter(
        "arlight_frames_duplicate_total",
        "frames a session already had, sent again by a client after a resume (not counted)");
    session_env.frames_skipped =
        &metrics.counter("arlight_frames_skipped_total", "frames refused by the capture library");
    session_env.frames_unchanged = &metrics.counter(
        "arlight_frames_unchanged_total",
        "frames processed but not merged: they agreed with the map (issue 37)");
    session_env.frames_glanced = &metrics.counter(
        "arlight_frames_glanced_total",
        "unchanged frames found so by the glance alone: decoded at 1/8, not processed (issue 37)");
    session_env.map_sets = &metrics.counter("arlight_map_sets_total", "map sets computed and sent");
    session_env.light_files = &metrics.counter(
        "arlight_light_files_total", "light files (light.json, specular.ktx2) computed for the admin");
    const std::vector<double> ms = {0.002, 0.005, 0.01, 0.02, 0.05, 0.1, 0.2, 0.5, 1};
    session_env.processing_seconds =
        &metrics.histogram("arlight_frame_processing_seconds", "capture time per frame", ms);
    session_env.update_latency_seconds = &metrics.histogram(
        "arlight_update_latency_seconds", "frame received to LightingUpdate sent", ms);
    session_env.map_set_seconds =
        &metrics.histogram("arlight_map_set_seconds", "time to compute and send a map set",
                           {0.1, 0.5, 1, 2, 5, 10, 30});
    std::filesystem::create_directories(config.data_dir / "sessions");

    connection_env.limits = config.limits;
    connection_env.max_send_queue_bytes = config.max_send_queue_bytes;
    connection_env.server_version = kServerVersion;
    connection_env.open_session = [this](const wire::Hello& h, bool web, wire::ErrorCode& code,
                                         std::string& why, std::string& address) {
      return opener->open(h, web, code, why, address);
    };
    connection_env.log = [this](const std::string& line) { log(line); };
    connection_env.checkpoint_soon = [this](std::shared_ptr<Session> s) {
      asio::post(disk, [this, s = std::move(s)] { save(*s); });
    };
    connection_env.hello_timeout = std::chrono::duration<double>(config.hello_timeout_s);
    connection_env.idle_timeout = std::chrono::duration<double>(config.idle_timeout_s);
    connection_env.watchers_refused = &metrics.counter(
        "arlight_watchers_refused_total", "watchers refused: the session had its maximum");
    connection_env.hello_timeouts = &metrics.counter(
        "arlight_hello_timeouts_total", "connections closed for sending no Hello in time");
    connection_env.idle_timeouts = &metrics.counter(
        "arlight_idle_timeouts_total", "authenticated connections closed for sending nothing");
    refused_total = &metrics.counter("arlight_connections_refused_limit_total",
                                     "connections refused: the limit of all connections");
    refused_unauthenticated =
        &metrics.counter("arlight_connections_refused_unauthenticated_total",
                         "connections refused: the limit of connections before their Hello");
    refused_per_address =
        &metrics.counter("arlight_connections_refused_per_address_total",
                         "connections refused: the limit of connections from one address");

    sessions_handed_over =
        &metrics.counter("arlight_sessions_handed_over_total",
                         "sessions closed here because a client resumed them on another daemon");
    sessions_lost = &metrics.counter(
        "arlight_sessions_lost_total",
        "sessions closed here unsaved: this daemon stopped past the lease's expiry and another "
        "took them over");
    opener.emplace(SessionOpener::Env{
        .tokens = tokens,
        .session_env = session_env,
        .lease_holder = lease_holder,
        .max_sessions = config.max_sessions,
        .sessions_mutex = sessions_mutex,
        .sessions = sessions,
        .make_room = [this](std::unique_lock<std::mutex>& lock) { make_room(lock); },
        .sessions_gauge = sessions_gauge,
        .takeover_waits = metrics.counter(
            "arlight_session_takeover_waits_total",
            "resumes answered Busy while another daemon still held the session's lease"),
        .redirected = metrics.counter(
            "arlight_sessions_redirected_total",
            "watchers and contributors told where the session they asked for lives (another "
            "daemon's lease)")});

    const tcp::endpoint ep(asio::ip::make_address(config.listen_host), config.listen_port);
    acceptor.open(ep.protocol());
    acceptor.set_option(tcp::acceptor::reuse_address(true));
    boost::system::error_code ec;
    acceptor.bind(ep, ec);
    if (ec)
      throw std::runtime_error("cannot listen on " + config.listen_host + ":" +
                               std::to_string(config.listen_port) + ": " + ec.message());
    acceptor.listen();
    bound_port = acceptor.local_endpoint().port();

    if (config.web_enabled) start_web();
    advertise();

    if (config.admin_enabled) {
      admin::AdminHandlers h;
      h.metrics = [this] { return metrics.render(); };
      h.sessions_json = [this] { return sessions_json(); };
      h.envmap_png = [this](const std::string& id) -> std::optional<std::vector<std::uint8_t>> {
        std::lock_guard lock(sessions_mutex);
        const auto it = sessions.find(id);
        if (it == sessions.end()) return std::nullopt;
        return it->second->envmap_png();
      };
      h.light_file = [this](const std::string& id, admin::AdminHandlers::LightFile file)
          -> std::optional<std::string> {
        std::shared_ptr<Session> session;
        {
          std::lock_guard lock(sessions_mutex);
          const auto it = sessions.find(id);
          if (it == sessions.end()) return std::nullopt;
          session = it->second;
        }
        // Computed outside the sessions' lock: the chain takes ~0.2 s.
        const auto files = session->light_files();
        if (file == admin::AdminHandlers::LightFile::Json) return files->light_json;
        return std::string(files->specular_ktx2.begin(), files->specular_ktx2.end());
      };
      h.healthy = [this] { return accepting.load(); };
      const bool default_file = config.admin_token_file.empty();
      admin_token_file = default_file ? config.data_dir / "admin.token" : config.admin_token_file;
      bool created = false;
      admin::AdminAccess access;
      access.token = load_admin_token(admin_token_file, default_file, &created);
      access.protect_all = config.admin_protect_all;
      if (created) spdlog::info("made an admin token: {}", admin_token_file.string());
      admin_server =
          std::make_unique<admin::AdminServer>(io, config.admin_host, config.admin_port, h, access);
    }
  }

  // The web port: its certificate (the given one, or a self-signed one kept in DATA/tls), the
  // listener, and the URL a phone opens.
  void start_web() {
    CertificateFiles cert{config.tls_cert, config.tls_key, false};
    if (config.tls_cert.empty()) {
      cert = ensure_self_signed_certificate(config.data_dir / "tls", local_names());
      if (cert.created)
        spdlog::info("made a self-signed certificate for the web port: {}", cert.cert.string());
    }
    web_tls = make_tls_context(cert.cert, cert.key);
    web_certificate = cert.cert;
    const std::string device =
        config.web_device.empty() ? tokens.first_device() : config.web_device;
    const std::string* token = tokens.token_of(device);
    if (!token)
      throw InputError("--web-device '" + device + "' is not in the tokens file " +
                       config.tokens_file.string());
    WebServerOptions o;
    o.host = config.web_host;
    o.port = config.web_port;
    o.root = config.web_root.empty() ? default_web_root() : config.web_root;
    o.on_websocket = [this](std::unique_ptr<wire::Transport> t) { adopt(std::move(t), true); };
    o.admit = [this](const std::string& address) { return admit_web_connection(address); };
    o.log = [this](const std::string& line) { log(line); };
    web_server = std::make_unique<WebServer>(io, *web_tls, std::move(o));
    phone_url = daemon::phone_url(
        config.web_url_host.empty() ? reachable_host(config.web_host) : config.web_url_host,
        web_server->port(), device, *token);
  }

  // The addresses the leases name (DaemonConfig::advertise): "auto" is the bound port at the
  // address a client on another machine would use.
  void advertise() {
    const auto choose = [](const std::string& configured, const std::string& host,
                           std::uint16_t port) {
      return configured == "auto" ? host + ":" + std::to_string(port) : configured;
    };
    lease_holder.address = choose(config.advertise, reachable_host(config.listen_host), bound_port);
    if (web_server)
      lease_holder.web_address =
          choose(config.advertise_web,
                 config.web_url_host.empty() ? reachable_host(config.web_host)
                                             : config.web_url_host,
                 web_server->port());
  }

  void log(const std::string& line) {
    std::lock_guard lock(log_mutex);
    const auto now = Clock::now();
    if (now - log_window > std::chrono::seconds(10)) {
      if (log_suppressed) spdlog::warn("({} more such messages suppressed)", log_suppressed);
      log_window = now, log_lines = 0, log_suppressed = 0;
    }
    if (++log_lines <= 20)
      spdlog::warn("{}", line);
    else
      ++log_suppressed;
  }

  std::string sessions_json() {
    nlohmann::json j = nlohmann::json::array();
    std::lock_guard lock(sessions_mutex);
    for (const auto& [id, s] : sessions) j.push_back(s->summary());
    return j.dump();
  }

  // Runs a step that checkpoints the session (Session::checkpoint, or Session::release: closes
  // it here for good, kept on disk, its lease let go); a failure (disk full, permissions) is
  // logged, rate-limited, and leaves the session open.
  bool to_disk(Session& s, void (Session::*step)()) {
    try {
      (s.*step)();
      return true;
    } catch (const std::exception& e) {
      log("checkpoint of session " + s.id() + " failed: " + e.what());
      return false;
    }
  }
  bool save(Session& s) { return to_disk(s, &Session::checkpoint); }
  bool release(Session& s) { return to_disk(s, &Session::release); }

  // Takes a released session out of the map, unless a newer one of that id replaced it there.
  void forget(const std::shared_ptr<Session>& s) {
    std::lock_guard lock(sessions_mutex);
    if (const auto it = sessions.find(s->id()); it != sessions.end() && it->second == s)
      sessions.erase(it);
    sessions_gauge.set(double(sessions.size()));
  }

  // A session that another daemon was asked for (session_lease.hpp): checkpointed, closed here
  // and let go, so the client's next attempt resumes it there (or here again).
  void hand_over(const std::shared_ptr<Session>& s) {
    if (!s->holds_lease()) return;  // handed over already (housekeeping asks every 250 ms)
    const auto dir = session_dir(session_env, s->id());
    if (!release(*s)) return;  // retried at the next housekeeping while the request stands
    SessionLease::clear_release_request(dir);
    forget(s);
    sessions_handed_over->inc();
    spdlog::info("session {} handed over to another daemon (checkpointed)", s->id());
  }

  // With `lock` (on sessions_mutex) held and the server full: makes room by closing the session
  // that has waited longest without a connection (checkpointed first, so it stays on disk and
  // can be resumed), as the idle timeout would have. When every session is connected, nothing.
  // The lock is let go while a checkpoint is written, so another Hello may take the room made:
  // hence the loop (without it, 8 phones arriving at once on a full server got Busy).
  void make_room(std::unique_lock<std::mutex>& lock) {
    while (int(sessions.size()) >= config.max_sessions) {
      std::shared_ptr<Session> idlest;
      for (const auto& [id, s] : sessions)
        if (!s->attached() && (!idlest || s->last_activity() < idlest->last_activity())) idlest = s;
      if (!idlest) return;
      sessions.erase(idlest->id());
      lock.unlock();
      if (!release(*idlest)) {  // not on disk: it stays open, and the new session is refused
        lock.lock();
        sessions.emplace(idlest->id(), idlest);
        return;
      }
      spdlog::info("session {} closed to make room (kept on disk)", idlest->id());
      lock.lock();
    }
  }

  void accept() {
    acceptor.async_accept(
        asio::make_strand(io), [this](boost::system::error_code ec, tcp::socket socket) {
          if (ec) {
            if (acceptor.is_open()) accept();
            return;
          }
          adopt(tls ? wire::make_tls_transport(wire::TlsSocket(std::move(socket), *tls),
                                               wire::TlsRole::AcceptAsServer)
                    : wire::make_tcp_transport(std::move(socket)));
          accept();
        });
  }

  // A client connection from any transport (TCP, TLS, WebSocket): one code path from here on.
  // Over a connection limit it is closed before anything is read from it.
  // `web`: a WebSocket of the web port (a redirect names the other daemon's web port).
  void adopt(std::unique_ptr<wire::Transport> transport, bool web = false) {
    const std::string address = peer_address(transport->peer());
    std::shared_ptr<ClientConnection> c;
    std::string refused;
    {
      std::lock_guard lock(connections_mutex);
      refused = over_a_limit(address);
      if (refused.empty()) {
        ConnectionEnv env = connection_env;
        env.web = web;
        c = std::make_shared<ClientConnection>(std::move(transport), env);
        connections.push_back(c);
      }
    }
    if (!c) {
      log(address + ": connection refused: " + refused);
      transport->close();
      return;
    }
    c->start();
  }

  // The web port's connections before they become protocol connections (plain HTTPS, and /ws
  // until its upgrade): counted against the same limits, all of them "before their Hello".
  struct WebConnectionSlot {
    std::string address;
  };
  std::vector<std::weak_ptr<WebConnectionSlot>> web_connections;  // connections_mutex
  std::shared_ptr<void> admit_web_connection(const std::string& address) {
    std::string refused;
    {
      std::lock_guard lock(connections_mutex);
      refused = over_a_limit(address);
      if (refused.empty()) {
        auto slot = std::make_shared<WebConnectionSlot>(WebConnectionSlot{address});
        web_connections.push_back(slot);
        return slot;
      }
    }
    log(address + ": web connection refused: " + refused);
    return nullptr;
  }

  // With connections_mutex held: which connection limit one more connection from `address`
  // would pass (counted in its metric), or empty when none.
  std::string over_a_limit(const std::string& address) {
    std::erase_if(connections, [](const auto& w) { return w.expired(); });
    std::erase_if(web_connections, [](const auto& w) { return w.expired(); });
    int all = 0, unauthenticated = 0, from_address = 0;
    for (const auto& w : connections)
      if (const auto other = w.lock()) {
        ++all;
        unauthenticated += !other->authenticated();
        from_address += other->address() == address;
      }
    for (const auto& w : web_connections)
      if (const auto other = w.lock()) {
        ++all, ++unauthenticated;
        from_address += other->address == address;
      }
    if (all >= config.max_connections) {
      refused_total->inc();
      return "the limit of " + std::to_string(config.max_connections) + " connections";
    }
    if (unauthenticated >= config.max_unauthenticated) {
      refused_unauthenticated->inc();
      return "the limit of " + std::to_string(config.max_unauthenticated) +
             " connections before their Hello";
    }
    if (from_address >= config.max_connections_per_address) {
      refused_per_address->inc();
      return "the limit of " + std::to_string(config.max_connections_per_address) +
             " connections from one address";
    }
    return {};
  }

  // Every second: checkpoint what changed (at the configured interval) and close sessions idle
  // past the timeout (they stay on disk for a resume).
  Clock::time_point last_checkpoint = Clock::now();
  std::atomic<bool> checkpoint_round_running{false};
  void schedule_housekeeping() {
    housekeeping.expires_after(std::chrono::milliseconds(250));
    housekeeping.async_wait([this](boost::system::error_code ec) {
      if (ec) return;
      const auto now = Clock::now();
      std::vector<std::shared_ptr<Session>> all;
      {
        std::lock_guard lock(sessions_mutex);
        for (auto& [id, s] : sessions) all.push_back(s);
      }
      // One round of checkpoints at a time: with many sessions a round can outlast the
      // interval, and rounds posted behind it would pile up on the disk thread. The next one
      // starts at the first tick after it ends.
      if (now - last_checkpoint >= std::chrono::duration<double>(config.checkpoint_interval_s) &&
          !checkpoint_round_running.exchange(true)) {
        last_checkpoint = now;
        asio::post(disk, [this, all] {
          for (const auto& s : all) save(*s);
          checkpoint_round_running = false;
        });
      }
      for (const auto& s : all) s->on_idle(now);
      // Leases expire unless renewed (session_lease.hpp): one lost, this daemon was stopped
      // and another has the session now; it is closed here without a write.
      for (const auto& s : all)
        if (!s->renew_lease())
          asio::post(disk, [this, s] {
            if (!s->abandon()) return;
            forget(s);
            sessions_lost->inc();
            spdlog::warn("session {} was taken over by another daemon while this one was "
                         "stopped; closed here unsaved",
                         s->id());
          });
      for (const auto& s : all)
        if (SessionLease::release_requested(session_dir(session_env, s->id()))) {
          asio::post(disk, [this, s] { hand_over(s); });
        } else if (!s->attached() && now - s->last_activity() >
                                         std::chrono::duration<double>(config.idle_timeout_s)) {
          asio::post(disk, [this, s] {
            if (release(*s)) forget(s);  // else kept open (and retried) rather than lost
          });
        }
      schedule_housekeeping();
    });
  }
};

Daemon::Daemon(DaemonConfig config) : impl_(std::make_unique<Impl>(std::move(config))) {}

Daemon::~Daemon() { stop(); }

void Daemon::start() {
  Impl& d = *impl_;
  // Sessions are the unit of parallelism (one frame per worker): OpenCV's own thread pool
  // inside each small decode/resize/feature call would only oversubscribe the cores.
  cv::setNumThreads(1);
  d.work.emplace(d.io.get_executor());
  d.accept();
  if (d.admin_server) d.admin_server->start();
  if (d.web_server) d.web_server->start();
  d.schedule_housekeeping();
  const unsigned n = d.config.threads > 0 ? unsigned(d.config.threads) : hardware_threads();
  for (unsigned i = 0; i < n; ++i) d.threads.emplace_back([&d] { d.io.run(); });
  spdlog::info("arlightd listening on {}:{} (admin {}), data in {}", d.config.listen_host, port(),
               admin_port(), d.config.data_dir.string());
}

void Daemon::stop() {
  Impl& d = *impl_;
  {
    std::unique_lock lock(d.stop_mutex);
    if (d.stopping) {  // another thread stops it (the signals' thread, then ~Daemon)
      d.stopped_cv.wait(lock, [&d] { return d.stopped; });
      return;
    }
    d.stopping = true;
  }
  d.accepting = false;
  asio::post(d.acceptor.get_executor(), [&d] {
    boost::system::error_code e;
    d.acceptor.close(e);
  });
  asio::post(d.io, [&d] {
    d.housekeeping.cancel();
    if (d.admin_server) d.admin_server->stop();
    if (d.web_server) d.web_server->stop();
  });
  {
    std::lock_guard lock(d.connections_mutex);
    for (auto& w : d.connections)
      if (auto c = w.lock()) c->close();
  }
  std::vector<std::shared_ptr<Session>> all;
  {
    std::lock_guard lock(d.sessions_mutex);
    for (auto& [id, s] : d.sessions) all.push_back(s);
  }
  for (const auto& s : all) {
    s->shutdown();
    d.save(*s);
  }
  d.work.reset();
  d.io.stop();
  for (auto& t : d.threads)
    if (t.joinable()) t.join();
  d.workers.join();
  d.disk.join();
  // Only now, and notified under the lock. The flag was set when stop() began: a spurious
  // wake-up could return wait() and its caller destroy the daemon while the checkpoints were
  // written; and a notify_all() outside the lock could still run while the caller destroyed
  // the condition variable (ThreadSanitizer saw it at every SIGTERM).
  std::lock_guard lock(d.stop_mutex);
  d.stopped = true;
  d.stopped_cv.notify_all();
}

void Daemon::wait() {
  std::unique_lock lock(impl_->stop_mutex);
  impl_->stopped_cv.wait(lock, [this] { return impl_->stopped; });
}

std::uint16_t Daemon::port() const { return impl_->bound_port; }

std::uint16_t Daemon::web_port() const { return impl_->web_server ? impl_->web_server->port() : 0; }

std::string Daemon::phone_url() const { return impl_->phone_url; }

std::filesystem::path Daemon::web_certificate() const { return impl_->web_certificate; }
std::filesystem::path Daemon::admin_token_file() const { return impl_->admin_token_file; }

std::uint16_t Daemon::admin_port() const {
  return impl_->admin_server ? impl_->admin_server->port() : 0;
}

}  // namespace arlight::daemon
