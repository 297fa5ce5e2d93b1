// Who owns a session when several arlightd share one data folder (behind a TCP balancer, a
// Kubernetes ReadWriteMany volume): DATA/sessions/<id>/lease, held with flock(2) by the one
// daemon that has the session in memory and writes its checkpoints. The kernel lets go of the
// lock the moment its owner dies (kill -9, a crash, the node's NFS lease running out), so a
// resume on another daemon takes over at once and reads the last checkpoint the dead one wrote;
// while the owner lives, nobody else can take the lock, so two daemons never write one session.
//
// A stopped owner (SIGSTOP, a VM paused, a process swapped out for good) would keep its flock
// for ever, so a lease also expires: its owner renews it (the file's modification time) every
// housekeeping tick, and a lease not renewed for kExpiry is taken over — the file is replaced
// by a new one (under DATA/sessions/<id>/lease.takeover, held by one contender at a time) and
// that is locked. An owner that wakes up finds its file replaced (held() is false), and stops:
// it neither writes the session again nor keeps it (issue 36 §5).
//
// A live owner hands a session over when asked: the daemon a client resumed on writes
// DATA/sessions/<id>/release-request; the owner notices it (its housekeeping), checkpoints the
// session, closes it and lets go, and the client's next attempt gets it wherever it lands.
//
// The lease also says where its owner is reached (issue 49 §2): a watcher or a contributor that
// a balancer sent to another daemon is told to go there (Error{Moved}); live_holder() is what
// that daemon reads.
#pragma once

#include <chrono>
#include <filesystem>
#include <optional>
#include <string>

namespace arlight::daemon {

// Who holds a lease, as its file says: a line for people and logs ("host pid=N"), then the
// addresses clients reach that daemon at ("address HOST:PORT", "web HOST:PORT"; empty: it
// advertises none).
struct LeaseHolder {
  LeaseHolder(std::string name = {}, std::string address = {}, std::string web_address = {})
      : name(std::move(name)), address(std::move(address)), web_address(std::move(web_address)) {}
  std::string name;
  std::string address;      // its client port (TCP or TLS)
  std::string web_address;  // its web port (the page's WebSocket, wss://HOST:PORT/ws)
  std::string text() const;                           // the file's contents
  static LeaseHolder parse(const std::string& text);  // what it could read of them
};

class SessionLease {
 public:
  // The lease of the session folder `dir` (created if needed) for `holder`, or std::nullopt
  // while another process holds it. The holder is written into the lease file (for people, and
  // for daemons redirecting clients to it). std::runtime_error naming the file when it cannot be
  // opened at all (permissions, a full disk).
  static std::optional<SessionLease> try_acquire(const std::filesystem::path& dir,
                                                 const LeaseHolder& holder);
  // Who holds (or last held) the lease of `dir`, as its file says; empty when unknown.
  static std::string owner_of(const std::filesystem::path& dir);
  // The holder of `dir`'s lease while a live process holds it — locked, and renewed within
  // kExpiry — else std::nullopt (no lease, its owner died, or it stopped renewing). The lock is
  // probed with a shared flock taken and let go at once: a try_acquire at that very instant
  // fails as if the lease were held, and its client retries (a resume is answered Busy).
  static std::optional<LeaseHolder> live_holder(const std::filesystem::path& dir);

  // A lease whose owner has not renewed it for this long is taken over by the next try_acquire.
  static constexpr std::chrono::seconds kExpiry{3};
  // The owner is alive: marks the lease renewed now. Returns held().
  bool renew();
  // Whether this is still the lease of its folder (false once another process took it over
  // from this one while it was stopped).
  bool held() const;

  // Asks the owner of `dir` to hand the session over (`who` says who asks); whether a request
  // is pending; withdraws it (the owner does once it has let go, and so does a new owner).
  static void request_release(const std::filesystem::path& dir, const std::string& who);
  static bool release_requested(const std::filesystem::path& dir);
  static void clear_release_request(const std::filesystem::path& dir);

  SessionLease(SessionLease&& other) noexcept;
  SessionLease& operator=(SessionLease&& other) noexcept;
  SessionLease(const SessionLease&) = delete;
  SessionLease& operator=(const SessionLease&) = delete;
  ~SessionLease();  // lets go

 private:
  SessionLease(int fd, std::filesystem::path path) : fd_(fd), path_(std::move(path)) {}
  int fd_ = -1;
  std::filesystem::path path_;
};

// This process as a lease owner: "host pid=N".
std::string lease_owner_name();

}  // namespace arlight::daemon
