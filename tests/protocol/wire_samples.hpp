// Messages of every type, once with every optional field set and once with none: shared by the
// codec tests and the writer of the seed corpus (tests/protocol/corpus/).
#pragma once

#include <vector>

#include "arlight/protocol/wire.hpp"

namespace arlight::test {

inline wire::CameraFrame sample_frame(std::uint64_t sequence, bool full) {
  wire::CameraFrame f;
  f.sequence = sequence;
  f.info = {12.5, 1.0 / 120.0, 2.0, glm::dquat(0.5, 0.5, -0.5, 0.5)};
  f.width = 4, f.height = 2;
  if (full) {
    f.format = wire::PixelFormat::Rgb8;
    for (int i = 0; i < 4 * 2 * 3; ++i) f.data.push_back(std::uint8_t(i * 11));
    f.imu = {{12.49, {0.1f, -0.2f, 0.3f}, {0.0f, 9.81f, 0.1f}},
             {12.495, {0.15f, -0.25f, 0.35f}, {0.1f, 9.8f, 0.0f}}};
  } else {
    f.has_orientation = false;
    f.format = wire::PixelFormat::Jpeg;
    f.data = {0xff, 0xd8, 0xff, 0xd9};
  }
  return f;
}

inline std::vector<wire::Message> messages_with_every_field() {
  CameraIntrinsics k;
  k.width = 640, k.height = 480, k.fx = 500.25, k.fy = 501.5, k.cx = 320.5, k.cy = 240.25;
  k.distortion = {0.1, -0.05, 0.001, -0.002, 0.01};
  ShCoeffs sh(3);
  for (std::size_t i = 0; i < sh.c.size(); ++i)
    sh.c[i] = glm::dvec3(0.5 * double(i), -0.25 * double(i), 1.0 + double(i));  // float-exact
  return {
      wire::Hello{1, "test 0.1", "phone-1", "secret", {"maps", "jpeg"}, "0123456789abcdef", ""},
      wire::CameraIntrinsicsMessage{k},
      sample_frame(7, true),
      wire::CalibrationSet{"debevec", {sample_frame(1, true), sample_frame(2, false)}},
      wire::RequestMaps{{1.0f, 10.0f, 1280.0f}, 256, Projection::Cube, "sh:12", wire::MapKind::Ggx, 5, 8},
      wire::Ping{0xfeedfacecafebeefull},
      wire::Bye{},
      wire::Welcome{
          "0123456789abcdef", "arlightd 0.1", true, 60, wire::WireLimits{1, 2, 3, 4}, {"location"}},
      wire::LightingUpdate{.frame_sequence = 9,
                           .frame_used = false,
                           .reason = "motion blur",
                           .sh = sh,
                           .dominant_direction = {0.0f, 0.6f, -0.8f},
                           .dominant_colour = {2.5f, 2.0f, 1.5f},
                           .coverage = 0.375f,
                           .frames_processed = 8,
                           .frames_dropped = 1,
                           .estimated = 0.625f,
                           .frame_exposure = 0.0125,
                           .sun_state = SunState::Confirmed,
                           .sun_direction = {0.0f, 0.6f, -0.8f},
                           .advised_width = 160,
                           .advised_height = 120,
                           .advised_fps = 10.0f,
                           .saved_sequence = 7,
                           .advised_frame_bytes = 31250,
                           .light_error = 0.125f,
                           .light_error_zones = 1,
                           .light_error_map = {4, 21},
                           .next_view = glm::vec3(0.0f, 0.8f, -0.6f),
                           .next_view_gain = 0.0625f,
                           .registration = wire::Registration::Registered},
      wire::MapTile{3, 2, 40.0f, Projection::LatLong, 256, 128, 0, 64, 64, 64, 64, {1, 2, 3},
                    wire::TileCoding::Half, wire::MapKind::Ggx, 0.25f},
      wire::MapSetComplete{3, 8, 0.25f, 0.5f, 120, 2, 17,
                           {{{0.0f, 0.6f, -0.8f}, {40.0f, 36.0f, 28.0f}, 0.0125f},
                            {{1.0f, 0.0f, 0.0f}, {0.5f, 0.5f, 0.5f}, 0.25f}}},
      wire::Progress{3, 5, 10},
      wire::Error{wire::ErrorCode::Moved, "session 42 is live on another arlightd", "10.0.0.2:7878"},
      wire::Pong{42},
      wire::CalibrationResult{true, "robertson", 7, "stored for device phone-1"},
      wire::ExposureAdvice{41, 0.000625, 0.0125f},
      wire::Location{{51.4545, -2.5879, 11.0}, 1.7e9, true, 1.5},
      wire::RequestJoinToken{},
      wire::JoinToken{"0123456789abcdef", "fedcba9876543210fedcba9876543210", 600.0f},
  };
}

inline std::vector<wire::Message> messages_with_no_optional_field() {
  return {
      wire::Hello{},
      wire::CameraIntrinsicsMessage{},
      sample_frame(0, false),
      wire::CalibrationSet{},
      wire::RequestMaps{},
      wire::Ping{},
      wire::Bye{},
      wire::Welcome{},
      wire::LightingUpdate{},
      wire::MapTile{0, 0, 0.0f, Projection::AngleMap, 8, 8, 0, 0, 0, 8, 8, {0}},
      wire::MapSetComplete{},
      wire::Progress{},
      wire::Error{},
      wire::Pong{},
      wire::CalibrationResult{},
      wire::ExposureAdvice{},
      wire::Location{},
      wire::RequestJoinToken{},
      wire::JoinToken{"", "t", 1.0f},  // its token and lifetime are required
  };
}

}  // namespace arlight::test
