#include "tokens.hpp"

#include <fcntl.h>
#include <stdlib.h>
#include <openssl/crypto.h>
#include <openssl/rand.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <cstring>
#include <stdexcept>
#include <fstream>
#include <sstream>

#include "arlight/common/error.hpp"

namespace arlight::daemon {

TokenStore TokenStore::load(const std::filesystem::path& path) {
  const std::string where = "tokens file '" + path.string() + "'";
  std::ifstream in(path);
  if (!in) throw InputError(where + ": cannot read it");
  TokenStore store;
  std::string line;
  for (int n = 1; std::getline(in, line); ++n) {
    const auto hash = line.find('#');
    if (hash != std::string::npos) line.resize(hash);
    std::istringstream fields(line);
    std::string device, token, role, extra;
    if (!(fields >> device)) continue;  // blank or comment
    const std::string line_no = where + ": line " + std::to_string(n);
    if (!(fields >> token) || ((fields >> role) && role != "watch") || (fields >> extra))
      throw InputError(line_no + ": expected '<device-id> <token>' or '<name> <token> watch'");
    if (token.size() < 8) throw InputError(line_no + ": token shorter than 8 characters");
    if (!store.tokens_.emplace(device, Entry{token, role == "watch"}).second)
      throw InputError(line_no + ": device '" + device + "' listed twice");
  }
  if (store.tokens_.empty()) throw InputError(where + ": no tokens in it");
  for (const auto& [device, entry] : store.tokens_)  // in sorted order
    if (!entry.watch_only) {
      store.first_device_ = device;
      return store;
    }
  throw InputError(where + ": only watch tokens in it (no device could capture)");
}

TokenStore::Access TokenStore::access(const std::string& device_id,
                                      const std::string& token) const {
  const auto it = tokens_.find(device_id);
  // Compare against something of the same length even for unknown devices, so the time does
  // not tell which device ids exist.
  const std::string& expected =
      it != tokens_.end() ? it->second.token : std::string(token.size(), '\0');
  const bool same_length = expected.size() == token.size();
  const std::string& probe = same_length ? token : expected;
  const bool equal = CRYPTO_memcmp(expected.data(), probe.data(), expected.size()) == 0;
  if (it == tokens_.end() || !same_length || !equal) return Access::None;
  return it->second.watch_only ? Access::WatchOnly : Access::Device;
}

namespace {

std::string random_hex_token() {
  std::array<unsigned char, 32> bytes;
  if (RAND_bytes(bytes.data(), int(bytes.size())) != 1)
    throw std::runtime_error("OpenSSL could not make random bytes for the admin token");
  static constexpr char kHex[] = "0123456789abcdef";
  std::string hex;
  for (unsigned char b : bytes) {
    hex += kHex[b >> 4];
    hex += kHex[b & 15];
  }
  return hex;
}

// Publishes `text` at `path` with mode 0600 unless a file is there already: written in full to
// a temporary first, then hard-linked into place, so daemons sharing a data folder never see a
// half-written token and the first one's token wins. False when `path` already existed.
bool create_private_file(const std::filesystem::path& path, const std::string& text) {
  const std::string where = "admin token file '" + path.string() + "'";
  std::string tmp = path.string() + ".XXXXXX";
  const int fd = ::mkostemp(tmp.data(), O_CLOEXEC);  // mode 0600, a name of its own
  if (fd < 0) throw InputError(where + ": cannot create it: " + std::strerror(errno));
  const bool written = ::write(fd, text.data(), text.size()) == ssize_t(text.size()) &&
                       ::fsync(fd) == 0;
  const bool closed = ::close(fd) == 0;
  const int linked = written && closed ? ::link(tmp.c_str(), path.c_str()) : -1;
  const int link_errno = errno;
  ::unlink(tmp.c_str());
  if (linked == 0) return true;
  if (written && closed && link_errno == EEXIST) return false;
  throw InputError(where + ": cannot write it: " + std::strerror(link_errno));
}

}  // namespace

std::string load_admin_token(const std::filesystem::path& path, bool create_if_missing,
                             bool* created) {
  const std::string where = "admin token file '" + path.string() + "'";
  if (created) *created = false;
  std::error_code ec;
  if (create_if_missing && !std::filesystem::exists(path, ec) && !ec) {
    const std::string token = random_hex_token();
    if (create_private_file(
            path, "# arlightd's admin token: send it as 'Authorization: Bearer <token>'\n" +
                      token + "\n")) {
      if (created) *created = true;
      return token;
    }  // another daemon on this data folder made one first: read that
  }
  std::ifstream in(path);
  if (!in) throw InputError(where + ": cannot read it");
  std::string line;
  for (int n = 1; std::getline(in, line); ++n) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    const auto first = line.find_first_not_of(" \t");
    if (first == std::string::npos || line[first] == '#') continue;
    const auto last = line.find_last_not_of(" \t");
    const std::string token = line.substr(first, last - first + 1);
    for (char c : token) {
      if (c <= ' ' || c > '~')
        throw InputError(where + ": line " + std::to_string(n) +
                         ": a token is one word of visible ASCII characters");
    }
    if (token.size() < 16)
      throw InputError(where + ": line " + std::to_string(n) + ": token shorter than 16 characters");
    return token;
  }
  throw InputError(where + ": no token in it");
}

}  // namespace arlight::daemon
