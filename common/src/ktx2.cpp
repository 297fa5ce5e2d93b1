// KTX 2.0 cube maps (Khronos KTX 2.0 specification, §3 file structure, §4 DFD).
#include "arlight/common/ktx2.hpp"

#include <Imath/half.h>

#include <algorithm>
#include <array>
#include <cstring>
#include <stdexcept>

#include "arlight/common/error.hpp"

namespace arlight {

namespace {

constexpr std::array<std::uint8_t, 12> kIdentifier = {0xAB, 'K', 'T', 'X', ' ', '2',
                                                      '0',  0xBB, '\r', '\n', 0x1A, '\n'};
constexpr std::uint32_t kVkFormatR32G32B32A32Sfloat = 109;
constexpr std::size_t kHeaderBytes = 80;  // identifier, header, index

void put32(std::vector<std::uint8_t>& out, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) out.push_back(std::uint8_t(v >> (8 * i)));
}
void pad_to(std::vector<std::uint8_t>& out, std::size_t align) {
  while (out.size() % align) out.push_back(0);
}
void set32(std::vector<std::uint8_t>& out, std::size_t at, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) out[at + std::size_t(i)] = std::uint8_t(v >> (8 * i));
}
void set64(std::vector<std::uint8_t>& out, std::size_t at, std::uint64_t v) {
  for (int i = 0; i < 8; ++i) out[at + std::size_t(i)] = std::uint8_t(v >> (8 * i));
}

// The basic data format descriptor of RGBA16F, linear BT.709 (KDF 1.3 §5).
std::vector<std::uint8_t> dfd_rgba16f() {
  std::vector<std::uint8_t> d;
  constexpr std::uint16_t kBlockBytes = 24 + 16 * 4;
  put32(d, 4 + kBlockBytes);  // dfdTotalSize
  put32(d, 0);                // vendorId 0 (Khronos), descriptorType 0 (basic)
  d.push_back(2), d.push_back(0);  // versionNumber 2 (KDF 1.3)
  d.push_back(std::uint8_t(kBlockBytes)), d.push_back(0);
  d.push_back(1);  // colorModel KHR_DF_MODEL_RGBSDA
  d.push_back(1);  // colorPrimaries KHR_DF_PRIMARIES_BT709
  d.push_back(1);  // transferFunction KHR_DF_TRANSFER_LINEAR
  d.push_back(0);  // flags: straight alpha
  for (int i = 0; i < 4; ++i) d.push_back(0);  // texelBlockDimension 1x1x1x1 (stored minus 1)
  d.push_back(8);                              // bytesPlane0: 8 bytes a texel
  for (int i = 0; i < 7; ++i) d.push_back(0);
  const std::uint8_t channels[4] = {0, 1, 2, 15};  // R, G, B, A
  for (int s = 0; s < 4; ++s) {
    d.push_back(std::uint8_t(16 * s)), d.push_back(0);  // bitOffset
    d.push_back(15);                                     // bitLength - 1
    d.push_back(std::uint8_t(channels[s] | 0x80 | 0x40));  // float, signed
    put32(d, 0);                                         // samplePosition
    put32(d, 0xBF800000u);                               // sampleLower: -1.0f
    put32(d, 0x3F800000u);                               // sampleUpper: 1.0f
  }
  return d;
}

void check_chain(std::span<const EnvMap> levels) {
  if (levels.empty()) throw std::invalid_argument("KTX2 cube: no levels");
  const int face = levels[0].layout.face_size();
  for (std::size_t k = 0; k < levels.size(); ++k) {
    const EnvLayout& l = levels[k].layout;
    if (l.projection() != Projection::Cube || l.face_size() != std::max(1, face >> k))
      throw std::invalid_argument("KTX2 cube: level " + std::to_string(k) + " is not a cube of face " +
                                  std::to_string(std::max(1, face >> k)));
  }
}

}  // namespace

std::vector<std::uint8_t> encode_ktx2_cube(std::span<const EnvMap> levels,
                                           const Ktx2KeyValues& key_values) {
  check_chain(levels);
  const auto face = std::uint32_t(levels[0].layout.face_size());
  const auto count = std::uint32_t(levels.size());
  std::vector<std::uint8_t> out(kIdentifier.begin(), kIdentifier.end());
  put32(out, kVkFormatR16G16B16A16Sfloat);
  put32(out, 2);  // typeSize
  put32(out, face), put32(out, face), put32(out, 0);  // width, height, depth
  put32(out, 0);      // layerCount (not an array)
  put32(out, 6);      // faceCount
  put32(out, count);  // levelCount
  put32(out, 0);      // supercompressionScheme
  const std::size_t index_at = out.size();
  out.resize(out.size() + 4 * 4 + 2 * 8);  // dfd, kvd offsets/lengths; sgd offset/length
  const std::size_t levels_at = out.size();
  out.resize(out.size() + 24 * std::size_t(count));

  const std::size_t dfd_at = out.size();
  const auto dfd = dfd_rgba16f();
  out.insert(out.end(), dfd.begin(), dfd.end());
  set32(out, index_at, std::uint32_t(dfd_at));
  set32(out, index_at + 4, std::uint32_t(dfd.size()));

  Ktx2KeyValues kv = key_values;
  kv.emplace_back("KTXwriter", "arlight");
  std::sort(kv.begin(), kv.end());
  const std::size_t kvd_at = out.size();
  for (const auto& [key, value] : kv) {
    put32(out, std::uint32_t(key.size() + 1 + value.size() + 1));
    out.insert(out.end(), key.begin(), key.end());
    out.push_back(0);
    out.insert(out.end(), value.begin(), value.end());
    out.push_back(0);
    pad_to(out, 4);
  }
  set32(out, index_at + 8, std::uint32_t(kvd_at));
  set32(out, index_at + 12, std::uint32_t(out.size() - kvd_at));

  // Mip data from the smallest level to the largest, each aligned to 8 (the texel size).
  for (std::size_t k = levels.size(); k-- > 0;) {
    pad_to(out, 8);
    const std::size_t at = out.size();
    const float* src = levels[k].image.data();
    const std::size_t texels = levels[k].image.texel_count();  // six faces stacked
    for (std::size_t t = 0; t < texels; ++t)
      for (int c = 0; c < 4; ++c) {
        const Imath::half h(c < 3 ? src[3 * t + std::size_t(c)] : 1.0f);
        const std::uint16_t bits = h.bits();
        out.push_back(std::uint8_t(bits)), out.push_back(std::uint8_t(bits >> 8));
      }
    const std::size_t bytes = out.size() - at;
    set64(out, levels_at + 24 * k, at);
    set64(out, levels_at + 24 * k + 8, bytes);
    set64(out, levels_at + 24 * k + 16, bytes);
  }
  return out;
}

Ktx2Cube decode_ktx2_cube(std::span<const std::uint8_t> b) {
  auto fail = [](const std::string& what) { throw InputError("KTX2: " + what); };
  auto get32 = [&](std::size_t at) {
    if (at + 4 > b.size()) fail("truncated at byte " + std::to_string(at));
    std::uint32_t v = 0;
    for (int i = 3; i >= 0; --i) v = (v << 8) | b[at + std::size_t(i)];
    return v;
  };
  auto get64 = [&](std::size_t at) { return std::uint64_t(get32(at)) | (std::uint64_t(get32(at + 4)) << 32); };
  if (b.size() < kHeaderBytes || !std::equal(kIdentifier.begin(), kIdentifier.end(), b.begin()))
    fail("not a KTX 2.0 file (identifier missing)");
  const std::uint32_t format = get32(12), type_size = get32(16), width = get32(20),
                      height = get32(24), depth = get32(28), layers = get32(32), faces = get32(36),
                      count = get32(40), scheme = get32(44);
  if (format != kVkFormatR16G16B16A16Sfloat && format != kVkFormatR32G32B32A32Sfloat)
    fail("vkFormat " + std::to_string(format) + " is not RGBA16F (97) or RGBA32F (109)");
  const std::size_t texel_bytes = format == kVkFormatR16G16B16A16Sfloat ? 8 : 16;
  if (type_size != texel_bytes / 4) fail("typeSize " + std::to_string(type_size) + " does not match the format");
  if (faces != 6 || width != height || depth != 0 || layers != 0)
    fail("not a cube map (faces " + std::to_string(faces) + ", " + std::to_string(width) + "x" +
         std::to_string(height) + ", depth " + std::to_string(depth) + ", layers " + std::to_string(layers) + ")");
  if (width == 0 || width > 16384) fail("face size " + std::to_string(width) + " out of range");
  if (count == 0 || count > 15 || (width >> (count - 1)) == 0)
    fail("levelCount " + std::to_string(count) + " does not fit face " + std::to_string(width));
  if (scheme != 0) fail("supercompression scheme " + std::to_string(scheme) + " is not supported");
  Ktx2Cube cube;
  const std::uint32_t kvd_at = get32(56), kvd_len = get32(60);
  if (std::uint64_t(kvd_at) + kvd_len > b.size()) fail("key/value data beyond the end of the file");
  for (std::size_t at = kvd_at; at + 4 <= std::size_t(kvd_at) + kvd_len;) {
    const std::uint32_t len = get32(at);
    if (at + 4 + len > std::size_t(kvd_at) + kvd_len) fail("a key/value entry overruns its block");
    const char* p = reinterpret_cast<const char*>(b.data() + at + 4);
    const std::string_view entry(p, len);
    const auto nul = entry.find('\0');
    if (nul == std::string_view::npos) fail("a key without its terminating NUL");
    std::string value(entry.substr(nul + 1));
    if (!value.empty() && value.back() == '\0') value.pop_back();
    cube.key_values.emplace_back(std::string(entry.substr(0, nul)), std::move(value));
    at += 4 + ((len + 3) & ~3u);
  }
  for (std::uint32_t k = 0; k < count; ++k) {
    const std::uint64_t at = get64(kHeaderBytes + 24 * k), len = get64(kHeaderBytes + 24 * k + 8);
    const std::size_t face = std::max<std::uint32_t>(1, width >> k);
    const std::size_t want = 6 * face * face * texel_bytes;
    if (len != want) fail("level " + std::to_string(k) + " holds " + std::to_string(len) + " bytes, not " + std::to_string(want));
    if (at + len > b.size()) fail("level " + std::to_string(k) + " lies beyond the end of the file");
    EnvMap level(EnvLayout(Projection::Cube, int(face), int(6 * face)));
    float* dst = level.image.data();
    for (std::size_t t = 0; t < 6 * face * face; ++t)
      for (int c = 0; c < 3; ++c) {
        const std::uint8_t* src = b.data() + at + t * texel_bytes;
        if (texel_bytes == 8) {
          Imath::half h;
          h.setBits(std::uint16_t(src[2 * c] | (src[2 * c + 1] << 8)));
          dst[3 * t + std::size_t(c)] = float(h);
        } else {
          std::memcpy(&dst[3 * t + std::size_t(c)], src + 4 * c, 4);
        }
      }
    cube.levels.push_back(std::move(level));
  }
  return cube;
}

}  // namespace arlight
