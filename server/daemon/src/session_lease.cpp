#include "session_lease.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <stdexcept>

namespace arlight::daemon {

namespace fs = std::filesystem;

namespace {

constexpr char kLeaseFile[] = "lease";
constexpr char kRequestFile[] = "release-request";

}  // namespace

std::optional<SessionLease> SessionLease::try_acquire(const fs::path& dir,
                                                      const std::string& owner) {
  fs::create_directories(dir);
  const fs::path path = dir / kLeaseFile;
  const int fd = ::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (fd < 0)
    throw std::runtime_error("cannot open the session lease " + path.string() + ": " +
                             std::strerror(errno));
  if (::flock(fd, LOCK_EX | LOCK_NB) != 0) {
    const int e = errno;
    ::close(fd);
    if (e == EWOULDBLOCK || e == EINTR) return std::nullopt;
    throw std::runtime_error("cannot lock the session lease " + path.string() + ": " +
                             std::strerror(e));
  }
  // The owner line is for people; the lock is what counts, so a failed write changes nothing.
  const std::string line = owner + "\n";
  if (::ftruncate(fd, 0) == 0) {
    [[maybe_unused]] const ssize_t n = ::pwrite(fd, line.data(), line.size(), 0);
  }
  return SessionLease(fd);
}

std::string SessionLease::owner_of(const fs::path& dir) {
  std::ifstream in(dir / kLeaseFile);
  std::string line;
  std::getline(in, line);
  return line;
}

void SessionLease::request_release(const fs::path& dir, const std::string& who) {
  std::ofstream(dir / kRequestFile) << who << "\n";
}

bool SessionLease::release_requested(const fs::path& dir) {
  std::error_code ec;
  return fs::exists(dir / kRequestFile, ec);
}

void SessionLease::clear_release_request(const fs::path& dir) {
  std::error_code ec;
  fs::remove(dir / kRequestFile, ec);
}

SessionLease::SessionLease(SessionLease&& other) noexcept : fd_(other.fd_) { other.fd_ = -1; }

SessionLease& SessionLease::operator=(SessionLease&& other) noexcept {
  if (this != &other) {
    if (fd_ >= 0) ::close(fd_);
    fd_ = other.fd_;
    other.fd_ = -1;
  }
  return *this;
}

SessionLease::~SessionLease() {
  if (fd_ >= 0) ::close(fd_);  // closing the last descriptor releases the flock
}

std::string lease_owner_name() {
  char host[256] = {};
  if (::gethostname(host, sizeof host - 1) != 0) std::strcpy(host, "unknown-host");
  return std::string(host) + " pid=" + std::to_string(::getpid());
}

}  // namespace arlight::daemon
