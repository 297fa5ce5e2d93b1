#include "tokens.hpp"

#include <openssl/crypto.h>

#include <fstream>
#include <sstream>

#include "arlight/error.hpp"

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
    std::string device, token, extra;
    if (!(fields >> device)) continue;  // blank or comment
    if (!(fields >> token) || (fields >> extra))
      throw InputError(where + ": line " + std::to_string(n) + ": expected '<device-id> <token>'");
    if (token.size() < 8)
      throw InputError(where + ": line " + std::to_string(n) + ": token shorter than 8 characters");
    if (!store.tokens_.emplace(device, token).second)
      throw InputError(where + ": line " + std::to_string(n) + ": device '" + device +
                       "' listed twice");
  }
  if (store.tokens_.empty()) throw InputError(where + ": no tokens in it");
  return store;
}

bool TokenStore::check(const std::string& device_id, const std::string& token) const {
  const auto it = tokens_.find(device_id);
  // Compare against something of the same length even for unknown devices, so the time does
  // not tell which device ids exist.
  const std::string& expected = it != tokens_.end() ? it->second : std::string(token.size(), '\0');
  const bool same_length = expected.size() == token.size();
  const std::string& probe = same_length ? token : expected;
  const bool equal = CRYPTO_memcmp(expected.data(), probe.data(), expected.size()) == 0;
  return it != tokens_.end() && same_length && equal;
}

}  // namespace arlight::daemon
