#include "arlight/render/material.hpp"

#include <opencv2/imgcodecs.hpp>

#include "arlight/error.hpp"

namespace arlight::render {

std::shared_ptr<const TextureImage> make_texture(cv::Mat pixels, bool srgb) {
  const int t = pixels.type();
  if (pixels.empty() || !(t == CV_8UC1 || t == CV_8UC3 || t == CV_8UC4 || t == CV_32FC1 ||
                          t == CV_32FC3))
    throw std::invalid_argument("texture must be a non-empty CV_8UC1/3/4 or CV_32FC1/3 image");
  return std::make_shared<const TextureImage>(TextureImage{std::move(pixels), srgb});
}

std::shared_ptr<const TextureImage> load_texture(const std::filesystem::path& path, bool srgb) {
  cv::Mat m = cv::imread(path.string(), cv::IMREAD_COLOR);  // 8-bit BGR
  if (m.empty()) throw InputError("'" + path.string() + "': cannot read the image");
  return make_texture(std::move(m), srgb);
}

}  // namespace arlight::render
