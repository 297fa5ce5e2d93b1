#include "sim_flags.hpp"

#include <charconv>
#include <cmath>
#include <exception>
#include <sstream>
#include <vector>

#include "arlight/app/client_app.hpp"
#include "arlight/common/error.hpp"
#include "arlight/common/geo.hpp"
#include "arlight/common/number_list.hpp"
#include "arlight/guided/guided_capture.hpp"

namespace arlight::sim_tool {

using sim::MarkerSpec;

namespace {

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

void add_sim_flags(CLI::App& app, sim::SimOptions& o, SimFlags& f) {
  app.add_option("--env", f.env, "the HDR environment map (probe), any projection")->required();
  app.add_option("--out", f.out, "the recording folder to write (new, empty or a recording)")
      ->required();
  app.add_option("--frames", o.frames, "number of frames")->capture_default_str();
  app.add_option("--fps", o.fps, "frames per second")->capture_default_str();
  app.add_option("--size", f.size, "image size WIDTHxHEIGHT")->capture_default_str();
  app.add_option("--fov", o.hfov_deg, "horizontal field of view, degrees")->capture_default_str();
  app.add_option("--trajectory", f.trajectory,
                 "sweep, poles-first (up and down first), top-down (ceiling first), orbit or "
                 "handheld")
      ->capture_default_str();
  app.add_flag("--guided", f.guided,
               "instead of --trajectory, a user who turns to the views arlightd's capture asks "
               "for (run in process; 90 deg/s at most, 0.3 s to react, a hand's tremor)");
  app.add_option("--response", o.response, "camera response: srgb, filmic or a JSON file")
      ->capture_default_str();
  app.add_option("--auto-exposure", f.auto_exposure, "on or off")->capture_default_str();
  app.add_option("--hdr-stops", o.hdr_stops,
                 "every second frame this many stops darker (HDR capture mode); 0: off")
      ->capture_default_str();
  app.add_option("--gyro-drift", o.gyro_drift_deg_per_s, "heading drift, degrees per second")
      ->capture_default_str();
  app.add_option("--noise", o.noise, "read noise sigma (linear, full scale = 1); 0: no noise")
      ->capture_default_str();
  app.add_option("--vignetting", o.vignetting, "vignetting V in 1 - V r^2")->capture_default_str();
  app.add_option("--jpeg-quality", o.jpeg_quality, "JPEG quality 1..100")->capture_default_str();
  app.add_option("--marker", f.marker, "ArUco marker ID,SIZE_M[,X,Y,Z] on the floor");
  app.add_option("--seed", f.seed, "random seed, 0..2^64-1")->capture_default_str();
  app.add_option("--bracket", o.bracket, "N frames of one view, one stop apart");
  app.add_option("--y4m", f.y4m,
                 "also write the frames as a YUV4MPEG2 video for Chromium's fake camera "
                 "(exposure fixed at the first view's, as a browser locks it)");
  app.add_option("--threads", f.threads, "worker threads (0: all cores)")->capture_default_str();
  app.add_option("--location", f.location,
                 "LAT,LON[,ALT]: where the phone is (degrees, degrees, metres), written to the "
                 "recording with --time so clients tell arlightd (the sun)");
  app.add_option("--time", f.time_text, "UTC time of the first frame, YYYY-MM-DDTHH:MM[:SS]Z");
  app.add_option("--north-offset", f.north_offset,
                 "the world's -Z is north, this many degrees east of true north (default: the "
                 "heading is arbitrary)");
  app.add_option("--object", f.object,
                 "also render references (REC/truth/reference/): this virtual object (sphere or a "
                 "glTF file, as arlight-client's --model) standing on the marker, ray traced "
                 "under the true room, with its shadow (needs --marker)");
  app.add_option("--object-material", f.object_material, "its material kd,ks,shininess")
      ->capture_default_str();
  app.add_option("--object-height", f.object_height, "its height, metres (0: 1.5 x the marker)")
      ->capture_default_str();
  app.add_option("--reference-every", f.reference_every,
                 "a reference for every N-th frame with the marker in view")
      ->capture_default_str();
}

std::optional<reference::ReferenceObject> finish_sim_options(const SimFlags& f,
                                                             sim::SimOptions& o) {
  o.env = f.env;
  o.out = f.out;
  o.y4m = f.y4m;
  if (!f.y4m.empty() && (o.hdr_stops > 0 || o.bracket > 0))
    throw InputError(
        "--y4m: a browser's camera has one locked exposure (no --hdr-stops, "
        "--bracket)");
  const ImageSize image = parse_image_size(f.size, "--size");
  o.width = image.width, o.height = image.height;
  if (o.frames < 1 || o.frames > 1000000) throw InputError("--frames: must be 1..1000000");
  if (!(o.fps > 0) || o.fps > 10000) throw InputError("--fps: must be > 0 (and <= 10000)");
  if (!(o.hfov_deg > 1 && o.hfov_deg < 179)) throw InputError("--fov: must be in (1, 179) degrees");
  o.trajectory = sim::trajectory_from_name(f.trajectory);
  if (f.auto_exposure != "on" && f.auto_exposure != "off")
    throw InputError("--auto-exposure '" + f.auto_exposure + "': use on or off");
  o.auto_exposure = f.auto_exposure == "on";
  if (!(o.hdr_stops >= 0 && o.hdr_stops <= 10)) throw InputError("--hdr-stops must be in [0, 10]");
  if (!(o.gyro_drift_deg_per_s >= 0) || o.gyro_drift_deg_per_s > 100)
    throw InputError("--gyro-drift: must be 0..100 degrees per second");
  if (!(o.noise >= 0) || o.noise > 1) throw InputError("--noise: must be 0..1");
  if (!(o.vignetting >= 0) || o.vignetting >= 1)
    throw InputError("--vignetting: must be in [0, 1)");
  if (o.jpeg_quality < 1 || o.jpeg_quality > 100)
    throw InputError("--jpeg-quality: must be 1..100");
  if (o.bracket < 0 || o.bracket > 64) throw InputError("--bracket: must be 1..64 frames");
  if (f.threads < 0) throw InputError("--threads: must be >= 0");
  if (!f.marker.empty() || f.marker_given) o.marker = parse_marker(f.marker);
  if (!f.location.empty()) {
    if (f.time_text.empty()) throw InputError("--location needs --time (the first frame's UTC)");
    recording::RecordedPlace p;
    p.where = parse_geo_location(f.location, "--location");
    p.utc_seconds = parse_utc_time(f.time_text, "--time");
    if (f.north_offset && !(std::abs(*f.north_offset) <= 180.0))
      throw InputError("--north-offset: must be in [-180, 180] degrees");
    p.north_offset_deg = f.north_offset;
    o.place = p;
  } else if (!f.time_text.empty() || f.north_offset) {
    throw InputError("--time and --north-offset need --location");
  }
  std::optional<reference::ReferenceObject> reference_object;
  if (!f.object.empty()) {
    if (!o.marker) throw InputError("--object stands on the marker: give --marker too");
    if (f.reference_every < 1) throw InputError("--reference-every: must be >= 1");
    if (f.object_height < 0 || f.object_height > 100)
      throw InputError("--object-height: must be 0..100 metres");
    reference_object.emplace();
    reference_object->model = f.object;
    reference_object->mesh = client_app::load_model(f.object);
    reference_object->material = client_app::parse_material(f.object_material);
    reference_object->height_m = f.object_height > 0 ? f.object_height : 1.5 * o.marker->size_m;
  }
  const auto [end, ec] = std::from_chars(f.seed.data(), f.seed.data() + f.seed.size(), o.seed);
  if (ec != std::errc() || end != f.seed.data() + f.seed.size())
    throw InputError("--seed '" + f.seed + "': expected a whole number 0..18446744073709551615");
  return reference_object;
}

std::vector<recording::Pose> guided_path(const sim::SimOptions& o) {
  if (o.bracket > 0 || o.marker) throw InputError("--guided: not with --bracket or --marker");
  guided::GuidedCaptureOptions g;
  g.camera.width = o.width, g.camera.height = o.height, g.camera.hfov_deg = o.hfov_deg;
  g.camera.fps = o.fps, g.camera.frames = o.frames;
  g.camera.response = o.response, g.camera.noise = o.noise, g.camera.vignetting = o.vignetting;
  g.camera.jpeg_quality = o.jpeg_quality, g.camera.seed = o.seed;
  g.camera.guided = sim::GuidedMotionParams{};
  g.capture.layout = capture::capture_layout_for(512);  // arlightd's default --size
  guided::GuidedCapture capture(o.env, g);
  std::vector<recording::Pose> path;
  while (const auto step = capture.step()) path.push_back({.orientation = step->frame.orientation});
  return path;
}

}  // namespace arlight::sim_tool
