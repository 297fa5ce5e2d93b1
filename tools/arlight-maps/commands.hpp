#pragma once

#include <CLI/CLI.hpp>
#include <functional>

namespace arlight::maps {

// Each subcommand registers its options on `app` and returns the function that runs it
// (called after parsing; returns the process exit status).
using Runner = std::function<int()>;
Runner add_sh_command(CLI::App& app);

}  // namespace arlight::maps
