// Native-only bridges between OpenCV and the renderer: camera frames and composites as cv::Mat,
// textures from image files (PNG, JPEG, WebP, ... through OpenCV) or from matrices. The
// renderer's core never includes this; the browser build leaves it out.
#pragma once

#include <filesystem>
#include <memory>
#include <opencv2/core/mat.hpp>

#include "arlight/common/image_u8.hpp"
#include "arlight/render/render.hpp"

namespace arlight::render {

// A view of an 8-bit matrix (no copy); std::invalid_argument for another depth.
ImageU8View view_of(const cv::Mat& image);

// Renderer::composite with OpenCV matrices: `frame_bgr` CV_8UC3 of the renderer's size, `out_bgr`
// (re)allocated only when its size or type differs.
void composite(Renderer& renderer, const cv::Mat& frame_bgr, const ToneMapping& tone,
               cv::Mat& out_bgr);

// A texture from a matrix in OpenCV's channel order: CV_8UC1/3/4 (gray, BGR, BGRA) or
// CV_32FC1/3 (gray, BGR, linear).
std::shared_ptr<const TextureImage> make_texture(const cv::Mat& pixels, bool srgb);

// Reads an image file; throws arlight::InputError naming the file when it cannot be read.
std::shared_ptr<const TextureImage> load_texture(const std::filesystem::path& path, bool srgb);

}  // namespace arlight::render
