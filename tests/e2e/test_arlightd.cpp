// Integration tests of arlightd: the real daemon binary on an ephemeral loopback port, driven by
// arlight-replay, arlight-capture and the client library; kill -9 and resume; bad messages;
// the admin endpoints.
#include <gtest/gtest.h>
#include <openssl/evp.h>
#include <openssl/pem.h>
#include <openssl/x509v3.h>
#include <signal.h>
#include <sys/wait.h>
#include <sys/socket.h>
#include <unistd.h>

#include <boost/asio/connect.hpp>
#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/read.hpp>
#include <boost/asio/write.hpp>
#include <chrono>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <glm/geometric.hpp>
#include <iterator>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <mutex>
#include <optional>
#include <regex>
#include <string>
#include <thread>

#include "arlight/common/hdr_io.hpp"
#include "arlight/common/ktx2.hpp"
#include "arlight/lighting/lighting.hpp"
#include "arlight/net/client_messages.hpp"
#include "arlight/net/client_net.hpp"
#include "arlight/protocol/recording.hpp"
#include "arlight/protocol/wire.hpp"
#include "support/client_frames.hpp"
#include "support/daemon_process.hpp"
#include "support/run_tool.hpp"
#include "support/sanitizer.hpp"

namespace fs = std::filesystem;
using namespace arlight;
using nlohmann::json;
using test::DaemonProcess;
using test::http_get;
using test::frame_gets_update;
using test::kToken;
using namespace std::chrono_literals;

namespace {

const fs::path& sample_recording() { return test::daemon_sample_recording(); }

// The daemon closes `c`'s connection with an Error of `code` whose message holds `text`.
void expect_closed_with(client::Client& c, const std::string& code, const std::string& text) {
  EXPECT_TRUE(c.wait_for([&] { return !c.connected(); }, 10s));
  ASSERT_TRUE(c.server_error().has_value());
  EXPECT_EQ(c.server_error()->first, code);
  EXPECT_NE(c.server_error()->second.find(text), std::string::npos) << c.server_error()->second;
}

json read_json(const fs::path& p) { return json::parse(std::ifstream(p)); }

Ktx2Cube read_ktx2(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  const std::vector<std::uint8_t> bytes((std::istreambuf_iterator<char>(in)), {});
  return decode_ktx2_cube(bytes);
}

// A self-signed P-256 certificate for `names` (subjectAltName), valid for an hour, written as
// PEM to `cert` and its key to `key` (made with OpenSSL here: no openssl program needed).
void write_self_signed_certificate(const fs::path& cert, const fs::path& key,
                                   const char* names = "IP:127.0.0.1,DNS:localhost") {
  EVP_PKEY* pkey = EVP_EC_gen("P-256");
  X509* x = X509_new();
  X509_set_version(x, 2);
  ASN1_INTEGER_set(X509_get_serialNumber(x), 1);
  X509_gmtime_adj(X509_getm_notBefore(x), -60);
  X509_gmtime_adj(X509_getm_notAfter(x), 3600);
  X509_set_pubkey(x, pkey);
  X509_NAME* name = X509_get_subject_name(x);
  X509_NAME_add_entry_by_txt(name, "CN", MBSTRING_ASC,
                             reinterpret_cast<const unsigned char*>("arlight test"), -1, -1, 0);
  X509_set_issuer_name(x, name);
  X509V3_CTX ctx;
  X509V3_set_ctx_nodb(&ctx);
  X509V3_set_ctx(&ctx, x, x, nullptr, nullptr, 0);
  X509_EXTENSION* san = X509V3_EXT_conf_nid(nullptr, &ctx, NID_subject_alt_name, names);
  X509_add_ext(x, san, -1);
  X509_EXTENSION_free(san);
  X509_sign(x, pkey, EVP_sha256());
  FILE* f = std::fopen(cert.c_str(), "w");
  PEM_write_X509(f, x);
  std::fclose(f);
  f = std::fopen(key.c_str(), "w");
  PEM_write_PrivateKey(f, pkey, nullptr, nullptr, 0, nullptr, nullptr);
  std::fclose(f);
  X509_free(x);
  EVP_PKEY_free(pkey);
}

}  // namespace

TEST(Arlightd, ReplayGetsTheOfflineCapturesShAndACompleteMapSet) {
  const fs::path dir = test::fresh_temp_dir("daemon_replay");
  DaemonProcess d(dir / "daemon");
  const auto r = test::run_tool(
      ARLIGHT_REPLAY_EXE, "--server " + d.server() + " --token " + kToken + " --recording " +
                              sample_recording().string() + " --out " + (dir / "replay").string());
  ASSERT_EQ(r.status, 0) << r.output;
  // The offline capture with the daemon's settings (its cube-map layout for --map-size 512,
  // alignment every 4th frame at 160 px, measured in the background and applied at the next
  // frame).
  const auto c = test::run_tool(
      ARLIGHT_CAPTURE_EXE, "--recording " + sample_recording().string() + " --out " +
                               (dir / "env.exr").string() + " --json " + (dir / "c.json").string() +
                               " --projection cube --size 192 --align-every 4 --align-width 160"
                               " --align-async");
  ASSERT_EQ(c.status, 0) << c.output;
  const json replay = read_json(dir / "replay" / "replay.json"),
             offline = read_json(dir / "c.json");
  EXPECT_EQ(replay["frames_processed"], 60);
  EXPECT_EQ(replay["frames_dropped"], 0);
  EXPECT_NEAR(replay["estimated"].get<double>(), 1.0 - replay["coverage"].get<double>(), 1e-6);
  ASSERT_EQ(replay["sh"].size(), offline["sh"].size());
  const double dc = offline["sh"][0][1].get<double>();
  for (std::size_t k = 0; k < offline["sh"].size(); ++k)
    for (int ch = 0; ch < 3; ++ch)
      EXPECT_NEAR(replay["sh"][k][ch].get<double>(), offline["sh"][k][ch].get<double>(), 1e-5 * dc)
          << "coefficient " << k << " channel " << ch;
  // A complete set of the 8 maps; the irradiance map keeps the environment's mean radiance.
  ASSERT_EQ(replay["maps"].size(), 8u);
  const LoadedEnvMap s1 = load_envmap(replay["maps"][0]["file"].get<std::string>());
  const auto table = texel_table(s1.env.layout);
  double sum = 0, area = 0;
  for (std::size_t i = 0; i < table->size(); ++i) {
    const float* p = s1.env.image.data() + 3 * std::size_t(table->index[i]);
    sum += table->solid_angle[i] * p[1], area += table->solid_angle[i];
  }
  const double env_mean = dc / (4 * std::numbers::pi * std::sqrt(1 / (4 * std::numbers::pi)));
  EXPECT_NEAR(sum / area, env_mean, 0.02 * env_mean);
}

// Issue 16 §1: from the first frame the live SH light the whole sphere, the unseen part
// estimated from the seen one, and each update says how much is estimated; a daemon started
// with --fill none leaves it black (and estimates nothing).
TEST(Arlightd, TheFirstFrameLightsTheWholeSphereAndSaysHowMuchIsEstimated) {
  const fs::path dir = test::fresh_temp_dir("daemon_fill");
  const recording::Recording rec = recording::read_recording(sample_recording());
  const auto first_update = [&](const std::vector<std::string>& args, const char* name) {
    DaemonProcess d(dir / name, args);
    client::Client c;
    c.connect("127.0.0.1", d.port(), "arlight-sim", kToken);
    c.send_intrinsics(rec.camera);
    EXPECT_TRUE(frame_gets_update(c, rec, 0)) << name;
    return c.last_update().value_or(client::LightingUpdate{});
  };
  const client::LightingUpdate filled = first_update({}, "estimate");
  const client::LightingUpdate black = first_update({"--fill", "none"}, "none");
  ASSERT_GT(filled.coverage, 0.02f);
  ASSERT_LT(filled.coverage, 0.2f);
  EXPECT_EQ(black.coverage, filled.coverage);
  EXPECT_NEAR(filled.estimated, 1.0f - filled.coverage, 1e-5f);
  EXPECT_EQ(black.estimated, 0.0f);
  // This client reports its exposure: the update echoes it (an exposure:unknown client gets
  // the daemon's estimate there instead).
  EXPECT_DOUBLE_EQ(filled.frame_exposure, rec.frames[0].exposure * rec.frames[0].gain);
  // The DC term is the mean radiance: black counts the unseen 80-98 % as 0.
  for (int ch = 0; ch < 3; ++ch) EXPECT_GT(filled.sh.c[0][ch], 3.0 * black.sh.c[0][ch]) << ch;
  // A bad --fill is refused naming it.
  const auto bad =
      test::run_tool(ARLIGHTD_EXE, "--fill black --tokens " + (dir / "none" / "tokens").string());
  EXPECT_EQ(bad.status, 2);
  EXPECT_NE(bad.output.find("--fill"), std::string::npos) << bad.output;
}

TEST(Arlightd, WrongTokenGetsUnauthorizedAndNothingElse) {
  const fs::path dir = test::fresh_temp_dir("daemon_token");
  DaemonProcess d(dir / "daemon");
  client::Client c;
  try {
    c.connect("127.0.0.1", d.port(), "arlight-sim", "not-the-token");
    FAIL() << "connected with a wrong token";
  } catch (const client::ClientError& e) {
    EXPECT_EQ(e.code(), "Unauthorized") << e.what();
  }
  client::Client unknown;
  EXPECT_THROW(unknown.connect("127.0.0.1", d.port(), "someone-else", kToken), client::ClientError);
}

TEST(Arlightd, BadMessagesCloseOnlyTheirConnection) {
  const fs::path dir = test::fresh_temp_dir("daemon_bad");
  DaemonProcess d(dir / "daemon");
  const recording::Recording rec = recording::read_recording(sample_recording());
  client::Client good;
  good.connect("127.0.0.1", d.port(), "arlight-sim", kToken);
  good.send_intrinsics(rec.camera);
  ASSERT_TRUE(frame_gets_update(good, rec, 1)) << "no update for frame 1";

  // Each misbehaving client handshakes properly first, then sends `bytes`.
  const auto expect_error = [&](const std::vector<std::uint8_t>& bytes, const std::string& code) {
    client::Client bad;
    bad.connect("127.0.0.1", d.port(), "arlight-sim", kToken);
    bad.send_raw(bytes);
    EXPECT_TRUE(bad.wait_for([&] { return !bad.connected(); }, 10s)) << "still open after " << code;
    const auto e = bad.server_error();
    ASSERT_TRUE(e.has_value()) << code;
    EXPECT_EQ(e->first, code) << e->second;
  };
  // Garbage with a plausible length.
  std::vector<std::uint8_t> garbage = {64, 0, 0, 0};
  for (int i = 0; i < 64; ++i) garbage.push_back(std::uint8_t(i * 37 + 11));
  expect_error(garbage, "BadMessage");
  // A length over the limit: refused before anything is allocated.
  expect_error({0, 0, 0, 0x40}, "TooLarge");
  // A real message cut short but framed with the shorter length: fails the verifier.
  std::vector<std::uint8_t> ping = wire::frame(wire::encode(wire::Ping{7}));
  std::vector<std::uint8_t> cut(ping.begin(), ping.begin() + 4 + 12);
  cut[0] = 12, cut[1] = cut[2] = cut[3] = 0;
  expect_error(cut, "BadMessage");
  // A frame before the camera's intrinsics.
  {
    client::Client early;
    early.connect("127.0.0.1", d.port(), "arlight-sim", kToken);
    const auto& f = rec.frames[0];
    early.send_jpeg_frame(1, f, rec.camera.width,
                          rec.camera.height, recording::read_frame_bytes(rec, 0));
    EXPECT_TRUE(early.wait_for([&] { return !early.connected(); }, 10s));
    ASSERT_TRUE(early.server_error().has_value());
    EXPECT_EQ(early.server_error()->first, "OutOfOrder");
  }
  // The good session carried on through all of it.
  for (std::uint64_t seq = 2; seq <= 3; ++seq)
    ASSERT_TRUE(frame_gets_update(good, rec, seq)) << "no update for frame " << seq;
  EXPECT_TRUE(good.connected());
  EXPECT_FALSE(good.server_error().has_value());
}

TEST(Arlightd, RefinedIntrinsicsKeepTheMapAndAnotherSizeIsRefused) {
  const fs::path dir = test::fresh_temp_dir("daemon_refine");
  DaemonProcess d(dir / "daemon");
  const recording::Recording rec = recording::read_recording(sample_recording());
  client::Client c;
  c.connect("127.0.0.1", d.port(), "arlight-sim", kToken);
  c.send_intrinsics(rec.camera);
  for (std::uint64_t seq = 1; seq <= 3; ++seq)
    ASSERT_TRUE(frame_gets_update(c, rec, seq)) << "no update for frame " << seq;
  const float coverage = c.last_update()->coverage;
  ASSERT_GT(coverage, 0.0f);

  // The same camera with a refined focal length: the map so far stays, frames carry on.
  CameraIntrinsics refined = rec.camera;
  refined.fx *= 1.04, refined.fy *= 1.04;
  c.send_intrinsics(refined);
  ASSERT_TRUE(frame_gets_update(c, rec, 4)) << "no update for frame 4";
  const wire::LightingUpdate u = *c.last_update();
  EXPECT_TRUE(c.connected());
  EXPECT_FALSE(c.server_error().has_value());
  EXPECT_EQ(u.frames_processed, 4u);
  EXPECT_GE(u.coverage, coverage);

  // Another size needs a new session.
  CameraIntrinsics other = rec.camera;
  other.width /= 2, other.height /= 2;
  c.send_intrinsics(other);
  expect_closed_with(c, "BadMessage", "another size");
}

namespace {

// What a raw TCP connection from `local` (a loopback address) gets before the daemon closes it:
// the bytes, and the seconds until it did (a 10 s receive timeout ends the wait otherwise).
struct RawOutcome {
  std::vector<std::uint8_t> bytes;
  double seconds = 0;
  bool closed = false;
};

class RawConnection {
 public:
  RawConnection(std::uint16_t port, const char* local = "127.0.0.1")
      : socket_(io_), opened_(std::chrono::steady_clock::now()) {
    namespace ip = boost::asio::ip;
    socket_.open(ip::tcp::v4());
    socket_.bind({ip::make_address(local), 0});
    socket_.connect({ip::make_address("127.0.0.1"), port});
    const timeval tv{10, 0};
    setsockopt(socket_.native_handle(), SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
  }
  RawOutcome wait_for_close() {
    RawOutcome r;
    std::uint8_t buf[4096];
    for (;;) {
      const ssize_t n = ::recv(socket_.native_handle(), buf, sizeof buf, 0);
      if (n <= 0) {
        r.closed = n == 0 || errno == ECONNRESET;
        break;
      }
      r.bytes.insert(r.bytes.end(), buf, buf + n);
    }
    r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - opened_).count();
    return r;
  }

 private:
  boost::asio::io_context io_;
  boost::asio::ip::tcp::socket socket_;
  std::chrono::steady_clock::time_point opened_;
};

// The framed message in a raw connection's bytes, as an Error.
std::optional<wire::Error> error_in(const std::vector<std::uint8_t>& bytes) {
  if (bytes.size() < 4) return std::nullopt;
  std::uint32_t n;
  std::memcpy(&n, bytes.data(), 4);
  if (bytes.size() < 4 + std::size_t(n)) return std::nullopt;
  const wire::Message m = wire::decode({bytes.begin() + 4, bytes.begin() + 4 + n});
  if (const auto* e = std::get_if<wire::Error>(&m)) return *e;
  return std::nullopt;
}

double metric(std::uint16_t admin, const std::string& name) {
  const auto [status, body] = test::http_get(admin, "/metrics");
  const std::regex line("\n" + name + " ([0-9.e+]+)");
  std::smatch m;
  return status == 200 && std::regex_search(body, m, line) ? std::stod(m[1]) : -1.0;
}

}  // namespace

// In the open: a connection that never says Hello is closed by the deadline with Error{Timeout};
// over each connection limit the next connection is closed before anything is read (0 bytes),
// while an authenticated session keeps getting updates; /metrics counts each.
TEST(Arlightd, HelloDeadlineAndConnectionLimitsRefuseOthersWhileASessionCarriesOn) {
  const fs::path dir = test::fresh_temp_dir("daemon_limits");
  DaemonProcess d(dir / "daemon", {"--hello-timeout", "1", "--max-unauthenticated", "2",
                                   "--max-per-address", "3", "--max-connections", "4"});
  const recording::Recording rec = recording::read_recording(sample_recording());
  client::Client good;
  good.connect("127.0.0.1", d.port(), "arlight-sim", kToken);
  good.send_intrinsics(rec.camera);
  std::uint64_t seq = 0;
  const auto still_served = [&] { return frame_gets_update(good, rec, ++seq); };
  ASSERT_TRUE(still_served());

  // 1. The Hello deadline, and the limit of connections before their Hello (2).
  {
    RawConnection a(d.port()), b(d.port());
    std::this_thread::sleep_for(200ms);  // both adopted
    const RawOutcome c = RawConnection(d.port()).wait_for_close();
    EXPECT_TRUE(c.closed);
    EXPECT_TRUE(c.bytes.empty()) << "a refused connection is closed before anything is sent";
    EXPECT_LT(c.seconds, 0.9);
    EXPECT_TRUE(still_served());
    const RawOutcome ra = a.wait_for_close();
    EXPECT_TRUE(ra.closed);
    EXPECT_GT(ra.seconds, 0.8);
    EXPECT_LT(ra.seconds, 5.0);
    const auto e = error_in(ra.bytes);
    ASSERT_TRUE(e.has_value());
    EXPECT_EQ(e->code, wire::ErrorCode::Timeout);
    EXPECT_NE(e->message.find("no Hello"), std::string::npos) << e->message;
    EXPECT_TRUE(b.wait_for_close().closed);
  }
  std::this_thread::sleep_for(300ms);  // the timed-out connections are gone

  // 2. Per address (3): `good` and two more sessions from 127.0.0.1; a fourth from there is
  // refused, one from 127.0.0.2 is not (it is then closed by the Hello deadline).
  client::Client second, third;
  second.connect("127.0.0.1", d.port(), "arlight-sim", kToken);
  third.connect("127.0.0.1", d.port(), "arlight-sim", kToken);
  {
    const RawOutcome refused = RawConnection(d.port()).wait_for_close();
    EXPECT_TRUE(refused.bytes.empty());
    EXPECT_LT(refused.seconds, 0.9);
    RawConnection other(d.port(), "127.0.0.2");
    std::this_thread::sleep_for(200ms);

    // 3. All connections (4): one from yet another address is refused.
    const RawOutcome over = RawConnection(d.port(), "127.0.0.3").wait_for_close();
    EXPECT_TRUE(over.bytes.empty());
    EXPECT_LT(over.seconds, 0.9);
    EXPECT_TRUE(still_served());
    const RawOutcome accepted = other.wait_for_close();
    ASSERT_TRUE(error_in(accepted.bytes).has_value()) << "127.0.0.2 was refused";
    EXPECT_EQ(error_in(accepted.bytes)->code, wire::ErrorCode::Timeout);
  }
  EXPECT_TRUE(good.connected() && second.connected() && third.connected());
  EXPECT_FALSE(good.server_error().has_value());

  EXPECT_EQ(metric(d.admin(), "arlight_hello_timeouts_total"), 3.0);
  EXPECT_EQ(metric(d.admin(), "arlight_connections_refused_unauthenticated_total"), 1.0);
  EXPECT_EQ(metric(d.admin(), "arlight_connections_refused_per_address_total"), 1.0);
  EXPECT_EQ(metric(d.admin(), "arlight_connections_refused_limit_total"), 1.0);
}

// An authenticated connection that sends nothing for the idle timeout is closed with
// Error{Timeout}; its session stays and resumes.
TEST(Arlightd, ASilentSessionIsClosedAfterTheIdleTimeoutAndResumes) {
  const fs::path dir = test::fresh_temp_dir("daemon_idle");
  DaemonProcess d(dir / "daemon", {"--idle-timeout", "2"});
  const recording::Recording rec = recording::read_recording(sample_recording());
  client::Client c;
  const wire::Welcome w = c.connect("127.0.0.1", d.port(), "arlight-sim", kToken);
  c.send_intrinsics(rec.camera);
  const auto opened = std::chrono::steady_clock::now();
  ASSERT_TRUE(c.wait_for([&] { return !c.connected(); }, 10s));
  const double after = std::chrono::duration<double>(std::chrono::steady_clock::now() - opened).count();
  EXPECT_GT(after, 1.5);
  ASSERT_TRUE(c.server_error().has_value());
  EXPECT_EQ(c.server_error()->first, "Timeout");
  client::Client again;
  const wire::Welcome resumed =
      again.connect("127.0.0.1", d.port(), "arlight-sim", kToken, "arlight-test", w.session_id);
  EXPECT_EQ(resumed.session_id, w.session_id);
  EXPECT_TRUE(resumed.resumed);
}

TEST(Arlightd, KilledAndRestartedDaemonResumesTheCheckpointedSession) {
  const fs::path dir = test::fresh_temp_dir("daemon_resume");
  std::string session, before_png;
  {
    DaemonProcess d(dir / "daemon");
    const auto r =
        test::run_tool(ARLIGHT_REPLAY_EXE, "--server " + d.server() + " --token " + kToken +
                                               " --recording " + sample_recording().string() +
                                               " --maps '' --out " + (dir / "replay").string());
    ASSERT_EQ(r.status, 0) << r.output;
    session = read_json(dir / "replay" / "replay.json")["session_id"];
    std::this_thread::sleep_for(3s);  // past the 2 s checkpoint interval
    const auto [status, png] = d.admin_get("/sessions/" + session + "/envmap.png");
    ASSERT_EQ(status, 200);
    before_png = png;
    d.kill9();
  }
  DaemonProcess again(dir / "daemon");
  // Not in memory any more: /sessions is empty until the client resumes.
  EXPECT_EQ(again.admin_get("/sessions/" + session + "/envmap.png").first, 404);
  client::Client c;
  const client::Welcome w =
      c.connect("127.0.0.1", again.port(), "arlight-sim", kToken, "test", session);
  EXPECT_TRUE(w.resumed);
  EXPECT_EQ(w.session_id, session);
  EXPECT_EQ(w.frames_processed, 60u);
  EXPECT_EQ(w.last_sequence, 60u);  // the checkpoint holds every frame the replay sent
  const auto [status, png] = again.admin_get("/sessions/" + session + "/envmap.png");
  ASSERT_EQ(status, 200);
  EXPECT_TRUE(png == before_png) << "the resumed map differs from the checkpointed one";
  // A client sending frames again that the session has (issue 36 §5): 58-60 are duplicates,
  // neither counted nor answered; 61-63 count.
  const recording::Recording rec = recording::read_recording(sample_recording());
  c.send_intrinsics(rec.camera);
  for (std::uint64_t seq = 58; seq <= 63; ++seq)
    c.send_jpeg_frame(seq, rec.frames[seq % rec.frames.size()], rec.camera.width,
                      rec.camera.height, recording::read_frame_bytes(rec, seq % rec.frames.size()));
  ASSERT_TRUE(c.wait_for([&] { return c.last_update() && c.last_update()->frame_sequence == 63; },
                         30s));
  EXPECT_LE(c.updates_received(), 3u);
  const json s = json::parse(again.admin_get("/sessions").second).at(0);
  EXPECT_EQ(s.at("frames_received"), 63);
  EXPECT_EQ(s.at("frames_duplicate"), 3);
  EXPECT_EQ(s.at("last_sequence"), 63);
  // Someone else's device cannot take it over; an unknown id is refused.
  client::Client other;
  EXPECT_THROW(other.connect("127.0.0.1", again.port(), "arlight-sim", kToken, "t", "deadbeef"),
               client::ClientError);
}

TEST(Arlightd, CalibrationSetStoresTheDevicesCurve) {
  const fs::path dir = test::fresh_temp_dir("daemon_calibration");
  const fs::path bracket = dir / "bracket";
  const auto s =
      test::run_tool(ARLIGHT_SIM_EXE, "--env " + std::string(ARLIGHT_SOURCE_DIR) +
                                          "/data/probes/venice.exr --out " + bracket.string() +
                                          " --bracket 7 --response filmic --size 320x240");
  ASSERT_EQ(s.status, 0) << s.output;
  const recording::Recording rec = recording::read_recording(bracket);
  std::vector<client::CalibrationFrame> frames;
  for (std::size_t i = 0; i < rec.frames.size(); ++i) {
    const auto& f = rec.frames[i];
    frames.push_back(
        {f, recording::read_frame_bytes(rec, i)});
  }
  DaemonProcess d(dir / "daemon");
  client::Client c;
  c.connect("127.0.0.1", d.port(), "arlight-sim", kToken);
  c.send_calibration_set("robertson", rec.camera.width, rec.camera.height, frames);
  ASSERT_TRUE(c.wait_for([&] { return c.calibration_result().has_value(); }, 60s));
  EXPECT_TRUE(c.calibration_result()->stored) << c.calibration_result()->message;
  EXPECT_TRUE(fs::exists(dir / "daemon" / "data" / "responses" / "arlight-sim.json"));
  // One exposure only cannot calibrate: a result saying why, and the connection stays.
  std::vector<client::CalibrationFrame> same(3, frames[3]);
  c.send_calibration_set("robertson", rec.camera.width, rec.camera.height, same);
  ASSERT_TRUE(c.wait_for([&] { return !c.calibration_result()->stored; }, 60s));
  EXPECT_NE(c.calibration_result()->message.find("exposure"), std::string::npos)
      << c.calibration_result()->message;
  EXPECT_TRUE(c.connected());
}

TEST(Arlightd, AdminEndpointsAnswer) {
  const fs::path dir = test::fresh_temp_dir("daemon_admin");
  DaemonProcess d(dir / "daemon");
  client::Client c;
  const auto w = c.connect("127.0.0.1", d.port(), "arlight-sim", kToken);
  EXPECT_EQ(http_get(d.admin(), "/healthz").first, 200);
  const auto [ms, metrics] = http_get(d.admin(), "/metrics");
  EXPECT_EQ(ms, 200);
  for (const char* name :
       {"arlight_sessions", "arlight_frames_received_total", "arlight_frames_processed_total",
        "arlight_frames_dropped_total", "arlight_frame_processing_seconds_bucket",
        "arlight_update_latency_seconds_count", "arlight_map_sets_total"})
    EXPECT_NE(metrics.find(name), std::string::npos) << name;
  const auto [ss, sessions] = d.admin_get("/sessions");
  EXPECT_EQ(ss, 200);
  const json j = json::parse(sessions);
  ASSERT_EQ(j.size(), 1u);
  EXPECT_EQ(j[0]["id"], w.session_id);
  EXPECT_EQ(d.admin_get("/sessions/nope/envmap.png").first, 404);
  // A room's picture and the session list need the token the daemon made in its data folder
  // (mode 0600); without it, or with another, 401 and nothing else.
  const fs::path token_file = dir / "daemon" / "data" / "admin.token";
  EXPECT_EQ(fs::status(token_file).permissions() & fs::perms::all,
            fs::perms::owner_read | fs::perms::owner_write);
  EXPECT_EQ(d.admin_token().size(), 64u);
  for (const std::string& token : {std::string(), std::string(64, '0'), std::string(kToken)}) {
    const auto [status, body] = http_get(d.admin(), "/sessions", token);
    EXPECT_EQ(status, 401) << token;
    EXPECT_EQ(body, "unauthorized\n");
    EXPECT_EQ(http_get(d.admin(), "/sessions/" + w.session_id + "/envmap.png", token).first, 401);
  }
  EXPECT_EQ(d.admin_get("/sessions/" + w.session_id + "/envmap.png").first, 200);
}

TEST(Arlightd, AdminServesALiveSessionsLightFiles) {
  // Issue 34 §2: the light of a session in the files engines read, from the admin port.
  const fs::path dir = test::fresh_temp_dir("daemon_light_files");
  DaemonProcess d(dir / "daemon");
  const auto r = test::run_tool(ARLIGHT_REPLAY_EXE, "--server " + d.server() + " --token " + kToken +
                                                        " --recording " + sample_recording().string() +
                                                        " --maps '' --out " + (dir / "replay").string());
  ASSERT_EQ(r.status, 0) << r.output;
  const std::string session = read_json(dir / "replay" / "replay.json")["session_id"];
  const auto [js, body] = d.admin_get("/sessions/" + session + "/light.json");
  ASSERT_EQ(js, 200) << body;
  const json light = json::parse(body);
  ASSERT_EQ(light["sh9"]["webxr"].size(), 27u);
  ASSERT_EQ(light["specular"]["levels"].size(), 4u);  // faces 128, 64, 32, 16
  EXPECT_EQ(light["specular"]["levels"][0]["face"], 128);
  const auto [ks, ktx] = d.admin_get("/sessions/" + session + "/specular.ktx2");
  ASSERT_EQ(ks, 200);
  const Ktx2Cube cube = decode_ktx2_cube(std::span(reinterpret_cast<const std::uint8_t*>(ktx.data()), ktx.size()));
  ASSERT_EQ(cube.levels.size(), 4u);
  EXPECT_EQ(cube.levels[0].layout.face_size(), 128);
  // The two files describe one room: the roughest level (the cosine-weighted mean radiance) has
  // the sphere's mean radiance, which SH-9's constant term gives as c00 Y00.
  const EnvMap& rough = cube.levels[3];
  const TexelTable& t = *texel_table(rough.layout);
  double mean = 0.0;
  for (std::size_t e = 0; e < t.size(); ++e)
    mean += t.solid_angle[e] * rough.image.data()[3 * std::size_t(t.index[e]) + 1] / (4.0 * M_PI);
  const double c00 = light["sh9"]["webxr"][1].get<double>() * 0.28209479;
  EXPECT_GT(mean, 0.0);
  EXPECT_NEAR(mean, c00, 0.03 * c00);
  // Both files came from one computation, kept while no frame arrives.
  EXPECT_EQ(metric(d.admin(), "arlight_light_files_total"), 1.0);
  EXPECT_EQ(d.admin_get("/sessions/" + session + "/specular.ktx2").second, ktx);
  EXPECT_EQ(metric(d.admin(), "arlight_light_files_total"), 1.0);
  EXPECT_EQ(d.admin_get("/sessions/nope/light.json").first, 404);
  EXPECT_EQ(http_get(d.admin(), "/sessions/" + session + "/specular.ktx2", "").first, 401);
  // A session that has sent no frame has no light yet: 409, saying so.
  client::Client fresh;
  const auto w = fresh.connect("127.0.0.1", d.port(), "arlight-sim", kToken);
  const auto [ns, why] = d.admin_get("/sessions/" + w.session_id + "/light.json");
  EXPECT_EQ(ns, 409);
  EXPECT_NE(why.find("no map yet"), std::string::npos) << why;
}

// Issue 34 §2 and §4: a client that asks for a GGX chain gets one computed from the session's
// map, the same chain arlight-maps ggx makes of the offline capture, and arlight-replay --ggx
// writes it with the SH and the primary light as the light files.
TEST(Arlightd, ReplayStreamsTheGgxChainAndWritesTheLightFiles) {
  const fs::path dir = test::fresh_temp_dir("daemon_ggx");
  DaemonProcess d(dir / "daemon");
  const auto r = test::run_tool(ARLIGHT_REPLAY_EXE, "--server " + d.server() + " --token " + kToken +
                                                        " --recording " + sample_recording().string() +
                                                        " --ggx 64 --out " + (dir / "replay").string());
  ASSERT_EQ(r.status, 0) << r.output;
  const json replay = read_json(dir / "replay" / "replay.json");
  ASSERT_TRUE(replay.contains("ggx")) << replay.dump();
  EXPECT_EQ(replay["ggx"]["frames"], 60);  // the full chain, once the frames stopped
  EXPECT_EQ(replay["ggx"]["levels"], 3);    // faces 64, 32, 16
  EXPECT_EQ(replay["maps"].size(), 0u);     // no Phong set was asked for
  const Ktx2Cube streamed = read_ktx2(dir / "replay" / "specular.ktx2");
  ASSERT_EQ(streamed.levels.size(), 3u);
  const json light = read_json(dir / "replay" / "light.json");
  EXPECT_EQ(light["sh9"]["webxr"].size(), 27u);
  EXPECT_NEAR(glm::length(glm::vec3(light["primary_light"]["direction"][0].get<float>(),
                                    light["primary_light"]["direction"][1].get<float>(),
                                    light["primary_light"]["direction"][2].get<float>())),
              1.0f, 1e-3f);
  EXPECT_TRUE(fs::exists(dir / "replay" / "lighting.gltf"));
  // The offline capture with the daemon's settings, and its chain by arlight-maps ggx.
  const auto c = test::run_tool(
      ARLIGHT_CAPTURE_EXE, "--recording " + sample_recording().string() + " --out " +
                               (dir / "env.exr").string() +
                               " --projection cube --size 192 --align-every 4 --align-width 160"
                               " --align-async");
  ASSERT_EQ(c.status, 0) << c.output;
  const auto g = test::run_tool(ARLIGHT_MAPS_EXE, "ggx --input " + (dir / "env.exr").string() +
                                                      " --face 64 --out " + (dir / "offline").string() +
                                                      " --json " + (dir / "g.json").string());
  ASSERT_EQ(g.status, 0) << g.output;
  const Ktx2Cube offline = read_ktx2(dir / "offline" / "specular.ktx2");
  ASSERT_EQ(offline.levels.size(), 3u);
  const auto roughness = [](const Ktx2Cube& cube) {
    for (const auto& [key, value] : cube.key_values)
      if (key == "arlight.ggx") return json::parse(value)["roughness"].get<std::vector<double>>();
    return std::vector<double>{};
  };
  ASSERT_EQ(roughness(streamed).size(), 3u);
  ASSERT_EQ(roughness(offline).size(), 3u);
  for (std::size_t k = 0; k < 3; ++k) {
    EXPECT_NEAR(roughness(streamed)[k], roughness(offline)[k], 1e-6) << "level " << k;
    const lighting::MapError e = lighting::map_error(offline.levels[k], streamed.levels[k]);
    std::printf("level %zu: streamed vs offline mean %.5f max %.5f\n", k, e.mean, e.max);
    // The mirror is the captured texels themselves: the daemon's and the offline capture of one
    // recording differ at a few texels where the asynchronous alignment lands on another frame
    // (mean 0.2 %, max 13 %); the prefiltered levels average that away (max <= 0.4 %).
    EXPECT_LT(e.mean, 0.005) << "level " << k;
    EXPECT_LT(e.max, k == 0 ? 0.25 : 0.02) << "level " << k;
  }
}

TEST(Arlightd, AdminTokenFromAFileAndProtectAll) {
  const fs::path dir = test::fresh_temp_dir("daemon_admin_token");
  fs::create_directories(dir);
  const std::string token = "operator-token-from-a-secret-0123";
  std::ofstream(dir / "admin-token") << "# mounted secret\n" << token << "\n";
  DaemonProcess d(dir / "daemon",
                  {"--admin-token-file", (dir / "admin-token").string(), "--admin-protect-all"});
  EXPECT_FALSE(fs::exists(dir / "daemon" / "data" / "admin.token"));  // none made
  EXPECT_EQ(http_get(d.admin(), "/healthz").first, 401);
  EXPECT_EQ(http_get(d.admin(), "/metrics").first, 401);
  EXPECT_EQ(http_get(d.admin(), "/healthz", token).first, 200);
  EXPECT_EQ(http_get(d.admin(), "/sessions", token).first, 200);
  // A named token file that is missing, short or empty stops the daemon with its name.
  std::ofstream(dir / "short") << "tooshort\n";
  std::ofstream(dir / "empty") << "# nothing\n";
  for (const char* bad : {"missing", "short", "empty"}) {
    const auto r = test::run_tool(ARLIGHTD_EXE, "--listen 127.0.0.1:0 --admin 127.0.0.1:0 "
                                                "--data-dir " + (dir / "data").string() +
                                                    " --tokens " + (dir / "daemon" / "tokens").string() +
                                                    " --admin-token-file " + (dir / bad).string());
    EXPECT_EQ(r.status, 2) << bad << ": " << r.output;
    EXPECT_NE(r.output.find("admin token file '" + (dir / bad).string() + "'"), std::string::npos)
        << r.output;
  }
}

TEST(Arlightd, TlsSessionsWorkAndPlainOrUntrustedClientsAreRefused) {
  const fs::path dir = test::fresh_temp_dir("daemon_tls");
  write_self_signed_certificate(dir / "cert.pem", dir / "key.pem");
  write_self_signed_certificate(dir / "other.pem", dir / "other-key.pem");
  DaemonProcess d(dir / "daemon", {"--tls-cert", (dir / "cert.pem").string(), "--tls-key",
                                   (dir / "key.pem").string()});
  // A replay over TLS, trusting the daemon's certificate, gets its updates and maps.
  const auto r =
      test::run_tool(ARLIGHT_REPLAY_EXE,
                     "--server " + d.server() + " --token " + kToken + " --recording " +
                         sample_recording().string() + " --tls-ca " + (dir / "cert.pem").string() +
                         " --maps 1,80 --map-size 64" + " --out " + (dir / "replay").string());
  ASSERT_EQ(r.status, 0) << r.output;
  const json summary = read_json(dir / "replay" / "replay.json");
  EXPECT_EQ(summary.at("updates_received").get<int>(), 60) << summary.dump();
  EXPECT_GE(summary.at("map_sets_completed").get<int>(), 1) << summary.dump();

  // A client that does not trust the certificate stops at the handshake.
  client::Client untrusted;
  untrusted.use_tls({.enabled = true, .ca_file = (dir / "other.pem").string()});
  try {
    untrusted.connect("127.0.0.1", d.port(), "arlight-sim", kToken);
    FAIL() << "connected trusting another certificate";
  } catch (const client::ClientError& e) {
    EXPECT_EQ(e.code(), "TLS") << e.what();
  }
  // A trusted certificate that names another host does not pass for 127.0.0.1.
  write_self_signed_certificate(dir / "named.pem", dir / "named-key.pem", "DNS:elsewhere.example");
  {
    DaemonProcess named(dir / "named", {"--tls-cert", (dir / "named.pem").string(), "--tls-key",
                                        (dir / "named-key.pem").string()});
    client::Client wrong_name;
    wrong_name.use_tls({.enabled = true, .ca_file = (dir / "named.pem").string()});
    try {
      wrong_name.connect("127.0.0.1", named.port(), "arlight-sim", kToken);
      FAIL() << "connected to a certificate for another name";
    } catch (const client::ClientError& e) {
      EXPECT_EQ(e.code(), "TLS") << e.what();
    }
  }
  // Plain TCP to a TLS port gets no Welcome, and the daemon serves TLS clients after it.
  client::Client plain;
  EXPECT_THROW(plain.connect("127.0.0.1", d.port(), "arlight-sim", kToken, "plain", {}, 3s),
               client::ClientError);
  client::Client again;
  again.use_tls({.enabled = true, .ca_file = (dir / "cert.pem").string()});
  EXPECT_FALSE(again.connect("127.0.0.1", d.port(), "arlight-sim", kToken).session_id.empty());
}

TEST(Arlightd, UnusableTlsFilesStopItNamingTheFile) {
  const fs::path dir = test::fresh_temp_dir("daemon_tls_bad");
  write_self_signed_certificate(dir / "cert.pem", dir / "key.pem");
  write_self_signed_certificate(dir / "other.pem", dir / "other-key.pem");
  std::ofstream(dir / "tokens") << "arlight-sim " << kToken << "\n";
  const std::string base = "--listen 127.0.0.1:0 --admin '' --data-dir " + (dir / "data").string() +
                           " --tokens " + (dir / "tokens").string();
  const auto missing =
      test::run_tool(ARLIGHTD_EXE, base + " --tls-cert " + (dir / "nope.pem").string() +
                                       " --tls-key " + (dir / "key.pem").string());
  EXPECT_EQ(missing.status, 2) << missing.output;
  EXPECT_NE(missing.output.find("nope.pem"), std::string::npos) << missing.output;
  const auto mismatched =
      test::run_tool(ARLIGHTD_EXE, base + " --tls-cert " + (dir / "cert.pem").string() +
                                       " --tls-key " + (dir / "other-key.pem").string());
  EXPECT_EQ(mismatched.status, 2) << mismatched.output;
  EXPECT_NE(mismatched.output.find("other-key.pem"), std::string::npos) << mismatched.output;
  const auto half =
      test::run_tool(ARLIGHTD_EXE, base + " --tls-cert " + (dir / "cert.pem").string());
  EXPECT_EQ(half.status, 2) << half.output;
}

TEST(Arlightd, AFloodOfFramesIsBoundedNewestFramesWinAndDropsAreCounted) {
  const fs::path dir = test::fresh_temp_dir("daemon_flood");
  DaemonProcess d(dir / "daemon", {"--workers", "1", "--queue-depth", "2"});
  const recording::Recording rec = recording::read_recording(sample_recording());
  client::Client c;
  c.connect("127.0.0.1", d.port(), "arlight-sim", kToken);
  c.send_intrinsics(rec.camera);
  // 120 frames as fast as the socket takes them: far faster than one worker processes them.
  constexpr std::uint64_t kFrames = 120;
  for (std::uint64_t seq = 1; seq <= kFrames; ++seq) {
    const std::size_t i = std::size_t(seq) % rec.frames.size();
    const auto& f = rec.frames[i];
    c.send_jpeg_frame(seq, f, rec.camera.width,
                      rec.camera.height, recording::read_frame_bytes(rec, i));
  }
  // The last frame always survives (newest wins), and every frame is either processed or
  // counted as dropped.
  ASSERT_TRUE(c.wait_for(
      [&] {
        const auto u = c.last_update();
        return u && u->frame_sequence == kFrames;
      },
      60s));
  const auto u = *c.last_update();
  EXPECT_GT(u.frames_dropped, 0u);
  EXPECT_EQ(u.frames_processed + u.frames_dropped, kFrames);
  EXPECT_EQ(c.updates_received(), u.frames_processed);
}

TEST(Arlightd, AFullDaemonClosesItsIdlestDisconnectedSessionToMakeRoom) {
  const fs::path dir = test::fresh_temp_dir("daemon_full");
  DaemonProcess d(dir / "daemon", {"--max-sessions", "2"});
  const recording::Recording rec = recording::read_recording(sample_recording());
  const auto one_frame = [&](client::Client& c) {
    c.send_intrinsics(rec.camera);
    const auto& f = rec.frames[0];
    c.send_jpeg_frame(1, f, rec.camera.width,
                      rec.camera.height, recording::read_frame_bytes(rec, 0));
    ASSERT_TRUE(c.wait_for([&] { return c.last_update().has_value(); }, 20s));
  };
  // A: one frame, then goodbye (disconnected, kept in memory until the idle timeout).
  std::string a_id;
  {
    client::Client a;
    a_id = a.connect("127.0.0.1", d.port(), "arlight-sim", kToken).session_id;
    one_frame(a);
    a.bye();
    a.wait_for([&] { return !a.connected(); }, 5s);
  }
  client::Client b, c, e;
  b.connect("127.0.0.1", d.port(), "arlight-sim", kToken);
  // Full (A idle, B connected): C gets A's place, A goes to disk.
  EXPECT_NO_THROW(c.connect("127.0.0.1", d.port(), "arlight-sim", kToken));
  // Full with two connected sessions: refused.
  try {
    e.connect("127.0.0.1", d.port(), "arlight-sim", kToken);
    FAIL() << "a third session while two are connected";
  } catch (const client::ClientError& err) {
    EXPECT_EQ(err.code(), "Busy") << err.what();
  }
  // A was kept: once there is room again, it resumes with its frame. The daemon learns of C's
  // close a moment after the client makes it; until then it is still full (Busy), as a real
  // client would be told, and retries.
  c.close();
  std::optional<client::Welcome> w;
  for (const auto until = std::chrono::steady_clock::now() + 5s; !w;) {
    client::Client a2;
    try {
      w = a2.connect("127.0.0.1", d.port(), "arlight-sim", kToken, "t", a_id);
    } catch (const client::ClientError& err) {
      if (err.code() != "Busy" || std::chrono::steady_clock::now() > until) throw;
      std::this_thread::sleep_for(50ms);
    }
  }
  EXPECT_TRUE(w->resumed);
  EXPECT_EQ(w->frames_processed, 1u);
}

// Byes arrive while frames are still being merged and the periodic checkpoint (every
// housekeeping tick here) is writing: two checkpoints of one session at once used to delete
// each other's files and abort the daemon. Every session must end up whole on disk and
// resumable after a kill -9.
TEST(Arlightd, ByesDuringPeriodicCheckpointsLeaveEverySessionWholeOnDisk) {
  const fs::path dir = test::fresh_temp_dir("daemon_bye_race");
  std::ofstream(dir / "arlightd.json") << R"({"checkpoint_interval_s": 0.25})";
  const std::vector<std::string> args = {"--config", (dir / "arlightd.json").string()};
  const recording::Recording rec = recording::read_recording(sample_recording());
  std::vector<std::vector<std::uint8_t>> jpegs;
  for (std::size_t i = 0; i < rec.frames.size(); ++i)
    jpegs.push_back(recording::read_frame_bytes(rec, i));
  constexpr int kSessions = 6;
  std::vector<std::string> ids;
  std::uint16_t port = 0;
  {
    DaemonProcess d(dir / "daemon", args);
    port = d.port();
    for (int round = 0; round < 4; ++round) {
      std::vector<std::unique_ptr<client::Client>> clients;
      for (int s = 0; s < kSessions; ++s) {
        clients.push_back(std::make_unique<client::Client>());
        ids.push_back(
            clients.back()->connect("127.0.0.1", d.port(), "arlight-sim", kToken).session_id);
        clients.back()->send_intrinsics(rec.camera);
      }
      // 30 fps each; session s says Bye right after its frame 12 + 4 s, frames still in flight.
      for (int k = 1; k <= 12 + 4 * (kSessions - 1); ++k) {
        for (int s = 0; s < kSessions; ++s) {
          if (k > 12 + 4 * s) continue;
          const std::size_t i = std::size_t(k + 7 * s) % rec.frames.size();
          const auto& f = rec.frames[i];
          clients[std::size_t(s)]->send_jpeg_frame(std::uint64_t(k),
                                                   f,
                                                   rec.camera.width, rec.camera.height, jpegs[i]);
          if (k == 12 + 4 * s) clients[std::size_t(s)]->bye();
        }
        std::this_thread::sleep_for(33ms);
      }
      std::this_thread::sleep_for(300ms);
      ASSERT_EQ(http_get(d.admin(), "/healthz").first, 200) << "round " << round;
    }
    // Every frame sent is accounted for on disk (processed, dropped or skipped), however slow
    // the build (a sanitizer's takes seconds): then the last checkpoints are written.
    const auto whole = [&] {
      for (const std::string& id : ids) {
        const fs::path manifest = dir / "daemon" / "data" / "sessions" / id / "session.json";
        if (!fs::exists(manifest)) return false;
        const json m = read_json(manifest);
        if (m["frames_processed"].get<int>() + m["frames_dropped"].get<int>() +
                m["frames_skipped"].get<int>() != m["frames_received"].get<int>())
          return false;
      }
      return true;
    };
    for (int i = 0; i < 1200 && !whole(); ++i) std::this_thread::sleep_for(50ms);
    ASSERT_TRUE(whole()) << "frames still unaccounted for after 60 s";
    d.kill9();
  }
  DaemonProcess again(dir / "daemon", args, port);
  for (const std::string& id : ids) {
    client::Client c;
    const client::Welcome w = c.connect("127.0.0.1", again.port(), "arlight-sim", kToken, "t", id);
    EXPECT_TRUE(w.resumed) << id;
    EXPECT_GT(w.frames_processed, 0u) << id;
    c.bye();
  }
}

// Issue 37 §1: frame advice. A 640x480 camera's LightingUpdates ask for 320x240 (what the map
// and the alignment resolve); such a frame is taken, one of another size is skipped saying what
// sizes are; once ten frames in a row agree with the map the rate asked for drops from 30 to 10
// (they are glanced at, not processed), and a frame of a changed room (a lamp switched on) takes
// it back to 30 at once, its own update's SH holding the lamp.
TEST(Arlightd, FrameAdviceAsksForTheSizeTheMapNeedsAndFewerFramesOnceTheyAgree) {
  const fs::path dir = test::fresh_temp_dir("daemon_frame_advice");
  const fs::path rec_dir = dir / "rec";
  ASSERT_EQ(test::run_tool(ARLIGHT_SIM_EXE, "--env " + std::string(ARLIGHT_SOURCE_DIR) +
                                                "/data/probes/venice.exr --out " +
                                                rec_dir.string() + " --frames 4 --size 640x480")
                .status,
            0);
  const recording::Recording rec = recording::read_recording(rec_dir);
  DaemonProcess d(dir / "daemon");
  client::Client c;
  c.connect("127.0.0.1", d.port(), "arlight-sim", kToken);
  c.send_intrinsics(rec.camera);
  const auto reduced = [&](const std::vector<std::uint8_t>& jpeg, cv::Size size, bool lamp) {
    cv::Mat im = cv::imdecode(jpeg, cv::IMREAD_COLOR), small;
    cv::resize(im, small, size, 0, 0, cv::INTER_AREA);
    if (lamp)
      small(cv::Rect(size.width / 3, size.height / 3, size.width / 3, size.height / 3))
          .setTo(cv::Scalar(235, 235, 235));
    std::vector<std::uint8_t> out;
    cv::imencode(".jpg", small, out, {cv::IMWRITE_JPEG_QUALITY, 90});
    return out;
  };
  std::uint64_t seq = 0;
  const auto send = [&](const std::vector<std::uint8_t>& jpeg, cv::Size size) {
    FrameInfo info = rec.frames[0];
    info.timestamp = 0.1 * double(++seq);
    c.send_jpeg_frame(seq, info, size.width, size.height, jpeg);
    EXPECT_TRUE(c.wait_for([&] { return c.last_update() && c.last_update()->frame_sequence >= seq; },
                           20s));
    return *c.last_update();
  };
  const auto full = recording::read_frame_bytes(rec, 0);
  const client::LightingUpdate first = send(full, {640, 480});
  EXPECT_TRUE(first.frame_used) << first.reason;
  EXPECT_EQ(first.advised_width, 320);
  EXPECT_EQ(first.advised_height, 240);
  EXPECT_EQ(first.advised_fps, 30.0f);
  const auto small = reduced(full, {320, 240}, false);
  EXPECT_LT(small.size(), full.size() / 2);
  const client::LightingUpdate taken = send(small, {320, 240});
  EXPECT_TRUE(taken.frame_used) << taken.reason;
  const client::LightingUpdate odd = send(reduced(full, {200, 150}, false), {200, 150});
  EXPECT_FALSE(odd.frame_used);
  EXPECT_NE(odd.reason.find("640x480 (or that reduced by a power of two)"), std::string::npos)
      << odd.reason;
  float settled_fps = 0.0f;
  client::LightingUpdate settled;
  for (int k = 0; k < 14; ++k) settled = send(small, {320, 240}), settled_fps = settled.advised_fps;
  EXPECT_EQ(settled_fps, 10.0f);
  // The settled frames cost their glance alone (capture's CaptureOptions::glance) ...
  double glanced = 0;
  for (const json& s : json::parse(d.admin_get("/sessions").second))
    glanced += s["frames_glanced"].get<double>();
  EXPECT_GE(glanced, 8.0);
  // ... and the lamp switched on is in the live SH of its own frame's update: at the settled
  // 10 frames a second, within 0.1 s and a frame's latency of the switch.
  const client::LightingUpdate lamp = send(reduced(full, {320, 240}, true), {320, 240});
  EXPECT_TRUE(lamp.frame_used);
  EXPECT_EQ(lamp.frame_sequence, seq);
  EXPECT_EQ(lamp.advised_fps, 30.0f);
  EXPECT_GT(lamp.sh.c[0].x, settled.sh.c[0].x * 1.01f);
}

// Issue 16 §3: map sets follow the map. One view of a room whose lamp goes on and off, sent
// again and again (the map changes, its coverage does not grow, and frames never pause: the old
// rule, 5 % more coverage or 150 frames or a 0.5 s pause, gave one set in all that time) gets a
// set each --map-interval, or as often as the machine computes them; an interval as long as the
// test holds them to two. Issue 37 §1: the same view of a room that does not change stops
// changing the map after its first frames (they agree with it: not merged), and the sets stop.
TEST(Arlightd, MapSetsFollowTheMapAtTheMapInterval) {
  const fs::path dir = test::fresh_temp_dir("daemon_map_interval");
  const recording::Recording rec = recording::read_recording(sample_recording());
  const auto jpeg = recording::read_frame_bytes(rec, 10);
  std::vector<std::uint8_t> lamp_on;  // the view with a bright panel in its middle
  {
    cv::Mat im = cv::imdecode(jpeg, cv::IMREAD_COLOR);
    im(cv::Rect(im.cols / 3, im.rows / 3, im.cols / 3, im.rows / 3)).setTo(cv::Scalar(235, 235, 235));
    cv::imencode(".jpg", im, lamp_on);
  }
  struct Run {
    std::uint64_t sets = 0;
    double set_seconds = 0;  // the last set's, as the daemon measured it
    double unchanged = 0;    // frames the daemon did not merge (/sessions)
    double dropped = 0;      // frames it dropped for newer ones (a busy machine)
  };
  // Sets run below the frames' priority: a busy machine (the suite runs two tests at once)
  // makes each take longer. Under the sanitizers one takes 10-15 s: that run checks only the
  // upper bounds (a sanitized daemon's frames at 20 a second would leave the sets no CPU).
  const double seconds = 3.0;
  const auto period = test::kSanitized ? 250ms : 50ms;
  const auto send_for = [&](const std::string& interval, bool lamp_switches) {
    DaemonProcess d(dir / ("daemon" + interval), {"--map-interval", interval});
    client::Client c;
    const std::string session = c.connect("127.0.0.1", d.port(), "arlight-sim", kToken).session_id;
    c.send_intrinsics(rec.camera);
    c.request_maps({1.0, 80.0}, 32);
    const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
    for (std::uint64_t seq = 1; std::chrono::steady_clock::now() < end; ++seq) {
      FrameInfo info = rec.frames[10];
      info.timestamp = std::chrono::duration<double>(period).count() * double(seq);
      c.send_jpeg_frame(seq, info, rec.camera.width, rec.camera.height,
                        lamp_switches && seq % 2 ? lamp_on : jpeg);
      std::this_thread::sleep_for(period);
    }
    Run run{c.map_sets_completed(), 0.0};
    if (const auto m = c.last_complete_maps()) run.set_seconds = m->server_seconds;
    for (const json& s : json::parse(d.admin_get("/sessions").second))
      if (s["id"] == session) {
        run.unchanged = s["frames_unchanged"].get<double>();
        run.dropped = s["frames_dropped"].get<double>() + s["frames_skipped"].get<double>();
      }
    std::printf(
        "--map-interval %s, %s: %llu map sets in %.0f s of one view (the last took %.3f s), "
        "%.0f frames not merged\n",
        interval.c_str(), lamp_switches ? "a lamp switching" : "nothing changing",
        static_cast<unsigned long long>(run.sets), seconds, run.set_seconds, run.unchanged);
    return run;
  };
  const Run frequent = send_for("0.1", true), rare = send_for("2", true);
  const Run still = send_for("0.1", false);
  // Each frame differs from the one before; one agrees with the map only where the daemon
  // dropped the frame before it, so two of the same kind met (seen once on a loaded machine).
  EXPECT_LE(frequent.unchanged, frequent.dropped);
  EXPECT_GT(still.unchanged, 0.5 * seconds / std::chrono::duration<double>(period).count());
  EXPECT_LE(still.sets, 3u);  // the first frames', then none
  EXPECT_LE(double(frequent.sets), seconds / 0.1 + 1);
  EXPECT_LE(rare.sets, 2u);  // the first, and one 2 s later
  if (test::kSanitized) return;
  // Back to back: about the sending time over one set's time, however long that is.
  ASSERT_GT(frequent.set_seconds, 0.0);
  EXPECT_GE(frequent.sets, 2u);  // the old rule: 1
  EXPECT_GE(double(frequent.sets), 0.5 * seconds / std::max(frequent.set_seconds, 0.1));
}

// Issue 34 §2: while frames arrive a GGX chain follows the map as previews (face <= 128, as many
// levels as asked); when they stop, the full chain of the request's face follows.
TEST(Arlightd, GgxChainsFollowTheMapWhileCapturingAndTheFullOneFollows) {
  const fs::path dir = test::fresh_temp_dir("daemon_ggx_follow");
  const recording::Recording rec = recording::read_recording(sample_recording());
  DaemonProcess d(dir / "daemon", {"--map-interval", "0.1"});
  client::Client c;
  std::mutex m;
  std::vector<std::pair<int, std::size_t>> chains;  // face, levels of each completed chain
  c.on_map_set_complete = [&](const client::ReceivedMapSet& set) {
    std::lock_guard lock(m);
    if (set.kind == wire::MapKind::Ggx)
      chains.emplace_back(set.maps.front().layout.width(), set.maps.size());
  };
  c.connect("127.0.0.1", d.port(), "arlight-sim", kToken);
  c.send_intrinsics(rec.camera);
  c.request_maps(client::ggx_request(256));
  const auto period = test::kSanitized ? 250ms : 50ms;
  for (std::uint64_t seq = 1; seq <= 40; ++seq) {
    const std::size_t i = (seq - 1) % rec.frames.size();
    FrameInfo info = rec.frames[i];
    info.timestamp = std::chrono::duration<double>(period).count() * double(seq);
    c.send_jpeg_frame(seq, info, rec.camera.width, rec.camera.height,
                      recording::read_frame_bytes(rec, i));
    std::this_thread::sleep_for(period);
  }
  // The full chain of the final map: on a busy machine a pause in the frames' processing may
  // bring a full chain mid-way too, and previews after it. The client holds a set before its
  // on_map_set_complete has run: wait for that too.
  ASSERT_TRUE(c.wait_for(
      [&] {
        const auto chain = c.last_complete_ggx();
        const auto update = c.last_update();
        std::lock_guard lock(m);
        return chain && update && chain->maps[0].layout.width() == 256 &&
               chain->frames == update->frames_processed && update->frame_sequence == 40 &&
               !chains.empty() && chains.back().first == 256;
      },
      60s));
  std::lock_guard lock(m);
  ASSERT_GE(chains.size(), 2u);
  std::size_t previews = 0;
  for (const auto& [face, levels] : chains) {
    EXPECT_EQ(levels, 5u) << "face " << face;  // 256 -> 16 and its previews 128 -> 8
    EXPECT_TRUE(face == 128 || face == 256) << face;
    previews += face == 128;
  }
  EXPECT_GE(previews, 1u);
  EXPECT_EQ(chains.back().first, 256);
  EXPECT_EQ(c.last_complete_ggx()->frames, c.last_update()->frames_processed);
}

// Issue 51 §1: a chain asked for with specular_lights comes with the lights taken out of it
// (at most as many as asked, each a unit direction, a power and a disc), and its level 0 (the
// mirror: the room itself) is the room less them; lights asked for beside the Phong maps are
// refused, closing only that connection.
TEST(Arlightd, AGgxChainComesWithTheLightsTakenOutOfIt) {
  const fs::path dir = test::fresh_temp_dir("daemon_ggx_lights");
  // Studio: its ring light is in view, unclipped in every second frame (10 stops
  // darker; a clipped lamp is no brighter than the walls beside it).
  const auto sim = test::run_tool(ARLIGHT_SIM_EXE, "--env " + std::string(ARLIGHT_SOURCE_DIR) +
                                                       "/data/probes/studio.exr --out " +
                                                       (dir / "rec").string() +
                                                       " --frames 40 --hdr-stops 10 --size 320x240 --seed 4");
  ASSERT_EQ(sim.status, 0) << sim.output;
  const recording::Recording rec = recording::read_recording(dir / "rec");
  DaemonProcess d(dir / "daemon");
  const auto first_chain = [&](int lights) {
    client::Client c;
    c.connect("127.0.0.1", d.port(), "arlight-sim", kToken);
    c.send_intrinsics(rec.camera);
    c.request_maps(client::ggx_request(32, 0, lights));
    // Paced, as a camera sends them: frames that arrive faster than they are merged are dropped.
    for (std::uint64_t seq = 1; seq <= rec.frames.size(); ++seq) {
      c.send_jpeg_frame(seq, rec.frames[seq - 1], rec.camera.width, rec.camera.height,
                        recording::read_frame_bytes(rec, seq - 1));
      EXPECT_TRUE(c.wait_for([&] {
        const auto u = c.last_update();
        return u && u->frame_sequence == seq;
      }, 30s));
    }
    EXPECT_TRUE(c.wait_for(
        [&] {
          const auto chain = c.last_complete_ggx();
          const auto update = c.last_update();
          return chain && update && update->frame_sequence == rec.frames.size() &&
                 chain->frames == update->frames_processed && chain->maps[0].layout.width() == 32;
        },
        60s));
    return c.last_complete_ggx();
  };
  const auto with = first_chain(kMaxSpecularLights), without = first_chain(0);
  ASSERT_TRUE(with && without);
  EXPECT_TRUE(without->lights.empty());
  ASSERT_FALSE(with->lights.empty()) << "studio's ring light";
  EXPECT_LE(with->lights.size(), std::size_t(kMaxSpecularLights));
  double light = 0;
  for (const SpecularLight& l : with->lights) {
    EXPECT_NEAR(glm::length(l.direction), 1.0f, 1e-3f);
    EXPECT_GT(luminance(l.power), 0.0f);
    EXPECT_LE(l.radius, 0.25f);
    light += luminance(l.power);
  }
  // Both sessions merged the same frames: the mirror level's light plus the lights' is the
  // whole room's.
  const auto power = [](const EnvMap& m) {
    const TexelTable& t = *texel_table(m.layout);
    double sum = 0;
    for (std::size_t i = 0; i < t.size(); ++i) {
      const float* p = m.image.data() + 3 * std::size_t(t.index[i]);
      sum += luminance(p[0], p[1], p[2]) * t.solid_angle[i];
    }
    return sum;
  };
  EXPECT_NEAR(power(with->maps[0]) + light, power(without->maps[0]), 0.01 * power(without->maps[0]));

  client::Client phong;
  phong.connect("127.0.0.1", d.port(), "arlight-sim", kToken);
  wire::RequestMaps lit_phong = client::map_request({1, 10}, 32, Projection::AngleMap);
  lit_phong.specular_lights = 2;
  phong.request_maps(lit_phong);
  expect_closed_with(phong, "BadMessage", "specular_lights is for a GGX chain");
}

// A connection's map request is its own: a client that resumes a session without asking for
// maps gets no map set computed for the previous connection's request however its frames change
// the map (the eval's SH-only run was once drawn with one); one that asks gets them.
TEST(Arlightd, AResumedSessionComputesMapSetsOnlyForItsNewConnectionsRequest) {
  const fs::path dir = test::fresh_temp_dir("daemon_resume_request");
  DaemonProcess d(dir / "daemon", {"--map-interval", "0.1"});
  const recording::Recording rec = recording::read_recording(sample_recording());
  std::uint64_t seq = 0;
  const auto send_frames = [&](client::Client& c, int n) {
    for (int i = 0; i < n; ++i) {
      const int f = int(seq % rec.frames.size());
      FrameInfo info = rec.frames[std::size_t(f)];
      info.timestamp = 0.05 * double(++seq);
      c.send_jpeg_frame(seq, info, rec.camera.width, rec.camera.height,
                        recording::read_frame_bytes(rec, f));
      std::this_thread::sleep_for(50ms);
    }
  };
  std::string session;
  // The sets the session has started (the admin's /sessions), once none has started for 3 s (the
  // full set that follows a preview included). Started, not completed: sets run at a low
  // priority, so a loaded machine (the other tests, sanitized) can hold one that started for the
  // earlier connection back until after the next connection came.
  const auto sets_started = [&] {
    const auto [status, body] = d.admin_get("/sessions");
    EXPECT_EQ(status, 200);
    for (const json& s : json::parse(body))
      if (s["id"] == session) return s["map_sets"].get<double>();
    ADD_FAILURE() << "session " << session << " not in /sessions";
    return -1.0;
  };
  const auto sets_when_quiet = [&] {
    double last = sets_started();
    for (int i = 0; i < 30; ++i) {
      std::this_thread::sleep_for(3000ms);
      const double now = sets_started();
      if (now == last) return now;
      last = now;
    }
    ADD_FAILURE() << "map sets never stopped";
    return last;
  };
  {
    client::Client a;
    session = a.connect("127.0.0.1", d.port(), "arlight-sim", kToken).session_id;
    a.send_intrinsics(rec.camera);
    a.request_maps({1.0, 80.0}, 32);
    send_frames(a, 10);
    ASSERT_TRUE(a.wait_for([&] { return a.map_sets_completed() >= 1; }, 60s));
    a.bye();
  }
  const double before = sets_when_quiet();
  ASSERT_GE(before, 1.0);
  {
    client::Client b;  // resumes, sends frames that change the map, asks for no maps
    ASSERT_TRUE(
        b.connect("127.0.0.1", d.port(), "arlight-sim", kToken, "arlight-test", session).resumed);
    b.send_intrinsics(rec.camera);
    send_frames(b, 20);
    // The last frame's update (a busy daemon drops older frames: the newest wins).
    ASSERT_TRUE(b.wait_for(
        [&] {
          const auto u = b.last_update();
          return u && u->frame_sequence >= seq;
        },
        60s));
    EXPECT_EQ(sets_when_quiet(), before) << "sets started for the previous connection's request";
    b.bye();
  }
  client::Client c;  // resumes and asks: its sets come
  ASSERT_TRUE(
      c.connect("127.0.0.1", d.port(), "arlight-sim", kToken, "arlight-test", session).resumed);
  c.request_maps({1.0, 80.0}, 32);
  EXPECT_TRUE(c.wait_for([&] { return c.map_sets_completed() >= 1; }, 60s));
}
