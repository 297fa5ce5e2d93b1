// arlightd's options table (server/daemon/src/options.cpp): the config file and the command
// line set the same DaemonConfig through it, flags override the file, and bad values name their
// flag or key.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>

#include "arlight/common/error.hpp"
#include "options.hpp"
#include "support/run_tool.hpp"

using namespace arlight;
using namespace arlight::daemon;
namespace fs = std::filesystem;

namespace {

// The config a command line gives, as arlightd parses it.
DaemonConfig parse(std::vector<std::string> args) {
  CLI::App app;
  CommandLine line(app);
  args.insert(args.begin(), "arlightd");
  std::vector<const char*> argv;
  for (const std::string& a : args) argv.push_back(a.c_str());
  app.parse(int(argv.size()), const_cast<char**>(argv.data()));
  return line.config();
}

std::string error_of(const std::vector<std::string>& args) {
  try {
    parse(args);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST(DaemonOptions, EveryOptionHasAFlagOrAKeyAndNoneIsNamedTwice) {
  std::set<std::string_view> flags, keys;
  for (const DaemonOption& o : daemon_options()) {
    EXPECT_FALSE(o.flag.empty() && o.key.empty());
    EXPECT_FALSE(o.help.empty()) << o.flag << o.key;
    if (!o.flag.empty()) {
      EXPECT_TRUE(flags.insert(o.flag).second) << o.flag;
    }
    if (!o.key.empty()) {
      EXPECT_TRUE(keys.insert(o.key).second) << o.key;
    }
  }
  // The example config's keys are all options.
  std::ifstream in(fs::path(ARLIGHT_SOURCE_DIR) / "deploy" / "arlightd.example.json");
  const nlohmann::json example = nlohmann::json::parse(in);
  for (const auto& [key, value] : example.items()) EXPECT_TRUE(keys.count(key)) << key;
}

TEST(DaemonOptions, FlagsOverrideTheConfigFileAndTheRestOfTheFileStands) {
  const fs::path dir = test::fresh_temp_dir("options_override");
  std::ofstream(dir / "c.json") << R"({"tokens": "/etc/t", "queue_depth": 5, "workers": 3,
      "checkpoint_interval_s": 0.25, "map_size": 256, "fill": "mean", "admin": ""})";
  const DaemonConfig file_only = parse({"--config", (dir / "c.json").string()});
  EXPECT_EQ(file_only.queue_depth, 5);
  EXPECT_EQ(file_only.workers, 3);
  EXPECT_DOUBLE_EQ(file_only.checkpoint_interval_s, 0.25);
  EXPECT_EQ(file_only.map_size, 256);
  EXPECT_EQ(file_only.fill, capture::Fill::Mean);
  EXPECT_FALSE(file_only.admin_enabled);
  EXPECT_EQ(file_only.tokens_file, "/etc/t");

  const DaemonConfig c =
      parse({"--config", (dir / "c.json").string(), "--queue-depth", "2", "--checkpoint-interval",
             "1.5", "--fill", "none", "--admin", "127.0.0.1:9000", "--listen", "0.0.0.0:7000",
             "--admin-protect-all", "--web", "0.0.0.0:8443"});
  EXPECT_EQ(c.queue_depth, 2);
  EXPECT_EQ(c.workers, 3);                         // not given: the file's
  EXPECT_DOUBLE_EQ(c.checkpoint_interval_s, 1.5);  // the flag (once lost under a file)
  EXPECT_EQ(c.fill, capture::Fill::None);
  EXPECT_TRUE(c.admin_enabled);
  EXPECT_EQ(c.admin_port, 9000);
  EXPECT_EQ(c.listen_host, "0.0.0.0");
  EXPECT_EQ(c.listen_port, 7000);
  EXPECT_TRUE(c.admin_protect_all);
  EXPECT_TRUE(c.web_enabled);
  EXPECT_EQ(c.web_port, 8443);
  // --admin '' turns the admin port off; another text flag given as '' changes nothing.
  const DaemonConfig off = parse({"--tokens", "t", "--admin", "", "--data-dir", ""});
  EXPECT_FALSE(off.admin_enabled);
  EXPECT_EQ(off.data_dir, DaemonConfig().data_dir);
}

TEST(DaemonOptions, BadValuesNameTheirFlagOrKey) {
  EXPECT_NE(error_of({"--tokens", "t", "--threads", "two"}).find("--threads: 'two' is not a whole"),
            std::string::npos);
  EXPECT_NE(error_of({"--tokens", "t", "--idle-timeout", "5s"}).find("--idle-timeout: '5s'"),
            std::string::npos);
  EXPECT_NE(error_of({"--tokens", "t", "--fill", "paint"}).find("--fill: expected none, mean"),
            std::string::npos);
  EXPECT_NE(
      error_of({"--tokens", "t", "--listen", "7878"}).find("--listen: '7878': expected HOST:PORT"),
      std::string::npos);
  EXPECT_NE(error_of({}).find("--tokens FILE is required"), std::string::npos);
  EXPECT_NE(error_of({"--tokens", "t", "--queue-depth", "0"}).find("queue depth 0"),
            std::string::npos);
  EXPECT_NE(error_of({"--tokens", "t", "--max-connections", "0"}).find("connection limits"),
            std::string::npos);
  const fs::path dir = test::fresh_temp_dir("options_bad");
  std::ofstream(dir / "c.json") << R"({"tokens": "t", "threads": "many"})";
  const std::string e = error_of({"--config", (dir / "c.json").string()});
  EXPECT_NE(e.find("c.json': threads: "), std::string::npos) << e;
  std::ofstream(dir / "d.json") << R"({"tokens": "t", "colour": "red"})";
  EXPECT_NE(error_of({"--config", (dir / "d.json").string()}).find("colour: unknown key"),
            std::string::npos);
}

// Where clients reach the daemon (issue 49 §2): auto by default, a HOST:PORT clients can use,
// or none.
TEST(DaemonOptions, AdvertisedAddressesAreAutoAReachableHostPortOrNone) {
  const DaemonConfig d = parse({"--tokens", "/etc/t"});
  EXPECT_EQ(d.advertise, "auto");
  EXPECT_EQ(d.advertise_web, "auto");
  const DaemonConfig c = parse(
      {"--tokens", "/etc/t", "--advertise", "10.0.0.2:7880", "--advertise-web", ""});
  EXPECT_EQ(c.advertise, "10.0.0.2:7880");
  EXPECT_EQ(c.advertise_web, "");
  EXPECT_NE(error_of({"--tokens", "/etc/t", "--advertise", "10.0.0.2"}).find("--advertise"),
            std::string::npos);
  EXPECT_NE(error_of({"--tokens", "/etc/t", "--advertise-web", "h:0"}).find("port 0"),
            std::string::npos);
}
