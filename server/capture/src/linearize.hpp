// Camera frame -> radiance samples (thesis ch. 3; tutorial §4.1): the inverse camera response
// and the exposure give radiance, weights distrust clipped, near-black and border pixels, and
// the weighted radiance is box-reduced to about the environment map's angular resolution.
#pragma once

#include <vector>

#include "arlight/common/camera.hpp"
#include "arlight/common/response.hpp"

namespace cv {
class Mat;
}

namespace arlight::capture {

// A frame reduced by `factor` along each axis. Pixel (i, j) holds the sums over its factor x
// factor block of full-resolution pixels of w * L (3 floats) and w, divided by factor^2, so
// weighted_radiance / weight is the block's weighted mean radiance and weight its mean weight.
struct LinearFrame {
  int width = 0, height = 0, factor = 1;
  std::vector<float> weighted_radiance;
  std::vector<float> weight;
  // Fraction of each block's pixels that are clipped (largest code >= kClippedCode), and how
  // many blocks have any: what the exposure advice looks at (issue 16 §4).
  std::vector<float> clipped;
  int clipped_blocks = 0;
};

inline constexpr int kClippedCode = 250;  // code_weight's clipping end

// The smallest linear value a clipped pixel can have (any channel at kClippedCode): a clipped
// pixel of a frame at exposure x gain E proves its radiance is at least this / E.
float clip_level(const CameraResponse& response);

// Weight of an 8-bit pixel from the largest of its three codes (Debevec-style hat, one-sided
// at each end): 0 towards clipping (>= 250) and towards black (<= 2), 1 in between, with a
// floor of 1e-3 for clipped pixels so that a texel only ever seen clipped still gets its lower
// bound rather than nothing.
float code_weight(int max_code);

// Weight of pixel (x, y) of a width x height image from its distance to the border: rises
// smoothly from 0 at the edge to 1 at 8 % of the smaller side, so frames blend without seams
// and the residual vignetting of the corners counts less.
float border_weight(int x, int y, int width, int height);

// Intrinsics of the same camera with its image reduced by `factor` (a pixel per block, at the
// block's centre): what a LinearFrame of that factor is seen through.
CameraIntrinsics reduced_intrinsics(const CameraIntrinsics& k, int factor);

// Linearises an 8-bit BGR frame (radiance = linear(code) / (exposure * gain)) and reduces it.
LinearFrame linearize(const cv::Mat& bgr8, const CameraResponse& response, double exposure_gain,
                      int factor);

}  // namespace arlight::capture
