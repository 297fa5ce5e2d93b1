// Map tiles on the wire (issue 36 §2): what a map set costs a browser's link in each coding, and
// its encode and decode time. The page has no zstd: its tiles travel as raw half floats that the
// WebSocket's permessage-deflate compresses (Beast's deflate at arlightd's level 3, memLevel 4,
// one stream per connection with a sync flush per message, as websocket_transport.cpp sets it
// up). Against it: the same half floats split into byte planes per channel with OpenEXR's ZIP
// predictor (lossless: TileCoding::Planar, what the page takes now), and RGB9E5 (GL's shared-exponent format, 4 bytes a texel, lossy: 9-bit
// mantissas under the texel's largest channel) — and zstd of halves and of the planes (what
// native clients got, and get now). The sets:
// venice's 8 thesis maps at 128² and its GGX chain from face 256 to 16, in 64² tiles.
#include <benchmark/benchmark.h>


#include <algorithm>
#include <array>
#include <string>
#include <boost/beast/zlib/deflate_stream.hpp>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <vector>

#include "arlight/common/hdr_io.hpp"
#include "arlight/common/resample.hpp"
#include "arlight/lighting/ggx.hpp"
#include "arlight/lighting/lighting.hpp"
#include "arlight/protocol/wire.hpp"

using namespace arlight;
namespace zlib = boost::beast::zlib;

namespace {

using Tile = std::vector<float>;  // RGB, 64x64 or smaller

std::vector<Tile> tiles_of(const std::vector<EnvMap>& maps) {
  std::vector<Tile> out;
  for (const EnvMap& m : maps)
    for (int y = 0; y < m.image.height(); y += 64)
      for (int x = 0; x < m.image.width(); x += 64) {
        const int w = std::min(64, m.image.width() - x), h = std::min(64, m.image.height() - y);
        Tile t(std::size_t(w) * h * 3);
        for (int r = 0; r < h; ++r)
          std::memcpy(&t[std::size_t(r) * w * 3], m.image.view().pixel(x, y + r),
                      sizeof(float) * 3 * std::size_t(w));
        out.push_back(std::move(t));
      }
  return out;
}

const std::vector<Tile>& set_tiles(int which) {
  static const std::array<std::vector<Tile>, 2> sets = [] {
    const EnvMap env = load_envmap(std::string(ARLIGHT_SOURCE_DIR) + "/data/probes/venice.exr").env;
    const EnvLayout layout = EnvLayout::for_size(Projection::AngleMap, 128);
    const std::vector<double> shininess = {1, 10, 20, 40, 80, 160, 320, 1280};
    const auto phong = lighting::compute_maps(resample(env, layout), shininess, layout,
                                              lighting::parse_method("auto"));
    const auto chain = lighting::compute_ggx_chain(
        resample(env, EnvLayout::for_size(Projection::Cube, 256)), {.face = 256, .min_face = 16});
    std::vector<EnvMap> levels;
    for (const auto& l : chain.levels) levels.push_back(l.map);
    return std::array{tiles_of(phong.maps), tiles_of(levels)};
  }();
  return sets[which];
}

std::vector<std::uint8_t> half_bytes(const Tile& t) {
  return wire::encode_half_rgb(t.data(), t.size() / 3, wire::TileCoding::Half);
}

// EXT_texture_shared_exponent's packing: 9-bit mantissas, a shared 5-bit exponent (bias 15).
std::vector<std::uint8_t> rgb9e5(const Tile& t) {
  const std::size_t n = t.size() / 3;
  std::vector<std::uint8_t> out(n * 4);
  constexpr float kMax = 65408.0f;  // (2^9 - 1) / 2^9 * 2^16
  for (std::size_t i = 0; i < n; ++i) {
    float c[3];
    for (int k = 0; k < 3; ++k) c[k] = std::clamp(t[3 * i + std::size_t(k)], 0.0f, kMax);
    const float m = std::max({c[0], c[1], c[2]});
    int e = std::max(-16, int(std::floor(std::log2(std::max(m, 1e-30f))))) + 1 + 15;
    if (int(std::floor(m / std::ldexp(1.0f, e - 15 - 9) + 0.5f)) == 512) ++e;
    const float scale = std::ldexp(1.0f, e - 15 - 9);
    std::uint32_t v = std::uint32_t(e) << 27;
    for (int k = 0; k < 3; ++k) v |= std::uint32_t(std::floor(c[k] / scale + 0.5f)) << (9 * k);
    std::memcpy(&out[4 * i], &v, 4);
  }
  return out;
}

Tile rgb9e5_decode(const std::vector<std::uint8_t>& in) {
  Tile t(in.size() / 4 * 3);
  for (std::size_t i = 0; i < in.size() / 4; ++i) {
    std::uint32_t v;
    std::memcpy(&v, &in[4 * i], 4);
    const float scale = std::ldexp(1.0f, int(v >> 27) - 15 - 9);
    for (int k = 0; k < 3; ++k) t[3 * i + std::size_t(k)] = float((v >> (9 * k)) & 511u) * scale;
  }
  return t;
}

// permessage-deflate as arlightd runs it: one stream, a sync flush after each message.
struct Deflater {
  zlib::deflate_stream stream;
  std::vector<std::uint8_t> out;
  Deflater() { stream.reset(3, 15, 4, zlib::Strategy::normal); }
  std::size_t message(const std::vector<std::uint8_t>& in) {
    out.resize(stream.upper_bound(in.size()) + 16);
    zlib::z_params z;
    z.next_in = in.data(), z.avail_in = in.size();
    z.next_out = out.data(), z.avail_out = out.size();
    boost::system::error_code ec;
    stream.write(z, zlib::Flush::sync, ec);
    return z.total_out - 4;  // the flush's empty block's 00 00 ff ff is not sent
  }
};

enum Coding { HalfDeflate, PlanarDeflate, Rgb9e5Deflate, Zstd, PlanarZstd };

void BM_MapSetCoding(benchmark::State& state) {
  const auto& tiles = set_tiles(int(state.range(0)));
  const auto coding = Coding(state.range(1));
  std::size_t bytes = 0, raw = 0;
  double max_error = 0;
  for (auto _ : state) {
    Deflater deflate;
    bytes = raw = 0;
    for (const Tile& t : tiles) {
      std::vector<std::uint8_t> data;
      Tile back;
      std::string why;
      switch (coding) {
        case HalfDeflate:
          data = half_bytes(t);
          bytes += deflate.message(data);
          back = *wire::decode_half_rgb(data, t.size() / 3, wire::TileCoding::Half, why);
          break;
        case PlanarDeflate:
          data = wire::encode_half_rgb(t.data(), t.size() / 3, wire::TileCoding::Planar);
          bytes += deflate.message(data);
          back = *wire::decode_half_rgb(data, t.size() / 3, wire::TileCoding::Planar, why);
          break;
        case Rgb9e5Deflate:
          data = rgb9e5(t);
          bytes += deflate.message(data);
          back = rgb9e5_decode(data);
          break;
        case PlanarZstd:
          data = wire::encode_half_rgb(t.data(), t.size() / 3, wire::TileCoding::ZstdPlanar);
          bytes += data.size();
          back = *wire::decode_half_rgb(data, t.size() / 3, wire::TileCoding::ZstdPlanar, why);
          break;
        case Zstd:
          data = wire::encode_half_rgb(t.data(), t.size() / 3, wire::TileCoding::ZstdHalf);
          bytes += data.size();
          back = *wire::decode_half_rgb(data, t.size() / 3, wire::TileCoding::ZstdHalf, why);
          break;
      }
      raw += t.size() * 2;
      for (std::size_t i = 0; i < t.size(); i += 3) {  // relative to the texel's largest channel
        const float m = std::max({t[i], t[i + 1], t[i + 2], 1e-6f});
        for (int k = 0; k < 3; ++k)
          max_error = std::max(max_error, double(std::abs(back[i + std::size_t(k)] - t[i + std::size_t(k)]) / m));
      }
      benchmark::DoNotOptimize(back.data());
    }
  }
  state.counters["set_kB"] = double(bytes) / 1e3;
  state.counters["half_kB"] = double(raw) / 1e3;
  state.counters["max_rel_error"] = max_error;
  static const char* names[] = {"half+deflate (the page before)", "Planar+deflate (the page now)",
                                "RGB9E5+deflate", "ZstdHalf (native clients before)",
                                "ZstdPlanar (native clients now)"};
  static const char* sets[] = {"8 Phong maps at 128²", "GGX chain 256 -> 16"};
  state.SetLabel(std::string(sets[state.range(0)]) + ": " + names[coding]);
}

}  // namespace

BENCHMARK(BM_MapSetCoding)->ArgsProduct({{0, 1}, {HalfDeflate, PlanarDeflate, Rgb9e5Deflate, Zstd, PlanarZstd}})
    ->Unit(benchmark::kMillisecond);
