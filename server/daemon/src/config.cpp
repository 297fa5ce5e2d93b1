#include <fstream>
#include <nlohmann/json.hpp>

#include "arlight/daemon.hpp"
#include "arlight/error.hpp"

namespace arlight::daemon {

void load_config_file(const std::filesystem::path& path, DaemonConfig& c) {
  const std::string where = "config '" + path.string() + "'";
  std::ifstream in(path);
  if (!in) throw InputError(where + ": cannot read it");
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(in);
  } catch (const nlohmann::json::exception& e) {
    throw InputError(where + ": not JSON: " + e.what());
  }
  if (!j.is_object()) throw InputError(where + ": expected a JSON object");
  for (const auto& [key, value] : j.items()) {
    try {
      if (key == "listen")
        wire::parse_endpoint(value.get<std::string>(), c.listen_host, c.listen_port);
      else if (key == "admin") {
        const std::string a = value.get<std::string>();
        c.admin_enabled = !a.empty();
        if (c.admin_enabled) wire::parse_endpoint(a, c.admin_host, c.admin_port);
      } else if (key == "admin_token_file")
        c.admin_token_file = value.get<std::string>();
      else if (key == "admin_protect_all")
        c.admin_protect_all = value.get<bool>();
      else if (key == "data_dir")
        c.data_dir = value.get<std::string>();
      else if (key == "tokens")
        c.tokens_file = value.get<std::string>();
      else if (key == "threads")
        c.threads = value.get<int>();
      else if (key == "workers")
        c.workers = value.get<int>();
      else if (key == "max_sessions")
        c.max_sessions = value.get<int>();
      else if (key == "idle_timeout_s")
        c.idle_timeout_s = value.get<double>();
      else if (key == "hello_timeout_s")
        c.hello_timeout_s = value.get<double>();
      else if (key == "max_connections")
        c.max_connections = value.get<int>();
      else if (key == "max_unauthenticated")
        c.max_unauthenticated = value.get<int>();
      else if (key == "max_connections_per_address")
        c.max_connections_per_address = value.get<int>();
      else if (key == "checkpoint_interval_s")
        c.checkpoint_interval_s = value.get<double>();
      else if (key == "map_size")
        c.map_size = value.get<int>();
      else if (key == "fill")
        c.fill = capture::fill_from_name(value.get<std::string>(), "");
      else if (key == "align_every")
        c.align_every = value.get<int>();
      else if (key == "queue_depth")
        c.queue_depth = value.get<int>();
      else if (key == "map_interval_s")
        c.map_interval_s = value.get<double>();
      else if (key == "tls_cert")
        c.tls_cert = value.get<std::string>();
      else if (key == "tls_key")
        c.tls_key = value.get<std::string>();
      else if (key == "web") {
        const std::string w = value.get<std::string>();
        c.web_enabled = !w.empty();
        if (c.web_enabled) wire::parse_endpoint(w, c.web_host, c.web_port);
      } else if (key == "web_root")
        c.web_root = value.get<std::string>();
      else if (key == "web_device")
        c.web_device = value.get<std::string>();
      else if (key == "web_url_host")
        c.web_url_host = value.get<std::string>();
      else
        throw InputError("unknown key");
    } catch (const nlohmann::json::exception& e) {
      throw InputError(where + ": " + key + ": " + e.what());
    } catch (const InputError& e) {
      throw InputError(where + ": " + key + ": " + e.what());
    }
  }
}

}  // namespace arlight::daemon
