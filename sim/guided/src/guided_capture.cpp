#include "arlight/guided/guided_capture.hpp"

#include <glm/geometric.hpp>

#include "arlight/common/response.hpp"

namespace arlight::guided {

glm::dvec3 view_direction(const glm::dquat& camera) {
  return glm::normalize(camera * glm::dvec3(0.0, 0.0, -1.0));
}

struct GuidedCapture::Impl {
  GuidedCaptureOptions options;
  sim::LiveCamera camera;
  capture::CaptureSession session;
  capture::ExposureAdvisor advisor;
  capture::ViewGuide guide;

  Impl(const std::filesystem::path& probe, const GuidedCaptureOptions& o)
      : options(o),
        camera(probe, o.camera),
        session(camera.intrinsics(), CameraResponse::named(o.camera.response), o.capture) {}
};

GuidedCapture::GuidedCapture(const std::filesystem::path& probe,
                             const GuidedCaptureOptions& options)
    : impl_(std::make_unique<Impl>(probe, options)) {}
GuidedCapture::~GuidedCapture() = default;
GuidedCapture::GuidedCapture(GuidedCapture&&) noexcept = default;
GuidedCapture& GuidedCapture::operator=(GuidedCapture&&) noexcept = default;

std::optional<GuidedStep> GuidedCapture::step() {
  Impl& m = *impl_;
  std::optional<sim::LiveFrame> frame = m.camera.next();
  if (!frame) return std::nullopt;
  GuidedStep s;
  s.result = m.session.add_encoded(
      frame->jpeg, {frame->time, frame->exposure, frame->gain, frame->orientation});
  // arlightd's order: the exposure advice first, then the update with the next view.
  if (const std::optional<double> asked = m.advisor.after_frame(s.result);
      asked && m.options.exposure_advice)
    m.camera.request_exposure(*asked);
  const glm::dquat& looking = s.result.used ? s.result.orientation : frame->orientation;
  s.proposal = m.guide.next(m.session.uncertainty(), view_direction(looking), frame->time);
  if (s.proposal) m.camera.propose_view(s.proposal->direction);
  s.frame = std::move(*frame);
  return s;
}

const capture::CaptureSession& GuidedCapture::session() const { return impl_->session; }
const sim::LiveCamera& GuidedCapture::camera() const { return impl_->camera; }
std::size_t GuidedCapture::advised_frames() const { return impl_->advisor.followed(); }

}  // namespace arlight::guided
