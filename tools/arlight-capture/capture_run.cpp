#include "capture_run.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <optional>
#include <string>
#include <vector>

#include "arlight/capture/calibration.hpp"
#include "arlight/capture/capture.hpp"
#include "arlight/common/atomic_file.hpp"
#include "arlight/common/error.hpp"
#include "arlight/common/hdr_io.hpp"
#include "arlight/common/pose.hpp"
#include "arlight/truth/truth.hpp"

namespace fs = std::filesystem;

namespace arlight::capture_tool {

namespace {

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

// The response the frames are linearised with, and where it came from.
CameraResponse choose_response(const CaptureFlags& o, const recording::Recording& rec) {
  if (!o.response.empty()) return CameraResponse::named(o.response);
  if (!o.response_dir.empty() && !rec.device_id.empty())
    if (auto r = capture::ResponseStore(o.response_dir).find(rec.device_id)) {
      std::printf("using %s's camera response from %s\n", rec.device_id.c_str(),
                  o.response_dir.c_str());
      return *r;
    }
  return CameraResponse::srgb();
}

void write_json(const fs::path& path, const nlohmann::json& j) {
  if (path.has_parent_path()) fs::create_directories(path.parent_path());
  write_file_atomically(path, j.dump(2) + "\n");
}

// 8-bit picture of where the map has data: black never seen, grey to white by summed weight.
void write_coverage_png(const fs::path& path, const capture::CaptureSession& s) {
  const std::vector<float> w = s.weights();
  const EnvLayout& layout = s.layout();
  float top = 0.0f;
  for (float v : w) top = std::max(top, v);
  cv::Mat img(layout.height(), layout.width(), CV_8U);
  for (int y = 0; y < layout.height(); ++y)
    for (int x = 0; x < layout.width(); ++x) {
      const float v = w[std::size_t(y) * layout.width() + x];
      img.at<std::uint8_t>(y, x) =
          v > 0.0f ? std::uint8_t(64 + std::lround(191.0f * std::min(1.0f, v / top))) : 0;
    }
  std::vector<std::uint8_t> png;
  cv::imencode(".png", img, png);
  write_file_atomically(path, std::string(png.begin(), png.end()));
}

// What a capture run measured, frame by frame.
struct CaptureTally {
  nlohmann::json skipped = nlohmann::json::array(), per_frame = nlohmann::json::array();
  std::vector<double> total_ms, decode_ms, linearize_ms, align_ms, exposure_ms, project_ms, sh_ms;
  std::vector<std::vector<double>> pass_ms;  // per pass: each used frame's ms
  std::vector<std::size_t> pass_unchanged;   // per pass: frames not merged
  double exposure_squared_error = 0.0;       // stops, of estimated against recorded (relative)
  std::size_t exposures_compared = 0;
  double squared_error = 0.0;  // degrees, of the orientation against the truth
  std::size_t compared = 0, aligned = 0;
};

// The JSON report (--json) and the summary on stdout of a finished capture.
void report_capture(const CaptureFlags& o, const recording::Recording& rec,
                    const capture::CaptureSession& session, const CaptureTally& t,
                    const fs::path& png, const fs::path& coverage_png) {
  nlohmann::json j;
  j["frames"] = rec.frames.size();
  j["frames_used"] = session.frames_used();
  j["coverage"] = session.coverage();
  j["fill"] = o.fill;
  j["exposure"] = o.exposure;
  if (t.exposures_compared)
    j["exposure_rms_stops"] = std::sqrt(t.exposure_squared_error / double(t.exposures_compared));
  j["estimated"] = session.estimated_fraction();
  j["median_frame_ms"] = median(t.total_ms);
  j["stages_median_ms"] = {{"decode", median(t.decode_ms)},   {"linearize", median(t.linearize_ms)},
                           {"align", median(t.align_ms)},     {"exposure", median(t.exposure_ms)},
                           {"project", median(t.project_ms)}, {"sh", median(t.sh_ms)}};
  j["merge"] = o.merge;
  j["passes"] = nlohmann::json::array();
  for (std::size_t p = 0; p < t.pass_ms.size(); ++p)
    j["passes"].push_back({{"frames", t.pass_ms[p].size()},
                           {"frames_unchanged", t.pass_unchanged[p]},
                           {"median_frame_ms", median(t.pass_ms[p])}});
  j["aligned_frames"] = t.aligned;
  if (t.compared) j["orientation_rms_deg"] = std::sqrt(t.squared_error / double(t.compared));
  j["sh_order"] = session.sh().order;
  j["sh"] = nlohmann::json::array();
  for (const glm::dvec3& c : session.sh().c) j["sh"].push_back({c.x, c.y, c.z});
  j["skipped"] = t.skipped;
  j["per_frame"] = t.per_frame;
  j["response"] = session.response().name();
  j["map"] = o.out.string();
  if (!o.json.empty()) write_json(o.json, j);

  std::printf("%zu of %zu frames used (%zu aligned), coverage %.1f %%, median %.2f ms per frame\n",
              std::size_t(session.frames_used()), rec.frames.size(), t.aligned,
              100.0 * session.coverage(), median(t.total_ms));
  if (session.estimated_fraction() > 0.0)
    std::printf("the unseen %.1f %% of the sphere is filled (--fill %s)\n",
                100.0 * session.estimated_fraction(), o.fill.c_str());
  if (t.compared)
    std::printf("orientation error vs truth: %.3f deg RMS\n",
                j["orientation_rms_deg"].get<double>());
  for (const auto& s : t.skipped)
    std::fprintf(stderr, "frame %zu skipped: %s\n", s["frame"].get<std::size_t>(),
                 s["reason"].get<std::string>().c_str());
  std::printf("wrote %s, %s, %s\n", o.out.c_str(), png.c_str(), coverage_png.c_str());
}

}  // namespace

int run_capture(const CaptureFlags& o, const recording::Recording& rec) {
  if (o.out.empty()) throw InputError("--out ENV.exr is required");
  const auto projection = parse_projection(o.projection);
  if (!projection) throw InputError("--projection: expected anglemap, latlong or cube");
  if (o.size < 16 || o.size > 4096) throw InputError("--size must be in [16, 4096]");
  capture::CaptureOptions options;
  options.layout = EnvLayout::for_size(*projection, o.size);
  options.sh_order = o.sh_order;
  options.align = !o.no_align;
  if (o.align_every < 0) throw InputError("--align-every must be >= 1");
  if (o.align_every > 0) options.align_every = o.align_every;
  if (o.align_width > 0) options.align_max_width = o.align_width;
  options.align_async = o.align_async;
  options.fill = capture::fill_from_name(o.fill, "--fill");
  if (o.exposure != "known" && o.exposure != "locked" && o.exposure != "estimate")
    throw InputError("--exposure: expected known, locked or estimate, got '" + o.exposure + "'");
  options.estimate_exposure = o.exposure == "estimate";
  if (o.merge == "all") {
    options.confident_weight = options.changed_ratio = std::numeric_limits<double>::infinity();
    options.unchanged_share = options.unchanged_bias = 0.0;
  } else if (o.merge != "changes") {
    throw InputError("--merge: expected changes or all, got '" + o.merge + "'");
  }
  if (o.passes < 1 || o.passes > 1000) throw InputError("--passes must be in [1, 1000]");
  capture::CaptureSession session(rec.camera, choose_response(o, rec), options);
  const std::optional<recording::Truth> truth = recording::read_truth(rec.folder);

  CaptureTally tally;
  // --exposure locked|estimate: the recorded exposures are withheld, every frame is given the
  // first one's (as arlightd does for a browser); `estimate` then measures each frame's.
  std::optional<double> locked_exposure;
  if (o.until_coverage < 0.0 || o.until_coverage > 1.0)
    throw InputError("--until-coverage must be a fraction in [0, 1]");
  // A pass after the first continues the clock: its timestamps are the recording's plus the
  // recording's span (and a frame's interval) per pass.
  const double span = rec.frames.empty()
                          ? 0.0
                          : rec.frames.back().timestamp - rec.frames.front().timestamp + 1.0 / 30.0;
  for (int pass = 0; pass < o.passes; ++pass) {
    tally.pass_ms.emplace_back();
    tally.pass_unchanged.push_back(0);
    recording::FrameReader reader(rec, false, [&](std::size_t i, const std::string& why) {
      if (pass == 0) tally.skipped.push_back({{"frame", i}, {"reason", why}});
    });
    while (const auto item = reader.next()) {
      if (o.until_coverage > 0.0 && session.coverage() >= o.until_coverage) break;
      const std::size_t i = item->index;
      recording::Frame f = *item->frame;
      f.timestamp += span * pass;
      const double recorded = f.exposure * f.gain;
      if (o.exposure != "known") {
        if (!locked_exposure) locked_exposure = recorded;
        f.exposure = *locked_exposure, f.gain = 1.0;
      }
      const capture::FrameResult r = session.add_encoded(item->jpeg, f);
      if (!r.used) {
        reader.skip(i, r.skipped_reason);
        continue;
      }
      tally.pass_ms.back().push_back(r.total_ms());
      tally.pass_unchanged.back() += r.unchanged ? 1 : 0;
      tally.total_ms.push_back(r.total_ms());
      tally.decode_ms.push_back(r.decode_ms), tally.linearize_ms.push_back(r.linearize_ms);
      tally.align_ms.push_back(r.align_ms), tally.project_ms.push_back(r.project_ms);
      tally.sh_ms.push_back(r.sh_ms);
      tally.exposure_ms.push_back(r.exposure_ms);
      tally.aligned += r.aligned ? 1 : 0;
      nlohmann::json row = {{"frame", i},
                            {"ms", r.total_ms()},
                            {"aligned", r.aligned},
                            {"inliers", r.align_inliers},
                            {"correction_deg", r.correction_deg},
                            {"align_note", r.align_note},
                            {"pass", pass},
                            {"texels_changed", r.texels_changed},
                            {"unchanged", r.unchanged},
                            {"glanced", r.glanced},
                            {"change", r.change},
                            {"bias", r.bias},
                            {"exposure_gain", r.exposure_gain}};
      if (o.exposure == "estimate") {
        row["exposure_estimated"] = r.exposure_estimated;
        row["exposure_samples"] = r.exposure_samples;
        const double stops = std::log2(r.exposure_gain / recorded);
        tally.exposure_squared_error += stops * stops;
        ++tally.exposures_compared;
      }
      if (truth && i < truth->poses.size()) {
        const double e = angle_deg(r.orientation, truth->poses[i].orientation);
        tally.squared_error += e * e;
        ++tally.compared;
        row["error_deg"] = e;
      }
      tally.per_frame.push_back(row);
    }
  }

  const EnvMap env = session.environment();
  ImageMetadata meta;
  meta.projection = *projection;
  for (const glm::dvec3& c : session.sh().c)
    meta.sh_coefficients.push_back({float(c.x), float(c.y), float(c.z)});
  meta.description = "captured by arlight-capture from " + rec.folder.string();
  meta.fill = o.fill;
  if (o.out.has_parent_path()) fs::create_directories(o.out.parent_path());
  write_exr(o.out, env.image.view(), meta);
  fs::path png = o.out, coverage_png = o.out;
  png.replace_extension(".png");
  coverage_png.replace_filename(o.out.stem().string() + "_coverage.png");
  write_png_preview(png, env.image.view());
  write_coverage_png(coverage_png, session);

  report_capture(o, rec, session, tally, png, coverage_png);
  return 0;
}

int run_calibration(const CaptureFlags& o, const recording::Recording& rec) {
  const auto method = capture::parse_calibration_method(o.calibrate);
  if (!method) throw InputError("--calibrate: expected robertson or debevec, got " + o.calibrate);
  if (o.response_out.empty() && o.response_dir.empty())
    throw InputError("--calibrate needs --response-out FILE or --response-dir DIR");
  std::vector<cv::Mat> images;
  std::vector<double> times;
  glm::dquat first_view{1, 0, 0, 0};
  recording::FrameReader reader(rec, false, [](std::size_t i, const std::string& why) {
    std::fprintf(stderr, "frame %zu skipped: %s\n", i, why.c_str());
  });
  while (const auto item = reader.next()) {
    const std::size_t i = item->index;
    const recording::Frame& f = *item->frame;
    cv::Mat im = cv::imdecode(item->jpeg, cv::IMREAD_COLOR);
    if (im.empty() || im.cols != rec.camera.width || im.rows != rec.camera.height) {
      std::fprintf(stderr, "frame %zu skipped: not a %dx%d image\n", i, rec.camera.width,
                   rec.camera.height);
      continue;
    }
    // A bracket is one view: frames that look elsewhere would calibrate garbage.
    if (!images.empty() && angle_deg(f.orientation, first_view) > 2.0)
      throw InputError("'" + rec.folder.string() + "' is not a bracket: frame " +
                       std::to_string(i) + " looks " +
                       std::to_string(angle_deg(f.orientation, first_view)) +
                       " degrees away from the first (record one view at several exposures, "
                       "e.g. arlight-sim --bracket 7)");
    if (images.empty()) first_view = f.orientation;
    images.push_back(im);
    times.push_back(f.exposure * f.gain);
  }
  const CameraResponse r = capture::calibrate_response(images, times, *method);
  if (!o.response_out.empty()) {
    r.save(o.response_out);
    std::printf("camera response (%s, %zu frames) written to %s\n", o.calibrate.c_str(),
                images.size(), o.response_out.c_str());
  }
  if (!o.response_dir.empty()) {
    if (rec.device_id.empty())
      throw InputError("'" + rec.folder.string() +
                       "' has no device_id, so --response-dir cannot file its curve");
    capture::ResponseStore(o.response_dir).save(rec.device_id, r);
    std::printf("camera response stored for device %s in %s\n", rec.device_id.c_str(),
                o.response_dir.c_str());
  }
  return 0;
}

}  // namespace arlight::capture_tool
