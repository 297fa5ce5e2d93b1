// Per-device tokens: a file of "<device-id> <token>" lines, '#' comments. Tokens are compared in
// constant time, so a client cannot learn a token byte by byte from response times.
#pragma once

#include <filesystem>
#include <map>
#include <string>

namespace arlight::daemon {

class TokenStore {
 public:
  // InputError naming the file and line for anything but blank, comment or two-field lines,
  // duplicate devices and an empty file.
  static TokenStore load(const std::filesystem::path& path);
  bool check(const std::string& device_id, const std::string& token) const;
  std::size_t size() const { return tokens_.size(); }
  // For the phone page's URL: the first device id (in sorted order) and a device's token.
  const std::string& first_device() const { return tokens_.begin()->first; }
  const std::string* token_of(const std::string& device_id) const {
    const auto it = tokens_.find(device_id);
    return it == tokens_.end() ? nullptr : &it->second;
  }

 private:
  std::map<std::string, std::string> tokens_;
};

// The admin port's bearer token: the first line of `path` that is not blank or a '#' comment,
// at least 16 characters of visible ASCII and nothing else on the line. When the file does not
// exist and `create_if_missing` is set, a fresh token (32 bytes from OpenSSL's RAND_bytes, as
// hex) is written there with mode 0600 and returned; `created` says so. InputError naming the
// file otherwise.
std::string load_admin_token(const std::filesystem::path& path, bool create_if_missing,
                             bool* created = nullptr);

}  // namespace arlight::daemon
