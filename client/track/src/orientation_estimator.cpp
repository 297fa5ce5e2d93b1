// OrientationEstimator: camera -> world orientation for a webcam, from the marker when it is
// seen and the visual gyro in between.
#include <numbers>

#include "arlight/track/orientation.hpp"

namespace arlight::track {

glm::dquat webcam_world_from_marker() {
  // Marker z -> world +Y, marker y -> world -Z, marker x -> world +X: -90 degrees about x.
  return glm::angleAxis(-0.5 * std::numbers::pi, glm::dvec3(1, 0, 0));
}

OrientationEstimator::OrientationEstimator(const CameraIntrinsics& camera,
                                           const OrientationOptions& options)
    : o_(options), gyro_(camera, options.gyro) {}

void OrientationEstimator::reset() {
  gyro_.reset();
  q_.reset();
  last_fix_ = 0;
}

OrientationEstimate OrientationEstimator::update(const cv::Mat& image, double timestamp,
                                                 const TrackResult* marker) {
  OrientationEstimate e;
  e.gyro = gyro_.update(image);
  // Prediction: the last orientation turned by the image's rotation since the last frame.
  std::optional<glm::dquat> predicted;
  if (q_) predicted = e.gyro.ok ? glm::normalize(*q_ * e.gyro.delta) : *q_;

  if (marker && marker->tracked) {
    // The tracker's camera -> marker orientation (raw: the filter here is the gyro blend).
    const glm::dquat measured =
        glm::normalize(webcam_world_from_marker() * marker->raw.orientation);
    // No prediction, a gyro that lost the image (the prediction is the last frame's) or a
    // large disagreement: the marker alone.
    if (!predicted || !e.gyro.ok || angle_deg(*predicted, measured) > o_.snap_deg) {
      q_ = measured;
    } else {
      // Complementary filter: gyro for the fast part, marker for the absolute orientation.
      q_ = glm::normalize(*predicted * exp_map(o_.marker_weight *
                                               log_map(glm::conjugate(*predicted) * measured)));
    }
    last_fix_ = timestamp;
    e.source = OrientationEstimate::Source::Marker;
  } else if (predicted) {
    q_ = predicted;
    e.source = e.gyro.ok ? OrientationEstimate::Source::Gyro : OrientationEstimate::Source::Stale;
  }
  e.orientation = q_;
  e.since_marker_s = q_ ? timestamp - last_fix_ : 0.0;
  return e;
}

}  // namespace arlight::track
