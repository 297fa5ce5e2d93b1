// The image-quality figures (sim/eval): PSNR and SSIM in masks against values worked out by
// hand, and the visible-differences predictor's behaviour (what a viewer sees and what is
// hidden by the image's own contrast).
#include <gtest/gtest.h>

#include <cmath>
#include <glm/geometric.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "arlight/common/error.hpp"
#include "arlight/eval/eval.hpp"

namespace {

using namespace arlight::eval;

cv::Mat noise_image(int seed, double mean, double sigma) {
  cv::Mat m(120, 160, CV_8UC3);
  cv::RNG rng(seed);
  rng.fill(m, cv::RNG::NORMAL, cv::Scalar::all(mean), cv::Scalar::all(sigma));
  return m;
}

TEST(MaskedQuality, PsnrCountsOnlyTheMaskedPixels) {
  const cv::Mat ref = noise_image(1, 120, 20);
  cv::Mat test = ref.clone();
  cv::Mat mask = cv::Mat::zeros(ref.size(), CV_8U);
  mask(cv::Rect(10, 10, 50, 40)).setTo(255);
  // +4 codes inside the mask (every value stays in range: clamp-safe by construction), 30
  // codes off outside it, which must not count.
  cv::Mat inside = test(cv::Rect(10, 10, 50, 40));
  inside.forEach<cv::Vec3b>([](cv::Vec3b& p, const int*) {
    for (int c = 0; c < 3; ++c)
      p[c] = cv::saturate_cast<std::uint8_t>(std::min(250, int(p[c])) + 4);
  });
  cv::Mat ref_clamped = ref.clone();
  ref_clamped(cv::Rect(10, 10, 50, 40)).forEach<cv::Vec3b>([](cv::Vec3b& p, const int*) {
    for (int c = 0; c < 3; ++c) p[c] = std::uint8_t(std::min(250, int(p[c])));
  });
  test(cv::Rect(100, 60, 40, 40)) += cv::Scalar::all(30);
  const MaskedQuality q = masked_quality(ref_clamped, test, mask);
  EXPECT_EQ(q.pixels, 2000u);
  EXPECT_NEAR(q.psnr_db, 10 * std::log10(255.0 * 255.0 / 16.0), 1e-9);  // 36.09 dB
  EXPECT_DOUBLE_EQ(masked_quality(ref, ref, mask).psnr_db, 100.0);      // identical
  EXPECT_EQ(masked_quality(ref, test, cv::Mat::zeros(ref.size(), CV_8U)).pixels, 0u);
}

TEST(MaskedQuality, SsimOfTwoFlatImagesIsTheLuminanceTerm) {
  // No variance: SSIM = (2ab + C1) / (a^2 + b^2 + C1), C1 = (0.01 x 255)^2 (Wang et al. 2004).
  const cv::Mat a(64, 64, CV_8UC3, cv::Scalar::all(100)), b(64, 64, CV_8UC3, cv::Scalar::all(120));
  const double c1 = std::pow(0.01 * 255, 2);
  const double expected = (2 * 100.0 * 120 + c1) / (100.0 * 100 + 120.0 * 120 + c1);  // 0.98368
  const MaskedQuality q = masked_quality(a, b, cv::Mat(a.size(), CV_8U, cv::Scalar(255)));
  EXPECT_NEAR(q.ssim, expected, 1e-4);
  EXPECT_NEAR(masked_quality(a, a, cv::Mat(a.size(), CV_8U, cv::Scalar(255))).ssim, 1.0, 1e-9);
  // Structure: an image against its negative around the same mean is far from 1.
  const cv::Mat n = noise_image(2, 128, 30), inverted = cv::Scalar::all(255) - n;
  EXPECT_LT(masked_quality(n, inverted, cv::Mat(n.size(), CV_8U, cv::Scalar(255))).ssim, 0.0);
}

TEST(MaskedQuality, RejectsMismatchedImages) {
  const cv::Mat a(10, 10, CV_8UC3), b(10, 12, CV_8UC3), m(10, 10, CV_8U);
  EXPECT_THROW(masked_quality(a, b, m), arlight::InputError);
  EXPECT_THROW(masked_quality(a, a, cv::Mat(10, 10, CV_8UC3)), arlight::InputError);
}

TEST(VisibleDifferences, SeesAStrongPatchAndNothingInIdenticalImages) {
  const cv::Mat ref(120, 160, CV_8UC3, cv::Scalar::all(110));
  EXPECT_EQ(visible_differences(ref, ref, 30).fraction_seen, 0.0);
  cv::Mat test = ref.clone();
  test(cv::Rect(60, 40, 40, 40)).setTo(cv::Scalar::all(170));
  cv::Mat patch = cv::Mat::zeros(ref.size(), CV_8U);
  patch(cv::Rect(60, 40, 40, 40)).setTo(255);
  const VisibleDifferences vd = visible_differences(ref, test, 30, patch);
  EXPECT_GT(vd.fraction_seen, 0.9);
  // Far from the patch nothing is predicted.
  EXPECT_LT(vd.probability.at<float>(5, 5), 0.05f);
}

TEST(VisibleDifferences, TheImagesOwnContrastMasksADifference) {
  // The same +-6 code noise is plain on a flat grey wall and hidden in a busy texture.
  const cv::Mat flat(120, 160, CV_8UC3, cv::Scalar::all(120));
  const cv::Mat busy = noise_image(3, 120, 45);
  cv::Mat noise(120, 160, CV_16SC3);
  cv::RNG(4).fill(noise, cv::RNG::UNIFORM, cv::Scalar::all(-6), cv::Scalar::all(7));
  const auto add = [&](const cv::Mat& m) {
    cv::Mat wide, out;
    m.convertTo(wide, CV_16SC3);
    cv::Mat(wide + noise).convertTo(out, CV_8UC3);
    return out;
  };
  const double on_flat = visible_differences(flat, add(flat), 30).fraction_seen,
               on_busy = visible_differences(busy, add(busy), 30).fraction_seen;
  EXPECT_GT(on_flat, 0.5);
  EXPECT_LT(on_busy, 0.5 * on_flat);
}

TEST(VisibleDifferences, FineDetailIsHarderToSeeWhenItIsSmallerOnTheRetina) {
  // A one-pixel checkerboard of +-1 code (1.7 % contrast) on grey: at 16 pixels per degree it
  // is 8 cycles per degree, where the eye is most sensitive (threshold 0.4 %); at 60 pixels per
  // degree it is 30 cycles per degree, where the threshold is ~2 %.
  const cv::Mat ref(96, 96, CV_8UC3, cv::Scalar::all(120));
  cv::Mat test = ref.clone();
  test.forEach<cv::Vec3b>([](cv::Vec3b& p, const int* pos) {
    p = cv::Vec3b::all(std::uint8_t((pos[0] + pos[1]) % 2 ? 121 : 119));
  });
  EXPECT_GT(visible_differences(ref, test, 16).fraction_seen, 0.9);
  EXPECT_LT(visible_differences(ref, test, 60).fraction_seen, 0.1);
}

// The sphere protocol: a room, the same room twice as bright, and the room turned.
arlight::EnvMap room_with_a_lamp(glm::dvec3 lamp) {
  arlight::EnvMap env(arlight::EnvLayout(arlight::Projection::LatLong, 128, 64));
  lamp = glm::normalize(lamp);
  for (int y = 0; y < 64; ++y)
    for (int x = 0; x < 128; ++x) {
      const glm::dvec3 d = env.layout.texel_dir(x, y);
      // A sky brighter above, and a lamp of ~10 degrees radius.
      const float sky = float(0.2 + 0.1 * d.y),
                  lamp_radiance = glm::dot(d, lamp) > 0.985 ? 40.0f : 0.0f;
      env.image.set(x, y, glm::vec3(sky + lamp_radiance, sky + 0.8f * lamp_radiance, sky));
    }
  return env;
}

TEST(SphereScores, AreZeroForTheTruthAndScaleFreeInSiRmse) {
  const arlight::EnvMap room = room_with_a_lamp({1, 1, -1});
  const LightingScore same = score_lighting(room, room);
  EXPECT_NEAR(same.diffuse.rmse, 0.0, 1e-9);
  EXPECT_NEAR(same.mirror.si_rmse, 0.0, 1e-9);
  EXPECT_NEAR(same.dominant_light_deg, 0.0, 1e-3);
  // Twice as bright: every image doubles, so the RMSE (relative to the true image's mean) is
  // the true image's RMS over its mean, >= 1, and the scale-invariant RMSE is 0.
  arlight::EnvMap bright = room;
  for (float& v : bright.image.storage()) v *= 2;
  const LightingScore twice = score_lighting(room, bright);
  for (const SphereScore& s : {twice.diffuse, twice.matte_silver, twice.mirror}) {
    EXPECT_GE(s.rmse, 1.0 - 1e-6);
    EXPECT_NEAR(s.si_rmse, 0.0, 1e-6);
  }
  EXPECT_NEAR(twice.dominant_light_deg, 0.0, 1e-3);
}

TEST(SphereScores, AMovedLampIsAnAngleAndAnError) {
  // The lamp 40 degrees further round the horizon: the dominant light turns by about that
  // much (the sky's own gradient pulls it a little up), and the spheres disagree.
  const double a = std::atan2(1.0, 1.0), b = a + 40.0 * M_PI / 180.0;
  const arlight::EnvMap truth = room_with_a_lamp({std::cos(a), 0.3, -std::sin(a)}),
                        moved = room_with_a_lamp({std::cos(b), 0.3, -std::sin(b)});
  const LightingScore s = score_lighting(truth, moved);
  EXPECT_NEAR(s.dominant_light_deg, 40.0, 4.0);
  EXPECT_GT(s.diffuse.si_rmse, 0.05);
  EXPECT_GT(s.mirror.si_rmse, s.diffuse.si_rmse);  // a mirror shows the lamp itself
  const arlight::EnvMap dark(arlight::EnvLayout(arlight::Projection::LatLong, 16, 8));
  EXPECT_THROW(score_lighting(dark, truth), arlight::InputError);
}

}  // namespace
