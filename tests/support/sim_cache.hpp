// Simulated recordings for the client's tests, made once (by arlight_sim, in process) and shared
// by the test processes (ctest runs every test in its own process, possibly in parallel): each
// recording lives in a temporary folder named after its options, made under an exclusive file
// lock, and reused while its stamp (sim::describe: the options and the simulator's build)
// matches.
#pragma once

#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/file.h>
#include <tbb/global_control.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <functional>
#include <string>

#include "arlight/common/error.hpp"
#include "arlight/sim/simulate.hpp"
#include "support/run_tool.hpp"

namespace arlight::test {

// A recording of venice simulated with `o` (its env and out are set here), on two threads.
inline std::filesystem::path simulated_recording(const std::string& name, sim::SimOptions o) {
  namespace fs = std::filesystem;
  o.env = std::string(ARLIGHT_SOURCE_DIR) + "/data/probes/venice.exr";
  const std::string stamp = sim::describe(o) + "\n";
  const std::size_t key = std::hash<std::string>{}(stamp);
  const fs::path base = fs::temp_directory_path() /
                        ("arlight_track_" + name + "_" + std::to_string(key % 1000000007));
  const fs::path rec = base / "rec";
  o.out = rec;
  const int lock = ::open((base.string() + ".lock").c_str(), O_CREAT | O_RDWR, 0644);
  if (lock >= 0) ::flock(lock, LOCK_EX);
  std::string old;
  if (std::ifstream in{base / "stamp"}) old.assign(std::istreambuf_iterator<char>(in), {});
  if (old != stamp || !fs::exists(rec / "recording.json")) {
    fs::remove_all(base);
    fs::create_directories(base);
    try {
      const tbb::global_control threads(tbb::global_control::max_allowed_parallelism, 2);
      sim::simulate(o);
      std::ofstream(base / "stamp") << stamp;
    } catch (const std::exception& e) {
      ADD_FAILURE() << "simulating " << sim::describe(o) << " failed: " << e.what();
    }
  }
  if (lock >= 0) ::close(lock);
  return rec;
}

// An orbit around a 0.2 m marker (id 7) at 640x480.
inline sim::SimOptions orbit_options(int frames, std::uint64_t seed) {
  sim::SimOptions o;
  o.trajectory = sim::TrajectoryKind::Orbit;
  o.marker = sim::MarkerSpec{7, 0.2, {0.0, -1.2, -0.8}};
  o.frames = frames;
  o.seed = seed;
  return o;
}

// The orbit the tracking tests judge: 120 frames, 4 s.
inline std::filesystem::path orbit_recording() {
  return simulated_recording("orbit", orbit_options(120, 3));
}

}  // namespace arlight::test
