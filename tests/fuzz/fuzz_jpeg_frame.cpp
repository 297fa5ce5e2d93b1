// Fuzz target: a camera frame's JPEG bytes as the capture library takes them from a client
// (CaptureSession::add_encoded: libjpeg through OpenCV, with the DCT-domain half-size decode).
// A frame that cannot be used comes back with used = false and a reason; it never throws.
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "arlight/capture/capture.hpp"
#include "fuzz_support.hpp"

using namespace arlight;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static capture::CaptureSession session = [] {
    capture::CaptureOptions options;
    options.layout = EnvLayout::for_size(Projection::AngleMap, 32);
    options.align = false;
    return capture::CaptureSession(CameraIntrinsics::from_fov(64, 48, 60), CameraResponse::srgb(),
                                   options);
  }();
  FrameInfo info;
  info.exposure = 1.0 / 60;
  const capture::FrameResult r = session.add_encoded({data, size}, info);
  if (!r.used && r.skipped_reason.empty()) fuzz::finding("a frame was refused without a reason");
  return 0;
}

FuzzSeeds arlight_fuzz_seeds() {
  cv::Mat image(48, 64, CV_8UC3);
  for (int y = 0; y < 48; ++y)
    for (int x = 0; x < 64; ++x) image.at<cv::Vec3b>(y, x) = cv::Vec3b(x * 4, y * 5, 128);
  FuzzSeeds seeds;
  for (int quality : {50, 95}) {
    std::vector<std::uint8_t> jpeg;
    cv::imencode(".jpg", image, jpeg, {cv::IMWRITE_JPEG_QUALITY, quality});
    seeds.push_back(jpeg);
  }
  std::vector<std::uint8_t> progressive;
  cv::imencode(".jpg", image, progressive, {cv::IMWRITE_JPEG_PROGRESSIVE, 1});
  seeds.push_back(progressive);
  return seeds;
}
