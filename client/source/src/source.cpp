// open_source: the client's --source spec to a FrameSource.
#include <string_view>

#include "arlight/error.hpp"
#include "arlight/source.hpp"

namespace arlight::source {

std::unique_ptr<FrameSource> open_source(const std::string& spec, const SourceOptions& options) {
  constexpr std::string_view kV4l2 = "v4l2:", kReplay = "replay:", kSim = "sim:";
  const std::string_view s(spec);
  if (s.starts_with(kV4l2) && s.size() > kV4l2.size())
    return std::make_unique<V4l2Source>(spec.substr(kV4l2.size()), options);
  if (s.starts_with(kReplay) && s.size() > kReplay.size())
    return std::make_unique<ReplaySource>(spec.substr(kReplay.size()), options);
  if (s.starts_with(kSim) && s.size() > kSim.size())
    return std::make_unique<SimSource>(spec.substr(kSim.size()), options);
  throw InputError("source '" + spec +
                   "': expected v4l2:/dev/videoN (a webcam), replay:REC_FOLDER (a recording) or "
                   "sim:PROBE.exr (a simulated phone in that room)");
}

}  // namespace arlight::source
