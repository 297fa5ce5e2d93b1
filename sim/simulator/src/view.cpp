#include "arlight/sim/view.hpp"

#include <algorithm>
#include <cmath>
#include <opencv2/core.hpp>

namespace arlight::sim {

cv::Mat ideal_view(const EnvSampler& sampler, const CameraIntrinsics& camera,
                   const glm::dquat& orientation, double exposure, const CameraResponse& response) {
  const PinholeCamera cam(camera);
  cv::Mat im(camera.height, camera.width, CV_8UC3);
  for (int y = 0; y < camera.height; ++y)
    for (int x = 0; x < camera.width; ++x) {
      const glm::vec3 l = sampler.sample(orientation * cam.unproject({x, y}));
      for (int c = 0; c < 3; ++c)
        im.at<cv::Vec3b>(y, x)[2 - c] = cv::saturate_cast<uchar>(
            std::lround(255.0f * response.encode(std::min(1.0f, float(l[c] * exposure)), c)));
    }
  return im;
}

}  // namespace arlight::sim
