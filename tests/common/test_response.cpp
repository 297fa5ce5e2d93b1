// Camera response curves: the standard ones, measured tables, and their files.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "arlight/common/error.hpp"
#include "arlight/common/response.hpp"

using namespace arlight;
namespace fs = std::filesystem;

TEST(Response, SrgbDecodesAndEncodesTheStandardCurve) {
  const CameraResponse r = CameraResponse::srgb();
  EXPECT_EQ(r.linear(0, 0), 0.0f);
  EXPECT_EQ(r.linear(255, 2), 1.0f);
  EXPECT_NEAR(r.linear(128, 1), 0.2158605, 1e-6);          // IEC 61966-2-1
  EXPECT_NEAR(r.linear(10, 0), 10 / 255.0 / 12.92, 1e-7);  // the linear toe
  for (int c = 0; c < 256; ++c) EXPECT_NEAR(r.encode(r.linear(c, 0), 0) * 255.0f, c, 1e-3);
  EXPECT_EQ(r.encode(3.0f, 0), 1.0f);  // clipping
}

TEST(Response, FilmicIsMonotoneInvertibleAndNotSrgb) {
  const CameraResponse f = CameraResponse::filmic(), s = CameraResponse::srgb();
  for (int c = 1; c < 256; ++c) EXPECT_GT(f.linear(c, 0), f.linear(c - 1, 0)) << c;
  for (int c = 0; c < 256; ++c) EXPECT_NEAR(f.encode(f.linear(c, 1), 1) * 255.0f, c, 1e-3);
  // The S-curve lifts the mid-tones and rolls the highlights off: same white, other shape.
  EXPECT_GT(f.encode(0.1f, 0), s.encode(0.1f, 0) + 0.05f);
  EXPECT_EQ(f.linear(255, 0), 1.0f);
}

TEST(Response, MeasuredTableIsNormalizedAndInvertedPiecewiseLinearly) {
  std::array<std::vector<float>, 3> t;
  const CameraResponse s = CameraResponse::srgb();
  for (int ch = 0; ch < 3; ++ch)
    for (int c = 0; c < 256; ++c) t[std::size_t(ch)].push_back(3.0f * (ch + 1) * s.linear(c, 0));
  const CameraResponse r = CameraResponse::from_table(t);
  for (int ch = 0; ch < 3; ++ch) {
    EXPECT_EQ(r.linear(255, ch), 1.0f);
    EXPECT_NEAR(r.linear(128, ch), s.linear(128, 0), 1e-6);
  }
  for (float x : {0.001f, 0.01f, 0.2f, 0.5f, 0.9f})
    EXPECT_NEAR(r.encode(x, 1), s.encode(x, 1), 1.0f / 255);
}

TEST(Response, BadTablesAreRefused) {
  std::array<std::vector<float>, 3> t;
  for (auto& ch : t)
    for (int c = 0; c < 256; ++c) ch.push_back(float(c));
  auto bad = t;
  bad[1].pop_back();
  EXPECT_THROW(CameraResponse::from_table(bad), std::invalid_argument);
  bad = t;
  bad[2][100] = 50.0f;  // decreasing
  EXPECT_THROW(CameraResponse::from_table(bad), std::invalid_argument);
  bad = t;
  bad[0][7] = std::nanf("");
  EXPECT_THROW(CameraResponse::from_table(bad), std::invalid_argument);
  bad = t;
  for (float& v : bad[0]) v = 0.0f;  // no top
  EXPECT_THROW(CameraResponse::from_table(bad), std::invalid_argument);
}

TEST(Response, FilesRoundTripAndDamagedOnesAreInputErrors) {
  const fs::path dir = fs::temp_directory_path() / "arlight_response_test";
  fs::remove_all(dir);
  fs::create_directories(dir);
  const CameraResponse f = CameraResponse::filmic();
  f.save(dir / "phone.json");
  const CameraResponse back = CameraResponse::load(dir / "phone.json");
  EXPECT_EQ(back.name(), "filmic");
  for (int c = 0; c < 256; ++c) EXPECT_EQ(back.linear(c, 2), f.linear(c, 2));
  const std::pair<const char*, const char*> cases[] = {
      {"{\"linear_of_code\": [[1,2,3]]}", "expected 3 channels"},
      {"{\"linear_of_code\": [[1,2],[1,2],[1,2]]}", "expected 256 values"},
      {"{\"linear_of_co", "not a camera response file"},
      {"[]", "not a camera response file"},
  };
  for (const auto& [text, says] : cases) {
    std::ofstream(dir / "bad.json", std::ios::trunc) << text;
    try {
      CameraResponse::load(dir / "bad.json");
      ADD_FAILURE() << text << " loaded";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(says), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("bad.json"), std::string::npos) << e.what();
    }
  }
  EXPECT_THROW(CameraResponse::load(dir / "missing.json"), InputError);
}
