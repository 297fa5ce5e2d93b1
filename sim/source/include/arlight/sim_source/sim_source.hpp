// The client's `sim:PROBE.exr` frame source: a simulated phone in the laboratory (sim/), kept out
// of client/source so that nothing in client/ links the simulator. A program that links both
// registers it into the client's source factory at startup (register_sim_source(); arlight-client
// does), after which open_source("sim:PROBE.exr", options) opens a SimSource.
#pragma once

#include <filesystem>
#include <memory>
#include <optional>
#include <string>

#include "arlight/source/source.hpp"

namespace arlight::source {

// A simulated phone inside a probe (arlight/sim/live_camera.hpp): renders each view along a
// sweep when asked, with auto-exposure, noise and JPEG, and follows exposure requests, so the
// whole loop with arlightd runs without hardware. Its orientation is exact (an ideal IMU).
class SimSource : public FrameSource {
 public:
  // InputError for an unreadable probe or unusable options (size, fps, frames).
  SimSource(const std::filesystem::path& probe, const SourceOptions& options = {});
  ~SimSource() override;
  std::optional<SourceFrame> next() override;
  CameraIntrinsics intrinsics() const override;
  std::string device_id() const override;
  std::string describe() const override;
  bool request_exposure(double exposure_gain) override;
  // With SourceOptions::guided: the simulated user turns there (arlight_sim's GuidedMotion).
  bool propose_view(const glm::dvec3& direction) override;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Registers the `sim:` scheme (register_source_scheme): `sim:PROBE.exr` opens a SimSource on that
// probe with open_source's options. Calling it again changes nothing.
void register_sim_source();

}  // namespace arlight::source
