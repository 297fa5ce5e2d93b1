#include "session_opener.hpp"

#include <openssl/rand.h>

#include <algorithm>
#include <filesystem>
#include <stdexcept>

#include "arlight/common/error.hpp"

namespace arlight::daemon {

namespace {

std::string new_session_id() {
  unsigned char bytes[16];
  if (RAND_bytes(bytes, sizeof bytes) != 1)
    throw std::runtime_error("no randomness for a session id");
  static const char* hex = "0123456789abcdef";
  std::string id;
  for (unsigned char b : bytes) id += hex[b >> 4], id += hex[b & 15];
  return id;
}

bool valid_session_id(const std::string& id) {
  return !id.empty() && id.size() <= 64 && std::all_of(id.begin(), id.end(), [](char c) {
    return (c >= '0' && c <= '9') || (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || c == '-';
  });
}

}  // namespace

// The session `id` (a Hello's `field`) when it is live on this daemon; else nullptr with
// BadMessage (not a session id), Moved (live on another daemon of this data folder, whose
// address for a connection like this one — `web`: a WebSocket — is `address`; issue 49 §2)
// or SessionNotFound.
std::shared_ptr<Session> SessionOpener::live_session(const std::string& id, const char* field,
                                                     bool web, wire::ErrorCode& code,
                                                     std::string& why, std::string& address) {
  if (!valid_session_id(id)) {
    code = wire::ErrorCode::BadMessage;
    why = std::string(field) + ": not a session id";
    return nullptr;
  }
  std::shared_ptr<Session> s;
  {
    std::lock_guard lock(env_.sessions_mutex);
    if (const auto it = env_.sessions.find(id); it != env_.sessions.end()) s = it->second;
  }
  if (!s || !s->holds_lease()) {
    code = wire::ErrorCode::SessionNotFound;
    why = "no live session " + id + " on this server";
    // A balancer may have brought the client here: the lease says where the session is.
    const auto holder = SessionLease::live_holder(session_dir(env_.session_env, id));
    if (holder && holder->name != env_.lease_holder.name) {
      address = web ? holder->web_address : holder->address;
      if (!address.empty()) {
        code = wire::ErrorCode::Moved;
        why = "session " + id + " is live on another arlightd (" + holder->name + ") at " +
              address + ": connect there";
        env_.redirected.inc();
      } else {
        why = "session " + id + " is live on another arlightd (" + holder->name +
              "), which advertises no address for " + (web ? "its web port" : "clients");
      }
    }
    return nullptr;
  }
  return s;
}

// A live session of this daemon for a Hello that asks to watch it: a watch-only token may
// watch any, a device's own token that device's sessions.
std::shared_ptr<Session> SessionOpener::watched_session(const wire::Hello& h, bool web,
                                                        wire::ErrorCode& code, std::string& why,
                                                        std::string& address) {
  const TokenStore::Access access = env_.tokens.access(h.device_id, h.auth_token);
  if (access == TokenStore::Access::None) {
    code = wire::ErrorCode::Unauthorized;
    why = "unauthorized: unknown device or wrong token";
    return nullptr;
  }
  const std::shared_ptr<Session> s =
      live_session(h.watch_session, "watch_session", web, code, why, address);
  if (!s) return nullptr;
  if (access == TokenStore::Access::Device && s->device_id() != h.device_id) {
    code = wire::ErrorCode::Unauthorized;
    why = "device " + h.device_id + " may watch only its own sessions (or use a watch token)";
    return nullptr;
  }
  return s;
}

// A live session of this daemon for a Hello that joins it as a contributor (issue 49 §1):
// with the session's own token (the session's device's, whatever device id the contributor
// names for itself: its camera response is that id's), or a join token its device asked for.
std::shared_ptr<Session> SessionOpener::joined_session(const wire::Hello& h, bool web,
                                                       wire::ErrorCode& code, std::string& why,
                                                       std::string& address) {
  if (h.device_id.empty()) {
    code = wire::ErrorCode::BadMessage;
    why = "join_session: the contributor names its own device_id";
    return nullptr;
  }
  const std::shared_ptr<Session> s =
      live_session(h.join_session, "join_session", web, code, why, address);
  if (!s) return nullptr;
  if (!env_.tokens.check(s->device_id(), h.auth_token)) {
    const Session::JoinTokenState t = s->join_token_state(h.auth_token);
    if (t == Session::JoinTokenState::Expired) {
      code = wire::ErrorCode::Unauthorized;
      why = "the join token has expired: ask the session's device for a new link";
      return nullptr;
    }
    if (t != Session::JoinTokenState::Valid) {
      code = wire::ErrorCode::Unauthorized;
      why = "unauthorized: joining session " + h.join_session +
            " takes its token or a join token its device asked for (and still holds)";
      return nullptr;
    }
  }
  return s;
}

std::shared_ptr<Session> SessionOpener::open(const wire::Hello& h, bool web, wire::ErrorCode& code,
                                             std::string& why, std::string& address) {
  if (!h.watch_session.empty()) return watched_session(h, web, code, why, address);
  if (!h.join_session.empty()) return joined_session(h, web, code, why, address);
  const std::string& device = h.device_id;
  const std::string& token = h.auth_token;
  if (!env_.tokens.check(device, token)) {
    code = wire::ErrorCode::Unauthorized;
    why = "unauthorized: unknown device or wrong token";
    return nullptr;
  }
  const std::string& resume = h.resume_session;
  std::unique_lock lock(env_.sessions_mutex);
  if (!resume.empty()) {
    if (!valid_session_id(resume)) {
      code = wire::ErrorCode::BadMessage;
      why = "resume_session: not a session id";
      return nullptr;
    }
    std::shared_ptr<Session> s;
    if (const auto it = env_.sessions.find(resume); it != env_.sessions.end()) {
      s = it->second;
      // Let go a moment ago (handed over, idle) but not yet out of the map: from disk again.
      if (!s->holds_lease()) env_.sessions.erase(it), s = nullptr;
    }
    if (!s) {
      env_.make_room(lock);
      if (int(env_.sessions.size()) >= env_.max_sessions) {
        code = wire::ErrorCode::Busy;
        why =
            "the server carries its maximum of " + std::to_string(env_.max_sessions) + " sessions";
        return nullptr;
      }
      const auto dir = session_dir(env_.session_env, resume);
      std::error_code exists_ec;
      if (std::filesystem::exists(dir / "session.json", exists_ec)) {
        // Another daemon on this data folder may have it: its lease says (session_lease.hpp).
        std::optional<SessionLease> lease;
        try {
          lease = SessionLease::try_acquire(dir, env_.lease_holder);
        } catch (const std::exception& e) {
          code = wire::ErrorCode::Internal;
          why = e.what();
          return nullptr;
        }
        if (!lease) {
          SessionLease::request_release(dir, env_.lease_holder.name);
          env_.takeover_waits.inc();
          code = wire::ErrorCode::Busy;
          why = "session " + resume + " is open on another arlightd (" +
                SessionLease::owner_of(dir) +
                "), which was asked to hand it over: try again in a second";
          return nullptr;
        }
        SessionLease::clear_release_request(dir);
        try {
          s = Session::load(resume, env_.session_env, std::move(*lease));
        } catch (const InputError& e) {
          code = wire::ErrorCode::Internal;
          why = e.what();
          return nullptr;
        }
        if (s) env_.sessions.emplace(resume, s);
      }
    }
    if (!s || s->device_id() != device) {
      code = wire::ErrorCode::SessionNotFound;
      why = "no session " + resume + " for this device";
      return nullptr;
    }
    // The client is here now: a hand-over asked for by another daemon is moot.
    SessionLease::clear_release_request(session_dir(env_.session_env, resume));
    env_.sessions_gauge.set(double(env_.sessions.size()));
    return s;
  }
  env_.make_room(lock);
  if (int(env_.sessions.size()) >= env_.max_sessions) {
    code = wire::ErrorCode::Busy;
    why = "the server carries its maximum of " + std::to_string(env_.max_sessions) + " sessions";
    return nullptr;
  }
  const std::string id = new_session_id();
  std::optional<SessionLease> lease;
  try {
    lease = SessionLease::try_acquire(session_dir(env_.session_env, id), env_.lease_holder);
  } catch (const std::exception& e) {
    code = wire::ErrorCode::Internal;
    why = e.what();
    return nullptr;
  }
  if (!lease) {  // 128 random bits taken already: something else is badly wrong
    code = wire::ErrorCode::Internal;
    why = "the new session's lease is held by another process";
    return nullptr;
  }
  auto s = std::make_shared<Session>(id, device, env_.session_env, std::move(*lease));
  env_.sessions.emplace(s->id(), s);
  env_.sessions_gauge.set(double(env_.sessions.size()));
  return s;
}

}  // namespace arlight::daemon
