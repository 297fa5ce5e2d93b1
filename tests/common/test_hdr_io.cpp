#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <random>

#include "arlight/common/hdr_io.hpp"

using namespace arlight;
namespace fs = std::filesystem;

namespace {

class HdrIo : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("arlight_hdr_io_" + std::to_string(::testing::UnitTest::GetInstance()->random_seed()) +
            "_" + ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

Image gradient(int w, int h) {  // channels of different magnitude
  Image img(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) img.set(x, y, {0.5f + x * 0.25f, 0.01f * y, 7.0f});
  return img;
}

// Writes `img` with OpenImageIO in whatever format the extension says (not through arlight).
void write_with_oiio(const fs::path& p, const Image& img, OIIO::TypeDesc type) {
  auto out = OIIO::ImageOutput::create(p.string());
  ASSERT_TRUE(out) << OIIO::geterror();
  OIIO::ImageSpec spec(img.width(), img.height(), 3, type);
  ASSERT_TRUE(out->open(p.string(), spec));
  ASSERT_TRUE(out->write_image(OIIO::TypeDesc::FLOAT, img.data()));
  ASSERT_TRUE(out->close());
}

// A PFM written by hand (OpenImageIO reads PFM but does not write it): bottom row first,
// little-endian floats (negative scale).
void write_pfm(const fs::path& p, const Image& img) {
  std::ofstream f(p, std::ios::binary);
  f << "PF\n" << img.width() << " " << img.height() << "\n-1.0\n";
  for (int y = img.height() - 1; y >= 0; --y)
    f.write(reinterpret_cast<const char*>(img.view().pixel(0, y)),
            std::streamsize(12 * img.width()));
}

std::string error_of(auto&& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  return "(no InputError)";
}

}  // namespace

TEST_F(HdrIo, ExrRoundTripWithMetadata) {
  const Image img = gradient(8, 4);
  ImageMetadata md;
  md.projection = Projection::LatLong;
  md.shininess = 80.0;
  for (int i = 0; i < 9; ++i) md.sh_coefficients.push_back({float(i), -float(i) * 0.5f, 1e-3f * i});
  md.description = "test map";
  for (ExrPixel px : {ExrPixel::Half, ExrPixel::Float}) {
    const fs::path p = dir_ / (px == ExrPixel::Half ? "half.exr" : "float.exr");
    write_exr(p, img.view(), md, px);
    const LoadedImage in = load_image(p);
    EXPECT_EQ(in.format, "openexr");
    ASSERT_EQ(in.image.width(), 8);
    ASSERT_EQ(in.image.height(), 4);
    const float tol = px == ExrPixel::Half ? 2e-3f : 0.0f;
    for (int y = 0; y < 4; ++y)
      for (int x = 0; x < 8; ++x)
        for (int c = 0; c < 3; ++c)
          ASSERT_NEAR(in.image.at(x, y)[c], img.at(x, y)[c], tol * std::abs(img.at(x, y)[c]));
    EXPECT_EQ(in.metadata.projection, Projection::LatLong);
    EXPECT_EQ(in.metadata.shininess, 80.0);
    ASSERT_EQ(in.metadata.sh_coefficients.size(), 9u);
    EXPECT_EQ(in.metadata.sh_coefficients[4][1], -2.0f);
    EXPECT_EQ(in.metadata.description, "test map");
    EXPECT_TRUE(in.sanitized.clean());
  }
  // No temporary files are left behind.
  int files = 0;
  for (auto& e : fs::directory_iterator(dir_)) files += e.is_regular_file();
  EXPECT_EQ(files, 2);
}

TEST_F(HdrIo, WritesASubViewOfALargerImage) {
  const Image img = gradient(8, 4);
  write_exr(dir_ / "tile.exr", img.view().sub(2, 1, 3, 2), {}, ExrPixel::Float);
  const LoadedImage in = load_image(dir_ / "tile.exr");
  ASSERT_EQ(in.image.width(), 3);
  ASSERT_EQ(in.image.height(), 2);
  EXPECT_EQ(in.image.at(0, 0), img.at(2, 1));
  EXPECT_EQ(in.image.at(2, 1), img.at(4, 2));
}

TEST_F(HdrIo, MetadataProjectionOverridesTheShapeGuess) {
  ImageMetadata md;
  md.projection = Projection::Cube;
  write_exr(dir_ / "cube.exr", Image(4, 24).view(), md);
  EXPECT_EQ(load_envmap(dir_ / "cube.exr").env.layout.projection(), Projection::Cube);
  write_exr(dir_ / "plain.exr", Image(8, 4).view());
  EXPECT_EQ(load_envmap(dir_ / "plain.exr").env.layout.projection(), Projection::LatLong);
}

TEST_F(HdrIo, ReadsEveryFormat) {
  Image img(6, 3);
  for (int y = 0; y < 3; ++y)
    for (int x = 0; x < 6; ++x) img.set(x, y, {0.5f + x * 0.25f, 0.4f + 0.1f * y, 1.0f});
  // Float formats keep linear values (RGBE to its shared-exponent precision: 8 mantissa bits
  // against the largest channel, truncated, so ~1.3 % for 0.6 next to 1.75).
  write_with_oiio(dir_ / "a.hdr", img, OIIO::TypeDesc::FLOAT);
  write_with_oiio(dir_ / "a.exr", img, OIIO::TypeDesc::FLOAT);
  write_pfm(dir_ / "a.pfm", img);
  for (const char* name : {"a.hdr", "a.pfm", "a.exr"}) {
    const LoadedImage in = load_image(dir_ / name);
    EXPECT_FALSE(in.decoded_srgb) << name;
    for (int y = 0; y < 3; ++y)
      for (int x = 0; x < 6; ++x)
        for (int c = 0; c < 3; ++c)
          ASSERT_NEAR(in.image.at(x, y)[c], img.at(x, y)[c], 0.015f * img.at(x, y)[c])
              << name << " " << x << "," << y << " (row 0 is the top row)";
  }
  // 8-bit formats hold sRGB-encoded values: 8-bit 188 decodes to linear ~0.5.
  Image grey(4, 4, glm::vec3(188.0f / 255.0f));
  for (const char* name : {"a.png", "a.jpg", "a.webp"}) {
    write_with_oiio(dir_ / name, grey, OIIO::TypeDesc::UINT8);
    const LoadedImage in = load_image(dir_ / name);
    EXPECT_TRUE(in.decoded_srgb) << name;
    EXPECT_NEAR(in.image.at(1, 1).x, 0.5029f, 0.02f) << name;
  }
}

TEST_F(HdrIo, GreyAndGreyAlphaBecomeGreyRgb) {
  for (int channels : {1, 2}) {
    const fs::path p = dir_ / ("grey" + std::to_string(channels) + ".exr");
    auto out = OIIO::ImageOutput::create(p.string());
    ASSERT_TRUE(out);
    OIIO::ImageSpec spec(2, 1, channels, OIIO::TypeDesc::FLOAT);
    const float px[4] = {0.25f, 0.9f, 0.75f, 0.1f};  // (grey[, alpha]) per pixel
    const float grey_only[2] = {0.25f, 0.75f};
    ASSERT_TRUE(out->open(p.string(), spec));
    ASSERT_TRUE(out->write_image(OIIO::TypeDesc::FLOAT, channels == 2 ? px : grey_only));
    ASSERT_TRUE(out->close());
    const LoadedImage in = load_image(p);
    EXPECT_EQ(in.image.at(0, 0), glm::vec3(0.25f)) << channels << " channels";
    EXPECT_EQ(in.image.at(1, 0), glm::vec3(0.75f)) << "alpha must not leak into a colour channel";
  }
}

TEST_F(HdrIo, MissingFileIsNamed) {
  const std::string e = error_of([&] { load_image(dir_ / "nope.exr"); });
  EXPECT_NE(e.find("nope.exr"), std::string::npos);
  EXPECT_NE(e.find("no such file"), std::string::npos);
  EXPECT_NE(error_of([&] { load_image(dir_); }).find("directory"), std::string::npos);
}

TEST_F(HdrIo, TruncatedExrIsAnErrorNotGarbage) {
  Image big(256, 128);
  for (std::size_t i = 0; i < big.storage().size(); ++i) big.storage()[i] = float(i % 977) * 0.01f;
  const fs::path p = dir_ / "trunc.exr";
  write_exr(p, big.view(), {}, ExrPixel::Float);
  fs::resize_file(p, fs::file_size(p) / 2);
  const std::string e = error_of([&] { load_image(p); });
  EXPECT_NE(e.find("trunc.exr"), std::string::npos) << e;
  EXPECT_EQ(e.find("(no InputError)"), std::string::npos) << e;
}

TEST_F(HdrIo, UnsupportedAndCorruptFiles) {
  std::ofstream(dir_ / "notes.txt") << "this is not an image\n";
  std::ofstream(dir_ / "fake.exr") << "not really an exr at all, just text";
  std::ofstream(dir_ / "empty.hdr");
  for (const char* name : {"notes.txt", "fake.exr", "empty.hdr"}) {
    const std::string e = error_of([&] { load_image(dir_ / name); });
    EXPECT_NE(e.find(name), std::string::npos) << e;
    EXPECT_NE(e.find("cannot"), std::string::npos) << e;
  }
}

TEST_F(HdrIo, CorruptedFilesLoadOrFailCleanly) {
  // Deterministically damaged EXR, HDR and PFM files (flipped bytes, cut short): each must
  // either load into finite, non-negative pixels or raise InputError; nothing else.
  Image img(32, 16);
  for (std::size_t i = 0; i < img.storage().size(); ++i) img.storage()[i] = float(i % 37) * 0.3f;
  write_exr(dir_ / "base.exr", img.view());
  write_with_oiio(dir_ / "base.hdr", img, OIIO::TypeDesc::FLOAT);
  write_pfm(dir_ / "base.pfm", img);
  std::mt19937 rng(2024);
  int loaded = 0, refused = 0;
  for (const char* ext : {".exr", ".hdr", ".pfm"}) {
    std::ifstream in(dir_ / ("base" + std::string(ext)), std::ios::binary);
    const std::vector<char> bytes((std::istreambuf_iterator<char>(in)), {});
    for (int round = 0; round < 120; ++round) {
      std::vector<char> b = bytes;
      for (unsigned k = 0; k <= rng() % 8; ++k) b[rng() % b.size()] = char(rng());
      if (round % 3 == 0) b.resize(rng() % b.size());
      const fs::path p = dir_ / ("damaged" + std::string(ext));
      std::ofstream(p, std::ios::binary | std::ios::trunc)
          .write(b.data(), std::streamsize(b.size()));
      try {
        const LoadedImage r = load_image(p);
        for (float v : r.image.storage()) ASSERT_TRUE(v >= 0.0f && std::isfinite(v));
        ++loaded;
      } catch (const InputError& e) {
        ASSERT_NE(std::string(e.what()).find("damaged"), std::string::npos) << e.what();
        ++refused;
      }
    }
  }
  EXPECT_GT(refused, 50);  // most damage is detected...
  EXPECT_GT(loaded, 10);   // ...and a flipped pixel byte still loads (then gets sanitised)
}

TEST_F(HdrIo, WrongShapeForAnEnvironmentMap) {
  write_exr(dir_ / "odd.exr", Image(30, 20).view());
  EXPECT_NE(error_of([&] { load_envmap(dir_ / "odd.exr"); }).find("not an environment map shape"),
            std::string::npos);
  write_exr(dir_ / "wide.exr", Image(64, 32).view());
  const std::string e = error_of([&] { load_envmap(dir_ / "wide.exr", Projection::AngleMap); });
  EXPECT_NE(e.find("anglemap must be square"), std::string::npos) << e;
  EXPECT_NE(e.find("64x32"), std::string::npos) << e;
}

TEST_F(HdrIo, OversizedImagesAreRefusedBeforeReading) {
  write_exr(dir_ / "big.exr", Image(64, 32).view());
  LoadOptions opts;
  opts.max_pixels = 1000;
  EXPECT_NE(error_of([&] { load_image(dir_ / "big.exr", opts); }).find("larger than the limit"),
            std::string::npos);
}

TEST_F(HdrIo, NanInfAndNegativeValuesAreCountedAndZeroed) {
  Image img(4, 2, glm::vec3(1.0f));
  img.set(0, 0, {-2.5f, 1.0f, 1.0f});
  img.set(1, 0, {std::numeric_limits<float>::quiet_NaN(), 1.0f, -0.5f});
  img.set(2, 1,
          {std::numeric_limits<float>::infinity(), -std::numeric_limits<float>::infinity(), 1.0f});
  write_exr(dir_ / "bad.exr", img.view(), {}, ExrPixel::Float);
  const LoadedImage in = load_image(dir_ / "bad.exr");
  EXPECT_EQ(in.sanitized.negative, 2u);
  EXPECT_EQ(in.sanitized.nan, 1u);
  EXPECT_EQ(in.sanitized.inf, 2u);
  EXPECT_EQ(in.sanitized.most_negative, -2.5f);
  EXPECT_EQ(in.image.at(0, 0).x, 0.0f);
  EXPECT_EQ(in.image.at(1, 0).x, 0.0f);
  EXPECT_EQ(in.image.at(2, 1).y, 0.0f);
  EXPECT_EQ(in.image.at(3, 1).x, 1.0f) << "good values are untouched";
  EXPECT_NE(in.sanitized.summary().find("2 negative"), std::string::npos);
  LoadOptions strict;
  strict.strict = true;
  EXPECT_NE(error_of([&] { load_image(dir_ / "bad.exr", strict); }).find("1 NaN"),
            std::string::npos);
}

TEST_F(HdrIo, RealProbeWithNegativeValues) {
  // studio.exr (Poly Haven via @pmndrs/assets) holds values down to about -149 from lossy DWAB.
  const fs::path probe = fs::path(ARLIGHT_SOURCE_DIR) / "data/probes/studio.exr";
  const LoadedEnvMap env = load_envmap(probe);
  EXPECT_EQ(env.env.layout.projection(), Projection::LatLong);
  EXPECT_GT(env.info.sanitized.negative, 100u);
  EXPECT_LT(env.info.sanitized.most_negative, -100.0f);
  for (float v : env.env.image.storage()) ASSERT_GE(v, 0.0f);
}

TEST_F(HdrIo, EverySharedProbeLoadsCleanlyAfterSanitising) {
  // ../shared/probes holds 18 real probes, several with negative values; skipped without it.
  const fs::path shared = fs::path(ARLIGHT_SOURCE_DIR) / "../shared/probes";
  if (!fs::is_directory(shared)) GTEST_SKIP() << shared << " is not present";
  int probes = 0;
  for (const auto& e : fs::directory_iterator(shared)) {
    if (e.path().extension() != ".exr") continue;
    const LoadedEnvMap env = load_envmap(e.path());
    EXPECT_EQ(env.env.layout.projection(), Projection::LatLong) << e.path();
    for (float v : env.env.image.storage()) ASSERT_TRUE(v >= 0.0f && std::isfinite(v)) << e.path();
    ++probes;
  }
  EXPECT_GE(probes, 10);
}

TEST_F(HdrIo, FailedWriteLeavesTheOldFileIntact) {
  const fs::path p = dir_ / "keep.exr";
  write_exr(p, gradient(8, 4).view());
  const auto before = fs::file_size(p);
  ImageMetadata bad;
  bad.sh_coefficients.resize(5);  // not a square count
  EXPECT_THROW(write_exr(p, Image(8, 4).view(), bad), std::invalid_argument);
  EXPECT_EQ(fs::file_size(p), before);
  EXPECT_NEAR(load_image(p).image.at(7, 0).x, 2.25f, 1e-3f);
}

TEST_F(HdrIo, PngPreviewIsTonemapped8Bit) {
  Image img(4, 1);
  img.set(0, 0, {0, 0, 0});
  img.set(1, 0, {1, 1, 1});
  img.set(2, 0, {1000, 1000, 1000});
  img.set(3, 0, {std::numeric_limits<float>::quiet_NaN(), 0, 0});
  write_png_preview(dir_ / "p.png", img.view(), PreviewOptions{0.0});
  auto in = OIIO::ImageInput::open((dir_ / "p.png").string());
  ASSERT_TRUE(in);
  EXPECT_EQ(in->spec().format, OIIO::TypeDesc::UINT8);
  unsigned char px[12];
  ASSERT_TRUE(in->read_image(0, 0, 0, 3, OIIO::TypeDesc::UINT8, px));
  EXPECT_EQ(px[0], 0);
  EXPECT_EQ(px[3], 188);  // 1 / (1 + 1) = 0.5 linear -> sRGB 188
  EXPECT_GE(px[6], 254);
  EXPECT_EQ(px[9], 0);  // NaN shows black
}

// OpenEXR 3.1 allocates a header attribute at its claimed size before reading it: a tiny file
// claiming a 1.7 GB string ran the fuzzer out of memory. It is refused first, naming the
// attribute (the fuzzer's input is kept in tests/fuzz/corpus/hdr_image/ too).
TEST(ExrHeader, AnAttributeLargerThanTheFileIsRefusedBeforeOpenExrAllocatesIt) {
  const std::filesystem::path file =
      std::filesystem::temp_directory_path() / "arlight_exr_huge_attribute.exr";
  std::string bytes = {'\x76', '\x2f', '\x31', '\x01', '\x02', '\x00', '\x00', '\x00'};
  bytes += std::string("capDate") + '\0' + "string" + '\0';
  const std::int32_t claimed = 1761607700;
  bytes.append(reinterpret_cast<const char*>(&claimed), 4);
  bytes += "2026:12:02 03:27:00";
  std::ofstream(file, std::ios::binary) << bytes;
  try {
    load_envmap(file);
    FAIL() << "loaded an EXR whose attribute claims 1.7 GB";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("'capDate' (string) claims 1761607700 bytes"),
              std::string::npos)
        << e.what();
  }
}

// libpng allocates a text chunk at its claimed size: the fuzzer's 279-byte PNG claiming a
// 1.6 GB tEXt chunk ran it out of memory. It is refused first, naming the chunk; a whole PNG
// loads.
TEST(PngChunks, AChunkLongerThanTheFileIsRefusedBeforeLibpngAllocatesIt) {
  std::ifstream in(std::filesystem::path(ARLIGHT_SOURCE_DIR) /
                       "tests/fuzz/corpus/hdr_image/"
                       "oom-png-huge-chunk-c272803cfc32195a2183a46ea8231c6c5b336e37",
                   std::ios::binary);
  const std::string input((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  ASSERT_GT(input.size(), 100u);
  const std::filesystem::path file =
      std::filesystem::temp_directory_path() / "arlight_png_huge_chunk.png";
  std::ofstream(file, std::ios::binary) << input.substr(1);  // its first byte chose ".png"
  try {
    load_envmap(file);
    FAIL() << "loaded a PNG whose chunk claims 1.6 GB";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("PNG chunk tEXt claims 1610612756 bytes"),
              std::string::npos)
        << e.what();
  }
  const std::filesystem::path whole =
      std::filesystem::temp_directory_path() / "arlight_png_whole.png";
  Image img(8, 4);
  img.set(3, 2, glm::vec3(0.5f));
  write_png_preview(whole, img.view(), {});
  EXPECT_EQ(load_envmap(whole).env.image.width(), 8);
}
