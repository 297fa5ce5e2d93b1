// arlightd as a child process on loopback for integration tests, and a minimal HTTP GET for
// its admin port. Needs ARLIGHTD_EXE defined to the daemon binary.
#pragma once

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <boost/asio/connect.hpp>
#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/read.hpp>
#include <boost/asio/write.hpp>
#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <regex>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "support/run_tool.hpp"

namespace arlight::test {

namespace fs = std::filesystem;

inline const std::string kToken = "test-token-0123456789";
// Two more lines of every test daemon's tokens file: another device, and a watch-only token.
inline const std::string kOtherDevice = "other-phone", kOtherToken = "other-token-0123456789";
inline const std::string kWatchName = "a-viewer", kWatchToken = "watch-token-0123456789";

std::pair<int, std::string> http_get(std::uint16_t port, const std::string& path,
                                     const std::string& bearer_token = "");

// arlightd as a child process on ephemeral ports; killed (SIGKILL) when destroyed.
class DaemonProcess {
 public:
  // `listen_port` 0: an ephemeral port (a restart can pass the previous one). `data_dir`:
  // the data folder (default dir/data; daemons behind a balancer share one).
  // `host`: the address its client port listens on (a shaped link's, tests/support/shaped_link.sh).
  explicit DaemonProcess(const fs::path& dir, const std::vector<std::string>& extra_args = {},
                         std::uint16_t listen_port = 0, const fs::path& data_dir = {},
                         const std::string& host = "127.0.0.1")
      : host_(host) {
    fs::create_directories(dir);
    data_ = data_dir.empty() ? dir / "data" : data_dir;
    std::ofstream(dir / "tokens") << "# device token\narlight-sim " << kToken << "\n"
                                  << kOtherDevice << " " << kOtherToken << "\n"
                                  << kWatchName << " " << kWatchToken << " watch\n";
    int out[2];
    if (pipe(out) != 0) throw std::runtime_error("pipe");
    pid_ = fork();
    if (pid_ == 0) {
      dup2(out[1], 1);
      close(out[0]);
      std::vector<std::string> args = {ARLIGHTD_EXE,
                                       "--listen",
                                       host + ":" + std::to_string(listen_port),
                                       "--admin",
                                       "127.0.0.1:0",
                                       "--data-dir",
                                       data_.string(),
                                       "--tokens",
                                       (dir / "tokens").string()};
      // Sessions outlive slow tests, unless the test sets its own idle timeout.
      if (std::find(extra_args.begin(), extra_args.end(), "--idle-timeout") == extra_args.end())
        args.insert(args.end(), {"--idle-timeout", "600"});
      args.insert(args.end(), extra_args.begin(), extra_args.end());
      std::vector<char*> argv;
      for (std::string& a : args) argv.push_back(a.data());
      argv.push_back(nullptr);
      execv(ARLIGHTD_EXE, argv.data());
      _exit(127);
    }
    close(out[1]);
    // A line on stdout names the ports ("arlightd: listening on 127.0.0.1:P, admin on A, web
    // on W"); the lines before it (the phone page's URL and QR code) are kept as the banner.
    const std::regex ports(R"(listening on [0-9.]+:(\d+), admin on (\d+), web on (\d+))");
    std::string line, seen;
    std::smatch m;
    char c;
    while (read(out[0], &c, 1) == 1) {
      if (c != '\n') {
        line += c;
        continue;
      }
      if (std::regex_search(line, m, ports)) break;
      seen += line + "\n";
      line.clear();
    }
    close(out[0]);
    if (m.empty()) {
      kill9();
      throw std::runtime_error("arlightd did not start: '" + seen + line + "'");
    }
    port_ = std::uint16_t(std::stoi(m[1])), admin_ = std::uint16_t(std::stoi(m[2]));
    web_ = std::uint16_t(std::stoi(m[3]));
    banner_ = seen;
  }
  ~DaemonProcess() { kill9(); }
  void kill9() {
    if (pid_ > 0) {
      ::kill(pid_, SIGKILL);
      waitpid(pid_, nullptr, 0);
      pid_ = -1;
    }
  }
  std::uint16_t port() const { return port_; }
  std::uint16_t admin() const { return admin_; }
  std::uint16_t web() const { return web_; }  // 0 without --web
  const fs::path& data_dir() const { return data_; }
  pid_t pid() const { return pid_; }
  const std::string& banner() const { return banner_; }
  std::string server() const { return host_ + ":" + std::to_string(port_); }
  // The admin token the daemon made in its data folder (its last line).
  std::string admin_token() const {
    std::ifstream in(data_ / "admin.token");
    std::string line, last;
    while (std::getline(in, line))
      if (!line.empty() && line[0] != '#') last = line;
    return last;
  }
  // A GET on the admin port with the admin token.
  std::pair<int, std::string> admin_get(const std::string& path) const {
    return http_get(admin_, path, admin_token());
  }

 private:
  fs::path data_;
  pid_t pid_ = -1;
  std::string host_;
  std::uint16_t port_ = 0, admin_ = 0, web_ = 0;
  std::string banner_;
};

// 60 frames of venice, 320x240, made once per test process (ctest runs tests in parallel
// processes, so the folder is per process). Needs ARLIGHT_SIM_EXE and ARLIGHT_SOURCE_DIR.
inline const fs::path& daemon_sample_recording() {
  static const fs::path rec = [] {
    const fs::path r = fresh_temp_dir("daemon_rec_" + std::to_string(getpid())) / "rec";
    const auto s =
        run_tool(ARLIGHT_SIM_EXE, "--env " + std::string(ARLIGHT_SOURCE_DIR) +
                                      "/data/probes/venice.exr --out " + r.string() +
                                      " --frames 60 --size 320x240 --seed 4");
    if (s.status != 0) throw std::runtime_error(s.output);
    return r;
  }();
  return rec;
}

// A minimal HTTP/1.0 GET, with "Authorization: Bearer" when a token is given: status code and
// body.
inline std::pair<int, std::string> http_get(std::uint16_t port, const std::string& path,
                                            const std::string& bearer_token) {
  boost::asio::io_context io;
  boost::asio::ip::tcp::socket s(io);
  s.connect({boost::asio::ip::make_address("127.0.0.1"), port});
  const std::string auth =
      bearer_token.empty() ? "" : "Authorization: Bearer " + bearer_token + "\r\n";
  const std::string req = "GET " + path + " HTTP/1.0\r\nHost: localhost\r\n" + auth + "\r\n";
  boost::asio::write(s, boost::asio::buffer(req));
  std::string all;
  boost::system::error_code ec;
  char buf[4096];
  for (;;) {
    const std::size_t n = s.read_some(boost::asio::buffer(buf), ec);
    all.append(buf, n);
    if (ec) break;
  }
  const int status = all.size() > 12 ? std::stoi(all.substr(9, 3)) : -1;
  const auto body = all.find("\r\n\r\n");
  return {status, body == std::string::npos ? "" : all.substr(body + 4)};
}

}  // namespace arlight::test
