// arlight-sim: simulates what a phone records while capturing an HDR environment, with ground
// truth (tools/README.md).
#include <tbb/global_control.h>

#include <CLI/CLI.hpp>
#include <chrono>
#include <cstdio>
#include <exception>
#include <memory>

#include "arlight/common/error.hpp"
#include "arlight/common/hdr_io.hpp"
#include "arlight/reference/reference.hpp"
#include "arlight/sim/simulate.hpp"
#include "sim_flags.hpp"

using namespace arlight;
using Clock = std::chrono::steady_clock;

int main(int argc, char** argv) {
  CLI::App app{
      "arlight-sim: renders what a phone records while capturing an HDR environment map "
      "(a recording, protocol/RECORDING.md), with the ground truth in REC/truth/"};
  sim::SimOptions o;
  sim_tool::SimFlags f;
  sim_tool::add_sim_flags(app, o, f);
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    std::fprintf(stderr, "arlight-sim: bad arguments: %s\n", e.what());
    return 2;
  }
  f.marker_given = app.count("--marker") > 0;

  try {
    const std::optional<reference::ReferenceObject> object = sim_tool::finish_sim_options(f, o);
    std::unique_ptr<tbb::global_control> limit;
    if (f.threads > 0)
      limit = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism,
                                                    std::size_t(f.threads));
    const auto start = Clock::now();
    if (f.guided) {
      o.path = sim_tool::guided_path(o);
      std::printf("arlight-sim: the guided path (%zu views, following arlightd's proposals) in "
                  "%.1f s\n",
                  o.path.size(), std::chrono::duration<double>(Clock::now() - start).count());
    }
    const int frames = sim::simulate(o);
    const double seconds = std::chrono::duration<double>(Clock::now() - start).count();
    std::printf("arlight-sim: wrote %d frames (%dx%d) to %s in %.1f s; ground truth in %s\n",
                frames, o.width, o.height, o.out.string().c_str(), seconds,
                (o.out / "truth").string().c_str());
    if (object) {
      const auto traced = Clock::now();
      const auto frames_done = reference::write_references(o.out, *object, load_envmap(o.env).env,
                                                           {}, f.reference_every);
      std::printf("arlight-sim: %zu reference views of the %s in %s in %.1f s\n",
                  frames_done.size(), f.object.c_str(),
                  (o.out / "truth" / reference::kReferenceFolder).string().c_str(),
                  std::chrono::duration<double>(Clock::now() - traced).count());
    }
    return 0;
  } catch (const InputError& e) {
    std::fprintf(stderr, "arlight-sim: bad input: %s\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "arlight-sim: error: %s\n", e.what());
    return 1;
  }
}
