#include "session_lease.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <ctime>
#include <fstream>
#include <sstream>
#include <stdexcept>

namespace arlight::daemon {

namespace fs = std::filesystem;

namespace {

constexpr char kLeaseFile[] = "lease";
constexpr char kRequestFile[] = "release-request";
constexpr char kTakeoverFile[] = "lease.takeover";

}  // namespace

namespace {

// The lease file opened and locked, or -1 while another process holds it. Throws naming the
// file when it cannot be opened or locked at all.
int open_locked(const fs::path& path, int flags) {
  const int fd = ::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC | flags, 0644);
  if (fd < 0) {
    if (errno == EEXIST) return -1;  // another contender made it first
    throw std::runtime_error("cannot open the session lease " + path.string() + ": " +
                             std::strerror(errno));
  }
  if (::flock(fd, LOCK_EX | LOCK_NB) != 0) {
    const int e = errno;
    ::close(fd);
    if (e == EWOULDBLOCK || e == EINTR) return -1;
    throw std::runtime_error("cannot lock the session lease " + path.string() + ": " +
                             std::strerror(e));
  }
  return fd;
}

// Whether the lease file was last renewed more than SessionLease::kExpiry ago.
bool expired(const fs::path& path) {
  struct stat st{};
  if (::stat(path.c_str(), &st) != 0) return false;
  struct timespec now{};
  ::clock_gettime(CLOCK_REALTIME, &now);
  const double age = double(now.tv_sec - st.st_mtim.tv_sec) +
                     1e-9 * double(now.tv_nsec - st.st_mtim.tv_nsec);
  return age > double(SessionLease::kExpiry.count());
}

}  // namespace

std::string LeaseHolder::text() const {
  std::string t = name + "\n";
  if (!address.empty()) t += "address " + address + "\n";
  if (!web_address.empty()) t += "web " + web_address + "\n";
  return t;
}

LeaseHolder LeaseHolder::parse(const std::string& text) {
  LeaseHolder h;
  std::istringstream in(text);
  std::getline(in, h.name);
  for (std::string line; std::getline(in, line);) {
    if (line.starts_with("address ")) h.address = line.substr(8);
    if (line.starts_with("web ")) h.web_address = line.substr(4);
  }
  return h;
}

std::optional<SessionLease> SessionLease::try_acquire(const fs::path& dir,
                                                      const LeaseHolder& holder) {
  fs::create_directories(dir);
  const fs::path path = dir / kLeaseFile;
  int fd = open_locked(path, 0);
  if (fd < 0 && expired(path)) {
    // Its owner stopped renewing it: take it over, one contender at a time (a second one
    // finds the new file locked and renewed).
    const int takeover = open_locked(dir / kTakeoverFile, 0);
    if (takeover >= 0) {
      fd = open_locked(path, 0);
      if (fd < 0 && expired(path)) {
        std::error_code ec;
        fs::remove(path, ec);
        fd = open_locked(path, O_EXCL);
      }
      ::close(takeover);
    }
  }
  if (fd < 0) return std::nullopt;
  // The holder's lines are for people and redirects; the lock is what counts, so a failed
  // write changes nothing here (a redirect then finds no address and refuses instead).
  const std::string line = holder.text();
  if (::ftruncate(fd, 0) == 0) {
    [[maybe_unused]] const ssize_t n = ::pwrite(fd, line.data(), line.size(), 0);
  }
  SessionLease lease(fd, path);
  lease.renew();
  return lease;
}

bool SessionLease::renew() {
  if (fd_ < 0) return false;
  ::futimens(fd_, nullptr);  // now
  return held();
}

bool SessionLease::held() const {
  if (fd_ < 0) return false;
  struct stat mine{}, named{};
  if (::fstat(fd_, &mine) != 0 || ::stat(path_.c_str(), &named) != 0) return false;
  return mine.st_ino == named.st_ino && mine.st_dev == named.st_dev;
}

std::string SessionLease::owner_of(const fs::path& dir) {
  std::ifstream in(dir / kLeaseFile);
  std::string line;
  std::getline(in, line);
  return line;
}

std::optional<LeaseHolder> SessionLease::live_holder(const fs::path& dir) {
  const fs::path path = dir / kLeaseFile;
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return std::nullopt;
  std::optional<LeaseHolder> holder;
  if (::flock(fd, LOCK_SH | LOCK_NB) == 0) {
    ::flock(fd, LOCK_UN);  // nobody holds it: its owner is gone
  } else if (errno == EWOULDBLOCK && !expired(path)) {
    std::string text(4096, '\0');
    const ssize_t n = ::pread(fd, text.data(), text.size(), 0);
    text.resize(n > 0 ? std::size_t(n) : 0);
    holder = LeaseHolder::parse(text);
  }
  ::close(fd);
  return holder;
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

SessionLease::SessionLease(SessionLease&& other) noexcept
    : fd_(other.fd_), path_(std::move(other.path_)) {
  other.fd_ = -1;
}

SessionLease& SessionLease::operator=(SessionLease&& other) noexcept {
  if (this != &other) {
    if (fd_ >= 0) ::close(fd_);
    fd_ = other.fd_;
    path_ = std::move(other.path_);
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
