// ReplaySource: the frames of a recording (protocol/RECORDING.md), decoded, optionally paced
// by their timestamps.
#include <spdlog/spdlog.h>

#include <chrono>
#include <opencv2/imgcodecs.hpp>
#include <thread>

#include "arlight/error.hpp"
#include "arlight/source.hpp"

namespace arlight::source {

struct ReplaySource::Impl {
  recording::Recording rec;
  SourceOptions options;
  std::size_t next = 0;  // the recording frame to look at next
  std::size_t skipped = 0;
  // Realtime pacing: the steady-clock instant and timestamp of the first delivered frame.
  std::optional<std::chrono::steady_clock::time_point> start;
  double first_timestamp = 0;

  void skip(std::size_t i, const std::string& why) {
    ++skipped;
    spdlog::warn("replay '{}': skipping frame {} ({}): {}", rec.folder.string(), i,
                 rec.frames[i].file, why);
  }
};

ReplaySource::ReplaySource(const std::filesystem::path& folder, const SourceOptions& options)
    : impl_(std::make_unique<Impl>()) {
  impl_->rec = recording::read_recording(folder);
  impl_->options = options;
}

ReplaySource::~ReplaySource() = default;

std::optional<SourceFrame> ReplaySource::next() {
  Impl& m = *impl_;
  while (m.next < m.rec.frames.size()) {
    const std::size_t i = m.next++;
    const recording::Frame& f = m.rec.frames[i];
    if (!f.problem.empty()) {
      m.skip(i, f.problem);
      continue;
    }
    SourceFrame out;
    try {
      out.jpeg = recording::read_frame_bytes(m.rec, i);
    } catch (const InputError& e) {  // changed on disk since the manifest was read
      m.skip(i, e.what());
      continue;
    }
    out.bgr = cv::imdecode(out.jpeg, cv::IMREAD_COLOR);
    if (out.bgr.empty()) {
      m.skip(i, "the JPEG does not decode");
      continue;
    }
    if (out.bgr.cols != m.rec.camera.width || out.bgr.rows != m.rec.camera.height) {
      m.skip(i, "decodes to " + std::to_string(out.bgr.cols) + "x" +
                    std::to_string(out.bgr.rows) + ", the camera is " +
                    std::to_string(m.rec.camera.width) + "x" +
                    std::to_string(m.rec.camera.height));
      continue;
    }
    out.timestamp = f.timestamp;
    out.exposure = f.exposure;
    out.gain = f.gain;
    out.orientation = f.orientation;
    out.index = i;
    if (m.options.realtime) {
      const auto now = std::chrono::steady_clock::now();
      if (!m.start) {
        m.start = now;
        m.first_timestamp = f.timestamp;
      } else {
        const auto due = *m.start + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                        std::chrono::duration<double>(f.timestamp -
                                                                      m.first_timestamp));
        if (due > now) std::this_thread::sleep_until(due);
      }
    }
    return out;
  }
  return std::nullopt;
}

CameraIntrinsics ReplaySource::intrinsics() const { return impl_->rec.camera; }
std::string ReplaySource::device_id() const { return impl_->rec.device_id; }
const recording::Recording& ReplaySource::recording() const { return impl_->rec; }
std::size_t ReplaySource::skipped() const { return impl_->skipped; }

std::string ReplaySource::describe() const {
  const recording::Recording& r = impl_->rec;
  return "replay:" + r.folder.string() + " (" + std::to_string(r.frames.size()) + " frames, " +
         std::to_string(r.camera.width) + "x" + std::to_string(r.camera.height) +
         (impl_->options.realtime ? ", real time)" : ", as fast as possible)");
}

}  // namespace arlight::source
