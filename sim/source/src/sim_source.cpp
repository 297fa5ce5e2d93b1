// SimSource: the client's sim:PROBE source, a shell over arlight_sim's LiveCamera, and its
// registration into open_source.
#include <chrono>
#include <thread>

#include "arlight/sim/live_camera.hpp"
#include "arlight/sim_source/sim_source.hpp"

namespace arlight::source {

struct SimSource::Impl {
  std::filesystem::path probe;
  SourceOptions options;
  sim::LiveCamera camera;
  std::optional<std::chrono::steady_clock::time_point> start;

  static sim::LiveCameraOptions camera_options(const SourceOptions& o) {
    sim::LiveCameraOptions c;
    c.width = o.width, c.height = o.height, c.fps = o.fps, c.frames = o.frames;
    if (o.guided) c.guided = sim::GuidedMotionParams{};
    return c;
  }
  Impl(const std::filesystem::path& p, const SourceOptions& o)
      : probe(p), options(o), camera(p, camera_options(o)) {}
};

SimSource::SimSource(const std::filesystem::path& probe, const SourceOptions& options)
    : impl_(std::make_unique<Impl>(probe, options)) {}
SimSource::~SimSource() = default;

std::optional<SourceFrame> SimSource::next() {
  Impl& m = *impl_;
  std::optional<sim::LiveFrame> f = m.camera.next();
  if (!f) return std::nullopt;
  if (m.options.realtime) {  // deliver at the frame's time, like a camera
    const auto now = std::chrono::steady_clock::now();
    if (!m.start) m.start = now;
    std::this_thread::sleep_until(*m.start + std::chrono::duration_cast<std::chrono::nanoseconds>(
                                                 std::chrono::duration<double>(f->time)));
  }
  SourceFrame out;
  out.bgr = std::move(f->bgr);
  out.jpeg = std::move(f->jpeg);
  out.timestamp = f->time;
  out.exposure = f->exposure, out.gain = f->gain;
  out.orientation = f->orientation;
  out.index = f->index;
  out.exposure_requested = f->requested;
  return out;
}

CameraIntrinsics SimSource::intrinsics() const { return impl_->camera.intrinsics(); }
std::string SimSource::device_id() const { return "arlight-sim"; }

std::string SimSource::describe() const {
  const sim::LiveCameraOptions& o = impl_->camera.options();
  return "sim:" + impl_->probe.string() + (o.guided ? " (a guided capture of " : " (a sweep of ") +
         std::to_string(o.frames) +
         " frames, " + std::to_string(o.width) + "x" + std::to_string(o.height) + " at " +
         std::to_string(int(o.fps)) + " fps" + (impl_->options.realtime ? ", real time)" : ")");
}

bool SimSource::request_exposure(double exposure_gain) {
  impl_->camera.request_exposure(exposure_gain);
  return true;
}

bool SimSource::propose_view(const glm::dvec3& direction) {
  if (!impl_->options.guided) return false;
  impl_->camera.propose_view(direction);
  return true;
}

void register_sim_source() {
  register_source_scheme(
      "sim",
      [](const std::string& probe, const SourceOptions& options) -> std::unique_ptr<FrameSource> {
        return std::make_unique<SimSource>(probe, options);
      },
      "sim:PROBE.exr (a simulated phone in that room)");
}

}  // namespace arlight::source
