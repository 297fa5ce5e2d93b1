#include "jpeg_decode.hpp"

// jpeglib.h needs size_t and FILE declared first.
#include <jerror.h>
#include <jpeglib.h>

#include <csetjmp>
#include <cstddef>
#include <cstdio>

namespace arlight::capture {

namespace {

// libjpeg reports fatal errors through error_exit, which must not return: it jumps back to
// decode_into (C frames cannot be unwound by a C++ exception).
struct ErrorManager {
  jpeg_error_mgr base;
  std::jmp_buf jump;
  char message[JMSG_LENGTH_MAX];
  bool truncated;
};

void on_error(j_common_ptr info) {
  auto* e = reinterpret_cast<ErrorManager*>(info->err);
  (*info->err->format_message)(info, e->message);
  std::longjmp(e->jump, 1);
}

void on_message(j_common_ptr info, int level) {
  auto* e = reinterpret_cast<ErrorManager*>(info->err);
  if (level < 0 && info->err->msg_code == JWRN_JPEG_EOF) e->truncated = true;
}

// The part that may jump back: `image` belongs to the caller, so no object of this frame is
// changed between setjmp and a longjmp.
bool decode_into(std::span<const std::uint8_t> bytes, std::span<const JpegSize> sizes,
                 std::size_t& which, ErrorManager& err, jpeg_decompress_struct& info,
                 cv::Mat& image) {
  if (setjmp(err.jump)) return false;
  jpeg_create_decompress(&info);
  jpeg_mem_src(&info, bytes.data(), static_cast<unsigned long>(bytes.size()));
  jpeg_read_header(&info, TRUE);
  // Checked before anything is allocated: the header alone could ask for gigabytes.
  which = 0;
  while (which < sizes.size() && (int(info.image_width) != sizes[which].width ||
                                  int(info.image_height) != sizes[which].height))
    ++which;
  if (which == sizes.size()) {
    const JpegSize& full = sizes.front();
    std::snprintf(err.message, sizeof err.message,
                  "image is %ux%u, the camera's intrinsics say %dx%d%s", info.image_width,
                  info.image_height, full.width, full.height,
                  sizes.size() > 1 ? " (or that reduced by a power of two)" : "");
    return false;
  }
  info.out_color_space = JCS_EXT_BGR;
  info.scale_num = 1;
  info.scale_denom = static_cast<unsigned>(sizes[which].scale);
  jpeg_start_decompress(&info);
  image.create(static_cast<int>(info.output_height), static_cast<int>(info.output_width), CV_8UC3);
  while (info.output_scanline < info.output_height && !err.truncated) {
    JSAMPROW row = image.ptr<JSAMPLE>(static_cast<int>(info.output_scanline));
    jpeg_read_scanlines(&info, &row, 1);
  }
  if (err.truncated) {
    std::snprintf(err.message, sizeof err.message, "the JPEG data ends early (truncated)");
    return false;
  }
  jpeg_finish_decompress(&info);
  return true;
}

}  // namespace

cv::Mat decode_jpeg_bgr(std::span<const std::uint8_t> bytes, std::span<const JpegSize> sizes,
                        std::size_t& which, std::string& error) {
  if (bytes.empty()) {
    error = "no data";
    return {};
  }
  jpeg_decompress_struct info{};
  ErrorManager err{};
  info.err = jpeg_std_error(&err.base);
  err.base.error_exit = on_error;
  err.base.emit_message = on_message;
  cv::Mat image;
  const bool ok = decode_into(bytes, sizes, which, err, info, image);
  jpeg_destroy_decompress(&info);
  if (!ok) {
    error = err.message;
    return {};
  }
  return image;
}

}  // namespace arlight::capture
