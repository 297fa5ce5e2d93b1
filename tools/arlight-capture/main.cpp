// arlight-capture: runs the capture library over a recorded sensor stream and writes the HDR
// environment map it builds, a coverage picture and a JSON report; or, with --calibrate,
// recovers the camera response from a bracketed recording.
#include <CLI/CLI.hpp>
#include <cstdio>

#include "arlight/common/error.hpp"
#include "arlight/protocol/recording.hpp"
#include "capture_run.hpp"

using namespace arlight;
using namespace arlight::capture_tool;

int main(int argc, char** argv) {
  CLI::App app{"arlight-capture: an HDR environment map from a recorded sensor stream"};
  CaptureFlags o;
  app.add_option("--recording", o.recording, "recording folder (protocol/RECORDING.md)")
      ->required();
  app.add_option("--out", o.out,
                 "environment map to write (EXR; a .png preview and "
                 "_coverage.png are written beside it)");
  app.add_option("--size", o.size, "map size: angle map NxN, lat-long 2NxN, cube N a face")
      ->default_val(512);
  app.add_option("--projection", o.projection, "anglemap | latlong | cube")
      ->default_val("anglemap");
  app.add_flag("--no-align", o.no_align, "use the sensor orientations as they are");
  app.add_option("--sh-order", o.sh_order, "live SH order (bands)")->default_val(8);
  app.add_flag("--align-async", o.align_async,
               "measure alignments on another thread, apply them at the next frame (as arlightd)");
  app.add_option("--align-width", o.align_width,
                 "largest width of the frame the alignment works on; default 320");
  app.add_option("--align-every", o.align_every,
                 "align every n-th frame (the others extrapolate the drift); default 1");
  app.add_option("--fill", o.fill,
                 "what the map holds where no frame looked: estimate (from the seen directions, "
                 "with a hemisphere prior), mean (of the seen texels) or none (black)")
      ->capture_default_str();
  app.add_option("--exposure", o.exposure,
                 "the frames' exposure x gain: known (as recorded), locked (withheld: every frame "
                 "at the first's, as arlightd takes a browser's) or estimate (withheld, each "
                 "frame's measured against the map)")
      ->capture_default_str();
  app.add_option("--until-coverage", o.until_coverage,
                 "stop once the map covers this fraction of the sphere (what a user has that "
                 "far into a sweep)");
  app.add_option("--passes", o.passes,
                 "replay the recording this many times into the one map (a phone that keeps "
                 "looking round the room; timestamps continue)")
      ->capture_default_str();
  app.add_option("--merge", o.merge,
                 "changes: frames that agree with the map are not merged and a changed room "
                 "replaces what was there (as arlightd); all: every frame into a plain "
                 "weighted mean")
      ->capture_default_str();
  app.add_option("--json", o.json, "write a JSON report here");
  app.add_option("--response", o.response,
                 "camera response: srgb | filmic | FILE (default: the device's curve from "
                 "--response-dir, else srgb)");
  app.add_option("--response-dir", o.response_dir, "folder of per-device response curves");
  app.add_option("--calibrate", o.calibrate,
                 "robertson | debevec: calibrate the camera response from a bracketed "
                 "recording (arlight-sim --bracket) instead of capturing");
  app.add_option("--response-out", o.response_out, "with --calibrate: write the curve here");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  try {
    const recording::Recording rec = recording::read_recording(o.recording);
    return o.calibrate.empty() ? run_capture(o, rec) : run_calibration(o, rec);
  } catch (const InputError& e) {
    std::fprintf(stderr, "arlight-capture: bad input: %s\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "arlight-capture: error: %s\n", e.what());
    return 1;
  }
}
