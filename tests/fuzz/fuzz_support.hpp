// What the fuzz targets share. Each target defines LLVMFuzzerTestOneInput (libFuzzer's entry
// point) and arlight_fuzz_seeds(): inputs made by the project's own writers, which
// `fuzz_<target> --write-seeds DIR` (the replay driver, replay_main.cpp) stores as the seed
// corpus tests/fuzz/corpus/<target>/. Parsers that take a file get the input written to a
// scratch folder of this process first; targets that need several files take an input split
// into parts at kPartMarker.
#pragma once

#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <exception>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>
#include <vector>

using FuzzSeeds = std::vector<std::vector<std::uint8_t>>;
FuzzSeeds arlight_fuzz_seeds();

namespace arlight::fuzz {

inline constexpr std::string_view kPartMarker = "\n--8<--\n";

// A folder of this process for the files an input is written to (in /dev/shm when there is one:
// a fuzzer writes one per input).
inline const std::filesystem::path& scratch() {
  static const std::filesystem::path dir = [] {
    const std::filesystem::path base =
        std::filesystem::exists("/dev/shm") ? "/dev/shm" : std::filesystem::temp_directory_path();
    const auto d = base / ("arlight-fuzz-" + std::to_string(::getpid()));
    std::filesystem::create_directories(d);
    std::atexit([] {
      std::error_code ec;
      std::filesystem::remove_all(scratch(), ec);
    });
    return d;
  }();
  return dir;
}

inline void write_file(const std::filesystem::path& path, std::string_view bytes) {
  std::ofstream(path, std::ios::binary | std::ios::trunc).write(bytes.data(), bytes.size());
}

// The input cut at each kPartMarker into at most `n` parts (the last takes the rest; missing
// parts are empty).
inline std::vector<std::string_view> split_parts(const std::uint8_t* data, std::size_t size,
                                                 std::size_t n) {
  std::string_view rest(reinterpret_cast<const char*>(data), size);
  std::vector<std::string_view> parts;
  while (parts.size() + 1 < n) {
    const auto at = rest.find(kPartMarker);
    if (at == std::string_view::npos) break;
    parts.push_back(rest.substr(0, at));
    rest.remove_prefix(at + kPartMarker.size());
  }
  parts.push_back(rest);
  parts.resize(n);
  return parts;
}

inline std::vector<std::uint8_t> join_parts(const std::vector<std::string>& parts) {
  std::string all;
  for (std::size_t i = 0; i < parts.size(); ++i) {
    if (i) all += kPartMarker;
    all += parts[i];
  }
  return {all.begin(), all.end()};
}

inline std::vector<std::uint8_t> bytes_of(std::string_view s) { return {s.begin(), s.end()}; }

inline std::string read_file(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// An input refused as it should be. With ARLIGHT_FUZZ_VERBOSE set (e.g. replaying a corpus to
// see which inputs a parser accepts) the reason is printed.
inline void refused(const std::exception& e) {
  static const bool verbose = std::getenv("ARLIGHT_FUZZ_VERBOSE") != nullptr;
  if (verbose) std::fprintf(stderr, "refused: %s\n", e.what());
}

// A finding: a parser misbehaved in a way a bad input must never cause.
[[noreturn]] inline void finding(const char* what) {
  std::fprintf(stderr, "fuzz finding: %s\n", what);
  std::abort();
}

}  // namespace arlight::fuzz
