#pragma once

#include <CLI/CLI.hpp>
#include <functional>
#include <string>

namespace arlight::maps {

// Each subcommand registers its options on `app` and returns the function that runs it
// (called after parsing; returns the process exit status).
using Runner = std::function<int()>;
Runner add_sh_command(CLI::App& app);
Runner add_compute_command(CLI::App& app);
Runner add_compare_command(CLI::App& app);
Runner add_diff_command(CLI::App& app);
Runner add_preview_command(CLI::App& app);
Runner add_ggx_command(CLI::App& app);
Runner add_export_command(CLI::App& app);

// --shininess, --size, --projection, shared by compute, compare and diff.
// --shininess, --size, --projection and --fill (what a map's unseen texels become: see
// load_working_map).
void add_map_options(CLI::App* sub, std::string* shininess, int* size, std::string* projection,
                     std::string* fill);

}  // namespace arlight::maps
