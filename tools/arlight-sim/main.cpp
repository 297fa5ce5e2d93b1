// arlight-sim: simulates what a phone records while capturing an HDR environment, with ground
// truth (tools/README.md).
#include <tbb/global_control.h>

#include <CLI/CLI.hpp>
#include <charconv>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <exception>
#include <memory>
#include <optional>
#include <sstream>

#include "arlight/client_app.hpp"
#include "arlight/error.hpp"
#include "arlight/hdr_io.hpp"
#include "arlight/number_list.hpp"
#include "arlight/reference.hpp"
#include "arlight/sim/simulate.hpp"

namespace {

using arlight::ImageSize;
using arlight::InputError;
using arlight::parse_geo_location;
using arlight::parse_image_size;
using arlight::parse_utc_time;
namespace recording = arlight::recording;
using namespace arlight::sim;


// ID,SIZE_M[,X,Y,Z]
MarkerSpec parse_marker(const std::string& s) {
  const std::string what = "--marker '" + s + "': ";
  std::vector<double> v;
  std::stringstream in(s);
  std::string part;
  while (std::getline(in, part, ',')) {
    std::size_t used = 0;
    double x = 0;
    try {
      x = std::stod(part, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    while (used < part.size() && std::isspace(static_cast<unsigned char>(part[used]))) ++used;
    if (part.empty() || used != part.size() || !std::isfinite(x))
      throw InputError(what + "'" + part + "' is not a number (expected ID,SIZE_M[,X,Y,Z])");
    v.push_back(x);
  }
  if (!s.empty() && s.back() == ',') v.push_back(NAN);  // a trailing comma: an empty value
  if (v.size() != 2 && v.size() != 5)
    throw InputError(what +
                     "expected ID,SIZE_M or ID,SIZE_M,X,Y,Z, e.g. 3,0.2 or 3,0.2,0,-1.2,-0.8");
  if (v[0] != std::floor(v[0]) || v[0] < 0 || v[0] > 49)
    throw InputError(what + "the id must be a whole number 0..49 (DICT_4X4_50)");
  if (!(v[1] > 0) || v[1] > 100) throw InputError(what + "the size must be > 0 metres");
  MarkerSpec m;
  m.id = int(v[0]);
  m.size_m = v[1];
  if (v.size() == 5) {
    if (!std::isfinite(v[4])) throw InputError(what + "empty coordinate");
    m.centre = {v[2], v[3], v[4]};
  }
  return m;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "arlight-sim: renders what a phone records while capturing an HDR environment map "
      "(a recording, protocol/RECORDING.md), with the ground truth in REC/truth/"};
  SimOptions o;
  std::string env, out, size = "640x480", trajectory = "sweep", auto_exposure = "on", marker;
  std::string seed = "0";
  int threads = 0;
  app.add_option("--env", env, "the HDR environment map (probe), any projection")->required();
  app.add_option("--out", out, "the recording folder to write (new, empty or a recording)")
      ->required();
  app.add_option("--frames", o.frames, "number of frames")->capture_default_str();
  app.add_option("--fps", o.fps, "frames per second")->capture_default_str();
  app.add_option("--size", size, "image size WIDTHxHEIGHT")->capture_default_str();
  app.add_option("--fov", o.hfov_deg, "horizontal field of view, degrees")->capture_default_str();
  app.add_option("--trajectory", trajectory,
                 "sweep, poles-first (up and down first), top-down (ceiling first), orbit or "
                 "handheld")
      ->capture_default_str();
  app.add_option("--response", o.response, "camera response: srgb, filmic or a JSON file")
      ->capture_default_str();
  app.add_option("--auto-exposure", auto_exposure, "on or off")->capture_default_str();
  app.add_option("--hdr-stops", o.hdr_stops,
                 "every second frame this many stops darker (HDR capture mode); 0: off")
      ->capture_default_str();
  app.add_option("--gyro-drift", o.gyro_drift_deg_per_s, "heading drift, degrees per second")
      ->capture_default_str();
  app.add_option("--noise", o.noise, "read noise sigma (linear, full scale = 1); 0: no noise")
      ->capture_default_str();
  app.add_option("--vignetting", o.vignetting, "vignetting V in 1 - V r^2")->capture_default_str();
  app.add_option("--jpeg-quality", o.jpeg_quality, "JPEG quality 1..100")->capture_default_str();
  app.add_option("--marker", marker, "ArUco marker ID,SIZE_M[,X,Y,Z] on the floor");
  app.add_option("--seed", seed, "random seed, 0..2^64-1")->capture_default_str();
  app.add_option("--bracket", o.bracket, "N frames of one view, one stop apart");
  std::string y4m;
  app.add_option("--y4m", y4m,
                 "also write the frames as a YUV4MPEG2 video for Chromium's fake camera "
                 "(exposure fixed at the first view's, as a browser locks it)");
  app.add_option("--threads", threads, "worker threads (0: all cores)")->capture_default_str();
  std::string location, time_text;
  std::optional<double> north_offset;
  app.add_option("--location", location,
                 "LAT,LON[,ALT]: where the phone is (degrees, degrees, metres), written to the "
                 "recording with --time so clients tell arlightd (the sun)");
  app.add_option("--time", time_text, "UTC time of the first frame, YYYY-MM-DDTHH:MM[:SS]Z");
  app.add_option("--north-offset", north_offset,
                 "the world's -Z is north, this many degrees east of true north (default: the "
                 "heading is arbitrary)");
  std::string object, object_material = "0.8,0.2,80";
  double object_height = 0;
  int reference_every = 1;
  app.add_option("--object", object,
                 "also render references (REC/truth/reference/): this virtual object (sphere or a "
                 "glTF file, as arlight-client's --model) standing on the marker, ray traced "
                 "under the true room, with its shadow (needs --marker)");
  app.add_option("--object-material", object_material, "its material kd,ks,shininess")
      ->capture_default_str();
  app.add_option("--object-height", object_height, "its height, metres (0: 1.5 x the marker)")
      ->capture_default_str();
  app.add_option("--reference-every", reference_every,
                 "a reference for every N-th frame with the marker in view")
      ->capture_default_str();
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

  try {
    o.env = env;
    o.out = out;
    o.y4m = y4m;
    if (!y4m.empty() && (o.hdr_stops > 0 || o.bracket > 0))
      throw InputError("--y4m: a browser's camera has one locked exposure (no --hdr-stops, "
                       "--bracket)");
    const ImageSize image = parse_image_size(size, "--size");
    o.width = image.width, o.height = image.height;
    if (o.frames < 1 || o.frames > 1000000) throw InputError("--frames: must be 1..1000000");
    if (!(o.fps > 0) || o.fps > 10000) throw InputError("--fps: must be > 0 (and <= 10000)");
    if (!(o.hfov_deg > 1 && o.hfov_deg < 179))
      throw InputError("--fov: must be in (1, 179) degrees");
    o.trajectory = trajectory_from_name(trajectory);
    if (auto_exposure != "on" && auto_exposure != "off")
      throw InputError("--auto-exposure '" + auto_exposure + "': use on or off");
    o.auto_exposure = auto_exposure == "on";
    if (!(o.hdr_stops >= 0 && o.hdr_stops <= 10))
      throw InputError("--hdr-stops must be in [0, 10]");
    if (!(o.gyro_drift_deg_per_s >= 0) || o.gyro_drift_deg_per_s > 100)
      throw InputError("--gyro-drift: must be 0..100 degrees per second");
    if (!(o.noise >= 0) || o.noise > 1) throw InputError("--noise: must be 0..1");
    if (!(o.vignetting >= 0) || o.vignetting >= 1)
      throw InputError("--vignetting: must be in [0, 1)");
    if (o.jpeg_quality < 1 || o.jpeg_quality > 100)
      throw InputError("--jpeg-quality: must be 1..100");
    if (o.bracket < 0 || o.bracket > 64) throw InputError("--bracket: must be 1..64 frames");
    if (threads < 0) throw InputError("--threads: must be >= 0");
    if (!marker.empty() || app.count("--marker")) o.marker = parse_marker(marker);
    if (!location.empty()) {
      if (time_text.empty()) throw InputError("--location needs --time (the first frame's UTC)");
      recording::RecordedPlace p;
      p.where = parse_geo_location(location, "--location");
      p.utc_seconds = parse_utc_time(time_text, "--time");
      if (north_offset && !(std::abs(*north_offset) <= 180.0))
        throw InputError("--north-offset: must be in [-180, 180] degrees");
      p.north_offset_deg = north_offset;
      o.place = p;
    } else if (!time_text.empty() || north_offset) {
      throw InputError("--time and --north-offset need --location");
    }
    std::optional<arlight::reference::ReferenceObject> reference_object;
    if (!object.empty()) {
      if (!o.marker) throw InputError("--object stands on the marker: give --marker too");
      if (reference_every < 1) throw InputError("--reference-every: must be >= 1");
      if (object_height < 0 || object_height > 100)
        throw InputError("--object-height: must be 0..100 metres");
      reference_object.emplace();
      reference_object->model = object;
      reference_object->mesh = arlight::client_app::load_model(object);
      reference_object->material = arlight::client_app::parse_material(object_material);
      reference_object->height_m = object_height > 0 ? object_height : 1.5 * o.marker->size_m;
    }
    const auto [end, ec] = std::from_chars(seed.data(), seed.data() + seed.size(), o.seed);
    if (ec != std::errc() || end != seed.data() + seed.size())
      throw InputError("--seed '" + seed + "': expected a whole number 0..18446744073709551615");

    std::unique_ptr<tbb::global_control> limit;
    if (threads > 0)
      limit = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism,
                                                    std::size_t(threads));
    const auto start = std::chrono::steady_clock::now();
    const int frames = simulate(o);
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    std::printf("arlight-sim: wrote %d frames (%dx%d) to %s in %.1f s; ground truth in %s\n",
                frames, o.width, o.height, o.out.string().c_str(), seconds,
                (o.out / "truth").string().c_str());
    if (reference_object) {
      const auto traced = std::chrono::steady_clock::now();
      const auto frames_done = arlight::reference::write_references(
          o.out, *reference_object, arlight::load_envmap(o.env).env, {}, reference_every);
      std::printf("arlight-sim: %zu reference views of the %s in %s in %.1f s\n",
                  frames_done.size(), object.c_str(),
                  (o.out / "truth" / arlight::reference::kReferenceFolder).string().c_str(),
                  std::chrono::duration<double>(std::chrono::steady_clock::now() - traced).count());
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
