// A capture guided by arlightd's proposed views, in one process (issue 48 §2). Each step takes
// the simulated phone's next frame (its JPEG, exposure and exact orientation), adds it to a
// capture session as arlightd does, follows arlightd's exposure advice, and hands the session's
// next view (a capture::ViewGuide's, as arlightd's session asks for it) to the guided user: the
// same loop as arlight-client --source sim:PROBE --guided against arlightd, without the network
// between them. With options.camera.guided unset the phone follows its fixed trajectory and the
// proposals are only recorded: the baseline the guided path is measured against.
#pragma once

#include <filesystem>
#include <memory>
#include <optional>

#include "arlight/capture/capture.hpp"
#include "arlight/capture/exposure_advice.hpp"
#include "arlight/sim/live_camera.hpp"

namespace arlight::guided {

struct GuidedCaptureOptions {
  sim::LiveCameraOptions camera;    // camera.guided set: the user follows the proposals
  capture::CaptureOptions capture;  // arlightd's session (its layout, fill and uncertainty)
  bool exposure_advice = true;      // the phone takes the darker frames arlightd asks for
};

struct GuidedStep {
  sim::LiveFrame frame;                           // as the phone took it (pixels and JPEG)
  capture::FrameResult result;                    // what the session made of it
  std::optional<capture::ProposedView> proposal;  // the view asked for after it
};

class GuidedCapture {
 public:
  // InputError for an unreadable probe or bad camera options; std::invalid_argument for bad
  // capture options (as CaptureSession).
  GuidedCapture(const std::filesystem::path& probe, const GuidedCaptureOptions& options);
  ~GuidedCapture();
  GuidedCapture(GuidedCapture&&) noexcept;
  GuidedCapture& operator=(GuidedCapture&&) noexcept;

  // The next frame through the loop; std::nullopt after the last.
  std::optional<GuidedStep> step();
  const capture::CaptureSession& session() const;
  const sim::LiveCamera& camera() const;
  std::size_t advised_frames() const;  // frames taken at an exposure arlightd's advice asked for

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Where a camera of orientation `camera` (camera -> world) looks: its -Z axis, unit.
glm::dvec3 view_direction(const glm::dquat& camera);

}  // namespace arlight::guided
