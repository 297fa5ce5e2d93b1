// A shaped network link for a test's lifetime (tests/support/shaped_link.sh: a network namespace
// "the phone" joined by a veth pair, tbf each way, nftables packet loss). Needs root and the
// ip, tc and nft commands (deploy/debian-packages.txt).
#pragma once

#include <stdexcept>
#include <string>

#include "support/run_tool.hpp"

namespace arlight::test {

class ShapedLink {
 public:
  // Link number k (1..250: 10.77.k.0/30), rate in Mbit/s each way, loss in percent each way.
  ShapedLink(int k, int rate_mbit, int loss_pct) : k_(k) {
    const RunResult r = run(" up " + std::to_string(k) + " " + std::to_string(rate_mbit) + " " +
                            std::to_string(loss_pct));
    if (r.status != 0) {
      run(" down " + std::to_string(k));  // what was made of it
      throw std::runtime_error("shaped_link.sh up failed: " + r.output);
    }
    const RunResult p = run(" on-phone " + std::to_string(k));
    on_phone_ = p.output.substr(0, p.output.find('\n')) + " ";
  }
  ~ShapedLink() { run(" down " + std::to_string(k_)); }
  ShapedLink(const ShapedLink&) = delete;
  ShapedLink& operator=(const ShapedLink&) = delete;

  // 100: a blackout; back to the link's loss with the same call.
  void set_loss(int loss_pct) const {
    const RunResult r = run(" loss " + std::to_string(k_) + " " + std::to_string(loss_pct));
    if (r.status != 0) throw std::runtime_error("shaped_link.sh loss failed: " + r.output);
  }
  std::string server_address() const { return "10.77." + std::to_string(k_) + ".1"; }
  // The prefix that runs a command on the phone's side of the link (nsenter into its namespace).
  const std::string& on_phone() const { return on_phone_; }

 private:
  static RunResult run(const std::string& args) {
    return run_tool(std::string(ARLIGHT_SOURCE_DIR) + "/tests/support/shaped_link.sh", args);
  }
  int k_;
  std::string on_phone_;
};

}  // namespace arlight::test
