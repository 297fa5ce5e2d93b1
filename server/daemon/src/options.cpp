#include "options.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <fstream>

#include "arlight/common/error.hpp"

namespace arlight::daemon {

namespace {

using json = nlohmann::json;
using Value = DaemonOption::Value;

// HOST:PORT, or '' for off.
void set_endpoint(const json& v, bool& enabled, std::string& host, std::uint16_t& port) {
  const std::string text = v.get<std::string>();
  enabled = !text.empty();
  if (enabled) wire::parse_endpoint(text, host, port);
}

// An --advertise value: "auto", '' or a HOST:PORT with both (apply() names the flag or key).
std::string advertised_endpoint(const json& v) {
  const std::string text = v.get<std::string>();
  if (text.empty() || text == "auto") return text;
  std::string host;
  std::uint16_t port = 0;
  wire::parse_endpoint(text, host, port);
  if (port == 0) throw InputError("'" + text + "': port 0 cannot be reached");
  return text;
}

// The text flags whose '' means something (the others given as '' leave their option as is).
constexpr std::string_view kFlagsWhereEmptyCounts[] = {"--admin", "--fill", "--advertise",
                                                       "--advertise-web"};

// The table. Flags first as --help lists them; map_size is the config file's alone.
const DaemonOption kOptions[] = {
    {"--listen", "listen", Value::Text, "HOST:PORT for clients (default 127.0.0.1:7878)",
     [](DaemonConfig& c, const json& v) {
       wire::parse_endpoint(v.get<std::string>(), c.listen_host, c.listen_port);
     }},
    {"--admin", "admin", Value::Text,
     "HOST:PORT of the admin HTTP server (default 127.0.0.1:7879; '' off)",
     [](DaemonConfig& c, const json& v) {
       set_endpoint(v, c.admin_enabled, c.admin_host, c.admin_port);
     }},
    {"--admin-token-file", "admin_token_file", Value::Text,
     "the admin port's bearer token for /sessions (default DATA/admin.token, made when missing)",
     [](DaemonConfig& c, const json& v) { c.admin_token_file = v.get<std::string>(); }},
    {"--admin-protect-all", "admin_protect_all", Value::Switch,
     "/healthz and /metrics need the admin token too",
     [](DaemonConfig& c, const json& v) { c.admin_protect_all = v.get<bool>(); }},
    {"--data-dir", "data_dir", Value::Text, "where sessions and response curves are kept",
     [](DaemonConfig& c, const json& v) { c.data_dir = v.get<std::string>(); }},
    {"--tokens", "tokens", Value::Text, "file of '<device-id> <token>' lines",
     [](DaemonConfig& c, const json& v) { c.tokens_file = v.get<std::string>(); }},
    {"--threads", "threads", Value::Integer, "network threads (0: one per core)",
     [](DaemonConfig& c, const json& v) { c.threads = v.get<int>(); }},
    {"--workers", "workers", Value::Integer, "frame-processing threads (0: one per core)",
     [](DaemonConfig& c, const json& v) { c.workers = v.get<int>(); }},
    {"--max-sessions", "max_sessions", Value::Integer, "live sessions at once",
     [](DaemonConfig& c, const json& v) { c.max_sessions = v.get<int>(); }},
    {"--max-watchers", "max_watchers", Value::Integer,
     "devices watching one session at once (Hello's watch_session; default 32)",
     [](DaemonConfig& c, const json& v) { c.max_watchers = v.get<int>(); }},
    {"--max-contributors", "max_contributors", Value::Integer,
     "other devices capturing into one session at once (Hello's join_session; default 4)",
     [](DaemonConfig& c, const json& v) { c.max_contributors = v.get<int>(); }},
    {"--idle-timeout", "idle_timeout_s", Value::Number,
     "seconds before a session with no connection, or no traffic, closes (kept on disk for a "
     "resume)",
     [](DaemonConfig& c, const json& v) { c.idle_timeout_s = v.get<double>(); }},
    {"--hello-timeout", "hello_timeout_s", Value::Number,
     "seconds a new connection has to send its Hello (default 5)",
     [](DaemonConfig& c, const json& v) { c.hello_timeout_s = v.get<double>(); }},
    {"--max-connections", "max_connections", Value::Integer,
     "client connections at once, TCP and WebSocket (default 256)",
     [](DaemonConfig& c, const json& v) { c.max_connections = v.get<int>(); }},
    {"--max-unauthenticated", "max_unauthenticated", Value::Integer,
     "connections that have not sent their Hello yet (default 64)",
     [](DaemonConfig& c, const json& v) { c.max_unauthenticated = v.get<int>(); }},
    {"--max-per-address", "max_connections_per_address", Value::Integer,
     "connections from one address (default 64)",
     [](DaemonConfig& c, const json& v) { c.max_connections_per_address = v.get<int>(); }},
    {"--checkpoint-interval", "checkpoint_interval_s", Value::Number,
     "seconds between checkpoints of a changing session: at most this much capture is lost when "
     "the daemon dies (default 2; 1 behind a balancer)",
     [](DaemonConfig& c, const json& v) { c.checkpoint_interval_s = v.get<double>(); }},
    {"", "map_size", Value::Integer, "the capture map's resolution as an angle map's N",
     [](DaemonConfig& c, const json& v) { c.map_size = v.get<int>(); }},
    {"--fill", "fill", Value::Text,
     "what a session's map holds where no frame has looked yet: estimate (from what was seen, "
     "default), mean or none (black)",
     [](DaemonConfig& c, const json& v) {
       c.fill = capture::fill_from_name(v.get<std::string>(), "");
     }},
    {"--align-every", "align_every", Value::Integer,
     "feature alignment on every n-th frame of a session (default 4)",
     [](DaemonConfig& c, const json& v) { c.align_every = v.get<int>(); }},
    {"--queue-depth", "queue_depth", Value::Integer,
     "frames of a session that may wait; a newer one drops the oldest (default 2)",
     [](DaemonConfig& c, const json& v) { c.queue_depth = v.get<int>(); }},
    {"--map-interval", "map_interval_s", Value::Number,
     "seconds between the starts of a session's map sets while its map changes (default 0.09: "
     "a set at least every 0.1 s; 0: each as soon as the last is done)",
     [](DaemonConfig& c, const json& v) { c.map_interval_s = v.get<double>(); }},
    {"--tls-cert", "tls_cert", Value::Text, "TLS: certificate chain (PEM) for the client port",
     [](DaemonConfig& c, const json& v) { c.tls_cert = v.get<std::string>(); }},
    {"--tls-key", "tls_key", Value::Text, "TLS: private key (PEM) of that certificate",
     [](DaemonConfig& c, const json& v) { c.tls_key = v.get<std::string>(); }},
    {"--web", "web", Value::Text,
     "HOST:PORT of the web port for phones (HTTPS: the browser client and /ws), e.g. "
     "0.0.0.0:8443; off by default",
     [](DaemonConfig& c, const json& v) {
       set_endpoint(v, c.web_enabled, c.web_host, c.web_port);
     }},
    {"--web-root", "web_root", Value::Text,
     "the browser client's files (default: web/ beside arlightd, or ../share/arlight/web)",
     [](DaemonConfig& c, const json& v) { c.web_root = v.get<std::string>(); }},
    {"--web-device", "web_device", Value::Text,
     "the device whose id and token the phone URL carries (default: the first in the tokens "
     "file)",
     [](DaemonConfig& c, const json& v) { c.web_device = v.get<std::string>(); }},
    {"--web-url-host", "web_url_host", Value::Text,
     "the host name or address in the phone URL (default: this machine's LAN address)",
     [](DaemonConfig& c, const json& v) { c.web_url_host = v.get<std::string>(); }},
    {"--advertise", "advertise", Value::Text,
     "HOST:PORT clients reach this daemon's client port at, for daemons sharing its data folder "
     "to send them here (default auto: the port's own address; '' none)",
     [](DaemonConfig& c, const json& v) { c.advertise = advertised_endpoint(v); }},
    {"--advertise-web", "advertise_web", Value::Text,
     "the same for the web port (default auto: the phone URL's host and the port; '' none)",
     [](DaemonConfig& c, const json& v) { c.advertise_web = advertised_endpoint(v); }},
};

// A flag's text as the JSON value its option takes.
json flag_value(const DaemonOption& o, const std::string& text) {
  switch (o.value) {
    case Value::Text:
      return text;
    case Value::Switch:
      return true;
    case Value::Integer: {
      int v = 0;
      const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
      if (ec != std::errc() || end != text.data() + text.size() || text.empty())
        throw InputError("'" + text + "' is not a whole number");
      return v;
    }
    case Value::Number: {
      std::size_t used = 0;
      double v = 0;
      try {
        v = std::stod(text, &used);
      } catch (const std::exception&) {
        used = 0;
      }
      if (used == 0 || used != text.size() || !std::isfinite(v))
        throw InputError("'" + text + "' is not a number");
      return v;
    }
  }
  return nullptr;
}

// Runs an option's setter; InputError names `where` and what was wrong.
void apply(const DaemonOption& o, DaemonConfig& c, const json& value, const std::string& where) {
  try {
    o.set(c, value);
  } catch (const json::exception& e) {
    throw InputError(where + ": " + e.what());
  } catch (const InputError& e) {
    throw InputError(where + ": " + e.what());
  }
}

}  // namespace

std::span<const DaemonOption> daemon_options() { return kOptions; }

void load_config_file(const std::filesystem::path& path, DaemonConfig& c) {
  const std::string where = "config '" + path.string() + "'";
  std::ifstream in(path);
  if (!in) throw InputError(where + ": cannot read it");
  json j;
  try {
    j = json::parse(in);
  } catch (const json::exception& e) {
    throw InputError(where + ": not JSON: " + e.what());
  }
  if (!j.is_object()) throw InputError(where + ": expected a JSON object");
  for (const auto& [key, value] : j.items()) {
    const DaemonOption* option = nullptr;
    for (const DaemonOption& o : kOptions)
      if (!o.key.empty() && o.key == key) option = &o;
    if (!option) throw InputError(where + ": " + key + ": unknown key");
    apply(*option, c, value, where + ": " + key);
  }
}

void check_config(const DaemonConfig& c) {
  if (c.tokens_file.empty()) throw InputError("--tokens FILE is required");
  if (c.queue_depth < 1 || c.queue_depth > 64)
    throw InputError("queue depth " + std::to_string(c.queue_depth) + " is not in [1, 64]");
  if (!(c.map_interval_s >= 0 && c.map_interval_s <= 3600))
    throw InputError("map interval " + std::to_string(c.map_interval_s) + " s is not in [0, 3600]");
  if (!(c.hello_timeout_s > 0) || !(c.idle_timeout_s > 0))
    throw InputError("the Hello and idle timeouts must be positive seconds");
  if (c.max_watchers < 0 || c.max_watchers > 4096)
    throw InputError("--max-watchers " + std::to_string(c.max_watchers) + " is not in [0, 4096]");
  if (c.max_contributors < 0 || c.max_contributors > 64)
    throw InputError("--max-contributors " + std::to_string(c.max_contributors) +
                     " is not in [0, 64]");
  if (c.max_connections < 1 || c.max_unauthenticated < 1 || c.max_connections_per_address < 1)
    throw InputError(
        "the connection limits (--max-connections, --max-unauthenticated, --max-per-address) "
        "must be at least 1");
}

CommandLine::CommandLine(CLI::App& app)
    : app_(app),
      texts_(std::size(kOptions)),
      switches_(std::make_unique<bool[]>(std::size(kOptions))) {
  app.add_option("--config", config_file_, "JSON config file (flags given here override it)");
  for (std::size_t i = 0; i < std::size(kOptions); ++i) {
    const DaemonOption& o = kOptions[i];
    if (o.flag.empty()) continue;
    const std::string flag(o.flag), help(o.help);
    if (o.value == Value::Switch)
      app.add_flag(flag, switches_[i], help);
    else
      app.add_option(flag, texts_[i], help)
          ->type_name(o.value == Value::Integer  ? "INT"
                      : o.value == Value::Number ? "FLOAT"
                                                 : "TEXT");
  }
}

DaemonConfig CommandLine::config() const {
  DaemonConfig c;
  if (!config_file_.empty()) load_config_file(config_file_, c);
  // Flags override the file. A flag given as '' leaves its option as the file (or the default)
  // has it, but for those whose '' means something: --admin '' turns the admin port off,
  // --advertise(-web) '' advertises nothing, and --fill '' is refused.
  for (std::size_t i = 0; i < std::size(kOptions); ++i) {
    const DaemonOption& o = kOptions[i];
    const std::string flag(o.flag);
    if (o.flag.empty() || app_.count(flag) == 0) continue;
    if (o.value == Value::Text && texts_[i].empty() &&
        std::find(std::begin(kFlagsWhereEmptyCounts), std::end(kFlagsWhereEmptyCounts), o.flag) ==
            std::end(kFlagsWhereEmptyCounts))
      continue;
    json value;
    try {
      value = flag_value(o, texts_[i]);
    } catch (const InputError& e) {
      throw InputError(flag + ": " + e.what());
    }
    apply(o, c, value, flag);
  }
  check_config(c);
  return c;
}

}  // namespace arlight::daemon
