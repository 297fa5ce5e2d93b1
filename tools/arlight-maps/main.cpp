// arlight-maps: environment-map lighting from the command line.
#include <CLI/CLI.hpp>
#include <cstdio>
#include <exception>
#include <functional>

#include "arlight/common/error.hpp"
#include "commands.hpp"

int main(int argc, char** argv) {
  CLI::App app{
      "arlight-maps: spherical harmonics, irradiance and reflection maps of HDR "
      "environment maps"};
  app.require_subcommand(1);
  std::function<int()> run;
  const std::pair<const char*, arlight::maps::Runner> commands[] = {
      {"compute", arlight::maps::add_compute_command(app)},
      {"compare", arlight::maps::add_compare_command(app)},
      {"diff", arlight::maps::add_diff_command(app)},
      {"sh", arlight::maps::add_sh_command(app)},
      {"preview", arlight::maps::add_preview_command(app)},
      {"ggx", arlight::maps::add_ggx_command(app)},
      {"export", arlight::maps::add_export_command(app)},
  };
  for (const auto& [name, runner] : commands)
    app.get_subcommand(name)->callback([&run, r = runner] { run = r; });
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  try {
    return run();
  } catch (const arlight::InputError& e) {
    std::fprintf(stderr, "arlight-maps: bad input: %s\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "arlight-maps: error: %s\n", e.what());
    return 1;
  }
}
