// arlight-client end to end: the real arlightd on loopback, a simulated capture of a room
// replayed into it, then arlight-client on a simulated phone orbiting a marker in that room,
// in the same session: frames tracked and rendered with the room's maps; and a daemon killed
// and restarted under a running client, which keeps rendering and resumes its session; and a
// simulated phone that follows the daemon's exposure advice.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <future>
#include <glm/geometric.hpp>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <thread>

#include "arlight/common/hdr_io.hpp"
#include "checkpoint.hpp"
#include "support/daemon_process.hpp"
#include "support/run_tool.hpp"
#include "support/sanitizer.hpp"

namespace fs = std::filesystem;
using namespace arlight;
using nlohmann::json;
using namespace std::chrono_literals;

namespace {

const std::string kProbe = std::string(ARLIGHT_SOURCE_DIR) + "/data/probes/venice.exr";
const std::string kBunny = std::string(ARLIGHT_SOURCE_DIR) + "/data/models/bunny.glb";

// A recording made by arlight-sim into dir/name (once per test process).
fs::path simulate(const fs::path& dir, const std::string& name, const std::string& args) {
  const fs::path rec = dir / name;
  const auto r = test::run_tool(
      ARLIGHT_SIM_EXE, "--env " + kProbe + " --out " + rec.string() + " --threads 1 " + args);
  if (r.status != 0) throw std::runtime_error(r.output);
  return rec;
}

// Replays a sweep of the room into the daemon and returns the session id.
std::string capture_room(const test::DaemonProcess& d, const fs::path& dir) {
  const fs::path sweep = simulate(dir, "sweep", "--frames 120 --size 320x240 --seed 11");
  const auto r = test::run_tool(
      ARLIGHT_REPLAY_EXE, "--server " + d.server() + " --token " + test::kToken + " --recording " +
                              sweep.string() + " --maps '' --out " + (dir / "replay").string());
  if (r.status != 0) throw std::runtime_error(r.output);
  return json::parse(std::ifstream(dir / "replay" / "replay.json")).at("session_id");
}

json read_json(const fs::path& p) { return json::parse(std::ifstream(p)); }

}  // namespace

TEST(ArlightClient, RendersTheBunnyOnTheMarkerLitByTheCapturedRoom) {
  const fs::path dir = test::fresh_temp_dir("client_render");
  test::DaemonProcess d(dir / "daemon");
  const std::string session = capture_room(d, dir);
  const fs::path orbit = simulate(
      dir, "orbit", "--frames 30 --size 320x240 --trajectory orbit --marker 7,0.2 --seed 12");
  const auto r = test::run_tool(
      ARLIGHT_CLIENT_EXE, "--server " + d.server() + " --token " + test::kToken +
                              " --source replay:" + orbit.string() + " --model " + kBunny +
                              " --marker 7,0.2 --resume " + session +
                              " --maps 1,20,80 --map-size 64 --wait-maps 60 --out " +
                              (dir / "client").string() + " --json " + (dir / "c.json").string());
  ASSERT_EQ(r.status, 0) << r.output;
  const json j = read_json(dir / "c.json");
  EXPECT_EQ(j.at("frames").get<int>(), 30) << j.dump();
  EXPECT_GE(j.at("tracked").get<int>(), 27) << j.dump();
  // Drawn from the third tracked frame on (world_from_marker needs three), always with maps.
  EXPECT_GE(j.at("lit_by_maps").get<int>(), j.at("tracked").get<int>() - 3) << j.dump();
  EXPECT_EQ(j.at("lit_by_sh").get<int>(), 0) << j.dump();
  EXPECT_EQ(j.at("session").at("id"), session);
  EXPECT_EQ(j.at("session").at("frames_sent").get<int>(), 30);
  // Loopback limits no frame's bytes (issue 36 §1): every frame at the best JPEG quality.
  EXPECT_EQ(j.at("session").at("jpeg_quality_mean").get<double>(), 90.0) << j.dump();
  EXPECT_GT(j.at("session").at("bytes_per_frame").get<double>(), 1000.0) << j.dump();
  EXPECT_LT(j.at("pose_error").at("median_cm").get<double>(), 1.0) << j.dump();
  EXPECT_LT(j.at("pose_error").at("median_deg").get<double>(), 1.0) << j.dump();
  // Issue 36 §4: each frame is tracked before it is drawn (registration first), so the object
  // stands where the truth puts it in every frame drawn, though the orbit turns 12 degrees a
  // frame: within 5 px of the truth's projection of its centre.
  EXPECT_GE(j.at("object_error_px").at("frames").get<int>(), j.at("tracked").get<int>() - 3) << j.dump();
  EXPECT_LE(j.at("object_error_px").at("max").get<double>(), 5.0) << j.at("object_error_px").dump();
  // The composite is the camera frame except where the bunny stands: over the marker, in the
  // middle of the image, and a small part of it.
  const cv::Mat in = cv::imread((orbit / "frames" / "000010.jpg").string());
  const cv::Mat out = cv::imread((dir / "client" / "frames" / "000010.png").string());
  ASSERT_FALSE(in.empty());
  ASSERT_EQ(out.size(), in.size());
  cv::Mat diff;
  cv::absdiff(in, out, diff);
  cv::Mat changed;
  cv::inRange(diff, cv::Scalar(0, 0, 0), cv::Scalar(12, 12, 12), changed);
  changed = 255 - changed;
  const double share = cv::countNonZero(changed) / double(changed.total());
  EXPECT_GT(share, 0.005);
  EXPECT_LT(share, 0.25);
  const cv::Moments m = cv::moments(changed, true);
  EXPECT_NEAR(m.m10 / m.m00, in.cols / 2.0, in.cols / 4.0);
  EXPECT_TRUE(fs::exists(dir / "client" / "contact_sheet.png"));
}

// Issue 34: a glTF metallic-roughness material (or a glTF's own) asks arlightd for the room's GGX
// chain and is
// shaded with it (and --out gets it as light files): every drawn frame used the chain, and a
// gold sphere is tinted by its F0
// against a white metal's under the same room (its R / B ratio above the white one's, which
// a material ignoring base colour, or a grey Phong fallback, would not give).
TEST(ArlightClient, AMetallicRoughnessSphereIsLitByTheRoomsGgxChain) {
  const fs::path dir = test::fresh_temp_dir("client_pbr");
  test::DaemonProcess d(dir / "daemon");
  const std::string session = capture_room(d, dir);
  const fs::path orbit = simulate(
      dir, "orbit", "--frames 12 --size 320x240 --trajectory orbit --marker 7,0.2 --seed 12");
  const cv::Mat in = cv::imread((orbit / "frames" / "000008.jpg").string());
  // At the recording's pace, as a camera gives frames: replayed as fast as possible under a
  // loaded machine, all 12 could be drawn before the first LightingUpdate (the session's SH)
  // came back, and only the last few were lit.
  const auto run = [&](const std::string& name, const std::string& material,
                       const std::string& model = "sphere") {
    const auto r = test::run_tool(
        ARLIGHT_CLIENT_EXE, "--server " + d.server() + " --token " + test::kToken +
                                " --source replay:" + orbit.string() +
                                " --model " + model + " --marker 7,0.2 --material " + material +
                                " --ggx 64 --occlusion none --shadow off --realtime --resume " + session +
                                " --wait-maps 60 --out " + (dir / name).string() + " --json " +
                                (dir / (name + ".json")).string());
    EXPECT_EQ(r.status, 0) << r.output;
    const json j = read_json(dir / (name + ".json"));
    EXPECT_GE(j.at("tracked").get<int>(), 10) << j.dump();
    EXPECT_GE(j.at("lit_by_ggx").get<int>(), j.at("tracked").get<int>() - 3) << j.dump();
    return cv::imread((dir / name / "frames" / "000008.png").string());
  };
  const cv::Mat gold = run("gold", "pbr:1,0.78,0.34,1,0.3"), white = run("white", "pbr:1,1,1,1,0.3");
  ASSERT_FALSE(gold.empty());
  // --out also holds the streamed chain as the light files engines read (face 64 -> 16).
  const json light = read_json(dir / "gold" / "light.json");
  EXPECT_EQ(light.at("specular").at("levels").size(), 3u) << light.dump();
  EXPECT_TRUE(fs::exists(dir / "gold" / "specular.ktx2"));
  ASSERT_FALSE(white.empty());
  cv::Mat diff, object;
  cv::absdiff(in, white, diff);
  cv::inRange(diff, cv::Scalar(0, 0, 0), cv::Scalar(30, 30, 30), object);
  object = 255 - object;
  ASSERT_GT(cv::countNonZero(object), 200);
  const cv::Scalar g = cv::mean(gold, object), w = cv::mean(white, object);  // B, G, R
  const double gold_tint = (g[2] / g[0]) / (w[2] / w[0]);
  std::printf("gold %s, white %s: R/B against white's x%.2f\n", cv::format("%.0f", g[2]).c_str(),
              cv::format("%.0f", w[2]).c_str(), gold_tint);
  // F0's 1 / 0.34 in radiance; after the camera response's gamma, with clipped highlights and
  // the Fresnel rim (white in both) in the mask, measured x1.31.
  EXPECT_GT(gold_tint, 1.2) << g << " " << w;
  EXPECT_GT(g[1] / g[0], w[1] / w[0]) << g << " " << w;  // G over B too (F0 0.78 against 0.34)

  // A glTF's own materials (--material model): the textured tiled ball (gold and terracotta
  // tiles, a white plinth) is lit by the chain too, and warmer than the white metal (what its
  // base colour texture gives; ignored textures or the Phong fallback would not; measured x1.29).
  const cv::Mat tiles = run("tiles", "model", std::string(ARLIGHT_SOURCE_DIR) + "/data/models/tiles.glb");
  ASSERT_FALSE(tiles.empty());
  cv::Mat tiled;
  cv::absdiff(in, tiles, diff);
  cv::inRange(diff, cv::Scalar(0, 0, 0), cv::Scalar(30, 30, 30), tiled);
  tiled = 255 - tiled;
  ASSERT_GT(cv::countNonZero(tiled), 200);
  const cv::Scalar t = cv::mean(tiles, tiled);
  std::printf("tiles: R/B against white's x%.2f\n", (t[2] / t[0]) / (w[2] / w[0]));
  EXPECT_GT((t[2] / t[0]) / (w[2] / w[0]), 1.2) << t << " " << w;
}

TEST(ArlightClient, KeepsRenderingWhenTheServerDiesAndResumesTheSession) {
  const fs::path dir = test::fresh_temp_dir("client_reconnect");
  std::optional<test::DaemonProcess> d(std::in_place, dir / "daemon");
  const std::uint16_t port = d->port();
  const std::string session = capture_room(*d, dir);
  // 5 s of frames at their own pace (10 s under ASan, where the restarted daemon takes seconds
  // to load the session); the daemon is killed once the client has streamed about a second of
  // them (however long the client took to start) and is back ~0.5 s later (the client retries
  // at once, then backs off from 0.1 s to 1 s).
  const fs::path orbit = simulate(dir, "orbit",
                                  std::string("--frames 150 --size 320x240 --trajectory orbit "
                                              "--marker 7,0.2 --seed 13 --fps ") +
                                      (test::kSanitized ? "15" : "30"));
  auto client = std::async(std::launch::async, [&] {
    return test::run_tool(ARLIGHT_CLIENT_EXE,
                          "--server 127.0.0.1:" + std::to_string(port) + " --token " +
                              test::kToken + " --source replay:" + orbit.string() +
                              " --model sphere --marker 7,0.2 --realtime --maps '' --resume " +
                              session + " --json " + (dir / "c.json").string());
  });
  const auto streaming = [&] {
    const auto [status, body] = d->admin_get("/sessions");
    if (status != 200) return false;
    for (const json& s : json::parse(body))
      if (s.at("id") == session && s.at("connected") == true &&
          s.at("frames_received").get<int>() >= 120 + 30)  // the sweep's 120, then 1-2 s more
        return true;
    return false;
  };
  const auto deadline = std::chrono::steady_clock::now() + 60s;
  while (!streaming() && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(50ms);
  d->kill9();
  d.reset();
  std::this_thread::sleep_for(500ms);
  d.emplace(dir / "daemon", std::vector<std::string>{}, port);
  const auto r = client.get();
  ASSERT_EQ(r.status, 0) << r.output;
  const json j = read_json(dir / "c.json");
  EXPECT_EQ(j.at("frames").get<int>(), 150) << j.dump();  // no frame was lost to the outage
  EXPECT_EQ(j.at("session").at("connects").get<int>(), 2) << j.dump() << r.output;
  EXPECT_EQ(j.at("session").at("id"), session) << j.dump();  // resumed, not a new session
  // Frames due while the daemon was down waited and went after the resume (issue 36 §5): the
  // session holds each of the client's frames once, after the sweep's 120.
  EXPECT_GT(j.at("session").at("frames_delayed").get<int>(), 0) << j.dump();
  EXPECT_EQ(j.at("session").at("frames_not_sent").get<int>(), 0) << j.dump();
  EXPECT_GT(j.at("lit_by_sh").get<int>(), 140) << j.dump();  // lit all along
  const int sent = j.at("session").at("frames_sent");
  const auto counted = [&] {
    const auto [status, body] = d->admin_get("/sessions");
    for (const json& s : json::parse(body))
      if (s.at("id") == session) return std::pair{s.at("frames_received").get<int>(),
                                                  s.at("frames_duplicate").get<int>()};
    return std::pair{-1, -1};
  };
  EXPECT_EQ(counted(), std::pair(120 + sent, 0)) << j.dump();
}

// The simulated phone's frame rate in the sim: sweeps below: a phone's 30 fps, but 8 under
// ASan, where neither the client's simulated camera nor arlightd keeps up with 30 (arlightd
// then drops frames as it should, and the sweep it captured is a third of the room).
const std::string kSimFps = test::kSanitized ? "8" : "30";

// Issue 16 §4's advice loop end to end: arlight-client's sim:PROBE source (a simulated phone
// sweeping lab.exr with auto-exposure) streams to arlightd, which asks for darker frames while
// lamps clip unmeasured; the phone takes them (at 30 fps, as a phone: a daemon that cannot keep
// up drops auto-exposed frames, never the advised one). The session's map then lights like the truth:
// within 3 % irradiance (the same sweep without advice, a replay of the same phone, ~35 % off).
TEST(ArlightClient, FollowsTheDaemonsExposureAdviceAndCapturesTheLampsOfLab) {
  const fs::path dir = test::fresh_temp_dir("client_exposure_advice");
  const fs::path data = dir / "daemon" / "data";
  test::DaemonProcess d(dir / "daemon");
  const std::string lab = std::string(ARLIGHT_SOURCE_DIR) + "/data/probes/lab.exr";
  const auto r = test::run_tool(
      ARLIGHT_CLIENT_EXE, "--server " + d.server() + " --token " + test::kToken + " --source sim:" +
                              lab + " --size 320x240 --frames 240 --fps " + kSimFps +
                              " --realtime --maps '' --json " + (dir / "c.json").string());
  ASSERT_EQ(r.status, 0) << r.output;
  const json j = read_json(dir / "c.json");
  EXPECT_EQ(j.at("frames").get<int>(), 240) << j.dump();
  const int advised = j.at("exposure_advice").at("received"),
            taken = j.at("exposure_advice").at("frames_taken");
  EXPECT_GE(advised, 5) << j.dump();
  EXPECT_GE(taken, advised - 2) << "advice not followed: " << j.dump();
  EXPECT_LE(taken, 240 / 3) << j.dump();

  // The session's map, from its last checkpoint (the client's Bye writes it), as an EXR.
  const std::string id = j.at("session").at("id");
  const fs::path manifest = data / "sessions" / id / "session.json";
  const auto deadline = std::chrono::steady_clock::now() + 20s;
  while ((!fs::exists(manifest) || read_json(manifest).at("frames_received").get<int>() < 240) &&
         std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(50ms);
  const auto checkpoint = daemon::read_checkpoint(data / "sessions" / id);
  ASSERT_TRUE(checkpoint);
  capture::CaptureOptions options;
  options.layout = checkpoint->capture_layout();
  capture::CaptureSession session(checkpoint->camera, CameraResponse::srgb(), options);
  session.restore(checkpoint->accumulators);
  ImageMetadata meta;
  meta.projection = options.layout.projection();
  write_exr(dir / "env.exr", session.measured_environment().image.view(), meta);
  const auto diff = test::run_tool(ARLIGHT_MAPS_EXE, "diff --reference " + lab + " --test " +
                                                         (dir / "env.exr").string() +
                                                         " --method auto --size 128 --json " +
                                                         (dir / "diff.json").string());
  ASSERT_EQ(diff.status, 0) << diff.output;
  double irradiance_error = -1;
  const json diff_json = read_json(dir / "diff.json");
  for (const json& m : diff_json.at("maps"))
    if (m.at("shininess").get<double>() == 1.0) irradiance_error = m.at("mean_error");
  std::printf("lab through arlightd with exposure advice: %d advices, %d frames taken at them, "
              "irradiance error %.2f %%\n",
              advised, taken, 100 * irradiance_error);
  EXPECT_GE(irradiance_error, 0.0);
  EXPECT_LE(irradiance_error, 0.03);
}

// Issue 48 end to end: every update states how far the light may be off and the view to take
// next, arlight-client prints both, and its guided sim: user (arlight-sim's GuidedMotion) turns
// where arlightd asks. After 8 s of a guided capture of city.exr the light is stated within
// 50 % (in-process, the same capture reaches ~7 %: arlight-bench-guided), on an 8 x 16 map.
TEST(ArlightClient, AGuidedSimulatedPhoneFollowsTheDaemonsNextViewAndPrintsTheLightsError) {
  const fs::path dir = test::fresh_temp_dir("client_guided");
  test::DaemonProcess d(dir / "daemon");
  const std::string city = std::string(ARLIGHT_SOURCE_DIR) + "/data/probes/city.exr";
  const auto r = test::run_tool(
      ARLIGHT_CLIENT_EXE, "--server " + d.server() + " --token " + test::kToken + " --source sim:" +
                              city + " --guided --size 320x240 --frames 240 --fps " + kSimFps +
                              " --realtime --maps '' --json " + (dir / "c.json").string());
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("a guided capture of"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find(", light +-"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find(", look "), std::string::npos) << r.output;
  const json j = read_json(dir / "c.json");
  const json& light = j.at("light");
  EXPECT_GT(light.at("error").get<double>(), 0.0) << light.dump();
  EXPECT_LT(light.at("error").get<double>(), 0.5) << light.dump();
  EXPECT_EQ(light.at("zones").get<int>(), 8);
  ASSERT_EQ(light.at("error_map_percent").size(), 128u);
  for (const json& e : light.at("error_map_percent")) EXPECT_LE(e.get<int>(), 255);
  if (!light.at("next_view").is_null()) {
    const json& v = light.at("next_view");
    EXPECT_NEAR(std::hypot(v[0].get<double>(), v[1].get<double>(), v[2].get<double>()), 1.0, 1e-3);
  }
}

// The sun (issue 17, dissertation §5.3.3): park.exr's sun stands 10.5 degrees up; at NREL in
// Golden, Colorado, on 2015-08-02 at 13:03 UTC so does the real one (at azimuth 75.5: the
// probe's north is 39 degrees off true north). A simulated phone sweeping the park with that
// place and time gets the sun confirmed by the map it captured, and the dominant light is the
// sun's direction (within the sweep's orientation error), where it was the SH's estimate.
TEST(ArlightClient, TellsArlightdWhereItIsAndGetsTheSunConfirmedByTheMap) {
  const fs::path dir = test::fresh_temp_dir("client_sun");
  test::DaemonProcess d(dir / "daemon");
  const std::string park = std::string(ARLIGHT_SOURCE_DIR) + "/data/probes/park.exr";
  const auto r = test::run_tool(
      ARLIGHT_CLIENT_EXE, "--server " + d.server() + " --token " + test::kToken + " --source sim:" +
                              park + " --size 320x240 --frames 240 --fps " + kSimFps +
                              " --realtime --maps '' --location 39.742476,-105.1786,1830"
                              " --time 2015-08-02T13:03:00Z --json " +
                              (dir / "c.json").string());
  ASSERT_EQ(r.status, 0) << r.output;
  const json j = read_json(dir / "c.json");
  ASSERT_EQ(j.at("sun").at("state"), "confirmed") << j.dump();
  const auto v = j.at("sun").at("direction").get<std::vector<double>>();
  const glm::dvec3 sun(v.at(0), v.at(1), v.at(2));
  const glm::dvec3 truth = glm::normalize(glm::dvec3(0.5808, 0.1829, -0.7932));  // park's sun
  const double off_deg = std::acos(std::min(1.0, glm::dot(sun, truth))) * 180.0 / M_PI;
  std::printf("sun confirmed at %.2f degrees from park.exr's sun\n", off_deg);
  EXPECT_LT(off_deg, 2.0);

  // Three hours later the sun stands 45 degrees up: the map's sun is not it (predicted only).
  const auto later = test::run_tool(
      ARLIGHT_CLIENT_EXE, "--server " + d.server() + " --token " + test::kToken + " --source sim:" +
                              park + " --size 320x240 --frames 240 --fps " + kSimFps +
                              " --realtime --maps '' --location 39.742476,-105.1786,1830"
                              " --time 2015-08-02T16:03:00Z --json " +
                              (dir / "later.json").string());
  ASSERT_EQ(later.status, 0) << later.output;
  EXPECT_EQ(read_json(dir / "later.json").at("sun").at("state"), "predicted");

  // A recording that carries its place and time (RECORDING.md "place", arlight-sim --location):
  // its replay tells arlightd without --location, and the sun is known (up, at 16:03 UTC). At
  // its pace (3 s): arlightd checks the sun at most once a second.
  const fs::path placed = simulate(dir, "placed",
                                   "--frames 12 --fps 4 --size 160x120 --location "
                                   "39.742476,-105.1786,1830 --time 2015-08-02T16:03:00Z");
  const auto replay =
      test::run_tool(ARLIGHT_CLIENT_EXE, "--server " + d.server() + " --token " + test::kToken +
                                             " --source replay:" + placed.string() +
                                             " --realtime --maps '' --json " +
                                             (dir / "placed.json").string());
  ASSERT_EQ(replay.status, 0) << replay.output;
  EXPECT_EQ(read_json(dir / "placed.json").at("sun").at("state"), "predicted") << replay.output;
  // arlight-replay tells arlightd too (a new session).
  const auto streamed = test::run_tool(
      ARLIGHT_REPLAY_EXE, "--server " + d.server() + " --token " + test::kToken + " --recording " +
                              placed.string() + " --realtime --maps '' --out " +
                              (dir / "placed_replay").string());
  ASSERT_EQ(streamed.status, 0) << streamed.output;
  EXPECT_EQ(read_json(dir / "placed_replay" / "replay.json").at("sun").at("state"), "predicted")
      << streamed.output;
  // ... and without a place it is not.
  const fs::path unplaced = simulate(dir, "unplaced", "--frames 12 --size 160x120");
  const auto plain =
      test::run_tool(ARLIGHT_CLIENT_EXE, "--server " + d.server() + " --token " + test::kToken +
                                             " --source replay:" + unplaced.string() +
                                             " --maps '' --json " + (dir / "plain.json").string());
  ASSERT_EQ(plain.status, 0) << plain.output;
  EXPECT_EQ(read_json(dir / "plain.json").at("sun").at("state"), "unknown");

  // A place off the Earth is refused, naming the flag.
  const auto bad = test::run_tool(ARLIGHT_CLIENT_EXE, "--server " + d.server() + " --token " +
                                                          test::kToken + " --source sim:" + park +
                                                          " --frames 2 --location 95,0");
  EXPECT_EQ(bad.status, 2) << bad.output;
  EXPECT_NE(bad.output.find("--location"), std::string::npos) << bad.output;
}

// Issue 18's evaluation (tutorial §8) and issue 17's question "does colour matching help?":
// arlight-sim renders the bunny ray traced under the true room for an orbit (references);
// arlight-client composites the same orbit at the true pose (the lighting alone is judged),
// lit by arlightd's maps of the captured room (with and without the bunny's occlusion of itself
// baked), by its live SH alone (ARCore's SH-9), and by the maps with colour matching;
// arlight-eval scores each against the references.
TEST(ArlightEval, ScoresTheCompositeLitByTheRoomsMapsAboveTheSh9One) {
  const std::string kGlossy = "0.3,0.7,160";  // reflections: what SH-9 cannot carry
  const fs::path dir = test::fresh_temp_dir("client_eval");
  test::DaemonProcess d(dir / "daemon");
  const std::string session = capture_room(d, dir);
  const fs::path orbit =
      simulate(dir, "orbit",
               "--frames 24 --size 320x240 --trajectory orbit --marker 7,0.2 --seed 12 "
               "--object " +
                   kBunny + " --object-material " + kGlossy + " --reference-every 4");
  const json refs = read_json(orbit / "truth" / "reference" / "reference.json");
  ASSERT_GE(refs.at("frames").size(), 5u) << refs.dump();
  // Every run shares one bake cache: the first bakes the bunny, the others read it back.
  const std::string client =
      "env XDG_CACHE_HOME=" + (dir / "cache").string() + " " + ARLIGHT_CLIENT_EXE;
  const auto composite = [&](const std::string& name, const std::string& args) {
    const auto r = test::run_tool(client, "--json " + (dir / (name + "_client.json")).string() +
                                              " --server " + d.server() + " --token " +
                                              test::kToken + " --source replay:" + orbit.string() +
                                              " --model " + kBunny + " --material " + kGlossy +
                                              " --marker 7,0.2 --pose truth --resume " + session +
                                              " " + args + " --out " + (dir / name).string());
    if (r.status != 0) throw std::runtime_error(r.output);
    const auto e =
        test::run_tool(ARLIGHT_EVAL_EXE, "composite --recording " + orbit.string() + " --frames " +
                                             (dir / name / "frames").string() + " --json " +
                                             (dir / (name + ".json")).string());
    if (e.status != 0) throw std::runtime_error(e.output);
    std::printf("%s: %s", name.c_str(), e.output.c_str());
    return read_json(dir / (name + ".json"));
  };
  const json maps = composite("maps", "--wait-maps 60");
  const json open = composite("open", "--wait-maps 60 --occlusion none");
  const json sh = composite("sh", "--maps ''");
  // A damaged cache file is baked again (and replaced), not trusted.
  const auto bakes = [&] {
    std::vector<fs::path> files;
    for (const auto& e : fs::directory_iterator(dir / "cache" / "arlight" / "bake"))
      files.push_back(e.path());
    return files;
  };
  ASSERT_EQ(bakes().size(), 1u);
  { std::ofstream(bakes()[0], std::ios::binary | std::ios::trunc) << "not a glb"; }
  const json matched = composite("match", "--wait-maps 60 --tone camera,match");
  const auto state = [&](const std::string& name) {
    return read_json(dir / (name + "_client.json")).at("occlusion").at("state").get<std::string>();
  };
  EXPECT_EQ(state("maps"), "baked");
  EXPECT_EQ(state("open"), "none");
  EXPECT_EQ(state("sh"), "cached");
  EXPECT_EQ(state("match"), "baked");
  EXPECT_GT(fs::file_size(bakes()[0]), 2826u * 16u);  // replaced by the bake
  const auto psnr = [](const json& j) { return j.at("object").at("psnr_db").get<double>(); };
  const auto ssim = [](const json& j) { return j.at("object").at("ssim").get<double>(); };
  EXPECT_EQ(maps.at("frames").size(), refs.at("frames").size());
  // Measured: maps 23.5 dB / SSIM 0.887, maps without the bunny's baked occlusion of itself
  // 22.8 dB / 0.881, SH 20.6 dB / 0.73, colour matching 13.2 dB / 0.66.
  EXPECT_GT(psnr(maps), psnr(open) + 0.3) << maps.dump() << open.dump();  // the reference traces it
  EXPECT_GT(psnr(maps), psnr(sh) + 1.5) << maps.dump() << sh.dump();
  EXPECT_GT(ssim(maps), ssim(sh) + 0.05) << maps.dump() << sh.dump();
  EXPECT_GT(psnr(maps), 21.0) << maps.dump();
  EXPECT_LT(maps.at("fraction_seen").get<double>(), sh.at("fraction_seen").get<double>());
  EXPECT_GT(psnr(maps), psnr(matched)) << matched.dump();  // RESULTS.md: matching does not help

  // The recorded frames themselves (no object at all) are far worse than any composite.
  const auto bare = test::run_tool(ARLIGHT_EVAL_EXE, "composite --recording " + orbit.string() +
                                                         " --frames " + (dir / "bare").string());
  EXPECT_EQ(bare.status, 2) << bare.output;  // no such composites: named
  EXPECT_NE(bare.output.find("000000.png"), std::string::npos) << bare.output;
}
