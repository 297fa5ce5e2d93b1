#include "linearize.hpp"

#include <algorithm>
#include <array>
#include <opencv2/core.hpp>

namespace arlight::capture {

namespace {

float smoothstep(float a, float b, float x) {
  const float t = std::clamp((x - a) / (b - a), 0.0f, 1.0f);
  return t * t * (3.0f - 2.0f * t);
}

// The border weight along one axis of n pixels: 0 at the edge, 1 from `ramp` pixels inwards.
float border_axis(int i, int n, float ramp) {
  const float d = std::min(float(i) + 0.5f, float(n) - float(i) - 0.5f);  // centre to edge
  return smoothstep(0.0f, ramp, d);
}

float border_ramp(int width, int height) { return 0.08f * float(std::min(width, height)); }

}  // namespace

float code_weight(int max_code) {
  const float low = smoothstep(2.0f, 24.0f, float(max_code));
  const float high = 1.0f - smoothstep(230.0f, float(kClippedCode), float(max_code));
  return std::max(low * high, max_code >= kClippedCode ? 1e-3f : 0.0f);
}

float border_weight(int x, int y, int width, int height) {
  const float ramp = border_ramp(width, height);
  return border_axis(x, width, ramp) * border_axis(y, height, ramp);
}

float clip_level(const CameraResponse& response) {
  float level = 1.0f;
  for (int c = 0; c < 3; ++c) level = std::min(level, float(response.linear(kClippedCode, c)));
  return level;
}

CameraIntrinsics reduced_intrinsics(const CameraIntrinsics& k, int factor) {
  CameraIntrinsics r = k;
  r.width = (k.width + factor - 1) / factor;
  r.height = (k.height + factor - 1) / factor;
  r.fx = k.fx / factor, r.fy = k.fy / factor;
  r.cx = (k.cx - 0.5 * (factor - 1)) / factor;
  r.cy = (k.cy - 0.5 * (factor - 1)) / factor;
  return r;
}

LinearFrame linearize(const cv::Mat& bgr8, const CameraResponse& response, double exposure_gain,
                      int factor) {
  CV_Assert(bgr8.type() == CV_8UC3 && factor >= 1 && exposure_gain > 0);
  const int w = bgr8.cols, h = bgr8.rows;
  LinearFrame out;
  out.factor = factor;
  out.width = (w + factor - 1) / factor;
  out.height = (h + factor - 1) / factor;
  out.weighted_radiance.assign(std::size_t(out.width) * out.height * 3, 0.0f);
  out.weight.assign(std::size_t(out.width) * out.height, 0.0f);
  out.clipped.assign(std::size_t(out.width) * out.height, 0.0f);

  // Radiance of each code per RGB channel, and the weight of each code.
  std::array<std::array<float, 256>, 3> radiance{};
  std::array<float, 256> weight_of_code{};
  for (int c = 0; c < 256; ++c) {
    for (int ch = 0; ch < 3; ++ch)
      radiance[std::size_t(ch)][std::size_t(c)] = float(response.linear(c, ch) / exposure_gain);
    weight_of_code[std::size_t(c)] = code_weight(c);
  }
  // The border weight is a product of one profile per axis (border_weight is separable).
  const float ramp = border_ramp(w, h);
  std::vector<float> wx(static_cast<std::size_t>(w)), wy(static_cast<std::size_t>(h));
  for (int x = 0; x < w; ++x) wx[std::size_t(x)] = border_axis(x, w, ramp);
  for (int y = 0; y < h; ++y) wy[std::size_t(y)] = border_axis(y, h, ramp);

  const float norm = 1.0f / float(factor * factor);
  for (int y = 0; y < h; ++y) {
    const float row_w = wy[std::size_t(y)] * norm;
    const std::uint8_t* row = bgr8.ptr<std::uint8_t>(y);
    float* acc = out.weighted_radiance.data() + std::size_t(y / factor) * out.width * 3;
    float* acc_w = out.weight.data() + std::size_t(y / factor) * out.width;
    float* acc_clipped = out.clipped.data() + std::size_t(y / factor) * out.width;
    for (int bx = 0; bx < out.width; ++bx) {
      float sr = 0.0f, sg = 0.0f, sb = 0.0f, sw = 0.0f;  // the block's row, in registers
      int clipped = 0;
      for (int x = bx * factor, end = std::min(w, x + factor); x < end; ++x) {
        const std::uint8_t b = row[3 * x], g = row[3 * x + 1], r = row[3 * x + 2];
        const std::uint8_t top = std::max({b, g, r});
        const float wt = weight_of_code[top] * wx[std::size_t(x)];
        sr += wt * radiance[0][r];
        sg += wt * radiance[1][g];
        sb += wt * radiance[2][b];
        sw += wt;
        clipped += top >= kClippedCode;
      }
      acc[3 * bx] += row_w * sr;
      acc[3 * bx + 1] += row_w * sg;
      acc[3 * bx + 2] += row_w * sb;
      acc_w[bx] += row_w * sw;
      acc_clipped[bx] += norm * float(clipped);
    }
  }
  for (const float c : out.clipped) out.clipped_blocks += c > 0.0f;
  return out;
}

}  // namespace arlight::capture
