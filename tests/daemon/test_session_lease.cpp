// Session leases (server/daemon/src/session_lease.*): one owner at a time, the kernel lets go
// when the owner dies, hand-over requests; and the checkpoint generation a taking-over daemon
// continues from.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <fstream>
#include <functional>
#include <glm/gtc/quaternion.hpp>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <thread>

#include "arlight/capture/capture.hpp"
#include "arlight/common/error.hpp"
#include "checkpoint.hpp"
#include "session.hpp"
#include "session_lease.hpp"

namespace arlight::daemon {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;

fs::path fresh_dir(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("arlight_lease_" + name);
  fs::remove_all(dir);
  return dir;
}

TEST(SessionLease, OneOwnerAtATimeAndFreeOnceLetGo) {
  const fs::path dir = fresh_dir("one") / "sessions" / "abc";
  auto first = SessionLease::try_acquire(dir, {"host-a pid=1"});
  ASSERT_TRUE(first.has_value());
  EXPECT_EQ(SessionLease::owner_of(dir), "host-a pid=1");
  // flock is per open file: even this process cannot take it twice.
  EXPECT_FALSE(SessionLease::try_acquire(dir, {"host-b pid=2"}).has_value());
  EXPECT_EQ(SessionLease::owner_of(dir), "host-a pid=1") << "a refused taker wrote the owner";
  SessionLease moved = std::move(*first);
  first.reset();  // the moved-from lease holds nothing
  EXPECT_FALSE(SessionLease::try_acquire(dir, {"host-b pid=2"}).has_value());
  { SessionLease gone = std::move(moved); }
  const auto second = SessionLease::try_acquire(dir, {"host-b pid=2"});
  ASSERT_TRUE(second.has_value());
  EXPECT_EQ(SessionLease::owner_of(dir), "host-b pid=2");
}

// A child process that takes the lease of `dir` as "child", then runs `then` with it (never
// returning); its pid once it holds the lease, or -1 when it could not take it.
pid_t lease_owner_process(const fs::path& dir, const std::function<void(SessionLease&)>& then) {
  int ready[2];
  if (pipe(ready) != 0) return -1;
  const pid_t child = fork();
  if (child == 0) {
    auto lease = SessionLease::try_acquire(dir, {"child"});
    const char ok = lease ? '1' : '0';
    [[maybe_unused]] const ssize_t n = write(ready[1], &ok, 1);
    if (lease) then(*lease);
    _exit(0);
  }
  char ok = 0;
  const bool held = read(ready[0], &ok, 1) == 1 && ok == '1';
  close(ready[0]), close(ready[1]);
  return held ? child : -1;
}

// The fail-over case: the owner is killed with SIGKILL; its lease is free at once.
TEST(SessionLease, TheKernelLetsGoWhenTheOwnerIsKilled) {
  const fs::path dir = fresh_dir("killed") / "s";
  const pid_t child = lease_owner_process(dir, [](SessionLease&) {
    for (;;) pause();
  });
  ASSERT_GT(child, 0);
  EXPECT_FALSE(SessionLease::try_acquire(dir, {"parent"}).has_value());
  kill(child, SIGKILL);
  waitpid(child, nullptr, 0);
  EXPECT_TRUE(SessionLease::try_acquire(dir, {"parent"}).has_value());
}

// A stopped owner (SIGSTOP) keeps its flock but stops renewing: its lease is taken over once
// it expires, and the owner, continued, finds it has lost it (issue 36 §5).
TEST(SessionLease, AStoppedOwnersLeaseIsTakenOverOnceItExpires) {
  const fs::path dir = fresh_dir("stopped") / "s";
  // The owner's housekeeping: renew every 100 ms; exit 3 once the lease is lost.
  const pid_t child = lease_owner_process(dir, [](SessionLease& lease) {
    while (lease.renew()) std::this_thread::sleep_for(100ms);
    _exit(3);
  });
  ASSERT_GT(child, 0);
  std::this_thread::sleep_for(SessionLease::kExpiry + 500ms);  // renewed all along
  EXPECT_FALSE(SessionLease::try_acquire(dir, {"parent"}).has_value());
  kill(child, SIGSTOP);
  const auto stopped = std::chrono::steady_clock::now();
  std::optional<SessionLease> taken;
  while (!taken && std::chrono::steady_clock::now() - stopped < SessionLease::kExpiry + 2s) {
    taken = SessionLease::try_acquire(dir, {"parent"});
    if (!taken) std::this_thread::sleep_for(100ms);
  }
  const auto waited = std::chrono::steady_clock::now() - stopped;
  kill(child, SIGCONT);
  ASSERT_TRUE(taken.has_value()) << "the stopped owner's lease never expired";
  EXPECT_GE(waited, SessionLease::kExpiry - 200ms);  // not before it expired
  EXPECT_TRUE(taken->held());
  EXPECT_EQ(SessionLease::owner_of(dir), "parent");
  int status = 0;
  waitpid(child, &status, 0);
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 3) << "the owner never saw it lost";
  EXPECT_TRUE(taken->renew());  // the new owner keeps it
  EXPECT_FALSE(SessionLease::try_acquire(dir, {"third"}).has_value());
}

// Where a session's owner is reached (issue 49 §2): read from a live lease only — held and
// renewed — so a redirect never sends a client to a daemon that died or stopped.
TEST(SessionLease, ALiveHoldersAddressesAreReadFromItsLeaseAndOnlyWhileItLives) {
  const fs::path dir = fresh_dir("holder") / "s";
  EXPECT_FALSE(SessionLease::live_holder(dir).has_value());  // no lease at all
  const LeaseHolder owner{"host-a pid=1", "10.0.0.1:7880", "10.0.0.1:8443"};
  EXPECT_EQ(LeaseHolder::parse(owner.text()).web_address, "10.0.0.1:8443");
  {
    const auto lease = SessionLease::try_acquire(dir, owner);
    ASSERT_TRUE(lease.has_value());
    const auto held = SessionLease::live_holder(dir);
    ASSERT_TRUE(held.has_value());
    EXPECT_EQ(held->name, "host-a pid=1");
    EXPECT_EQ(held->address, "10.0.0.1:7880");
    EXPECT_EQ(held->web_address, "10.0.0.1:8443");
    EXPECT_EQ(SessionLease::owner_of(dir), "host-a pid=1");  // the line for people, as before
    // The probe took nothing: the lease is still its owner's alone.
    EXPECT_TRUE(lease->held());
    EXPECT_FALSE(SessionLease::try_acquire(dir, {"host-b pid=2"}).has_value());
  }
  EXPECT_FALSE(SessionLease::live_holder(dir).has_value()) << "a lease let go still names its owner";

  // A killed owner: at once; a stopped one: once its lease expired.
  pid_t child = lease_owner_process(dir, [](SessionLease&) {
    for (;;) pause();
  });
  ASSERT_GT(child, 0);
  EXPECT_TRUE(SessionLease::live_holder(dir).has_value());
  kill(child, SIGKILL);
  waitpid(child, nullptr, 0);
  EXPECT_FALSE(SessionLease::live_holder(dir).has_value());
  child = lease_owner_process(dir, [](SessionLease& lease) {
    while (lease.renew()) std::this_thread::sleep_for(100ms);
    _exit(3);
  });
  ASSERT_GT(child, 0);
  EXPECT_TRUE(SessionLease::live_holder(dir).has_value());
  kill(child, SIGSTOP);
  std::this_thread::sleep_for(SessionLease::kExpiry + 300ms);
  EXPECT_FALSE(SessionLease::live_holder(dir).has_value()) << "a stopped owner counted as live";
  kill(child, SIGKILL);
  waitpid(child, nullptr, 0);
}

TEST(SessionLease, HandOverRequestsComeAndGo) {
  const fs::path dir = fresh_dir("request") / "s";
  const auto lease = SessionLease::try_acquire(dir, {"owner"});
  ASSERT_TRUE(lease);
  EXPECT_FALSE(SessionLease::release_requested(dir));
  SessionLease::request_release(dir, "other pid=9");
  EXPECT_TRUE(SessionLease::release_requested(dir));
  SessionLease::clear_release_request(dir);
  EXPECT_FALSE(SessionLease::release_requested(dir));
  SessionLease::clear_release_request(dir);  // nothing to withdraw: no error
}

TEST(SessionLease, AFolderThatCannotHoldALeaseThrows) {
  const fs::path base = fresh_dir("bad");
  fs::create_directories(base);
  std::ofstream(base / "file") << "x";
  EXPECT_ANY_THROW(SessionLease::try_acquire(base / "file", {"me"}));  // not a folder
}

SessionCheckpoint small_checkpoint() {
  SessionCheckpoint c;
  c.id = "feed";
  c.device_id = "phone";
  c.camera = CameraIntrinsics::from_fov(64, 48, 60);
  c.map_size = 8;
  c.coverage = 0.375;
  c.accumulators.weight.assign(64, 1.0f);
  c.accumulators.weighted_radiance.assign(192, 0.5f);
  return c;
}

// A daemon that resumes a session continues its generations: were it to start at 1 again, its
// first checkpoint would overwrite accum-1.bin while the manifest still named the old one's
// checksum, and a crash in between would lose the session.
TEST(SessionCheckpoint, TheGenerationAndCoverageComeBack) {
  const fs::path dir = fresh_dir("generation");
  write_checkpoint(dir, small_checkpoint(), 7);
  const auto back = read_checkpoint(dir);
  ASSERT_TRUE(back);
  EXPECT_EQ(back->generation, 7);
  EXPECT_DOUBLE_EQ(back->coverage, 0.375);
  EXPECT_TRUE(fs::exists(dir / "accum-7.bin"));
  // A checkpoint from before the field: the generation is read from the file's name.
  nlohmann::json meta = nlohmann::json::parse(std::ifstream(dir / "session.json"));
  meta.erase("generation");
  meta.erase("coverage");
  std::ofstream(dir / "session.json") << meta.dump();
  const auto old = read_checkpoint(dir);
  ASSERT_TRUE(old);
  EXPECT_EQ(old->generation, 7);
  EXPECT_DOUBLE_EQ(old->coverage, 0.0);
}

// Issue 16 §2: sessions capture into a cube map now; a checkpoint written by a daemon from
// before (an angle map of map_size, no "layout" in its manifest) still resumes, converted.
TEST(SessionCheckpoint, AnAngleMapCheckpointFromBeforeResumesInTheCubeLayout) {
  SessionEnv env;
  env.data_dir = fresh_dir("old_layout");
  env.map_size = 128;
  const EnvLayout old_layout = EnvLayout::for_size(Projection::AngleMap, 128);
  // What such a daemon captured: grey frames looking ahead and to the side.
  const CameraIntrinsics camera = CameraIntrinsics::from_fov(160, 120, 60);
  capture::CaptureOptions o;
  o.layout = old_layout;
  o.align = false;
  capture::CaptureSession old(camera, CameraResponse::srgb(), o);
  for (double yaw : {0.0, 50.0})
    ASSERT_TRUE(
        old.add_image(cv::Mat(120, 160, CV_8UC3, cv::Scalar(90, 120, 150)),
                      {0.0, 0.01, 1.0, glm::angleAxis(glm::radians(yaw), glm::dvec3(0, 1, 0))})
            .used);
  SessionCheckpoint c;
  c.id = "0ld5e55101";
  c.device_id = "phone";
  c.camera = camera;
  c.map_size = 128;
  c.frames_received = c.frames_processed = 2;
  c.coverage = old.coverage();
  c.accumulators = old.accumulators();
  write_checkpoint(session_dir(env, c.id), c, 1);
  nlohmann::json meta =
      nlohmann::json::parse(std::ifstream(session_dir(env, c.id) / "session.json"));
  ASSERT_FALSE(meta.contains("layout"));
  auto lease = SessionLease::try_acquire(session_dir(env, c.id), {"test"});
  ASSERT_TRUE(lease);
  const auto s = Session::load(c.id, env, std::move(*lease));
  ASSERT_TRUE(s);
  const nlohmann::json summary = s->summary();
  // The same part of the sphere is seen (to within the texels along its edge).
  EXPECT_NEAR(summary["coverage"].get<double>(), c.coverage, 0.01 * c.coverage + 0.002);
  EXPECT_EQ(s->frames_processed(), 2u);
  // Its next checkpoint is in the cube layout and names it.
  s->checkpoint();
  const auto back = read_checkpoint(session_dir(env, c.id));
  ASSERT_TRUE(back);
  ASSERT_TRUE(back->layout);
  EXPECT_EQ(*back->layout, capture::capture_layout_for(128));
  EXPECT_EQ(back->layout->projection(), Projection::Cube);
  EXPECT_EQ(back->accumulators.weight.size(), back->layout->texel_count());
  s->shutdown();
}

// A manifest whose layout does not fit its accumulators is damaged: refused, naming it.
TEST(SessionCheckpoint, ALayoutThatDoesNotFitTheAccumulatorsIsRefused) {
  const fs::path dir = fresh_dir("bad_layout");
  SessionCheckpoint c = small_checkpoint();
  c.layout = EnvLayout::for_size(Projection::Cube, 8);  // 384 texels, the file has 64
  write_checkpoint(dir, c, 1);
  try {
    read_checkpoint(dir);
    FAIL() << "read a checkpoint whose layout does not fit";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("8x48"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace arlight::daemon
