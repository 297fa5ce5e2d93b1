#include "arlight/common/atomic_file.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include <cstdint>
#include <mutex>
#include <random>
#include <stdexcept>
#include <string>
#include <system_error>

namespace arlight {

namespace fs = std::filesystem;

fs::path temp_sibling(const fs::path& path) {
  static std::mt19937_64 rng{std::random_device{}()};
  static std::mutex mutex;
  std::uint64_t r;
  {
    std::lock_guard lock(mutex);
    r = rng();
  }
  fs::path tmp = path;
  tmp += ".tmp-" + std::to_string(::getpid()) + "-" + std::to_string(r % 1000000);
  tmp += path.extension();
  return tmp;
}

void write_file_atomically(const fs::path& path, std::string_view bytes) {
  const fs::path tmp = temp_sibling(path);
  const auto fail = [&](const std::string& what) {
    std::error_code ignored;
    fs::remove(tmp, ignored);
    throw std::runtime_error("cannot write " + path.string() + ": " + what);
  };
  // POSIX calls so the data can be fsynced before the rename: after a crash the file is the
  // old version or the new one, never a renamed but empty one.
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) fail(std::strerror(errno));
  std::size_t written = 0;
  while (written < bytes.size()) {
    const ssize_t n = ::write(fd, bytes.data() + written, bytes.size() - written);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      const std::string why = std::strerror(errno);
      ::close(fd);
      fail(why);
    }
    written += std::size_t(n);
  }
  if (::fsync(fd) != 0) {
    const std::string why = std::strerror(errno);
    ::close(fd);
    fail(why);
  }
  if (::close(fd) != 0) fail(std::strerror(errno));
  std::error_code ec;
  fs::rename(tmp, path, ec);
  if (ec) fail(ec.message());
  // The rename itself is durable once the folder is synced.
  const fs::path dir = path.has_parent_path() ? path.parent_path() : fs::path(".");
  if (const int dfd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC); dfd >= 0) {
    ::fsync(dfd);
    ::close(dfd);
  }
}

}  // namespace arlight
