// arlightd: the lighting daemon (see README.md and protocol/PROTOCOL.md).
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <csignal>
#include <cstdio>
#include <thread>

#include "arlight/common/error.hpp"
#include "options.hpp"
#include "phone_link.hpp"

using namespace arlight;

namespace {

// What the user needs on stdout: the phone's URL (its fragment holds the device's token and
// never leaves the phone) and the same as a QR code to scan, then the one "listening" line.
void print_addresses(const daemon::Daemon& d, const daemon::DaemonConfig& c) {
  if (d.web_port()) {
    std::printf("arlightd: phone page %s\n", d.phone_url().c_str());
    std::printf("%s",
                daemon::qr_terminal(daemon::qr_modules(d.phone_url()), isatty(fileno(stdout)) != 0)
                    .c_str());
    if (c.tls_cert.empty())
      std::printf(
          "arlightd: the web port's certificate is %s, self-signed: a phone asks to "
          "accept it once\n",
          d.web_certificate().c_str());
  }
  std::printf("arlightd: listening on %s:%u, admin on %u, web on %u%s\n", c.listen_host.c_str(),
              unsigned(d.port()), unsigned(d.admin_port()), unsigned(d.web_port()),
              c.tls_cert.empty() ? "" : ", TLS");
  if (d.admin_port())
    std::printf("arlightd: admin token in %s (/sessions needs 'Authorization: Bearer TOKEN')\n",
                d.admin_token_file().c_str());
}

}  // namespace

int main(int argc, char** argv) {
  // A peer or a log reader that goes away must not kill the daemon: writes then fail with
  // EPIPE instead of raising SIGPIPE. Logs go to stderr; stdout carries the one "listening" line.
  std::signal(SIGPIPE, SIG_IGN);
  spdlog::set_default_logger(spdlog::stderr_color_mt("arlightd"));
  CLI::App app{
      "arlightd: builds HDR environment maps from phones' and webcams' frames and "
      "streams lighting back"};
  daemon::CommandLine command_line(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  try {
    const daemon::DaemonConfig c = command_line.config();

    // Signals go to a thread of their own, which stops the daemon cleanly (checkpoints first).
    sigset_t set;
    sigemptyset(&set);
    sigaddset(&set, SIGINT);
    sigaddset(&set, SIGTERM);
    pthread_sigmask(SIG_BLOCK, &set, nullptr);
    daemon::Daemon d(c);
    d.start();
    print_addresses(d, c);
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
