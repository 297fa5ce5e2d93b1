// Flag groups the programs share, spelled once: how a program that talks to arlightd connects
// (arlight-client, arlight-replay, arlight-load).
#pragma once

#include <CLI/CLI.hpp>

#include "arlight/net/client_net.hpp"

namespace arlight::tools {

struct ConnectionFlags {
  client::TlsOptions tls;
  bool websocket = false;

  // --tls and --tls-ca; with `websocket_flag`, --websocket too (the programs that speak to the
  // web port as the browser client does).
  void add_to(CLI::App& app, bool websocket_flag = true) {
    app.add_flag("--tls", tls.enabled, "connect with TLS (trusting the system's CAs)");
    app.add_option("--tls-ca", tls.ca_file, "connect with TLS, trusting this PEM CA/certificate");
    if (websocket_flag)
      app.add_flag("--websocket", websocket,
                   "connect to arlightd's web port (--server HOST:WEBPORT) over wss://.../ws, as "
                   "the browser client does (with --tls-ca for a self-signed certificate)");
  }
  // A protocol client set up to connect so.
  void apply(client::Client& c) const {
    c.use_tls(tls);
    c.use_websocket(websocket);
  }
};

}  // namespace arlight::tools
