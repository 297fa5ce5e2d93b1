// Session leases (server/daemon/src/session_lease.*): one owner at a time, the kernel lets go
// when the owner dies, hand-over requests; and the checkpoint generation a taking-over daemon
// continues from.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <fstream>
#include <nlohmann/json.hpp>
#include <thread>

#include "checkpoint.hpp"
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
  auto first = SessionLease::try_acquire(dir, "host-a pid=1");
  ASSERT_TRUE(first.has_value());
  EXPECT_EQ(SessionLease::owner_of(dir), "host-a pid=1");
  // flock is per open file: even this process cannot take it twice.
  EXPECT_FALSE(SessionLease::try_acquire(dir, "host-b pid=2").has_value());
  EXPECT_EQ(SessionLease::owner_of(dir), "host-a pid=1") << "a refused taker wrote the owner";
  SessionLease moved = std::move(*first);
  first.reset();  // the moved-from lease holds nothing
  EXPECT_FALSE(SessionLease::try_acquire(dir, "host-b pid=2").has_value());
  { SessionLease gone = std::move(moved); }
  const auto second = SessionLease::try_acquire(dir, "host-b pid=2");
  ASSERT_TRUE(second.has_value());
  EXPECT_EQ(SessionLease::owner_of(dir), "host-b pid=2");
}

// The fail-over case: the owner is killed with SIGKILL; its lease is free at once.
TEST(SessionLease, TheKernelLetsGoWhenTheOwnerIsKilled) {
  const fs::path dir = fresh_dir("killed") / "s";
  int ready[2];
  ASSERT_EQ(pipe(ready), 0);
  const pid_t child = fork();
  if (child == 0) {
    auto lease = SessionLease::try_acquire(dir, "child");
    const char ok = lease ? '1' : '0';
    [[maybe_unused]] const ssize_t n = write(ready[1], &ok, 1);
    for (;;) pause();
  }
  char ok = 0;
  ASSERT_EQ(read(ready[0], &ok, 1), 1);
  ASSERT_EQ(ok, '1');
  EXPECT_FALSE(SessionLease::try_acquire(dir, "parent").has_value());
  kill(child, SIGKILL);
  waitpid(child, nullptr, 0);
  EXPECT_TRUE(SessionLease::try_acquire(dir, "parent").has_value());
  close(ready[0]), close(ready[1]);
}

TEST(SessionLease, HandOverRequestsComeAndGo) {
  const fs::path dir = fresh_dir("request") / "s";
  const auto lease = SessionLease::try_acquire(dir, "owner");
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
  EXPECT_ANY_THROW(SessionLease::try_acquire(base / "file", "me"));  // not a folder
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

}  // namespace
}  // namespace arlight::daemon
