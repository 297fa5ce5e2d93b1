// arlightd: the lighting daemon. Phones and webcams connect over TCP (protocol/PROTOCOL.md),
// stream frames and orientation, and get live SH after every frame and map sets (irradiance and
// reflection maps) in the background while they capture. Sessions checkpoint to the data
// folder and can be resumed after a disconnect or a restart.
#pragma once

#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "arlight/capture/fill.hpp"
#include "arlight/protocol/wire.hpp"

namespace arlight::daemon {

struct DaemonConfig {
  std::string listen_host = "127.0.0.1";
  std::uint16_t listen_port = 7878;  // 0: an ephemeral port (tests)
  std::string admin_host = "127.0.0.1";
  std::uint16_t admin_port = 7879;  // 0: ephemeral
  bool admin_enabled = true;
  // The admin port's bearer token for /sessions and /sessions/<id>/... (a room's picture): read
  // from this file; empty: DATA/admin.token, made with a fresh random token (mode 0600) when
  // missing. admin_protect_all: /healthz and /metrics need it too.
  std::filesystem::path admin_token_file;
  bool admin_protect_all = false;
  std::filesystem::path data_dir = "arlight-data";
  std::filesystem::path tokens_file;  // required: "<device-id> <token>" lines
  // TLS on the client port (both PEM files, or neither for plain TCP): the certificate chain
  // and its private key. The admin port stays plain HTTP on loopback.
  std::filesystem::path tls_cert, tls_key;
  // The web port (HTTPS): the browser client for phones and its WebSocket endpoint /ws. Served
  // with tls_cert/tls_key, or without them a self-signed certificate kept in DATA/tls/.
  bool web_enabled = false;
  std::string web_host = "0.0.0.0";
  std::uint16_t web_port = 8443;  // 0: ephemeral
  std::filesystem::path web_root;  // the client's files; empty: beside the executable
  std::string web_device;          // the device whose token the phone URL carries; empty: first
  std::string web_url_host;        // the host in that URL; empty: this machine's LAN address
  // Where clients reach this daemon (HOST:PORT), written into the lease of every session it
  // holds, so that another daemon on the same data folder sends a watcher or a contributor that
  // a balancer brought it here (Error{Moved}, issue 49 §2). "auto": the client port's own
  // address (a LAN address when it listens on all), and the web port's as the phone URL names
  // it; empty: none (such a client is told SessionNotFound).
  std::string advertise = "auto";
  std::string advertise_web = "auto";
  int threads = 0;                    // network threads; 0: hardware concurrency
  int workers = 0;                    // frame-processing threads; 0: hardware concurrency
  int max_sessions = 32;              // live sessions at once
  int max_watchers = 32;              // devices watching one session at once
  int max_contributors = 4;           // other devices capturing into one session (issue 49)
  // A session without a connection, or a connected one that sent nothing, for this long is
  // closed (kept on disk for a resume).
  double idle_timeout_s = 300;
  // Connections (the client port and every connection to the web port together: plain HTTPS
  // counts as "before its Hello" until it closes or becomes a /ws session): a Hello within
  // hello_timeout_s of connecting, and at most this many at once in all, before their Hello, and
  // from one address.
  // Over a limit a new connection is closed at once (counted on /metrics, logged).
  double hello_timeout_s = 5;
  int max_connections = 256;
  int max_unauthenticated = 64;
  int max_connections_per_address = 64;
  double checkpoint_interval_s = 2;
  // The capture map's resolution as an angle map's N; sessions capture into a cube map with
  // about as many texels (capture::capture_layout_for: face 3N/8), whose texels cover nearly
  // the same solid angle wherever the camera looks. Checkpoints of other layouts are converted.
  int map_size = 512;
  // What a session's map holds where no frame has looked yet: the estimate from what was seen
  // (its live SH and map sets light objects right from the first frames) or black (none).
  capture::Fill fill = capture::Fill::Estimate;
  // Feature alignment on every n-th frame of a session, on the frame reduced to at most
  // align_max_width (the drift model extrapolates in between): at 30 fps, every 4th frame at
  // 160 pixels keeps a 0.5 deg/s drift to ~0.34 deg RMS (0.32 every 3rd, 0.48 every 6th; a
  // 640x480 city sweep, bench/RESULTS.md), measured on another thread so the live path never
  // stalls behind an alignment.
  int align_every = 4;
  int align_max_width = 160;
  // Frames of one session that may wait for a worker; when full, a new frame drops the oldest
  // waiting one (counted and reported). 1: only the newest frame ever waits.
  int queue_depth = 2;
  // A session's map sets follow its map: a new one starts as soon as a frame has changed the
  // map and the last one is done, but no sooner than this after the last one started (issue 16
  // §3; 0: back to back).
  double map_interval_s = 0.09;
  wire::WireLimits limits;
  std::size_t max_send_queue_bytes = 64u << 20;  // a client slower than this is disconnected
};

// Reads a JSON config file over `config`: its keys are the options' (server/daemon/src/
// options.cpp: listen, admin, data_dir, tokens, threads, map_size, fill, web, ...). InputError
// names the file and key.
void load_config_file(const std::filesystem::path& path, DaemonConfig& config);
// The checks arlightd makes of its whole config before it starts (InputError naming the
// option): a tokens file, the queue depth in [1, 64], the map interval in [0, 3600] s, positive
// timeouts and connection limits.
void check_config(const DaemonConfig& config);

class Daemon {
 public:
  // Loads the tokens and binds the ports (InputError / std::runtime_error naming what failed).
  explicit Daemon(DaemonConfig config);
  ~Daemon();
  Daemon(const Daemon&) = delete;
  Daemon& operator=(const Daemon&) = delete;

  void start();  // runs the network and worker threads
  // Closes everything and checkpoints every session; returns once that is done, whichever
  // thread does it (never call it from the daemon's own threads).
  void stop();
  void wait();   // until stop() (e.g. from a signal handler thread)
  std::uint16_t port() const;
  std::uint16_t admin_port() const;  // 0 when disabled
  // The file the admin token was read from (or written to); empty when the admin port is off.
  std::filesystem::path admin_token_file() const;
  std::uint16_t web_port() const;    // 0 when disabled
  // The phone page's URL with the device id and token in its fragment; empty when no web port.
  std::string phone_url() const;
  // The certificate the web port serves (the self-signed one, or tls_cert).
  std::filesystem::path web_certificate() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace arlight::daemon
