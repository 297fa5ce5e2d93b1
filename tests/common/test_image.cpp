#include <gtest/gtest.h>

#include "arlight/common/image.hpp"

using namespace arlight;

namespace {

Image ramp(int w, int h) {
  Image img(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) img.set(x, y, {float(x), float(y), float(x * 10 + y)});
  return img;
}

double mean_channel(const Image& img, int c) {
  double s = 0;
  for (int y = 0; y < img.height(); ++y)
    for (int x = 0; x < img.width(); ++x) s += img.at(x, y)[c];
  return s / double(img.texel_count());
}

}  // namespace

TEST(Image, ViewsAddressSubRectangles) {
  Image img = ramp(8, 4);
  ImageView sub = img.view().sub(2, 1, 3, 2);
  EXPECT_EQ(sub.width, 3);
  EXPECT_EQ(sub.at(0, 0), glm::vec3(2, 1, 21)) << "sub-view origin";
  sub.set(2, 1, {-1, -1, -1});
  EXPECT_EQ(img.at(4, 2), glm::vec3(-1, -1, -1)) << "writes through a view reach the image";
  EXPECT_THROW(img.view().sub(6, 0, 3, 1), std::out_of_range);
  const Image copy = copy_image(sub);
  EXPECT_EQ(copy.width(), 3);
  EXPECT_EQ(copy.at(2, 1), glm::vec3(-1, -1, -1));
  EXPECT_EQ(copy.at(0, 0), glm::vec3(2, 1, 21));
  EXPECT_THROW(Image(-1, 2), std::invalid_argument);
}

TEST(Image, BilinearIsExactAtTexelCentresAndLinearBetween) {
  Image img = ramp(5, 3);
  EXPECT_EQ(sample_bilinear(img.view(), 2.5, 1.5), glm::vec3(2, 1, 21));
  const glm::vec3 mid = sample_bilinear(img.view(), 3.0, 1.5);  // halfway between x=2 and x=3
  EXPECT_FLOAT_EQ(mid.x, 2.5f);
  const glm::vec3 q = sample_bilinear(img.view(), 2.75, 2.0);
  EXPECT_FLOAT_EQ(q.x, 2.25f);
  EXPECT_FLOAT_EQ(q.y, 1.5f);
  // Clamp holds the edge texel; wrap blends the last column with the first.
  EXPECT_FLOAT_EQ(sample_bilinear(img.view(), 0.0, 1.5).x, 0.0f);
  EXPECT_FLOAT_EQ(sample_bilinear(img.view(), 0.0, 1.5, Edge::Wrap).x, 2.0f);  // (4 + 0) / 2
}

TEST(Image, DownsampleEvenSizeIsBoxMean) {
  Image img = ramp(4, 2);
  Image half = downsample2x(img.view());
  ASSERT_EQ(half.width(), 2);
  ASSERT_EQ(half.height(), 1);
  EXPECT_FLOAT_EQ(half.at(0, 0).x, 0.5f);
  EXPECT_FLOAT_EQ(half.at(1, 0).x, 2.5f);
  EXPECT_FLOAT_EQ(half.at(1, 0).y, 0.5f);
}

TEST(Image, DownsampleOddSizeKeepsTheAreaMean) {
  // 5 texels -> 3, each output covering 5/3 input texels: the mean must be preserved exactly
  // and the middle output texel must be the symmetric mix 1/3, 1, 1/3 of inputs 1, 2, 3.
  Image img = ramp(5, 7);
  Image half = downsample2x(img.view());
  ASSERT_EQ(half.width(), 3);
  ASSERT_EQ(half.height(), 4);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(mean_channel(half, c), mean_channel(img, c), 1e-5);
  EXPECT_NEAR(half.at(1, 0).x, (1.0 / 3 * 1 + 1.0 * 2 + 1.0 / 3 * 3) / (5.0 / 3), 1e-6);
}

TEST(Image, WeightedDownsampleIgnoresZeroWeightTexels) {
  Image img(2, 2, glm::vec3(1.0f));
  img.set(1, 1, {100, 100, 100});
  const float w[4] = {1, 1, 1, 0};
  std::vector<float> out_w;
  Image half = downsample2x(img.view(), w, &out_w);
  EXPECT_FLOAT_EQ(half.at(0, 0).x, 1.0f);
  EXPECT_FLOAT_EQ(out_w[0], 3.0f);
}

TEST(Image, MipPyramidEndsInTheMean) {
  Image img = ramp(12, 5);
  auto levels = build_mip_pyramid(img);
  // 12x5 -> 6x3 -> 3x2 -> 2x1 -> 1x1
  ASSERT_EQ(levels.size(), 5u);
  EXPECT_EQ(levels[2].width(), 3);
  EXPECT_EQ(levels[2].height(), 2);
  const Image& top = levels.back();
  ASSERT_EQ(top.width() * top.height(), 1);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(top.at(0, 0)[c], mean_channel(img, c), 1e-4);
}
