// Per-device tokens: a file of "<device-id> <token>" lines, '#' comments, and "<name> <token>
// watch" lines: a watch-only token, which may watch any live session of this server (Hello's
// watch_session) but capture none. A device's own token watches that device's sessions. Tokens
// are compared in constant time, so a client cannot learn a token byte by byte from response
// times.
#pragma once

#include <filesystem>
#include <map>
#include <string>

namespace arlight::daemon {

class TokenStore {
 public:
  // InputError naming the file and line for anything but blank, comment, device or watch
  // lines, duplicate names, an empty file and one without a device.
  static TokenStore load(const std::filesystem::path& path);
  enum class Access { None, Device, WatchOnly };
  Access access(const std::string& device_id, const std::string& token) const;
  // A device that may capture.
  bool check(const std::string& device_id, const std::string& token) const {
    return access(device_id, token) == Access::Device;
  }
  std::size_t size() const { return tokens_.size(); }
  // For the phone page's URL: the first capturing device id (in sorted order) and a device's
  // token.
  const std::string& first_device() const { return first_device_; }
  const std::string* token_of(const std::string& device_id) const {
    const auto it = tokens_.find(device_id);
    return it == tokens_.end() ? nullptr : &it->second.token;
  }

 private:
  struct Entry {
    std::string token;
    bool watch_only = false;
  };
  std::map<std::string, Entry> tokens_;
  std::string first_device_;
};

// The admin port's bearer token: the first line of `path` that is not blank or a '#' comment,
// at least 16 characters of visible ASCII and nothing else on the line. When the file does not
// exist and `create_if_missing` is set, a fresh token (32 bytes from OpenSSL's RAND_bytes, as
// hex) is written there with mode 0600 and returned; `created` says so. InputError naming the
// file otherwise.
std::string load_admin_token(const std::filesystem::path& path, bool create_if_missing,
                             bool* created = nullptr);

}  // namespace arlight::daemon
