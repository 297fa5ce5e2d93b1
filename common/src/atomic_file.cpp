#include "arlight/atomic_file.hpp"

#include <unistd.h>

#include <cstdint>
#include <fstream>
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
  std::error_code ec;
  {
    std::ofstream f(tmp, std::ios::binary | std::ios::trunc);
    f.write(bytes.data(), std::streamsize(bytes.size()));
    if (!f.flush()) {
      f.close();
      fs::remove(tmp, ec);
      throw std::runtime_error("cannot write " + path.string());
    }
  }
  fs::rename(tmp, path, ec);
  if (ec) {
    std::error_code ignored;
    fs::remove(tmp, ignored);
    throw std::runtime_error("cannot write " + path.string() + ": " + ec.message());
  }
}

}  // namespace arlight
