// ReplaySource: the frames of a recording (protocol/RECORDING.md), decoded, optionally paced
// by their timestamps.
#include <spdlog/spdlog.h>

#include <opencv2/imgcodecs.hpp>

#include "arlight/common/error.hpp"
#include "arlight/source/source.hpp"

namespace arlight::source {

struct ReplaySource::Impl {
  recording::Recording rec;
  SourceOptions options;
  std::optional<recording::FrameReader> reader;  // skips unusable frames, paces
};

ReplaySource::ReplaySource(const std::filesystem::path& folder, const SourceOptions& options)
    : impl_(std::make_unique<Impl>()) {
  Impl& m = *impl_;
  m.rec = recording::read_recording(folder);
  m.options = options;
  m.reader.emplace(m.rec, options.realtime, [&m](std::size_t i, const std::string& why) {
    spdlog::warn("replay '{}': skipping frame {} ({}): {}", m.rec.folder.string(), i,
                 m.rec.frames[i].file, why);
  });
}

ReplaySource::~ReplaySource() = default;

std::optional<SourceFrame> ReplaySource::next() {
  Impl& m = *impl_;
  while (auto item = m.reader->next()) {
    SourceFrame out;
    out.bgr = cv::imdecode(item->jpeg, cv::IMREAD_COLOR);
    if (out.bgr.empty()) {
      m.reader->skip(item->index, "the JPEG does not decode");
      continue;
    }
    if (out.bgr.cols != m.rec.camera.width || out.bgr.rows != m.rec.camera.height) {
      m.reader->skip(item->index, "decodes to " + std::to_string(out.bgr.cols) + "x" +
                                      std::to_string(out.bgr.rows) + ", the camera is " +
                                      std::to_string(m.rec.camera.width) + "x" +
                                      std::to_string(m.rec.camera.height));
      continue;
    }
    const recording::Frame& f = *item->frame;
    out.jpeg = std::move(item->jpeg);
    out.timestamp = f.timestamp;
    out.exposure = f.exposure;
    out.gain = f.gain;
    out.orientation = f.orientation;
    out.index = item->index;
    return out;
  }
  return std::nullopt;
}

CameraIntrinsics ReplaySource::intrinsics() const { return impl_->rec.camera; }
std::string ReplaySource::device_id() const { return impl_->rec.device_id; }
const recording::Recording& ReplaySource::recording() const { return impl_->rec; }
std::size_t ReplaySource::skipped() const { return impl_->reader->skipped(); }

bool ReplaySource::live() const { return impl_->options.realtime; }

std::string ReplaySource::describe() const {
  const recording::Recording& r = impl_->rec;
  return "replay:" + r.folder.string() + " (" + std::to_string(r.frames.size()) + " frames, " +
         std::to_string(r.camera.width) + "x" + std::to_string(r.camera.height) +
         (impl_->options.realtime ? ", real time)" : ", as fast as possible)");
}

}  // namespace arlight::source
