// Fuzz target: an environment map or probe as the tools and the daemon load it (OpenImageIO:
// EXR, Radiance HDR, PNG, ...). load_envmap must refuse what it cannot use with an InputError;
// what it accepts is finite and non-negative (sanitised), of a projection's shape.
#include <cmath>

#include "arlight/common/error.hpp"
#include "arlight/common/hdr_io.hpp"
#include "fuzz_support.hpp"

using namespace arlight;
namespace fs = std::filesystem;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  // OpenImageIO picks the reader by the file's extension first: the first byte chooses it.
  static const char* kExtensions[] = {".exr", ".hdr", ".png", ".pfm", ".tif"};
  if (size == 0) return 0;
  const fs::path file = fuzz::scratch() / (std::string("image") + kExtensions[data[0] % 5]);
  fuzz::write_file(file, std::string_view(reinterpret_cast<const char*>(data + 1), size - 1));
  LoadOptions options;
  options.max_pixels = 1u << 20;  // a fuzzer's memory limit; the refusal path is the same
  try {
    const LoadedEnvMap env = load_envmap(file, std::nullopt, options);
    for (float v : env.env.image.storage())
      if (!std::isfinite(v) || v < 0) fuzz::finding("a loaded map holds a non-finite or negative value");
  } catch (const InputError& e) {
    fuzz::refused(e);
  }
  return 0;
}

FuzzSeeds arlight_fuzz_seeds() {
  Image img(8, 4);
  for (int y = 0; y < 4; ++y)
    for (int x = 0; x < 8; ++x) img.set(x, y, glm::vec3(x * 0.5f, y * 2.0f, 100.0f));
  const auto with_extension = [](std::uint8_t which, const std::string& bytes) {
    std::vector<std::uint8_t> seed = {which};
    seed.insert(seed.end(), bytes.begin(), bytes.end());
    return seed;
  };
  FuzzSeeds seeds;
  write_exr(fuzz::scratch() / "seed.exr", img.view());
  seeds.push_back(with_extension(0, fuzz::read_file(fuzz::scratch() / "seed.exr")));
  write_exr(fuzz::scratch() / "seed-float.exr", img.view(), {}, ExrPixel::Float);
  seeds.push_back(with_extension(0, fuzz::read_file(fuzz::scratch() / "seed-float.exr")));
  write_png_preview(fuzz::scratch() / "seed.png", img.view());
  seeds.push_back(with_extension(2, fuzz::read_file(fuzz::scratch() / "seed.png")));
  // Radiance RGBE, flat scanlines (Ward's format: a header, a blank line, the resolution).
  std::string hdr = "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 4 +X 8\n";
  for (int i = 0; i < 32; ++i) hdr += std::string{char(128), char(64 + i), char(32), char(129)};
  seeds.push_back(with_extension(1, hdr));
  return seeds;
}
