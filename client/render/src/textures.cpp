#include "textures.hpp"

#include <algorithm>
#include <vector>

namespace arlight::render {

namespace {

// Gray, RGB or RGBA texels as RGBA (alpha 1 where there was none).
template <class T>
std::vector<T> to_rgba(const std::vector<T>& src, std::size_t texels, int channels, T one) {
  std::vector<T> rgba(texels * 4, one);
  for (std::size_t i = 0; i < texels; ++i)
    for (int c = 0; c < 4; ++c)
      if (c < 3 || channels == 4) rgba[4 * i + c] = src[i * channels + (channels == 1 ? 0 : c)];
  return rgba;
}

}  // namespace

GLenum env_target(Projection p) {
  return p == Projection::Cube ? GL_TEXTURE_CUBE_MAP : GL_TEXTURE_2D;
}

void upload_env(const EnvMap& env, gl::Texture& tex, int& width, int& height) {
  const GLenum target = env_target(env.layout.projection());
  const bool fresh = tex.id == 0 || width != env.layout.width() || height != env.layout.height();
  if (fresh) {
    tex = gl::Texture();
    tex.create();
  }
  glBindTexture(target, tex.id);
  glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
  glPixelStorei(GL_UNPACK_ROW_LENGTH, 0);
  const int w = env.layout.width(), h = env.layout.height();
  // RGBA: llvmpipe fetches 3-channel formats through a slow generic path.
  const std::vector<float> rgba = to_rgba(env.image.storage(), env.image.texel_count(), 3, 1.0f);
  if (target == GL_TEXTURE_CUBE_MAP) {
    const int n = env.layout.face_size();
    for (int f = 0; f < 6; ++f) {
      const float* face = rgba.data() + std::size_t(f) * n * n * 4;
      if (fresh)
        glTexImage2D(GL_TEXTURE_CUBE_MAP_POSITIVE_X + GLenum(f), 0, GL_RGBA16F, n, n, 0, GL_RGBA,
                     GL_FLOAT, face);
      else
        glTexSubImage2D(GL_TEXTURE_CUBE_MAP_POSITIVE_X + GLenum(f), 0, 0, 0, n, n, GL_RGBA,
                        GL_FLOAT, face);
    }
    gl::set_sampling(target, GL_LINEAR, GL_CLAMP_TO_EDGE, GL_CLAMP_TO_EDGE);
  } else {
    if (fresh)
      glTexImage2D(target, 0, GL_RGBA16F, w, h, 0, GL_RGBA, GL_FLOAT, rgba.data());
    else
      glTexSubImage2D(target, 0, 0, 0, w, h, GL_RGBA, GL_FLOAT, rgba.data());
    const bool latlong = env.layout.projection() == Projection::LatLong;
    gl::set_sampling(target, GL_LINEAR, latlong ? GL_REPEAT : GL_CLAMP_TO_EDGE, GL_CLAMP_TO_EDGE);
  }
  glTexParameteri(target, GL_TEXTURE_MAX_LEVEL, 0);
  width = w, height = h;
  gl::check("uploading an environment map");
}

gl::Texture upload_ggx_chain(const std::vector<EnvMap>& levels) {
  gl::Texture tex;
  tex.create();
  glBindTexture(GL_TEXTURE_CUBE_MAP, tex.id);
  glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
  glPixelStorei(GL_UNPACK_ROW_LENGTH, 0);
  for (std::size_t k = 0; k < levels.size(); ++k) {
    const EnvMap& m = levels[k];
    const int n = m.layout.face_size();
    const std::vector<float> rgba = to_rgba(m.image.storage(), m.image.texel_count(), 3, 1.0f);
    for (int f = 0; f < 6; ++f)
      glTexImage2D(GL_TEXTURE_CUBE_MAP_POSITIVE_X + GLenum(f), GLint(k), GL_RGBA16F, n, n, 0,
                   GL_RGBA, GL_FLOAT, rgba.data() + std::size_t(f) * n * n * 4);
  }
  gl::set_sampling(GL_TEXTURE_CUBE_MAP, GL_LINEAR, GL_CLAMP_TO_EDGE, GL_CLAMP_TO_EDGE);
  glTexParameteri(GL_TEXTURE_CUBE_MAP, GL_TEXTURE_MIN_FILTER, GL_LINEAR_MIPMAP_LINEAR);
  glTexParameteri(GL_TEXTURE_CUBE_MAP, GL_TEXTURE_BASE_LEVEL, 0);
  glTexParameteri(GL_TEXTURE_CUBE_MAP, GL_TEXTURE_MAX_LEVEL, GLint(levels.size()) - 1);
  gl::check("uploading a GGX chain");
  return tex;
}

gl::Texture upload_dfg(const DfgTable& table) {
  const int size = table.size;
  gl::Texture tex;
  tex.create();
  glBindTexture(GL_TEXTURE_2D, tex.id);
  glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
  glPixelStorei(GL_UNPACK_ROW_LENGTH, 0);
  std::vector<float> rgba(std::size_t(size) * std::size_t(size) * 4, 1.0f);
  for (int j = 0; j < size; ++j) {
    const float average = float(table.average_albedo(j));
    for (int i = 0; i < size; ++i) {
      float* t = &rgba[4 * (std::size_t(j) * std::size_t(size) + std::size_t(i))];
      t[0] = table.at(i, j).x, t[1] = table.at(i, j).y, t[2] = average;
    }
  }
  glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA16F, size, size, 0, GL_RGBA, GL_FLOAT, rgba.data());
  gl::set_sampling(GL_TEXTURE_2D, GL_LINEAR, GL_CLAMP_TO_EDGE, GL_CLAMP_TO_EDGE);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAX_LEVEL, 0);
  gl::check("uploading the DFG table");
  return tex;
}

gl::Texture upload_pixel_texture(std::array<std::uint8_t, 4> rgba) {
  gl::Texture tex;
  tex.create();
  glBindTexture(GL_TEXTURE_2D, tex.id);
  glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA8, 1, 1, 0, GL_RGBA, GL_UNSIGNED_BYTE, rgba.data());
  gl::set_sampling(GL_TEXTURE_2D, GL_NEAREST, GL_REPEAT, GL_REPEAT);
  return tex;
}

gl::Texture upload_material_texture(const TextureImage& image) {
  const std::size_t texels = std::size_t(image.width) * image.height;
  const bool is_float = !image.f32.empty();
  const std::vector<float> rgba_f =
      is_float ? to_rgba(image.f32, texels, image.channels, 1.0f) : std::vector<float>{};
  const std::vector<std::uint8_t> rgba_u8 =
      is_float ? std::vector<std::uint8_t>{}
               : to_rgba(image.u8, texels, image.channels, std::uint8_t(255));
  gl::Texture tex;
  tex.create();
  glBindTexture(GL_TEXTURE_2D, tex.id);
  glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
  glPixelStorei(GL_UNPACK_ROW_LENGTH, 0);
  if (is_float)
    glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA16F, image.width, image.height, 0, GL_RGBA, GL_FLOAT,
                 rgba_f.data());
  else
    glTexImage2D(GL_TEXTURE_2D, 0, image.srgb ? GL_SRGB8_ALPHA8 : GL_RGBA8, image.width,
                 image.height, 0, GL_RGBA, GL_UNSIGNED_BYTE, rgba_u8.data());
  glGenerateMipmap(GL_TEXTURE_2D);
  gl::set_sampling(GL_TEXTURE_2D, GL_LINEAR, GL_REPEAT, GL_REPEAT);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR_MIPMAP_LINEAR);
  gl::check("uploading a material texture");
  return tex;
}

void upload_response_lut(const CameraResponse& response, gl::Texture& tex) {
  std::vector<float> lut(std::size_t(kResponseLutSize) * 4, 1.0f);
  for (int i = 0; i < kResponseLutSize; ++i) {
    const float t = float(i) / float(kResponseLutSize - 1);
    for (int c = 0; c < 3; ++c)
      lut[std::size_t(i) * 4 + std::size_t(c)] = response.encode(t * t, c);
  }
  tex.create();
  glBindTexture(GL_TEXTURE_2D, tex.id);
  glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
  glPixelStorei(GL_UNPACK_ROW_LENGTH, 0);
  glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA32F, kResponseLutSize, 1, 0, GL_RGBA, GL_FLOAT, lut.data());
  gl::set_sampling(GL_TEXTURE_2D, GL_NEAREST, GL_CLAMP_TO_EDGE, GL_CLAMP_TO_EDGE);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAX_LEVEL, 0);
  gl::check("uploading the camera response table");
}

void upload_response_inverse(const CameraResponse& response, gl::Texture& tex) {
  std::vector<float> lut(256 * 4, 1.0f);
  for (int code = 0; code < 256; ++code)
    for (int c = 0; c < 3; ++c)
      lut[std::size_t(code) * 4 + std::size_t(c)] = response.linear(code, c);
  tex.create();
  glBindTexture(GL_TEXTURE_2D, tex.id);
  glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
  glPixelStorei(GL_UNPACK_ROW_LENGTH, 0);
  glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA32F, 256, 1, 0, GL_RGBA, GL_FLOAT, lut.data());
  gl::set_sampling(GL_TEXTURE_2D, GL_NEAREST, GL_CLAMP_TO_EDGE, GL_CLAMP_TO_EDGE);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAX_LEVEL, 0);
  gl::check("uploading the inverse camera response table");
}

}  // namespace arlight::render
