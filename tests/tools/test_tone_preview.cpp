// tools/preview (arlight_tone_preview): the local tone-mapping operators of the tools' previews
// against common/'s global curve.
#include <gtest/gtest.h>

#include <cstdint>
#include <cstdlib>
#include <optional>
#include <vector>

#include "arlight/common/error.hpp"
#include "arlight/common/image.hpp"
#include "arlight/preview/tone_preview.hpp"

using namespace arlight;

// Tutorial §9: a room whose range no global curve holds — a dim wall with a pattern at 0.01
// and a lit window with a pattern at 100 (13 stops apart). At the auto exposure Reinhard's
// global x/(1+x) leaves each side's pattern a few codes; the local operators keep more.
TEST(PreviewTone, LocalOperatorsKeepDetailInTheShadowsAndTheLights) {
  Image img(128, 64);
  for (int y = 0; y < 64; ++y)
    for (int x = 0; x < 128; ++x) {
      const float base = x < 64 ? 0.01f : 100.0f, stripe = (x / 4 + y / 4) % 2 ? 1.5f : 0.67f;
      img.set(x, y, glm::vec3(base * stripe));
    }
  // The pattern's contrast in codes: the mean absolute code difference between neighbouring
  // stripes, inside each half (away from the edge between them).
  const auto detail = [&](PreviewTone tone, bool bright) {
    const std::vector<std::uint8_t> px = tone_preview_pixels(img.view(), {std::nullopt, tone});
    double sum = 0;
    int n = 0;
    for (int y = 8; y < 56; ++y)
      for (int x = bright ? 72 : 8; x < (bright ? 120 : 56); ++x) {
        sum += std::abs(int(px[(std::size_t(y) * 128 + x) * 3 + 1]) -
                        int(px[(std::size_t(y) * 128 + x + 4) * 3 + 1]));
        ++n;
      }
    return sum / n;
  };
  // Measured: global 5 and 5 codes; Drago 10 and 12; Reinhard & Devlin 51 and 20; Mantiuk
  // 0 and 37 (it gives up the dark side of so bare a pair, not of a real room's).
  const double global_worst =
      std::min(detail(PreviewTone::Global, false), detail(PreviewTone::Global, true));
  EXPECT_LE(global_worst, 6.0);
  for (const PreviewTone tone : {PreviewTone::Drago, PreviewTone::Reinhard})
    EXPECT_GE(std::min(detail(tone, false), detail(tone, true)), 2 * global_worst)
        << preview_tone_name(tone);
  EXPECT_GT(detail(PreviewTone::Mantiuk, true), 5 * detail(PreviewTone::Global, true));
  EXPECT_EQ(parse_preview_tone("mantiuk"), PreviewTone::Mantiuk);
  EXPECT_THROW(parse_preview_tone("aces"), InputError);
}
