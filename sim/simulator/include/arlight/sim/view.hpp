// An ideal camera's view of a probe: what benchmarks and tests feed the capture when they want
// frames without the simulated phone's noise, vignetting, auto-exposure and JPEG.
#pragma once

#include <glm/gtc/quaternion.hpp>

#include "arlight/common/camera.hpp"
#include "arlight/common/resample.hpp"
#include "arlight/common/response.hpp"

namespace cv {
class Mat;
}

namespace arlight::sim {

// 8-bit BGR (OpenCV's order) of `camera` turned by `orientation` (camera -> world) inside the
// probe `sampler` samples: code = round(255 response(min(1, radiance x exposure))) per channel,
// every pixel's ray through the pinhole model.
cv::Mat ideal_view(const EnvSampler& sampler, const CameraIntrinsics& camera,
                   const glm::dquat& orientation, double exposure,
                   const CameraResponse& response = CameraResponse::srgb());

}  // namespace arlight::sim
