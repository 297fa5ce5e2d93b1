// arlightd: the lighting daemon (see README.md and protocol/PROTOCOL.md).
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <csignal>
#include <cstdio>
#include <thread>

#include "arlight/daemon.hpp"
#include "arlight/error.hpp"
#include "phone_link.hpp"

using namespace arlight;

int main(int argc, char** argv) {
  // A peer or a log reader that goes away must not kill the daemon: writes then fail with
  // EPIPE instead of raising SIGPIPE. Logs go to stderr; stdout carries the one "listening" line.
  std::signal(SIGPIPE, SIG_IGN);
  spdlog::set_default_logger(spdlog::stderr_color_mt("arlightd"));
  CLI::App app{
      "arlightd: builds HDR environment maps from phones' and webcams' frames and "
      "streams lighting back"};
  daemon::DaemonConfig c;
  std::string listen, admin, config, tls_cert, tls_key, web, web_root, web_device, web_url_host;
  std::string fill;
  std::string data_dir, tokens, admin_token_file;
  app.add_option("--config", config, "JSON config file (flags given here override it)");
  app.add_option("--listen", listen, "HOST:PORT for clients (default 127.0.0.1:7878)");
  app.add_option("--admin", admin,
                 "HOST:PORT of the admin HTTP server (default 127.0.0.1:7879; '' off)");
  app.add_option("--admin-token-file", admin_token_file,
                 "the admin port's bearer token for /sessions (default DATA/admin.token, made "
                 "when missing)");
  app.add_flag("--admin-protect-all", c.admin_protect_all,
               "/healthz and /metrics need the admin token too");
  app.add_option("--data-dir", data_dir, "where sessions and response curves are kept");
  app.add_option("--tokens", tokens, "file of '<device-id> <token>' lines");
  app.add_option("--threads", c.threads, "network threads (0: one per core)");
  app.add_option("--workers", c.workers, "frame-processing threads (0: one per core)");
  app.add_option("--max-sessions", c.max_sessions, "live sessions at once");
  app.add_option("--idle-timeout", c.idle_timeout_s,
                 "seconds before a session with no connection, or no traffic, closes (kept on "
                 "disk for a resume)");
  app.add_option("--hello-timeout", c.hello_timeout_s,
                 "seconds a new connection has to send its Hello (default 5)");
  app.add_option("--max-connections", c.max_connections,
                 "client connections at once, TCP and WebSocket (default 256)");
  app.add_option("--max-unauthenticated", c.max_unauthenticated,
                 "connections that have not sent their Hello yet (default 64)");
  app.add_option("--max-per-address", c.max_connections_per_address,
                 "connections from one address (default 64)");
  app.add_option("--checkpoint-interval", c.checkpoint_interval_s,
                 "seconds between checkpoints of a changing session: at most this much capture "
                 "is lost when the daemon dies (default 2; 1 behind a balancer)");
  app.add_option("--fill", fill,
                 "what a session's map holds where no frame has looked yet: estimate (from what "
                 "was seen, default), mean or none (black)");
  app.add_option("--align-every", c.align_every,
                 "feature alignment on every n-th frame of a session (default 4)");
  app.add_option("--queue-depth", c.queue_depth,
                 "frames of a session that may wait; a newer one drops the oldest (default 2)");
  app.add_option("--map-interval", c.map_interval_s,
                 "seconds between the starts of a session's map sets while its map changes "
                 "(default 0.09: a set at least every 0.1 s; 0: each as soon as the last is done)");
  app.add_option("--tls-cert", tls_cert, "TLS: certificate chain (PEM) for the client port");
  app.add_option("--tls-key", tls_key, "TLS: private key (PEM) of that certificate");
  app.add_option("--web", web,
                 "HOST:PORT of the web port for phones (HTTPS: the browser client and /ws), e.g. "
                 "0.0.0.0:8443; off by default");
  app.add_option("--web-root", web_root,
                 "the browser client's files (default: web/ beside arlightd, or "
                 "../share/arlight/web)");
  app.add_option("--web-device", web_device,
                 "the device whose id and token the phone URL carries (default: the first in "
                 "the tokens file)");
  app.add_option("--web-url-host", web_url_host,
                 "the host name or address in the phone URL (default: this machine's LAN "
                 "address)");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  try {
    if (app.count("--fill")) c.fill = capture::fill_from_name(fill, "--fill");
    if (!config.empty()) {
      daemon::DaemonConfig from_file;
      daemon::load_config_file(config, from_file);
      // Flags override the file: apply the file first, then what was given on the line.
      const daemon::DaemonConfig flags = c;
      c = from_file;
      if (app.count("--threads")) c.threads = flags.threads;
      if (app.count("--workers")) c.workers = flags.workers;
      if (app.count("--max-sessions")) c.max_sessions = flags.max_sessions;
      if (app.count("--idle-timeout")) c.idle_timeout_s = flags.idle_timeout_s;
      if (app.count("--hello-timeout")) c.hello_timeout_s = flags.hello_timeout_s;
      if (app.count("--max-connections")) c.max_connections = flags.max_connections;
      if (app.count("--max-unauthenticated")) c.max_unauthenticated = flags.max_unauthenticated;
      if (app.count("--max-per-address"))
        c.max_connections_per_address = flags.max_connections_per_address;
      if (app.count("--align-every")) c.align_every = flags.align_every;
      if (app.count("--fill")) c.fill = flags.fill;
      if (app.count("--queue-depth")) c.queue_depth = flags.queue_depth;
      if (app.count("--map-interval")) c.map_interval_s = flags.map_interval_s;
      if (app.count("--admin-protect-all")) c.admin_protect_all = flags.admin_protect_all;
    }
    if (!listen.empty()) wire::parse_endpoint(listen, c.listen_host, c.listen_port);
    if (app.count("--admin")) {
      c.admin_enabled = !admin.empty();
      if (c.admin_enabled) wire::parse_endpoint(admin, c.admin_host, c.admin_port);
    }
    if (!data_dir.empty()) c.data_dir = data_dir;
    if (!admin_token_file.empty()) c.admin_token_file = admin_token_file;
    if (!tokens.empty()) c.tokens_file = tokens;
    if (!tls_cert.empty()) c.tls_cert = tls_cert;
    if (!tls_key.empty()) c.tls_key = tls_key;
    if (!web.empty()) {
      c.web_enabled = true;
      wire::parse_endpoint(web, c.web_host, c.web_port);
    }
    if (!web_root.empty()) c.web_root = web_root;
    if (!web_device.empty()) c.web_device = web_device;
    if (!web_url_host.empty()) c.web_url_host = web_url_host;
    if (c.tokens_file.empty()) throw InputError("--tokens FILE is required");
    if (c.queue_depth < 1 || c.queue_depth > 64)
      throw InputError("queue depth " + std::to_string(c.queue_depth) + " is not in [1, 64]");
    if (!(c.map_interval_s >= 0 && c.map_interval_s <= 3600))
      throw InputError("map interval " + std::to_string(c.map_interval_s) +
                       " s is not in [0, 3600]");
    if (!(c.hello_timeout_s > 0) || !(c.idle_timeout_s > 0))
      throw InputError("the Hello and idle timeouts must be positive seconds");
    if (c.max_connections < 1 || c.max_unauthenticated < 1 || c.max_connections_per_address < 1)
      throw InputError("the connection limits (--max-connections, --max-unauthenticated, "
                       "--max-per-address) must be at least 1");

    // Signals go to a thread of their own, which stops the daemon cleanly (checkpoints first).
    sigset_t set;
    sigemptyset(&set);
    sigaddset(&set, SIGINT);
    sigaddset(&set, SIGTERM);
    pthread_sigmask(SIG_BLOCK, &set, nullptr);
    daemon::Daemon d(c);
    d.start();
    if (d.web_port()) {
      // What the user needs for a phone: the URL (its fragment holds the device's token and
      // never leaves the phone) and the same as a QR code to scan.
      std::printf("arlightd: phone page %s\n", d.phone_url().c_str());
      std::printf(
          "%s", daemon::qr_terminal(daemon::qr_modules(d.phone_url()), isatty(fileno(stdout)) != 0)
                    .c_str());
      if (c.tls_cert.empty())
        std::printf("arlightd: the web port's certificate is %s, self-signed: a phone asks to "
                    "accept it once\n",
                    d.web_certificate().c_str());
    }
    std::printf("arlightd: listening on %s:%u, admin on %u, web on %u%s\n", c.listen_host.c_str(),
                unsigned(d.port()), unsigned(d.admin_port()), unsigned(d.web_port()),
                c.tls_cert.empty() ? "" : ", TLS");
    if (d.admin_port())
      std::printf("arlightd: admin token in %s (/sessions needs 'Authorization: Bearer TOKEN')\n",
                  d.admin_token_file().c_str());
    std::fflush(stdout);
    std::thread signals([&] {
      int sig = 0;
      sigwait(&set, &sig);
      spdlog::info("signal {}: stopping", sig);
      d.stop();
    });
    d.wait();
    signals.detach();
    return 0;
  } catch (const InputError& e) {
    std::fprintf(stderr, "arlightd: bad input: %s\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "arlightd: error: %s\n", e.what());
    return 1;
  }
}
