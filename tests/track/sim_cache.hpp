// Simulated recordings for the tracking tests, made once and shared by the test processes
// (ctest runs every test in its own process, possibly in parallel): each recording lives in a
// temporary folder named after its arguments, made under an exclusive file lock, and reused
// while its stamp (the arguments and the simulator's modification time) matches.
#pragma once

#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/file.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <functional>
#include <sstream>
#include <string>

#include "support/run_tool.hpp"

namespace arlight::test {

inline std::filesystem::path simulated_recording(const std::string& name,
                                                 const std::string& args) {
  namespace fs = std::filesystem;
  const std::string sim = ARLIGHT_SIM_EXE;
  std::ostringstream stamp;
  stamp << args << "\n" << fs::last_write_time(sim).time_since_epoch().count() << "\n";
  const std::size_t key = std::hash<std::string>{}(stamp.str());
  const fs::path base = fs::temp_directory_path() / ("arlight_track_" + name + "_" +
                                                     std::to_string(key % 1000000007));
  const fs::path rec = base / "rec";
  const int lock = ::open((base.string() + ".lock").c_str(), O_CREAT | O_RDWR, 0644);
  if (lock >= 0) ::flock(lock, LOCK_EX);
  std::string old;
  if (std::ifstream in{base / "stamp"}) old.assign(std::istreambuf_iterator<char>(in), {});
  if (old != stamp.str() || !fs::exists(rec / "recording.json")) {
    fs::remove_all(base);
    fs::create_directories(base);
    const RunResult r = run_tool(sim, "--env " + std::string(ARLIGHT_SOURCE_DIR) +
                                          "/data/probes/venice.exr --out " + rec.string() + " " +
                                          args);
    if (r.status != 0) {
      if (lock >= 0) ::close(lock);
      ADD_FAILURE() << "arlight-sim " << args << " failed:\n" << r.output;
      return rec;
    }
    std::ofstream(base / "stamp") << stamp.str();
  }
  if (lock >= 0) ::close(lock);
  return rec;
}

// The orbit around a 0.2 m marker (id 7) that the tracking tests judge: 120 frames, 4 s.
inline std::filesystem::path orbit_recording() {
  return simulated_recording("orbit", "--trajectory orbit --marker 7,0.2 --frames 120 "
                                      "--size 640x480 --seed 3 --threads 2");
}

}  // namespace arlight::test
