// Which session a Hello opens (protocol/PROTOCOL.md items 1 and 2, "Contributors", "A fleet"):
// a new one; one resumed from this daemon's memory or from the shared data folder (its lease
// taken, or its live owner asked to hand it over); or the live session a watcher or a
// contributor names — here, or on another daemon of the fleet, which the client is sent to
// (Error{Moved}). The daemon owns the sessions; the opener decides for one Hello at a time.
#pragma once

#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>

#include "arlight/admin/metrics.hpp"
#include "arlight/protocol/wire.hpp"
#include "session.hpp"
#include "session_lease.hpp"
#include "tokens.hpp"

namespace arlight::daemon {

class SessionOpener {
 public:
  // The daemon's, for as long as the opener lives.
  struct Env {
    const TokenStore& tokens;
    const SessionEnv& session_env;
    const LeaseHolder& lease_holder;  // this daemon in the leases it takes
    int max_sessions;
    std::mutex& sessions_mutex;  // guards `sessions`
    std::map<std::string, std::shared_ptr<Session>>& sessions;
    // With the lock on sessions_mutex held and the server full: closes idle sessions (kept on
    // disk) to make room, if it can.
    std::function<void(std::unique_lock<std::mutex>&)> make_room;
    admin::Gauge& sessions_gauge;
    admin::Counter& takeover_waits;  // resumes answered Busy while another daemon held the lease
    admin::Counter& redirected;      // Hellos answered Moved
  };
  explicit SessionOpener(Env env) : env_(std::move(env)) {}

  // Authenticates `h` and returns its session, or nullptr with the Error to send (`code`,
  // `why`, and for Moved the `address` of the daemon that has the session, of the kind of port
  // the Hello came to: `web`, the web port's WebSocket).
  std::shared_ptr<Session> open(const wire::Hello& h, bool web, wire::ErrorCode& code,
                                std::string& why, std::string& address);

 private:
  std::shared_ptr<Session> live_session(const std::string& id, const char* field, bool web,
                                        wire::ErrorCode& code, std::string& why,
                                        std::string& address);
  std::shared_ptr<Session> watched_session(const wire::Hello& h, bool web, wire::ErrorCode& code,
                                           std::string& why, std::string& address);
  std::shared_ptr<Session> joined_session(const wire::Hello& h, bool web, wire::ErrorCode& code,
                                          std::string& why, std::string& address);

  Env env_;
};

}  // namespace arlight::daemon
