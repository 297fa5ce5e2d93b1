#include "arlight/sim/live_camera.hpp"

#include <tbb/parallel_for.h>

#include <cmath>
#include <opencv2/imgcodecs.hpp>

#include "arlight/common/error.hpp"
#include "arlight/common/hdr_io.hpp"
#include "arlight/common/resample.hpp"
#include "arlight/common/response.hpp"
#include "imaging.hpp"

namespace arlight::sim {

struct LiveCamera::Impl {
  LiveCameraOptions options;
  CameraIntrinsics intrinsics;
  PinholeCamera camera;
  EnvSampler sampler;
  Trajectory trajectory;
  std::optional<GuidedMotion> guided;
  Sensor sensor;
  std::vector<glm::dvec3> pixel_dir;  // camera-space ray of every pixel
  std::size_t next_index = 0;
  double log_auto = 0.0;  // the auto-exposure's state: log(exposure x gain)
  double requested = 0.0;

  Impl(const LiveCameraOptions& o, const EnvMap& probe, const CameraResponse& response)
      : options(o),
        intrinsics(CameraIntrinsics::from_fov(o.width, o.height, o.hfov_deg)),
        camera(intrinsics),
        sampler(probe),
        trajectory(trajectory_params(o)),
        sensor(intrinsics, SensorParams::with(o.noise, o.vignetting, o.seed), response) {
    if (o.guided) {
      GuidedMotionParams g = *o.guided;
      g.seed = o.seed;
      guided.emplace(g);
    }
    pixel_dir.resize(std::size_t(o.width) * std::size_t(o.height));
    for (int y = 0; y < o.height; ++y)
      for (int x = 0; x < o.width; ++x)
        pixel_dir[std::size_t(y) * std::size_t(o.width) + std::size_t(x)] =
            camera.unproject({double(x), double(y)});
  }

  static TrajectoryParams trajectory_params(const LiveCameraOptions& o) {
    TrajectoryParams tp;
    tp.kind = o.trajectory;
    tp.duration = std::max(1, o.frames - 1) / o.fps;
    tp.hfov_deg = o.hfov_deg;
    tp.vfov_deg = vertical_fov_deg(o.hfov_deg, o.width, o.height);
    tp.seed = o.seed;
    return tp;
  }
};

LiveCamera::LiveCamera(const std::filesystem::path& probe, const LiveCameraOptions& o) {
  if (o.width < 16 || o.height < 16 || o.width > 8192 || o.height > 8192)
    throw InputError("sim camera: size " + std::to_string(o.width) + "x" +
                     std::to_string(o.height) + " is not in 16..8192");
  if (!(o.fps > 0.0 && o.fps <= 1000.0) || o.frames < 1 || !(o.hfov_deg > 1 && o.hfov_deg < 170))
    throw InputError("sim camera: fps must be in (0, 1000], frames >= 1, hfov in (1, 170)");
  LoadedEnvMap probe_map = load_envmap(probe);
  const CameraResponse response = CameraResponse::named(o.response);
  impl_ = std::make_unique<Impl>(o, probe_map.env, response);
}

LiveCamera::~LiveCamera() = default;
LiveCamera::LiveCamera(LiveCamera&&) noexcept = default;
LiveCamera& LiveCamera::operator=(LiveCamera&&) noexcept = default;

CameraIntrinsics LiveCamera::intrinsics() const { return impl_->intrinsics; }
const LiveCameraOptions& LiveCamera::options() const { return impl_->options; }

void LiveCamera::request_exposure(double exposure_gain) {
  impl_->requested = exposure_gain > 0.0 && std::isfinite(exposure_gain) ? exposure_gain : 0.0;
}

void LiveCamera::propose_view(const glm::dvec3& direction) {
  Impl& s = *impl_;
  if (!s.guided) return;
  const double now = s.next_index > 0 ? double(s.next_index - 1) / s.options.fps : 0.0;
  s.guided->propose(direction, now);
}

std::optional<LiveFrame> LiveCamera::next() {
  Impl& s = *impl_;
  const LiveCameraOptions& o = s.options;
  if (s.next_index >= std::size_t(o.frames)) return std::nullopt;
  LiveFrame f;
  f.index = s.next_index++;
  f.time = double(f.index) / o.fps;
  f.orientation = s.guided ? s.guided->at(f.time) : s.trajectory.at(f.time).orientation;
  // The auto-exposure as arlight-sim runs it; a requested frame leaves its state alone.
  const double metered = metered_mean(
      s.camera, [&](const glm::dvec3& ray) { return s.sampler.sample(f.orientation * ray, 0.0); });
  s.log_auto = auto_exposure_step(s.log_auto, metered, f.index == 0);
  ExposureSetting setting = split_exposure(std::exp(s.log_auto));
  if (s.requested > 0.0) {
    setting = split_exposure(s.requested);
    f.requested = true;
    s.requested = 0.0;
  }
  f.exposure = setting.exposure, f.gain = setting.gain;
  f.bgr.create(o.height, o.width, CV_8UC3);
  tbb::parallel_for(0, o.height, [&](int y) {
    std::vector<glm::vec3> row(std::size_t(o.width));
    for (int x = 0; x < o.width; ++x)
      row[std::size_t(x)] = s.sampler.sample(
          f.orientation * s.pixel_dir[std::size_t(y) * std::size_t(o.width) + std::size_t(x)],
          0.0);
    s.sensor.expose_row(f.index, y, row.data(), setting, f.bgr.ptr<std::uint8_t>(y));
  });
  if (o.jpeg_quality > 0 &&
      !cv::imencode(".jpg", f.bgr, f.jpeg, {cv::IMWRITE_JPEG_QUALITY, o.jpeg_quality}))
    throw std::runtime_error("sim camera: JPEG encoding failed");
  return f;
}

}  // namespace arlight::sim
