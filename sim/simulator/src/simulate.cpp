#include <tbb/parallel_for.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdio>
#include <functional>
#include <glm/geometric.hpp>
#include <numbers>
#include <opencv2/imgcodecs.hpp>
#include <optional>
#include <sstream>
#include <utility>

#include "arlight/common/error.hpp"
#include "arlight/common/hdr_io.hpp"
#include "arlight/common/resample.hpp"
#include "arlight/common/response.hpp"
#include "arlight/protocol/recording.hpp"
#include "arlight/sim/simulate.hpp"
#include "arlight/truth/truth.hpp"
#include "imaging.hpp"
#include "noise.hpp"
#include "y4m.hpp"

namespace arlight::sim {

namespace fs = std::filesystem;

namespace {

constexpr double kDeg = std::numbers::pi / 180.0;
constexpr double kImuRate = 200;               // Hz
constexpr double kOrientationNoiseDeg = 0.02;  // per axis, white, per frame
constexpr double kGyroNoise = 0.002;           // rad/s per axis and sample
constexpr double kAccelNoise = 0.02;           // m/s^2 per axis and sample
constexpr double kGravity = 9.81;
constexpr int kSuper = 4;                        // supersampling where the marker is

// An --out folder is either absent, empty, or an earlier recording (which is replaced).
void prepare_output(const fs::path& out) {
  std::error_code ec;
  const std::string q = "--out '" + out.string() + "'";
  if (fs::exists(out, ec)) {
    if (!fs::is_directory(out, ec)) throw InputError(q + ": exists and is not a folder");
    if (!fs::is_empty(out, ec)) {
      if (!fs::is_regular_file(out / recording::kManifestName, ec))
        throw InputError(q + ": a non-empty folder that is not a recording (no " +
                         recording::kManifestName + "); refusing to write into it");
      // Manifest first: an interrupted cleanup never leaves a manifest without its frames.
      fs::remove(out / recording::kManifestName);
      fs::remove(out / "imu.csv");
      fs::remove_all(out / "frames");
      fs::remove_all(out / recording::kTruthFolder);
    }
  }
  fs::create_directories(out);
}

// The true environment as a lat-long map (the probe itself when it is one).
EnvMap latlong_truth(const EnvMap& env) {
  if (env.layout.projection() == Projection::LatLong) return env;
  const int n = env.layout.projection() == Projection::Cube ? 2 * env.layout.face_size()
                                                            : std::max(16, env.layout.width() / 2);
  return resample(env, EnvLayout::for_size(Projection::LatLong, n));
}

// The rendered scene: the environment at infinity and, optionally, the marker on the floor.
struct Scene {
  const EnvSampler& env;
  const std::optional<MarkerScene>& marker;

  glm::vec3 radiance(const glm::dvec3& origin, const glm::dvec3& dir) const {
    if (marker)
      if (const auto m = marker->hit(origin, dir)) return *m;
    return env.sample(dir, 0.0);
  }
};

}  // namespace

std::string describe(const SimOptions& o) {
  std::ostringstream d;
  d.precision(17);
  d << "env=" << o.env.string() << " frames=" << o.frames << " fps=" << o.fps << " size=" << o.width
    << "x" << o.height << " hfov=" << o.hfov_deg << " trajectory=" << int(o.trajectory)
    << " response=" << o.response << " auto_exposure=" << o.auto_exposure
    << " hdr_stops=" << o.hdr_stops << " drift=" << o.gyro_drift_deg_per_s << " noise=" << o.noise
    << " vignetting=" << o.vignetting << " jpeg=" << o.jpeg_quality << " seed=" << o.seed
    << " bracket=" << o.bracket << " y4m=" << !o.y4m.empty();
  if (o.marker)
    d << " marker=" << o.marker->id << "," << o.marker->size_m << "," << o.marker->centre.x << ","
      << o.marker->centre.y << "," << o.marker->centre.z;
  if (o.place)
    d << " place=" << o.place->where.latitude_deg << "," << o.place->where.longitude_deg << ","
      << o.place->where.altitude_m << "," << o.place->utc_seconds << ","
      << o.place->north_offset_deg.value_or(1000.0);
  if (!o.path.empty()) {  // a given path: its poses, hashed
    std::uint64_t h = 0;
    for (const Pose& p : o.path)
      for (const double v : {p.position.x, p.position.y, p.position.z, p.orientation.w,
                             p.orientation.x, p.orientation.y, p.orientation.z})
        h = mix64(h ^ std::bit_cast<std::uint64_t>(v));
    d << " path=" << o.path.size() << ":" << h;
  }
  d << " built=" << __DATE__ << " " << __TIME__;
  return d.str();
}

int simulate(const SimOptions& o) {
  const CameraResponse response = CameraResponse::named(o.response);
  LoadedEnvMap probe = load_envmap(o.env);
  if (!probe.info.sanitized.clean())
    std::fprintf(stderr, "arlight-sim: %s: %s\n", o.env.string().c_str(),
                 probe.info.sanitized.summary().c_str());
  const EnvMap& env = probe.env;
  prepare_output(o.out);

  const CameraIntrinsics intrinsics = CameraIntrinsics::from_fov(o.width, o.height, o.hfov_deg);
  const PinholeCamera camera(intrinsics);
  const bool bracket = o.bracket > 0;
  const int n = bracket ? o.bracket : o.frames;
  const double duration = (n - 1) / o.fps;

  // Where the camera is: a trajectory, or one fixed view (yaw 0, pitch 0) for a bracket.
  TrajectoryParams tp;
  tp.kind = o.trajectory;
  tp.duration = duration;
  tp.hfov_deg = o.hfov_deg;
  tp.vfov_deg = vertical_fov_deg(o.hfov_deg, o.width, o.height);
  if (o.marker) tp.target = o.marker->centre;
  tp.seed = o.seed;
  const Trajectory trajectory(tp);
  const bool given_path = !o.path.empty() && !bracket;
  if (given_path && int(o.path.size()) != n)
    throw InputError("a given path of " + std::to_string(o.path.size()) + " poses for " +
                     std::to_string(n) + " frames");
  // A given path: the frames' poses, slerped (and lerped) in between.
  const auto path_at = [&](double t) -> Pose {
    const double x = std::clamp(t * o.fps, 0.0, double(n - 1));
    const auto i = std::size_t(std::min(std::floor(x), double(std::max(0, n - 2))));
    const std::size_t j = std::min(i + 1, std::size_t(n - 1));
    const double f = std::clamp(x - double(i), 0.0, 1.0);
    Pose p;
    p.position = glm::mix(o.path[i].position, o.path[j].position, f);
    p.orientation = glm::normalize(glm::slerp(o.path[i].orientation, o.path[j].orientation, f));
    return p;
  };
  const std::function<Pose(double)> pose_at = [&](double t) {
    return bracket ? Pose{} : given_path ? path_at(t) : trajectory.at(t);
  };
  const std::function<glm::dvec3(double)> omega_at = [&](double t) {
    if (bracket) return glm::dvec3(0.0);
    if (!given_path) return trajectory.angular_velocity(t);
    return angular_velocity(
        [&](double u) { return path_at(u).orientation; }, t, duration);
  };
  std::vector<Pose> poses;
  for (int i = 0; i < n; ++i) poses.push_back(pose_at(i / o.fps));

  const EnvSampler sampler(env);
  std::optional<MarkerScene> marker;
  if (o.marker) marker.emplace(*o.marker, upper_hemisphere_irradiance_mean(env));
  const Scene scene{sampler, marker};

  // Unit camera-space direction of every pixel centre, computed once.
  std::vector<glm::dvec3> pixel_dir(std::size_t(o.width) * std::size_t(o.height));
  tbb::parallel_for(0, o.height, [&](int y) {
    for (int x = 0; x < o.width; ++x)
      pixel_dir[std::size_t(y) * std::size_t(o.width) + std::size_t(x)] =
          camera.unproject({double(x), double(y)});
  });

  // Exposure: meter each view's mean luminance on a coarse grid, then run the auto-exposure.
  std::vector<double> metered(std::size_t(n), 0.0);
  tbb::parallel_for(0, n, [&](int i) {
    const Pose& p = poses[std::size_t(i)];
    metered[std::size_t(i)] = metered_mean(
        camera, [&](const glm::dvec3& ray) { return scene.radiance(p.position, p.orientation * ray); });
  });
  std::vector<ExposureSetting> settings =
      bracket ? bracket_exposures(metered[0], n)
              : auto_exposure(metered, o.auto_exposure && o.y4m.empty());
  if (!bracket && o.hdr_stops > 0)
    for (std::size_t i = 1; i < settings.size(); i += 2)
      settings[i] = split_exposure(settings[i].product() * std::exp2(-o.hdr_stops));

  const Sensor sensor(intrinsics, SensorParams::with(o.noise, o.vignetting, o.seed), response);

  // One frame: scene radiance per pixel (4x4 supersampled where the marker sheet may be, so
  // its edges are anti-aliased), then the sensor, then JPEG.
  auto render = [&](int i) {
    const Pose& pose = poses[std::size_t(i)];
    const PixelBox box = marker ? marker->footprint(camera, pose) : PixelBox{};
    cv::Mat bgr(o.height, o.width, CV_8UC3);
    tbb::parallel_for(0, o.height, [&](int y) {
      std::vector<glm::vec3> row(std::size_t(o.width));
      for (int x = 0; x < o.width; ++x) {
        const glm::dvec3 dir =
            pose.orientation * pixel_dir[std::size_t(y) * std::size_t(o.width) + std::size_t(x)];
        glm::vec3 l;
        bool done = false;
        if (x >= box.x0 && x <= box.x1 && y >= box.y0 && y <= box.y1) {
          glm::dvec3 sum(0.0);
          bool touched = false;
          for (int sy = 0; sy < kSuper; ++sy)
            for (int sx = 0; sx < kSuper; ++sx) {
              const glm::dvec2 sub(x - 0.5 + (sx + 0.5) / kSuper, y - 0.5 + (sy + 0.5) / kSuper);
              const glm::dvec3 d = pose.orientation * camera.unproject(sub);
              const auto m = marker->hit(pose.position, d);
              touched |= m.has_value();
              sum += glm::dvec3(m ? *m : sampler.sample(d, 0.0));
            }
          if (touched) l = glm::vec3(sum / double(kSuper * kSuper)), done = true;
        }
        if (!done) l = sampler.sample(dir, 0.0);
        row[std::size_t(x)] = l;
      }
      sensor.expose_row(std::uint64_t(i), y, row.data(), settings[std::size_t(i)],
                        bgr.ptr<std::uint8_t>(y));
    });
    std::vector<std::uint8_t> jpeg;
    if (!cv::imencode(".jpg", bgr, jpeg, {cv::IMWRITE_JPEG_QUALITY, o.jpeg_quality}))
      throw std::runtime_error("JPEG encoding failed");
    return std::pair(std::move(jpeg), bgr);
  };

  // What the phone's orientation sensor reports: heading drift about world +Y (an IMU with
  // accelerometer tilt correction drifts only in heading) and a little white noise.
  const double drift_sign = (hash64(o.seed, Stream::DriftSign) & 1) ? 1.0 : -1.0;
  const double drift = drift_sign * o.gyro_drift_deg_per_s * kDeg;  // rad/s about world +Y
  auto sensor_orientation = [&](int i) {
    const double t = i / o.fps;
    glm::dvec3 v;
    for (int a = 0; a < 3; ++a)
      v[a] = kOrientationNoiseDeg * kDeg * normal(hash64(o.seed, Stream::OrientationNoise, i, a));
    const double angle = glm::length(v);
    const glm::dquat noise = angle > 0 ? glm::angleAxis(angle, v / angle) : glm::dquat(1, 0, 0, 0);
    return glm::normalize(glm::angleAxis(drift * t, glm::dvec3(0, 1, 0)) *
                          poses[std::size_t(i)].orientation * noise);
  };

  recording::RecordingWriter writer(o.out, intrinsics, "arlight-sim");
  std::optional<Y4mWriter> video;
  if (!o.y4m.empty()) video.emplace(o.y4m, o.width, o.height, int(std::lround(o.fps)));
  constexpr int kBatch = 8;  // frames rendered concurrently, then written in order
  for (int first = 0; first < n; first += kBatch) {
    const int count = std::min(kBatch, n - first);
    std::vector<std::pair<std::vector<std::uint8_t>, cv::Mat>> frames(
        static_cast<std::size_t>(count));
    tbb::parallel_for(0, count, [&](int k) { frames[std::size_t(k)] = render(first + k); });
    for (int k = 0; k < count; ++k) {
      const int i = first + k;
      const cv::Mat& bgr = frames[std::size_t(k)].second;
      if (video) video->add(bgr.data, std::ptrdiff_t(bgr.step));
      writer.add_frame(frames[std::size_t(k)].first, i / o.fps, settings[std::size_t(i)].exposure,
                       settings[std::size_t(i)].gain, sensor_orientation(i));
    }
  }

  // IMU at 200 Hz: gyro = true angular velocity + the drift (in camera coordinates) + noise,
  // accelerometer = gravity's reaction in camera coordinates + noise.
  const long samples = std::lround(std::floor(duration * kImuRate + 1e-9)) + 1;
  for (long k = 0; k < samples; ++k) {
    const double t = k / kImuRate;
    const glm::dquat to_camera = glm::conjugate(pose_at(t).orientation);
    recording::ImuSample s;
    s.timestamp = t;
    s.gyro = omega_at(t) + to_camera * glm::dvec3(0, drift, 0);
    s.accel = to_camera * glm::dvec3(0, kGravity, 0);
    for (int a = 0; a < 3; ++a) {
      s.gyro[a] += kGyroNoise * normal(hash64(o.seed, Stream::GyroNoise, std::uint64_t(k), a));
      s.accel[a] += kAccelNoise * normal(hash64(o.seed, Stream::AccelNoise, std::uint64_t(k), a));
    }
    writer.add_imu(s);
  }

  // The ground truth, before the manifest: a complete recording always has its truth.
  const fs::path truth_dir = o.out / recording::kTruthFolder;
  fs::create_directories(truth_dir);
  ImageMetadata meta;
  meta.projection = Projection::LatLong;
  meta.description = "arlight-sim ground truth: " + o.env.string();
  const EnvMap truth_env = latlong_truth(env);
  write_exr(truth_dir / "env.exr", truth_env.image.view(), meta);
  response.save(truth_dir / "response.json");
  recording::Truth truth;
  truth.probe = o.env.string();
  truth.radiance_scale = 1.0;
  truth.response = response.name();
  truth.gyro_drift_deg_per_s = drift_sign * o.gyro_drift_deg_per_s;
  truth.poses = poses;
  if (marker) {
    truth.marker = recording::MarkerTruth{"DICT_4X4_50", marker->spec().id, marker->spec().size_m,
                                          marker->pose()};
    for (const Pose& p : poses) truth.marker_visible.push_back(marker->visible(camera, p));
  }
  recording::write_truth(o.out, truth);
  if (o.place) writer.set_place(*o.place);
  writer.finish();
  return n;
}

}  // namespace arlight::sim
