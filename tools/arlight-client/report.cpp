#include "report.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "arlight/common/atomic_file.hpp"

namespace arlight::client_app {

namespace fs = std::filesystem;

namespace {

// A few frames side by side: what the demo shows at a glance.
void write_contact_sheet(const std::vector<cv::Mat>& frames, const fs::path& path) {
  if (frames.empty()) return;
  const int cols = std::min<int>(4, int(frames.size()));
  const int rows = (int(frames.size()) + cols - 1) / cols;
  const int w = 320, h = frames[0].rows * w / frames[0].cols;
  cv::Mat sheet(rows * h, cols * w, CV_8UC3, cv::Scalar(0, 0, 0));
  for (std::size_t i = 0; i < frames.size(); ++i) {
    cv::Mat small;
    cv::resize(frames[i], small, cv::Size(w, h), 0, 0, cv::INTER_AREA);
    small.copyTo(sheet(cv::Rect(int(i) % cols * w, int(i) / cols * h, w, h)));
  }
  std::vector<std::uint8_t> png;
  cv::imencode(".png", sheet, png);
  write_file_atomically(path,
                        std::string_view(reinterpret_cast<const char*>(png.data()), png.size()));
}

}  // namespace

static nlohmann::json summary_json(const RunStats& s, const LinkStats& ls) {
  nlohmann::json j;
  j["frames"] = s.frames;
  j["tracked"] = s.tracked;
  j["median_frame_ms"] = median(s.frame_ms);
  j["stages_ms"] = {{"decode", median(s.decode_ms)},
                    {"tracking", median(s.track_ms)},
                    {"render", median(s.render_ms)},
                    {"tonemap", median(s.tonemap_ms)}};
  if (!s.error_cm.empty())
    j["pose_error"] = {{"median_cm", median(s.error_cm)},
                       {"median_deg", median(s.error_deg)},
                       {"p95_cm", percentile(s.error_cm, 0.95)},
                       {"p95_deg", percentile(s.error_deg, 0.95)},
                       {"max_cm", percentile(s.error_cm, 1.0)},
                       {"max_deg", percentile(s.error_deg, 1.0)},
                       {"frames", s.error_cm.size()}};
  if (!s.object_error_px.empty())
    j["object_error_px"] = {{"median", median(s.object_error_px)},
                            {"p95", percentile(s.object_error_px, 0.95)},
                            {"max", percentile(s.object_error_px, 1.0)},
                            {"frames", s.object_error_px.size()}};
  j["shadow_lights"] = {{"median", median(s.shadow_lights)},
                        {"min", s.shadow_lights.empty() ? 0.0 : percentile(s.shadow_lights, 0.0)},
                        {"max", percentile(s.shadow_lights, 1.0)},
                        {"frames", s.shadow_lights.size()}};
  j["lit_by_maps"] = s.lit_by_maps;
  j["lit_by_sh"] = s.lit_by_sh;
  j["lit_by_ggx"] = s.lit_by_ggx;
  j["exposure_advice"] = {{"received", ls.exposure_advice},
                          {"frames_taken", s.exposure_requested}};
  const auto per_frame = [&](std::uint64_t sum) {  // a mean over the frames' JPEGs
    return ls.frames_encoded ? double(sum) / double(ls.frames_encoded) : 0.0;
  };
  j["session"] = {{"id", ls.session_id},           {"connects", ls.connects},
                  {"frames_sent", ls.frames_sent}, {"frames_not_sent", ls.frames_not_sent},
                  {"frames_resent", ls.frames_resent}, {"frames_delayed", ls.frames_delayed},
                  {"frames_held_back", ls.frames_held_back},
                  {"frames_held_in_flight", ls.frames_held_in_flight},
                  {"bytes_per_frame", per_frame(ls.frame_bytes)},
                  {"jpeg_quality_mean", per_frame(ls.jpeg_quality_sum)},
                  {"advised_frame_bytes", ls.advised_frame_bytes},
                  {"updates", ls.updates},         {"map_sets", ls.map_sets},
                  {"refused", ls.refused},         {"last_error", ls.last_error},
                  {"resumes", nlohmann::json::array()}};
  for (const Resume& r : ls.resumes)
    j["session"]["resumes"].push_back({{"frames_sent_before", r.frames_sent_before},
                                       {"frames_processed", r.frames_processed},
                                       {"last_sequence", r.last_sequence},
                                       {"frames_to_resend", r.frames_to_resend},
                                       {"first_coverage", r.first_coverage}});
  return j;
}

std::function<std::optional<Pose>(std::size_t)> true_poses(std::optional<recording::Truth> truth) {
  if (!truth || !truth->marker) return {};
  return [t = std::move(*truth)](std::size_t i) { return recording::camera_in_marker(t, i); };
}

RunOutput::RunOutput(fs::path out, fs::path json_path)
    : out_(std::move(out)), json_path_(std::move(json_path)) {
  if (!out_.empty()) fs::create_directories(out_ / "frames");
}

void RunOutput::add(const FrameReport& r, const cv::Mat& composited, const Lighting& light) {
  if (!out_.empty()) {
    char name[32];
    std::snprintf(name, sizeof name, "%06zu.png", written_++);
    cv::imwrite((out_ / "frames" / name).string(), composited);
    if (r.drawn && drawn_.size() < 64) drawn_.push_back(composited.clone());
  }
  // arlightd's statement of the light: "good to +-N %" and where it asks the camera to look.
  char stated[96] = "";
  if (light.light_error > 0 && light.light_error < wire::kLightErrorUnknown)
    std::snprintf(stated, sizeof stated, ", light +-%.0f %%", 100 * light.light_error);
  else if (light.light_error >= wire::kLightErrorUnknown)
    std::snprintf(stated, sizeof stated, ", light unknown");
  if (light.next_view) {
    const std::size_t n = std::strlen(stated);
    std::snprintf(stated + n, sizeof stated - n, ", look %.2f %.2f %.2f", light.next_view->x,
                  light.next_view->y, light.next_view->z);
  }
  std::printf("frame %zu: %s, %s, track %.1f ms, render %.1f ms, tonemap %.1f ms%s\n", r.index,
              r.track_status.c_str(),
              !r.drawn                                   ? "not drawn"
              : r.lit_by == render::LightingSource::Maps ? "maps"
                                                         : "SH",
              r.track_ms, r.render_ms, r.tonemap_ms, stated);
}

void RunOutput::finish(const RunStats& stats, const LinkStats& link, const nlohmann::json& extra) {
  if (!out_.empty()) {
    std::vector<cv::Mat> picked;
    const std::size_t n = std::min<std::size_t>(8, drawn_.size());
    for (std::size_t i = 0; i < n; ++i) picked.push_back(drawn_[i * drawn_.size() / n]);
    write_contact_sheet(picked, out_ / "contact_sheet.png");
    if (std::system("command -v ffmpeg > /dev/null 2>&1") == 0) {
      const std::string cmd = "ffmpeg -loglevel error -y -framerate 30 -i '" +
                              (out_ / "frames" / "%06d.png").string() + "' -pix_fmt yuv420p '" +
                              (out_ / "composited.mp4").string() + "'";
      if (std::system(cmd.c_str()) != 0) spdlog::warn("ffmpeg could not write the MP4");
    }
  }
  nlohmann::json j = summary_json(stats, link);
  j.update(extra);
  const std::string text = j.dump(2) + "\n";
  if (!json_path_.empty()) write_file_atomically(json_path_, text);
  if (!out_.empty()) write_file_atomically(out_ / "client.json", text);
  std::printf(
      "%zu frames, %zu tracked, median %.1f ms per frame (tracking %.1f, render %.1f, "
      "tone map %.1f)%s%s\n",
      stats.frames, stats.tracked, median(stats.frame_ms), median(stats.track_ms),
      median(stats.render_ms), median(stats.tonemap_ms), out_.empty() ? "" : "; frames in ",
      out_.c_str());
}

}  // namespace arlight::client_app
