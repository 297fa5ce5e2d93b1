// Tests of the daemon's token files: the device tokens and the admin port's bearer token
// (parsing, refusals naming the file and line, creation with mode 0600, one token when several
// daemons on a shared data folder make it at once).
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "arlight/common/error.hpp"
#include "tokens.hpp"

namespace {

namespace fs = std::filesystem;
using arlight::InputError;
using arlight::daemon::load_admin_token;
using arlight::daemon::TokenStore;

fs::path fresh_dir(const std::string& name) {
  const fs::path d = fs::temp_directory_path() / ("arlight_test_tokens_" + name);
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

std::string error_of(const fs::path& path, bool create = false) {
  try {
    load_admin_token(path, create);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(DeviceTokens, ChecksOnlyTheRightDeviceAndToken) {
  const fs::path d = fresh_dir("devices");
  std::ofstream(d / "tokens") << "# devices\nphone-1 aaaaaaaa-1111\n\nwebcam bbbbbbbb-2222 # lab\n";
  const TokenStore s = TokenStore::load(d / "tokens");
  EXPECT_EQ(s.size(), 2u);
  EXPECT_TRUE(s.check("phone-1", "aaaaaaaa-1111"));
  EXPECT_FALSE(s.check("phone-1", "bbbbbbbb-2222"));
  EXPECT_FALSE(s.check("phone-1", "aaaaaaaa-111"));
  EXPECT_FALSE(s.check("nobody", "aaaaaaaa-1111"));
  std::ofstream(d / "twice") << "a 12345678\na 87654321\n";
  EXPECT_THROW(TokenStore::load(d / "twice"), InputError);
}

TEST(DeviceTokens, WatchTokensWatchButNeverCapture) {
  const fs::path d = fresh_dir("watch");
  std::ofstream(d / "tokens") << "a-viewer cccccccc-3333 watch\nphone-1 aaaaaaaa-1111\n";
  const TokenStore s = TokenStore::load(d / "tokens");
  EXPECT_EQ(s.access("a-viewer", "cccccccc-3333"), TokenStore::Access::WatchOnly);
  EXPECT_FALSE(s.check("a-viewer", "cccccccc-3333"));  // may not capture
  EXPECT_EQ(s.access("a-viewer", "aaaaaaaa-1111"), TokenStore::Access::None);
  EXPECT_EQ(s.access("phone-1", "aaaaaaaa-1111"), TokenStore::Access::Device);
  EXPECT_EQ(s.first_device(), "phone-1");  // the phone URL never carries a watch token
  std::ofstream(d / "only-watch") << "viewer 12345678 watch\n";
  EXPECT_THROW(TokenStore::load(d / "only-watch"), InputError);
  std::ofstream(d / "bad-role") << "phone 12345678 admin\n";
  EXPECT_THROW(TokenStore::load(d / "bad-role"), InputError);
}

TEST(AdminToken, ReadsTheFirstTokenLineOfAFile) {
  const fs::path d = fresh_dir("read");
  std::ofstream(d / "t") << "# comment\n\n  0123456789abcdef-token \r\nsecond-line-is-ignored\n";
  EXPECT_EQ(load_admin_token(d / "t", false), "0123456789abcdef-token");
}

TEST(AdminToken, BadFilesAreNamedWithWhatIsWrong) {
  const fs::path d = fresh_dir("bad");
  std::ofstream(d / "short") << "short-token\n";
  std::ofstream(d / "spaces") << "two words-of-a-long-token\n";
  std::ofstream(d / "empty") << "# only a comment\n";
  EXPECT_NE(error_of(d / "missing").find("'" + (d / "missing").string() + "': cannot read"),
            std::string::npos);
  EXPECT_NE(error_of(d / "short").find("line 1: token shorter than 16"), std::string::npos);
  EXPECT_NE(error_of(d / "spaces").find("one word"), std::string::npos);
  EXPECT_NE(error_of(d / "empty").find("no token"), std::string::npos);
  // A file that exists is never replaced, even when creating is allowed.
  EXPECT_NE(error_of(d / "short", true).find("shorter"), std::string::npos);
}

TEST(AdminToken, AMissingDefaultFileIsMadePrivateAndKept) {
  const fs::path d = fresh_dir("create");
  bool created = false;
  const std::string token = load_admin_token(d / "admin.token", true, &created);
  EXPECT_TRUE(created);
  EXPECT_EQ(token.size(), 64u);
  EXPECT_EQ(token.find_first_not_of("0123456789abcdef"), std::string::npos);
  EXPECT_EQ(fs::status(d / "admin.token").permissions() & fs::perms::all,
            fs::perms::owner_read | fs::perms::owner_write);
  EXPECT_EQ(load_admin_token(d / "admin.token", true, &created), token);  // read, not remade
  EXPECT_FALSE(created);
  EXPECT_NE(load_admin_token(fresh_dir("create2") / "admin.token", true), token);  // random
  EXPECT_EQ(std::distance(fs::directory_iterator(d), fs::directory_iterator()), 1);  // no temp
}

TEST(AdminToken, DaemonsMakingItAtOnceAllGetTheSameToken) {
  const fs::path d = fresh_dir("race");
  for (int round = 0; round < 20; ++round) {
    const fs::path file = d / ("admin-" + std::to_string(round) + ".token");
    std::vector<std::string> got(4);
    std::vector<std::thread> threads;
    for (std::size_t i = 0; i < got.size(); ++i)
      threads.emplace_back([&, i] { got[i] = load_admin_token(file, true); });
    for (auto& t : threads) t.join();
    EXPECT_EQ(std::set<std::string>(got.begin(), got.end()).size(), 1u) << "round " << round;
    EXPECT_EQ(load_admin_token(file, false), got[0]);
  }
}

}  // namespace
