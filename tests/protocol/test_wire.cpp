// The typed codec (protocol/include/arlight/protocol/wire.hpp) on its own: every message survives a round
// trip with its optional fields set and unset, and every class of corruption is refused with
// the fault, message and field it concerns.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>

#include "arlight/protocol/wire.hpp"
#include "wire_samples.hpp"

namespace arlight {
namespace {

namespace fs = std::filesystem;
using wire::DecodeError;
using wire::Fault;

// Runs decode and returns the error it throws (fails the test if it does not throw).
DecodeError refusal(std::span<const std::uint8_t> bytes, const wire::WireLimits& limits = {}) {
  try {
    const wire::Message m = wire::decode(bytes, limits);
    ADD_FAILURE() << "accepted as " << wire::message_name(m);
  } catch (const DecodeError& e) {
    return e;
  }
  return DecodeError(Fault::Missing, "", "", "no error");
}

TEST(WireCodec, EveryMessageRoundTripsWithEveryOptionalFieldSet) {
  const auto messages = test::messages_with_every_field();
  ASSERT_EQ(messages.size(), std::variant_size_v<wire::Message>);
  for (std::size_t i = 0; i < messages.size(); ++i) {
    ASSERT_EQ(messages[i].index(), i) << "samples must follow the union order";
    const auto bytes = wire::encode(messages[i]);
    const wire::Message back = wire::decode(bytes);
    EXPECT_TRUE(back == messages[i]) << wire::message_name(messages[i]);
  }
}

// A Hello resumes a session or watches one (PROTOCOL.md item 1): the sample above resumes.
TEST(WireCodec, AHelloWatchesOrResumesNotBoth) {
  wire::Hello watch{1, "three", "viewer", "secret", {"tiles:half"}, "", ""};
  watch.watch_session = "0123456789abcdef0123456789abcdef";
  EXPECT_TRUE(wire::decode(wire::encode(watch)) == wire::Message(watch));
  watch.resume_session = watch.watch_session;
  const DecodeError e = refusal(wire::encode(watch));
  EXPECT_EQ(e.field(), "watch_session");
  EXPECT_EQ(e.fault(), Fault::OutOfRange);
  // Joining (issue 49 §1) is a third kind: alone it goes, with another it is refused.
  wire::Hello join{1, "phone b", "phone-2", "secret", {}, "", ""};
  join.join_session = "0123456789abcdef0123456789abcdef";
  EXPECT_TRUE(wire::decode(wire::encode(join)) == wire::Message(join));
  for (const bool resume : {true, false}) {
    wire::Hello both = join;
    (resume ? both.resume_session : both.watch_session) = join.join_session;
    const DecodeError j = refusal(wire::encode(both));
    EXPECT_EQ(j.field(), "join_session");
    EXPECT_EQ(j.fault(), Fault::OutOfRange);
  }
}

// A join token (issue 49 §1): none, one too long, or a lifetime that is not a time is refused.
TEST(WireCodec, AJoinTokenIsChecked) {
  const wire::JoinToken fine{"0123456789abcdef0123456789abcdef", "00ff00ff00ff00ff00ff00ff00ff00ff",
                             600.0f};
  EXPECT_EQ(std::get<wire::JoinToken>(wire::decode(wire::encode(fine))), fine);
  for (const auto& [bad, field] :
       {std::pair{wire::JoinToken{fine.session_id, "", 600.0f}, "token"},
        std::pair{wire::JoinToken{fine.session_id, std::string(65, 'a'), 600.0f}, "token"},
        std::pair{wire::JoinToken{fine.session_id, fine.token, 0.0f}, "expires_in"},
        std::pair{wire::JoinToken{fine.session_id, fine.token,
                                  std::numeric_limits<float>::quiet_NaN()},
                  "expires_in"}}) {
    const DecodeError e = refusal(wire::encode(bad));
    EXPECT_EQ(e.field(), field);
    EXPECT_EQ(e.fault(), Fault::OutOfRange);
  }
}

TEST(WireCodec, EveryMessageRoundTripsWithNoOptionalField) {
  for (const wire::Message& m : test::messages_with_no_optional_field()) {
    const wire::Message back = wire::decode(wire::encode(m));
    EXPECT_TRUE(back == m) << wire::message_name(m);
  }
  // Absent really means absent: the frame without orientation says so, Welcome has no limits.
  const auto frame =
      std::get<wire::CameraFrame>(wire::decode(wire::encode(test::sample_frame(0, false))));
  EXPECT_FALSE(frame.has_orientation);
  EXPECT_EQ(frame.info.orientation, glm::dquat(0, 0, 0, 0));
  EXPECT_FALSE(std::get<wire::Welcome>(wire::decode(wire::encode(wire::Welcome{}))).limits);
}

TEST(WireCodec, MessageNamesFollowTheSchema) {
  EXPECT_STREQ(wire::message_name(wire::CameraIntrinsicsMessage{}), "CameraIntrinsics");
  EXPECT_STREQ(wire::message_name(wire::CalibrationResult{}), "CalibrationResult");
  EXPECT_STREQ(wire::error_code_name(wire::ErrorCode::SessionNotFound), "SessionNotFound");
}

TEST(WireCodec, TruncatedMessagesAreRefusedAtEveryLength) {
  const auto bytes = wire::encode(test::sample_frame(3, true));
  for (std::size_t n = 0; n < bytes.size(); ++n) {
    const DecodeError e = refusal(std::span(bytes).first(n));
    EXPECT_TRUE(e.fault() == Fault::NotArlight || e.fault() == Fault::Malformed)
        << n << " bytes: " << e.what();
    EXPECT_EQ(e.code(), wire::ErrorCode::BadMessage);
  }
}

TEST(WireCodec, WrongIdentifierIsNotAnArlightMessage) {
  auto bytes = wire::encode(wire::Ping{1});
  bytes[4] = 'X';  // the identifier "ARL1" sits after the root offset
  const DecodeError e = refusal(bytes);
  EXPECT_EQ(e.fault(), Fault::NotArlight) << e.what();
  EXPECT_NE(std::string(e.what()).find("ARL1"), std::string::npos);
}

TEST(WireCodec, UnknownUnionTagIsRefused) {
  // Ping and Pong are the same table under another tag: the one byte in which their encodings
  // differ is the union tag.
  const auto ping = wire::encode(wire::Ping{77});
  const auto pong = wire::encode(wire::Pong{77});
  ASSERT_EQ(ping.size(), pong.size());
  std::vector<std::size_t> differ;
  for (std::size_t i = 0; i < ping.size(); ++i)
    if (ping[i] != pong[i]) differ.push_back(i);
  ASSERT_EQ(differ.size(), 1u);
  for (std::uint8_t tag : {std::uint8_t(0), std::uint8_t(std::variant_size_v<wire::Message> + 1),
                           std::uint8_t(200)}) {
    auto bytes = ping;
    bytes[differ[0]] = tag;
    const DecodeError e = refusal(bytes);
    // Tag 0 (NONE) with a table, or a tag past the schema's last member.
    EXPECT_TRUE(e.fault() == Fault::UnknownMessage || e.fault() == Fault::Malformed)
        << int(tag) << ": " << e.what();
    if (tag != 0) {
      EXPECT_EQ(e.fault(), Fault::UnknownMessage) << e.what();
    }
  }
}

TEST(WireCodec, OutOfRangeEnumsNameTheirField) {
  auto frame = test::sample_frame(1, false);
  frame.format = wire::PixelFormat(7);
  DecodeError e = refusal(wire::encode(frame));
  EXPECT_EQ(e.fault(), Fault::OutOfRange);
  EXPECT_EQ(e.message(), "CameraFrame");
  EXPECT_EQ(e.field(), "format");
  EXPECT_EQ(e.code(), wire::ErrorCode::Unsupported);

  e = refusal(wire::encode(wire::RequestMaps{{1.0f}, 64, Projection(9), "auto"}));
  EXPECT_EQ(e.message(), "RequestMaps");
  EXPECT_EQ(e.field(), "projection");
  EXPECT_EQ(e.code(), wire::ErrorCode::Unsupported);

  e = refusal(wire::encode(wire::MapTile{.map_width = 64,
                                         .map_height = 64,
                                         .width = 1,
                                         .height = 1,
                                         .data = {1},
                                         .coding = wire::TileCoding(5)}));
  EXPECT_EQ(e.message(), "MapTile");
  EXPECT_EQ(e.field(), "coding");
  EXPECT_EQ(e.code(), wire::ErrorCode::Unsupported);

  wire::RequestMaps kind{{1.0f}, 64, Projection::Cube, "auto"};
  kind.kind = wire::MapKind(3);
  e = refusal(wire::encode(kind));
  EXPECT_EQ(e.message(), "RequestMaps");
  EXPECT_EQ(e.field(), "kind");

  e = refusal(wire::encode(wire::Error{wire::ErrorCode(99), "?"}));
  EXPECT_EQ(e.fault(), Fault::OutOfRange);
  EXPECT_EQ(e.field(), "code");
  // Moved says where to (issue 49 §2), as HOST:PORT; no other error names an address.
  for (const char* address : {"", "10.0.0.2", "10.0.0.2:0", ":7878", "10.0.0.2:99999"}) {
    e = refusal(wire::encode(wire::Error{wire::ErrorCode::Moved, "elsewhere", address}));
    EXPECT_EQ(e.field(), "address") << address;
  }
  e = refusal(wire::encode(wire::Error{wire::ErrorCode::Busy, "full", "10.0.0.2:7878"}));
  EXPECT_EQ(e.field(), "address");
  EXPECT_EQ(std::get<wire::Error>(wire::decode(wire::encode(
                wire::Error{wire::ErrorCode::Moved, "elsewhere", "[fd00::2]:7890"})))
                .address,
            "[fd00::2]:7890");

  e = refusal(
      wire::encode(wire::MapTile{1, 0, 1.0f, Projection::AngleMap, 64, 64, 0, 32, 0, 64, 8, {1}}));
  EXPECT_EQ(e.message(), "MapTile");
  EXPECT_EQ(e.field(), "x") << e.what();  // a tile reaching past the map's edge
  e = refusal(
      wire::encode(wire::MapTile{1, 0, 1.0f, Projection::AngleMap, 64, 64, 13, 0, 0, 1, 1, {1}}));
  EXPECT_EQ(e.field(), "level");
  e = refusal(wire::encode(wire::MapTile{1, 0, 0.0f, Projection::Cube, 8, 48, 0, 0, 0, 8, 8, {1},
                                         wire::TileCoding::Half, wire::MapKind::Ggx, 1.5f}));
  EXPECT_EQ(e.field(), "roughness");
}

// Messages from before the GGX chain (issue 34 §2) carry no kind: they read as the Phong set.
TEST(WireCodec, OldMapMessagesReadAsPhong) {
  const fs::path valid = fs::path(ARLIGHT_SOURCE_DIR) / "tests/protocol/corpus/valid";
  for (const char* name : {"4-RequestMaps", "9-MapTile"}) {
    std::ifstream in(valid / name, std::ios::binary);
    ASSERT_TRUE(in) << name;
    const std::vector<std::uint8_t> bytes((std::istreambuf_iterator<char>(in)), {});
    const wire::Message m = wire::decode(bytes);
    if (const auto* r = std::get_if<wire::RequestMaps>(&m)) {
      EXPECT_EQ(r->kind, wire::MapKind::Phong);
      EXPECT_EQ(r->levels, 0);
      EXPECT_EQ(r->size, 256u);
    } else {
      const auto& t = std::get<wire::MapTile>(m);
      EXPECT_EQ(t.kind, wire::MapKind::Phong);
      EXPECT_EQ(t.shininess, 40.0f);
    }
  }
}

// A LightingUpdate from before the frame advice (issue 37 §1; the seed corpus keeps one): no
// advice, which clients read as "every frame, at the camera's size".
TEST(WireCodec, AnOldLightingUpdateCarriesNoFrameAdvice) {
  std::ifstream in(fs::path(ARLIGHT_SOURCE_DIR) / "tests/protocol/corpus/valid/8-LightingUpdate",
                   std::ios::binary);
  ASSERT_TRUE(in);
  const std::vector<std::uint8_t> bytes((std::istreambuf_iterator<char>(in)), {});
  const auto u = std::get<wire::LightingUpdate>(wire::decode(bytes));
  EXPECT_EQ(u.frame_sequence, 9u);
  EXPECT_EQ(u.advised_width, 0);
  EXPECT_EQ(u.advised_height, 0);
  EXPECT_EQ(u.advised_fps, 0.0f);
}

// LightingUpdate's fractions and exposure (issue 16): outside their ranges a message is
// refused, naming the field.
TEST(WireCodec, LightingUpdateFractionsAndExposureAreChecked) {
  const auto refused_field = [](float coverage, float estimated, double exposure) {
    wire::LightingUpdate u;
    u.coverage = coverage, u.estimated = estimated, u.frame_exposure = exposure;
    const DecodeError e = refusal(wire::encode(u));
    EXPECT_EQ(e.fault(), Fault::OutOfRange);
    EXPECT_EQ(e.message(), "LightingUpdate");
    return e.field();
  };
  EXPECT_EQ(refused_field(1.5f, 0.0f, 0.0), "coverage");
  EXPECT_EQ(refused_field(0.5f, -0.25f, 0.0), "coverage");
  EXPECT_EQ(refused_field(0.0f, std::numeric_limits<float>::quiet_NaN(), 0.0), "coverage");
  EXPECT_EQ(refused_field(0.5f, 0.5f, -0.01), "frame_exposure");
  EXPECT_EQ(refused_field(0.5f, 0.5f, std::numeric_limits<double>::infinity()), "frame_exposure");
  wire::LightingUpdate fine;
  fine.coverage = 0.25f, fine.estimated = 0.75f, fine.frame_exposure = 0.02;
  EXPECT_EQ(std::get<wire::LightingUpdate>(wire::decode(wire::encode(fine))), fine);
}

// The light's uncertainty and the next view (issue 48): a map whose size is not the zones', a
// view that is not a direction or an error out of range is refused, naming the field; an
// update from before them (the seed corpus) states none.
TEST(WireCodec, LightUncertaintyAndNextViewAreChecked) {
  const auto refused_field = [](const wire::LightingUpdate& u) {
    const DecodeError e = refusal(wire::encode(u));
    EXPECT_EQ(e.fault(), Fault::OutOfRange);
    EXPECT_EQ(e.message(), "LightingUpdate");
    return e.field();
  };
  wire::LightingUpdate fine;
  fine.light_error = 0.08f, fine.light_error_zones = 2;
  fine.light_error_map = {1, 2, 3, 4, 5, 6, 7, 255};
  fine.next_view = glm::vec3(0.0f, 1.0f, 0.0f), fine.next_view_gain = 0.03f;
  EXPECT_EQ(std::get<wire::LightingUpdate>(wire::decode(wire::encode(fine))), fine);
  wire::LightingUpdate u = fine;
  u.light_error_map.pop_back();
  EXPECT_EQ(refused_field(u), "light_error_map");
  u = fine, u.light_error_zones = 33, u.light_error_map.assign(2 * 33 * 33, 1);
  EXPECT_EQ(refused_field(u), "light_error_zones");
  u = fine, u.light_error = -0.5f;
  EXPECT_EQ(refused_field(u), "light_error");
  u = fine, u.light_error = std::numeric_limits<float>::quiet_NaN();
  EXPECT_EQ(refused_field(u), "light_error");
  u = fine, u.next_view = glm::vec3(0.0f, 2.0f, 0.0f);
  EXPECT_EQ(refused_field(u), "next_view");
  u = fine, u.next_view_gain = 11.0f;
  EXPECT_EQ(refused_field(u), "next_view_gain");
  u = fine, u.registration = wire::Registration(3);
  EXPECT_EQ(refused_field(u), "registration");
  std::ifstream in(fs::path(ARLIGHT_SOURCE_DIR) / "tests/protocol/corpus/valid/8-LightingUpdate",
                   std::ios::binary);
  ASSERT_TRUE(in);
  const std::vector<std::uint8_t> bytes((std::istreambuf_iterator<char>(in)), {});
  const auto old = std::get<wire::LightingUpdate>(wire::decode(bytes));
  EXPECT_EQ(old.light_error, 0.0f);
  EXPECT_TRUE(old.light_error_map.empty());
  EXPECT_FALSE(old.next_view.has_value());
}

// ExposureAdvice (issue 16 §4): an exposure that is not one, or a fraction outside [0, 1].
TEST(WireCodec, ExposureAdviceRangesAreChecked) {
  const auto refused_field = [](double exposure, float clipped) {
    const DecodeError e = refusal(wire::encode(wire::ExposureAdvice{3, exposure, clipped}));
    EXPECT_EQ(e.fault(), Fault::OutOfRange);
    EXPECT_EQ(e.message(), "ExposureAdvice");
    return e.field();
  };
  EXPECT_EQ(refused_field(-1e-3, 0.1f), "exposure");
  EXPECT_EQ(refused_field(std::numeric_limits<double>::quiet_NaN(), 0.1f), "exposure");
  EXPECT_EQ(refused_field(1e-3, 1.5f), "clipped");
  EXPECT_EQ(refused_field(1e-3, -0.5f), "clipped");
  const wire::ExposureAdvice fine{3, 1.0 / 4000, 0.02f};
  EXPECT_EQ(std::get<wire::ExposureAdvice>(wire::decode(wire::encode(fine))), fine);
}

// Frame advice in a LightingUpdate (issue 37 §1): half a size, or a rate that is not one.
TEST(WireCodec, FrameAdviceRangesAreChecked) {
  const auto advice = [](std::uint16_t w, std::uint16_t h, float fps) {
    wire::LightingUpdate u;
    u.advised_width = w, u.advised_height = h, u.advised_fps = fps;
    return u;
  };
  const auto refused_field = [&](std::uint16_t w, std::uint16_t h, float fps) {
    const DecodeError e = refusal(wire::encode(advice(w, h, fps)));
    EXPECT_EQ(e.fault(), Fault::OutOfRange);
    EXPECT_EQ(e.message(), "LightingUpdate");
    return e.field();
  };
  EXPECT_EQ(refused_field(160, 0, 30), "advised_width");
  EXPECT_EQ(refused_field(0, 120, 30), "advised_width");
  EXPECT_EQ(refused_field(160, 120, -1), "advised_fps");
  EXPECT_EQ(refused_field(160, 120, std::numeric_limits<float>::quiet_NaN()), "advised_fps");
  EXPECT_EQ(refused_field(160, 120, 1000), "advised_fps");
  const wire::LightingUpdate fine = advice(160, 120, 10);
  EXPECT_EQ(std::get<wire::LightingUpdate>(wire::decode(wire::encode(fine))), fine);
}

// Location (issue 17): a place off the Earth, a time the ephemeris does not cover, a north
// that is not an azimuth; and a LightingUpdate's sun that is not a direction or a state.
TEST(WireCodec, LocationAndTheSunAreChecked) {
  const auto refused_field = [](const wire::Message& m) {
    const DecodeError e = refusal(wire::encode(m));
    EXPECT_EQ(e.fault(), Fault::OutOfRange);
    return e.message() + "." + e.field();
  };
  const wire::Location fine{{-33.86, 151.21, 58.0}, 1.7e9, false, 0.0};
  EXPECT_EQ(std::get<wire::Location>(wire::decode(wire::encode(fine))), fine);
  wire::Location bad = fine;
  bad.where.latitude_deg = 95.0;
  EXPECT_EQ(refused_field(bad), "Location.latitude");
  bad = fine, bad.where.longitude_deg = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(refused_field(bad), "Location.latitude");
  bad = fine, bad.utc_seconds = 1e15;
  EXPECT_EQ(refused_field(bad), "Location.utc_seconds");
  bad = fine, bad.north_offset_deg = 270.0;
  EXPECT_EQ(refused_field(bad), "Location.north_offset");
  wire::LightingUpdate u;
  u.sh = ShCoeffs(1);
  u.sun_state = SunState::Predicted, u.sun_direction = {0.0f, 2.0f, 0.0f};
  EXPECT_EQ(refused_field(u), "LightingUpdate.sun_direction");
  u.sun_direction = {0.0f, 0.0f, 0.0f};
  EXPECT_EQ(refused_field(u), "LightingUpdate.sun_direction");
  u.sun_state = SunState(7), u.sun_direction = {0.0f, 1.0f, 0.0f};
  EXPECT_EQ(refused_field(u), "LightingUpdate.sun_state");
  u.sun_state = SunState::BelowHorizon;
  EXPECT_EQ(std::get<wire::LightingUpdate>(wire::decode(wire::encode(u))), u);
}

TEST(WireCodec, LengthsOverTheLimitsAreTooLarge) {
  const wire::WireLimits limits{.max_message_bytes = 1u << 20,
                                .max_frame_pixels = 100 * 100,
                                .max_map_size = 512,
                                .max_maps = 4};
  auto frame = test::sample_frame(1, false);
  frame.width = 101, frame.height = 100;
  DecodeError e = refusal(wire::encode(frame), limits);
  EXPECT_EQ(e.fault(), Fault::OverLimit);
  EXPECT_EQ(e.code(), wire::ErrorCode::TooLarge);
  EXPECT_EQ(e.message(), "CameraFrame");

  e = refusal(wire::encode(wire::RequestMaps{{1, 2, 3, 4, 5}, 64, Projection::AngleMap, ""}),
              limits);
  EXPECT_EQ(e.field(), "shininess");
  EXPECT_EQ(e.code(), wire::ErrorCode::TooLarge);

  wire::CalibrationSet set;
  set.frames.assign(wire::kMaxCalibrationFrames + 1, test::sample_frame(1, false));
  e = refusal(wire::encode(set));
  EXPECT_EQ(e.field(), "frames");
  EXPECT_EQ(e.fault(), Fault::OverLimit);

  e = refusal(wire::encode(wire::Hello{1, "", std::string(5000, 'd'), "", {}, "", ""}));
  EXPECT_EQ(e.message(), "Hello");
  EXPECT_EQ(e.field(), "device_id");
  EXPECT_EQ(e.fault(), Fault::OverLimit);

  // The whole message against max_message_bytes, and a header announcing too much.
  auto big = test::sample_frame(1, false);
  big.data.assign(2u << 20, 0);
  e = refusal(wire::encode(big), limits);
  EXPECT_EQ(e.fault(), Fault::OverLimit);
  const auto header = wire::frame_header(std::size_t(limits.max_message_bytes) + 1);
  EXPECT_THROW(wire::read_header(header, limits.max_message_bytes), DecodeError);
  EXPECT_EQ(wire::read_header(wire::frame_header(1000), limits.max_message_bytes), 1000u);
  try {
    wire::read_header(wire::frame_header(0), limits.max_message_bytes);
    ADD_FAILURE() << "length 0 accepted";
  } catch (const DecodeError& z) {
    EXPECT_EQ(z.code(), wire::ErrorCode::BadMessage);
  }
}

TEST(WireCodec, VectorsOfTheWrongSizeAreRefused) {
  wire::LightingUpdate u;
  u.sh = ShCoeffs(3);
  u.sh.c.resize(4);  // order 3 needs 9 coefficients
  DecodeError e = refusal(wire::encode(u));
  EXPECT_EQ(e.fault(), Fault::WrongSize);
  EXPECT_EQ(e.message(), "LightingUpdate");
  EXPECT_EQ(e.field(), "sh");

  auto frame = test::sample_frame(1, true);
  frame.data.pop_back();  // RGB8 needs width * height * 3 bytes
  e = refusal(wire::encode(frame));
  EXPECT_EQ(e.fault(), Fault::WrongSize);
  EXPECT_EQ(e.field(), "data");

  frame.data.clear();
  e = refusal(wire::encode(frame));
  EXPECT_EQ(e.fault(), Fault::Missing);
}

// The verifier checks a vector's length word, not its elements' alignment: an IMU vector 4 bytes
// off (the wire fuzzer's find, kept in its corpus) is refused, not read misaligned.
TEST(WireCodec, MisalignedVectorsOfDoublesAreRefused) {
  std::ifstream in(fs::path(ARLIGHT_SOURCE_DIR) / "tests/fuzz/corpus/wire/crash-imu-misaligned",
                   std::ios::binary);
  const std::vector<std::uint8_t> bytes((std::istreambuf_iterator<char>(in)),
                                        std::istreambuf_iterator<char>());
  ASSERT_GT(bytes.size(), 100u);
  const DecodeError e = refusal(bytes);
  EXPECT_EQ(e.fault(), Fault::Malformed);
  EXPECT_EQ(e.message(), "CameraFrame");
  EXPECT_EQ(e.field(), "imu");
}

// A payload that starts off an 8-byte boundary (a frame read after its 4-byte header) decodes
// the same: the codec reads its doubles from an aligned copy (the sanitizer build checks it).
TEST(WireCodec, APayloadAtAnyAddressDecodes) {
  const wire::CameraFrame frame = test::sample_frame(3, true);
  ASSERT_FALSE(frame.imu.empty());
  const std::vector<std::uint8_t> bytes = wire::encode(frame);
  for (std::size_t shift : {1, 4, 6}) {
    std::vector<std::uint8_t> shifted(shift, 0);
    shifted.insert(shifted.end(), bytes.begin(), bytes.end());
    const auto back = wire::decode(std::span(shifted).subspan(shift));
    EXPECT_TRUE(std::get<wire::CameraFrame>(back) == frame) << "shifted by " << shift;
  }
}

TEST(WireCodec, FramingAddsTheLittleEndianLength) {
  const auto envelope = wire::encode(wire::Ping{5});
  const auto framed = wire::frame(envelope);
  ASSERT_EQ(framed.size(), envelope.size() + 4);
  EXPECT_EQ(framed[0], std::uint8_t(envelope.size()));
  EXPECT_EQ(framed[1], 0);
  EXPECT_TRUE(std::equal(envelope.begin(), envelope.end(), framed.begin() + 4));
}

TEST(WireCodec, HalfFloatTilesRoundTripAndRefuseDamage) {
  std::vector<float> rgb = {0.0f, 0.5f, 1.0f, 2.0f, 65000.0f, 1e-3f};
  for (const auto coding : {wire::TileCoding::ZstdHalf, wire::TileCoding::Half,
                            wire::TileCoding::ZstdPlanar, wire::TileCoding::Planar}) {
    SCOPED_TRACE(int(coding));
    const auto data = wire::encode_half_rgb(rgb.data(), 2, coding);
    std::string why;
    const auto back = wire::decode_half_rgb(data, 2, coding, why);
    ASSERT_TRUE(back) << why;
    for (std::size_t i = 0; i < rgb.size(); ++i) EXPECT_NEAR((*back)[i], rgb[i], rgb[i] * 1e-3);
    EXPECT_FALSE(wire::decode_half_rgb(data, 3, coding, why));
    EXPECT_NE(why.find("expected 18"), std::string::npos) << why;
    EXPECT_FALSE(wire::decode_half_rgb(std::span(data).first(3), 2, coding, why));
  }
  // Half is the bytes a browser reads with a DataView: little-endian IEEE halves (1.0 = 0x3c00).
  const auto half = wire::encode_half_rgb(rgb.data(), 2, wire::TileCoding::Half);
  ASSERT_EQ(half.size(), 12u);
  EXPECT_EQ(half[4], 0x00);
  EXPECT_EQ(half[5], 0x3c);
  // Each coding refuses the other's bytes: zstd is not 12 raw bytes, raw bytes are not zstd.
  std::string why;
  EXPECT_FALSE(wire::decode_half_rgb(half, 2, wire::TileCoding::ZstdHalf, why));
  EXPECT_FALSE(
      wire::decode_half_rgb(wire::encode_half_rgb(rgb.data(), 2), 2, wire::TileCoding::Half, why));
  // A non-finite texel is refused.
  std::vector<float> inf = {0, 0, 0, 1e9f, 0, 0};
  EXPECT_FALSE(wire::decode_half_rgb(wire::encode_half_rgb(inf.data(), 2, wire::TileCoding::Half),
                                     2, wire::TileCoding::Half, why));
  EXPECT_NE(why.find("non-finite"), std::string::npos) << why;

  // Planar: the same halves as byte planes, each byte the difference from the one before + 128.
  const auto planes = wire::encode_half_rgb(rgb.data(), 2, wire::TileCoding::Planar);
  ASSERT_EQ(planes.size(), 12u);
  EXPECT_EQ(planes[0], half[0]);                         // R's low bytes first
  EXPECT_EQ(planes[1], std::uint8_t(half[6] - half[0] + 128));  // texel 1's R low byte
  EXPECT_EQ(planes[3], std::uint8_t(half[7] - half[1] + 128));  // R's high bytes next
}

TEST(WireCodec, TileCodingFollowsTheHelloCapabilities) {
  using wire::TileCoding;
  EXPECT_EQ(wire::choose_tile_coding({"maps", "jpeg"}), TileCoding::ZstdHalf);  // before codings
  EXPECT_EQ(wire::choose_tile_coding({"maps", wire::kCapabilityTilesHalf}), TileCoding::Half);
  EXPECT_EQ(wire::choose_tile_coding({wire::kCapabilityTilesHalf, wire::kCapabilityTilesZstd}),
            TileCoding::ZstdHalf);
  EXPECT_EQ(wire::choose_tile_coding({wire::kCapabilityTilesZstd}), TileCoding::ZstdHalf);
  // The planes when named: zstd's for a client with zstd, raw for a browser.
  EXPECT_EQ(wire::choose_tile_coding({wire::kCapabilityTilesZstdPlanar, wire::kCapabilityTilesZstd,
                                      wire::kCapabilityTilesHalf}),
            TileCoding::ZstdPlanar);
  EXPECT_EQ(wire::choose_tile_coding({wire::kCapabilityTilesPlanar, wire::kCapabilityTilesHalf}),
            TileCoding::Planar);
  EXPECT_EQ(wire::choose_tile_coding({wire::kCapabilityTilesPlanar, wire::kCapabilityTilesZstd}),
            TileCoding::ZstdHalf);
}

// The seed corpus for the fuzzers: valid/ decodes, broken/ is refused. ARLIGHT_WRITE_CORPUS=1
// rewrites it from the samples above (then commit the files, except 4-RequestMaps, 8-
// LightingUpdate and 9-MapTile: kept as written before fields were added, the tests above read
// them as old messages).
TEST(WireCodec, SeedCorpusDecodesAsItsFolderSays) {
  const fs::path corpus = fs::path(ARLIGHT_SOURCE_DIR) / "tests/protocol/corpus";
  if (std::getenv("ARLIGHT_WRITE_CORPUS")) {
    const auto write = [&](const std::string& name, const std::vector<std::uint8_t>& bytes) {
      fs::create_directories((corpus / name).parent_path());
      std::ofstream(corpus / name, std::ios::binary)
          .write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
    };
    int n = 0;
    for (const auto& set :
         {test::messages_with_every_field(), test::messages_with_no_optional_field()})
      for (const wire::Message& m : set)
        write("valid/" + std::to_string(n++) + "-" + wire::message_name(m), wire::encode(m));
    const auto frame = wire::encode(test::sample_frame(3, true));
    write("broken/truncated-CameraFrame", {frame.begin(), frame.begin() + long(frame.size() / 2)});
    auto id = wire::encode(wire::Ping{1});
    id[4] = 'X';
    write("broken/wrong-identifier", id);
    auto rgb = test::sample_frame(1, true);
    rgb.data.pop_back();
    write("broken/rgb8-wrong-size", wire::encode(rgb));
    auto fmt = test::sample_frame(1, false);
    fmt.format = wire::PixelFormat(7);
    write("broken/unknown-pixel-format", wire::encode(fmt));
    wire::LightingUpdate u;
    u.sh = ShCoeffs(3);
    u.sh.c.resize(4);
    write("broken/sh-wrong-size", wire::encode(u));
    write("broken/garbage", {64, 0, 0, 0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12});
  }
  int valid = 0, broken = 0;
  for (const auto& entry : fs::recursive_directory_iterator(corpus)) {
    if (!entry.is_regular_file()) continue;
    std::ifstream in(entry.path(), std::ios::binary);
    const std::vector<std::uint8_t> bytes((std::istreambuf_iterator<char>(in)),
                                          std::istreambuf_iterator<char>());
    if (entry.path().parent_path().filename() == "valid") {
      EXPECT_NO_THROW(wire::decode(bytes)) << entry.path();
      ++valid;
    } else {
      EXPECT_THROW(wire::decode(bytes), DecodeError) << entry.path();
      ++broken;
    }
  }
  EXPECT_EQ(valid, 2 * int(std::variant_size_v<wire::Message>));
  EXPECT_GE(broken, 6);
}


// The lights taken out of a GGX chain (issue 51 §1): more than a shader takes, a direction that
// is not one, a power below 0 or not finite, a radius out of [0, pi/2) are refused, naming the
// field; a request for more lights than a shader takes too.
TEST(WireCodec, TheChainsLightsAreChecked) {
  const auto refusal_of = [](const wire::Message& m) {
    const DecodeError e = refusal(wire::encode(m));
    return std::string(e.message()) + "." + std::string(e.field()) + " " + fault_name(e.fault());
  };
  const SpecularLight sun{{0.0f, 0.6f, -0.8f}, {40.0f, 36.0f, 28.0f}, 0.0125f};
  wire::MapSetComplete fine{3, 5, 0.25f, 0.5f, 120, 0, 17, {sun}};
  EXPECT_EQ(std::get<wire::MapSetComplete>(wire::decode(wire::encode(fine))), fine);
  for (const auto& [light, count] :
       std::vector<std::pair<SpecularLight, std::size_t>>{
           {sun, std::size_t(kMaxSpecularLights) + 1},
           {{{0.0f, 1.2f, 0.0f}, sun.power, sun.radius}, 1},
           {{sun.direction, {1.0f, -0.5f, 1.0f}, sun.radius}, 1},
           {{sun.direction, {1.0f, std::numeric_limits<float>::infinity(), 1.0f}, sun.radius}, 1},
           {{sun.direction, sun.power, -0.1f}, 1},
           {{sun.direction, sun.power, 2.0f}, 1}}) {
    wire::MapSetComplete bad = fine;
    bad.lights.assign(count, light);
    EXPECT_EQ(refusal_of(bad), count > 1 ? "MapSetComplete.lights OverLimit"
                                         : "MapSetComplete.lights OutOfRange");
  }
  wire::RequestMaps many;
  many.kind = wire::MapKind::Ggx, many.size = 256, many.specular_lights = kMaxSpecularLights + 1;
  EXPECT_EQ(refusal_of(many), "RequestMaps.specular_lights OverLimit");
}

}  // namespace
}  // namespace arlight
