#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

#include "arlight/common/error.hpp"
#include "arlight/render/opencv.hpp"

namespace arlight::render {

ImageU8View view_of(const cv::Mat& image) {
  if (image.depth() != CV_8U || image.empty())
    throw std::invalid_argument("an 8-bit image is needed, not OpenCV type " +
                                std::to_string(image.type()));
  return {image.data, image.cols, image.rows, image.channels(), std::ptrdiff_t(image.step[0])};
}

void composite(Renderer& renderer, const cv::Mat& frame_bgr, const ToneMapping& tone,
               cv::Mat& out_bgr) {
  if (frame_bgr.type() != CV_8UC3)
    throw std::invalid_argument("composite: the camera frame must be 8-bit BGR (CV_8UC3)");
  out_bgr.create(frame_bgr.rows, frame_bgr.cols, CV_8UC3);  // continuous when it allocates
  if (!out_bgr.isContinuous()) out_bgr = cv::Mat(frame_bgr.rows, frame_bgr.cols, CV_8UC3);
  renderer.composite(view_of(frame_bgr), tone, std::span(out_bgr.data, out_bgr.total() * 3));
}

std::shared_ptr<const TextureImage> make_texture(const cv::Mat& pixels, bool srgb) {
  const int t = pixels.type();
  if (pixels.empty() ||
      !(t == CV_8UC1 || t == CV_8UC3 || t == CV_8UC4 || t == CV_32FC1 || t == CV_32FC3))
    throw std::invalid_argument("texture must be a non-empty CV_8UC1/3/4 or CV_32FC1/3 image");
  cv::Mat rgb;  // the renderer's order: R, G, B(, A)
  if (pixels.channels() == 3)
    cv::cvtColor(pixels, rgb, cv::COLOR_BGR2RGB);
  else if (pixels.channels() == 4)
    cv::cvtColor(pixels, rgb, cv::COLOR_BGRA2RGBA);
  else
    rgb = pixels.isContinuous() ? pixels : pixels.clone();
  if (rgb.depth() == CV_8U) return make_texture(view_of(rgb), srgb);
  const float* f = rgb.ptr<float>();
  return make_texture(rgb.cols, rgb.rows, rgb.channels(),
                      std::vector<float>(f, f + rgb.total() * rgb.channels()));
}

std::shared_ptr<const TextureImage> load_texture(const std::filesystem::path& path, bool srgb) {
  cv::Mat m = cv::imread(path.string(), cv::IMREAD_COLOR);  // 8-bit BGR
  if (m.empty()) throw InputError("'" + path.string() + "': cannot read the image");
  return make_texture(m, srgb);
}

}  // namespace arlight::render
