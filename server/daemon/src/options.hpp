// Internal: arlightd's options in one table. Each names its flag, its key in the JSON config file
// (either may be missing), its help text and how its value sets the DaemonConfig; the command
// line, the config file, their error messages and --help all come from it, so an option is added
// in one place.
#pragma once

#include <CLI/CLI.hpp>
#include <memory>
#include <nlohmann/json.hpp>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "arlight/daemon/daemon.hpp"

namespace arlight::daemon {

struct DaemonOption {
  enum class Value { Text, Integer, Number, Switch };
  std::string_view flag;  // "--listen"; empty: only in the config file
  std::string_view key;   // "listen"; empty: only on the command line
  Value value;
  std::string_view help;
  // Sets the option from its value (a flag's text is converted to `value`'s JSON type first);
  // throws InputError or nlohmann::json::exception for a bad one.
  void (*set)(DaemonConfig& config, const nlohmann::json& value);
};

std::span<const DaemonOption> daemon_options();

// arlightd's command line: --config FILE and every option with a flag, added to `app`.
class CommandLine {
 public:
  explicit CommandLine(CLI::App& app);
  // After app.parse(): the config file's keys, then the flags given over them, checked
  // (check_config). InputError names the flag, or the file and key, that was wrong.
  DaemonConfig config() const;

 private:
  CLI::App& app_;
  std::string config_file_;
  std::vector<std::string> texts_;    // per option: the flag's text
  std::unique_ptr<bool[]> switches_;  // per option: a Switch flag given
};

}  // namespace arlight::daemon
