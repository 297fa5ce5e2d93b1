// Two phones, one room (issue 49 §1, PROTOCOL.md "Contributors"): the real arlightd on a loopback
// port, a session's own phone and a second phone that joins it, each through the client library
// with frames of the simulated room. The second phone's heading origin and sensitivity are its
// own; it is registered with the session's map before its frames are merged, and a phone in
// another room never is.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <glm/gtc/quaternion.hpp>
#include <mutex>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <thread>

#include "arlight/capture/capture.hpp"
#include "arlight/common/hdr_io.hpp"
#include "arlight/common/resample.hpp"
#include "arlight/net/client_messages.hpp"
#include "arlight/net/client_net.hpp"
#include "arlight/sim/view.hpp"
#include "support/daemon_process.hpp"

namespace fs = std::filesystem;
using namespace arlight;
using namespace std::chrono_literals;
using test::DaemonProcess;

namespace {

const CameraIntrinsics kCamera = CameraIntrinsics::from_fov(320, 240, 60);

const EnvSampler& room(const std::string& name) {
  static std::map<std::string, std::pair<std::unique_ptr<EnvMap>, std::unique_ptr<EnvSampler>>>
      rooms;
  auto& r = rooms[name];
  if (!r.first) {
    r.first = std::make_unique<EnvMap>(
        resample(load_envmap(std::string(ARLIGHT_SOURCE_DIR) + "/data/probes/" + name + ".exr").env,
                 EnvLayout::for_size(Projection::LatLong, 512)));
    r.second = std::make_unique<EnvSampler>(*r.first);
  }
  return *r.second;
}

glm::dquat view(double yaw, double pitch) {
  return glm::normalize(glm::angleAxis(glm::radians(yaw), glm::dvec3(0, 1, 0)) *
                        glm::angleAxis(glm::radians(pitch), glm::dvec3(1, 0, 0)));
}

// A phone of the test: its client, its frames' sequence, its sensor's heading origin (degrees
// off the room's) and how much more sensitive its camera is than it says.
struct Phone {
  client::Client client;
  std::uint64_t sequence = 0;
  double heading = 0.0, sensitivity = 1.0;
  double drift = 0.0;  // degrees a second its heading drifts (a gyro's bias)
  // The daemon it talks to: when an update does not come, what the daemon says of its sessions
  // (whether the frame reached it) goes with the failure (CI once saw one phone's updates stop
  // under the sanitizers' load while the others' came: issue 50 §5).
  const DaemonProcess* daemon = nullptr;
  bool missed = false;  // an update did not come

  std::string daemon_state() {
    if (!daemon) return "";
    const auto [status, sessions] = daemon->admin_get("/sessions");
    return "\n/sessions (" + std::to_string(status) + "): " + sessions +
           "\nthis client: connected " + std::to_string(client.connected()) + ", stalled " +
           std::to_string(client.stalled());
  }

  // Its view of `name` at world yaw and pitch, answered: the update.
  client::LightingUpdate look(const std::string& name, double yaw, double pitch) {
    const double exposure = 0.02;
    const cv::Mat image =
        sim::ideal_view(room(name), kCamera, view(yaw, pitch), exposure * sensitivity);
    std::vector<std::uint8_t> jpeg;
    cv::imencode(".jpg", image, jpeg, {cv::IMWRITE_JPEG_QUALITY, 92});
    const std::uint64_t seq = ++sequence;
    const double time = 0.05 * double(seq);
    const glm::dquat sensor =
        glm::normalize(glm::angleAxis(glm::radians(-heading - drift * time), glm::dvec3(0, 1, 0)) *
                       view(yaw, pitch));
    client.send_jpeg_frame(seq, {time, exposure, 1.0, sensor}, kCamera.width, kCamera.height, jpeg);
    const bool answered = client.wait_for(
        [&] {
          const auto u = client.last_update();
          return u && u->frame_sequence >= seq;
        },
        missed ? 1s : 20s);  // once one is missing, the rest fail fast (not ctest's timeout)
    EXPECT_TRUE(answered) << "no update for frame " << seq << (missed ? "" : daemon_state());
    missed = missed || !answered;
    return client.last_update().value_or(client::LightingUpdate{});
  }
};

// Sweeps yaw [from, to) every `step` degrees in each band of `pitches`; the last update.
client::LightingUpdate sweep(Phone& p, const std::string& name, double from, double to,
                             const std::vector<double>& pitches = {-15.0, 25.0},
                             double step = 15.0) {
  client::LightingUpdate last;
  for (double pitch : pitches)
    for (double yaw = from; yaw < to; yaw += step) last = p.look(name, yaw, pitch);
  return last;
}

// Phone `a` starts a session on `d` as its own device: the session's id.
std::string start_session(const DaemonProcess& d, Phone& a) {
  a.daemon = &d;
  const std::string id =
      a.client.connect("127.0.0.1", d.port(), "arlight-sim", test::kToken, "phone a").session_id;
  a.client.send_intrinsics(kCamera);
  return id;
}

// Relative difference of the irradiance (SH bands 0-2) of two updates.
double irradiance_difference(const client::LightingUpdate& a, const client::LightingUpdate& b) {
  double diff = 0.0, norm = 0.0;
  for (std::size_t k = 0; k < 9; ++k)
    diff += glm::length(a.sh.c[k] - b.sh.c[k]), norm += glm::length(a.sh.c[k]);
  return diff / norm;
}

// The SH of what the sweeps see of the room, as it is: the views' exact images at their exact
// orientations, merged by the capture library alone (no JPEG, no alignment).
ShCoeffs seen_room_sh(const std::string& name) {
  capture::CaptureOptions o;
  o.layout = capture::capture_layout_for(512);
  o.fill = capture::Fill::None;
  o.align = false;
  capture::CaptureSession s(kCamera, CameraResponse::srgb(), o);
  for (double pitch : {-15.0, 25.0})
    for (double yaw = 0.0; yaw < 360.0; yaw += 15.0)
      s.add_image(sim::ideal_view(room(name), kCamera, view(yaw, pitch), 0.02),
                  {0.0, 0.02, 1.0, view(yaw, pitch)});
  return s.measured_sh();
}

// The code of the ClientError joining `session` as `device` with `token` throws, or "".
std::string join_refusal(const DaemonProcess& d, const std::string& session,
                         const std::string& device, const std::string& token) {
  client::Client c;
  c.join(session);
  try {
    c.connect("127.0.0.1", d.port(), device, token, "phone b");
  } catch (const client::ClientError& e) {
    return e.code();
  }
  return "";
}

}  // namespace

TEST(Contributors, TwoPhonesCaptureOneRoomAndAThirdInAnotherIsNeverMerged) {
  const fs::path dir = test::fresh_temp_dir("contributors");
  DaemonProcess d(dir / "daemon", {"--max-contributors", "2", "--fill", "none"});
  // One phone's whole sweep, for comparison.
  Phone alone;
  alone.daemon = &d;
  alone.client.connect("127.0.0.1", d.port(), "arlight-sim", test::kToken, "phone a");
  alone.client.send_intrinsics(kCamera);
  const client::LightingUpdate whole = sweep(alone, "venice", 0.0, 360.0);
  alone.client.bye();

  // Two: the session's own phone sweeps the first half and a bit.
  Phone a;
  const std::string id = start_session(d, a);
  a.client.request_maps(client::ggx_request(32, 3));
  const client::LightingUpdate half = sweep(a, "venice", 0.0, 200.0);
  EXPECT_EQ(half.registration, wire::Registration::Own);
  EXPECT_LT(half.coverage, whole.coverage - 0.05);

  // The second joins with the session's token under its own name: 123 degrees off in heading
  // and drifting 2 degrees a second, 1.5x as sensitive as it says.
  Phone b;
  b.heading = 123.0, b.sensitivity = 1.5, b.drift = 2.0;
  b.daemon = &d;
  b.client.join(id);
  EXPECT_EQ(b.client.connect("127.0.0.1", d.port(), "phone-b", test::kToken, "phone b").session_id,
            id);
  b.client.send_intrinsics(kCamera);
  // Its first view, of what the map has, waits for a second to agree; then it is registered.
  const client::LightingUpdate first = b.look("venice", 170.0, -15.0);
  EXPECT_EQ(first.registration, wire::Registration::Waiting);
  EXPECT_FALSE(first.frame_used);
  EXPECT_NE(first.reason.find("registering"), std::string::npos) << first.reason;
  const client::LightingUpdate second = b.look("venice", 180.0, -15.0);
  EXPECT_EQ(second.registration, wire::Registration::Registered) << second.reason;
  EXPECT_TRUE(second.frame_used);
  const client::LightingUpdate both = sweep(b, "venice", 180.0, 360.0);
  EXPECT_EQ(both.registration, wire::Registration::Registered);
  // Together they cover what one phone did, and the map lights as one phone's: its irradiance's
  // error against the room's within half a point of one phone's (the same views, two cameras'
  // JPEGs and alignments).
  EXPECT_NEAR(both.coverage, whole.coverage, 0.01);
  client::LightingUpdate truth;
  truth.sh = seen_room_sh("venice");
  const double one_error = irradiance_difference(whole, truth),
               two_error = irradiance_difference(both, truth);
  EXPECT_LT(std::abs(two_error - one_error), 0.005) << one_error << " " << two_error;
  std::printf("irradiance error against the views' exact map: one phone %.3f %%, two %.3f %%\n",
              100.0 * one_error, 100.0 * two_error);
  EXPECT_LT(irradiance_difference(both, whole), 0.01);
  // The contributor gets the session's map sets.
  EXPECT_TRUE(b.client.wait_for([&] { return b.client.last_complete_ggx().has_value(); }, 30s));

  // A third phone in another room joins: never registered, the session's map unharmed.
  Phone c;
  c.heading = 40.0;
  c.daemon = &d;
  c.client.join(id);
  c.client.connect("127.0.0.1", d.port(), "phone-c", test::kToken, "phone c");
  c.client.send_intrinsics(kCamera);
  for (int k = 0; k < 12; ++k) {
    const client::LightingUpdate u = c.look("park", 30.0 * k, k % 2 ? 25.0 : -15.0);
    EXPECT_EQ(u.registration, wire::Registration::Waiting) << "frame " << k;
    EXPECT_FALSE(u.frame_used);
  }
  const client::LightingUpdate after = a.look("venice", 100.0, -15.0);
  EXPECT_LT(irradiance_difference(after, both), 1e-3);
  EXPECT_NEAR(after.coverage, both.coverage, 1e-4);

  // A fourth is one over --max-contributors; a wrong token, an unknown session and a Hello
  // that both joins and resumes are refused; a contributor asking for maps is closed, and the
  // session carries on.
  EXPECT_EQ(join_refusal(d, id, "phone-d", test::kToken), "Busy");
  EXPECT_EQ(join_refusal(d, id, "phone-d", "wrong"), "Unauthorized");
  EXPECT_EQ(join_refusal(d, std::string(32, 'f'), "phone-d", test::kToken), "SessionNotFound");
  c.client.request_maps(client::ggx_request(32, 3));
  EXPECT_TRUE(c.client.wait_for([&] { return c.client.server_error().has_value(); }, 10s));
  EXPECT_EQ(c.client.server_error()->first, "Unauthorized");
  EXPECT_TRUE(a.look("venice", 110.0, -15.0).frame_used);

  // /sessions counts them; the contributor leaving does not end the session.
  b.client.bye();
  const auto [status, text] = d.admin_get("/sessions");
  ASSERT_EQ(status, 200);
  EXPECT_NE(text.find("\"contributors\""), std::string::npos) << text;
  EXPECT_TRUE(a.look("venice", 120.0, -15.0).frame_used);
}

// A join link's token (RequestJoinToken): another device joins with it and its own id; the token
// ends when the session's device leaves, and a contributor does not end the session.
TEST(Contributors, AJoinTokenLetsAnotherDeviceJoinUntilTheSessionsDeviceLeaves) {
  const fs::path dir = test::fresh_temp_dir("contributors_token");
  DaemonProcess d(dir / "daemon");
  Phone a;
  const client::Welcome w =
      a.client.connect("127.0.0.1", d.port(), "arlight-sim", test::kToken, "phone a");
  const std::string id = w.session_id;
  EXPECT_NE(std::find(w.capabilities.begin(), w.capabilities.end(), "join"), w.capabilities.end());
  a.client.send_intrinsics(kCamera);
  sweep(a, "venice", 0.0, 120.0);
  a.client.request_join_token();
  ASSERT_TRUE(a.client.wait_for([&] { return a.client.join_token().has_value(); }, 10s));
  const wire::JoinToken token = *a.client.join_token();
  EXPECT_EQ(token.session_id, id);
  EXPECT_EQ(token.token.size(), 32u);
  EXPECT_NEAR(token.expires_in_s, 600.0f, 1.0f);
  // Another device, unknown to the tokens file, joins with it.
  Phone b;
  b.heading = 45.0;
  b.client.join(id);
  b.client.connect("127.0.0.1", d.port(), "someone-elses-phone", token.token, "phone b");
  b.client.send_intrinsics(kCamera);
  b.look("venice", 60.0, -15.0);
  EXPECT_EQ(b.look("venice", 70.0, -15.0).registration, wire::Registration::Registered);
  // A watcher or contributor cannot ask for one; a made-up token joins nothing.
  b.client.request_join_token();
  EXPECT_TRUE(b.client.wait_for([&] { return b.client.server_error().has_value(); }, 10s));
  EXPECT_EQ(b.client.server_error()->first, "Unauthorized");
  EXPECT_EQ(join_refusal(d, id, "phone-c", std::string(32, '0')), "Unauthorized");
  // The session's device leaves: its token ends (the session stays for a resume).
  a.client.bye();
  std::string code;
  for (int k = 0; k < 50 && code != "Unauthorized"; ++k) {
    std::this_thread::sleep_for(100ms);
    code = join_refusal(d, id, "phone-c", token.token);
  }
  EXPECT_EQ(code, "Unauthorized");
}

// A contributor's bad input closes it alone: a frame before its camera, another camera size, a
// Hello that names no device; the session's own phone carries on.
TEST(Contributors, AContributorsBadInputClosesOnlyIt) {
  const fs::path dir = test::fresh_temp_dir("contributors_bad");
  DaemonProcess d(dir / "daemon");
  Phone a;
  const std::string id = start_session(d, a);
  sweep(a, "venice", 0.0, 90.0);
  const auto closed_with = [&](const std::function<void(client::Client&)>& misbehave) {
    client::Client c;
    c.join(id);
    c.connect("127.0.0.1", d.port(), "phone-b", test::kToken, "phone b");
    misbehave(c);
    EXPECT_TRUE(c.wait_for([&] { return c.server_error().has_value(); }, 10s));
    return c.server_error().value_or(std::pair<std::string, std::string>{}).first;
  };
  const cv::Mat image = sim::ideal_view(room("venice"), kCamera, view(10.0, 0.0), 0.02);
  std::vector<std::uint8_t> jpeg;
  cv::imencode(".jpg", image, jpeg);
  EXPECT_EQ(closed_with([&](client::Client& c) {
              c.send_jpeg_frame(1, {0.0, 0.02, 1.0, view(10.0, 0.0)}, kCamera.width, kCamera.height,
                                jpeg);
            }),
            "OutOfOrder");
  EXPECT_EQ(closed_with([&](client::Client& c) {
              c.send_intrinsics(kCamera);
              c.send_intrinsics(CameraIntrinsics::from_fov(640, 480, 60));
            }),
            "BadMessage");
  EXPECT_EQ(join_refusal(d, id, "", test::kToken), "BadMessage");
  EXPECT_TRUE(a.look("venice", 30.0, -15.0).frame_used);
}

// A contributor that follows exposure advice gets its own (issue 16 §4), in its own units: the
// sun it sees clipped is asked of it darker than it says it took the frame at.
TEST(Contributors, AContributorGetsItsOwnExposureAdvice) {
  const fs::path dir = test::fresh_temp_dir("contributors_advice");
  DaemonProcess d(dir / "daemon");
  Phone a;
  const std::string id = start_session(d, a);
  sweep(a, "park", 0.0, 360.0, {-15.0, 25.0, 55.0}, 30.0);
  for (const bool follows : {true, false}) {
    Phone b;
    b.heading = 60.0, b.sensitivity = 1.5;
    if (follows) b.client.add_capability(wire::kCapabilityExposureAdvice);
    std::vector<wire::ExposureAdvice> advice;
    std::mutex m;
    b.client.on_exposure_advice = [&](const wire::ExposureAdvice& e) {
      std::lock_guard lock(m);
      advice.push_back(e);
    };
    b.client.join(id);
    b.client.connect("127.0.0.1", d.port(), "phone-b", test::kToken, "phone b");
    b.client.send_intrinsics(kCamera);
    sweep(b, "park", 5.0, 365.0, {-15.0, 25.0, 55.0}, 30.0);
    std::lock_guard lock(m);
    if (!follows) {
      EXPECT_TRUE(advice.empty()) << advice.size() << " advices to a contributor that did not ask";
      continue;
    }
    ASSERT_FALSE(advice.empty()) << "no advice for the clipped sun";
    // Darker than the 0.02 s its frames said, and in its units (it is 1.5x as sensitive as it
    // says: the map's exposure x 1.5).
    EXPECT_LT(advice.front().exposure, 0.02);
    EXPECT_GT(advice.front().clipped, 0.0f);
    b.client.bye();
  }
}

TEST(Contributors, TheCheckpointKeepsTheContributorsRegistration) {
  const fs::path dir = test::fresh_temp_dir("contributors_resume");
  std::string id;
  {
    DaemonProcess d(dir / "daemon");
    Phone a;
    id = a.client.connect("127.0.0.1", d.port(), "arlight-sim", test::kToken, "phone a").session_id;
    a.client.send_intrinsics(kCamera);
    sweep(a, "venice", 0.0, 200.0);
    Phone b;
    b.heading = -70.0;
    b.client.join(id);
    b.client.connect("127.0.0.1", d.port(), "phone-b", test::kToken, "phone b");
    b.client.send_intrinsics(kCamera);
    b.look("venice", 150.0, -15.0);
    ASSERT_EQ(b.look("venice", 160.0, -15.0).registration, wire::Registration::Registered);
    b.client.bye();
    a.client.bye();  // checkpointed on the daemon's disk thread
    const fs::path manifest = dir / "daemon" / "data" / "sessions" / id / "session.json";
    bool kept = false;
    for (int k = 0; k < 100 && !kept; ++k) {
      std::this_thread::sleep_for(100ms);
      std::ifstream in(manifest);
      const std::string text((std::istreambuf_iterator<char>(in)), {});
      kept = text.find("\"phone-b\"") != std::string::npos;
    }
    ASSERT_TRUE(kept) << manifest << " names no contributor";
  }
  // Another daemon on the data folder: the session resumes, and the phone that joined before
  // is registered at its first frame, without a search.
  DaemonProcess d(dir / "daemon");
  Phone a;
  a.client.connect("127.0.0.1", d.port(), "arlight-sim", test::kToken, "phone a", id);
  a.client.send_intrinsics(kCamera);
  a.sequence = 100;
  a.look("venice", 10.0, -15.0);
  Phone b;
  b.heading = -70.0;
  b.client.join(id);
  b.client.connect("127.0.0.1", d.port(), "phone-b", test::kToken, "phone b");
  b.client.send_intrinsics(kCamera);
  const client::LightingUpdate u = b.look("venice", 250.0, 25.0);  // where the map has nothing
  EXPECT_EQ(u.registration, wire::Registration::Registered) << u.reason;
  EXPECT_TRUE(u.frame_used);
}
