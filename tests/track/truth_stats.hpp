// Helpers for judging tracking against arlight-sim's truth: the decoded frames of a recording
// with their truth, and percentile summaries of error lists.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "arlight/source/source.hpp"
#include "arlight/track/track.hpp"
#include "arlight/truth/truth.hpp"

namespace arlight::test {

struct TruthFrames {
  CameraIntrinsics camera;
  recording::Truth truth;
  std::vector<source::SourceFrame> frames;  // every frame (none has a problem)
};

inline TruthFrames load_truth_frames(const std::filesystem::path& rec) {
  TruthFrames t;
  source::ReplaySource src(rec);
  t.camera = src.intrinsics();
  const auto truth = recording::read_truth(rec);
  EXPECT_TRUE(truth.has_value()) << rec;
  if (truth) t.truth = *truth;
  while (auto f = src.next()) t.frames.push_back(std::move(*f));
  EXPECT_EQ(t.frames.size(), t.truth.poses.size());
  return t;
}

// The true camera pose in the marker frame: inverse(marker -> world) * (camera -> world).
inline track::Pose camera_in_marker(const recording::Truth& truth, std::size_t i) {
  return track::compose(track::inverse(truth.marker->pose), truth.poses[i]);
}

struct Stats {
  double median = 0, p95 = 0, max = 0;
  std::size_t n = 0;
};

inline Stats stats(std::vector<double> v) {
  Stats s;
  s.n = v.size();
  if (v.empty()) return s;
  std::sort(v.begin(), v.end());
  auto at = [&](double q) { return v[std::min(v.size() - 1, std::size_t(q * (v.size() - 1) + 0.5))]; };
  s.median = at(0.5);
  s.p95 = at(0.95);
  s.max = v.back();
  return s;
}

inline void report(const std::string& what, const Stats& s, const char* unit) {
  std::printf("[ figures  ] %s over %zu: median %.4f, 95th %.4f, max %.4f %s\n", what.c_str(), s.n,
              s.median, s.p95, s.max, unit);
}

}  // namespace arlight::test
