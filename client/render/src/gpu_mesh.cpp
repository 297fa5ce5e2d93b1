#include <algorithm>
#include <cmath>
#include <cstring>

#include "arlight/render/render.hpp"
#include "gl.hpp"

namespace arlight::render {

// One buffer holding the attribute arrays one after the other (positions, normals, uvs,
// tangents, occlusion, transfer), locations 0-4 as in ibl.vert and the transfer's three vec3s at
// 5-7 (interleaved, 9 floats a vertex); absent ones read constant defaults.
GpuMesh::GpuMesh(const Mesh& mesh) {
  const std::size_t n = mesh.positions.size();
  if (n == 0 || mesh.normals.size() != n || mesh.indices.empty())
    throw std::invalid_argument("GpuMesh: the mesh needs positions, one normal each, and indices");
  has_uvs_ = mesh.uvs.size() == n;
  has_tangents_ = has_uvs_ && mesh.tangents.size() == n;
  has_occlusion_ = mesh.occlusion.size() == n;
  has_transfer_ = mesh.transfer.size() == n * kTransferCoefficients;
  bounds_ = mesh.bounds;
  index_count_ = mesh.indices.size();
  parts_ = mesh.parts.empty() ? std::vector<MeshPart>{{0, std::uint32_t(index_count_), -1}} : mesh.parts;
  for (const MeshPart& p : parts_)
    if (std::size_t(p.first_index) + p.index_count > index_count_)
      throw std::invalid_argument("GpuMesh: a part reaches beyond the mesh's indices");
  const std::size_t pos_bytes = n * sizeof(glm::vec3),
                    uv_bytes = has_uvs_ ? n * sizeof(glm::vec2) : 0,
                    tan_bytes = has_tangents_ ? n * sizeof(glm::vec4) : 0,
                    occ_bytes = has_occlusion_ ? n * sizeof(glm::vec4) : 0,
                    transfer_bytes = has_transfer_ ? n * kTransferCoefficients * sizeof(float) : 0;
  const std::size_t transfer_at = 2 * pos_bytes + uv_bytes + tan_bytes + occ_bytes;
  std::vector<std::uint8_t> data(transfer_at + transfer_bytes);
  std::memcpy(data.data(), mesh.positions.data(), pos_bytes);
  std::memcpy(data.data() + pos_bytes, mesh.normals.data(), pos_bytes);
  if (uv_bytes) std::memcpy(data.data() + 2 * pos_bytes, mesh.uvs.data(), uv_bytes);
  if (tan_bytes) std::memcpy(data.data() + 2 * pos_bytes + uv_bytes, mesh.tangents.data(), tan_bytes);
  if (occ_bytes)
    std::memcpy(data.data() + 2 * pos_bytes + uv_bytes + tan_bytes, mesh.occlusion.data(),
                occ_bytes);
  if (transfer_bytes) std::memcpy(data.data() + transfer_at, mesh.transfer.data(), transfer_bytes);

  glGenVertexArrays(1, &vao_);
  glGenBuffers(1, &vbo_);
  glGenBuffers(1, &ibo_);
  glBindVertexArray(vao_);
  glBindBuffer(GL_ARRAY_BUFFER, vbo_);
  glBufferData(GL_ARRAY_BUFFER, GLsizeiptr(data.size()), data.data(), GL_STATIC_DRAW);
  auto attrib = [](GLuint loc, int comps, std::size_t offset, GLsizei stride = 0) {
    glEnableVertexAttribArray(loc);
    glVertexAttribPointer(loc, comps, GL_FLOAT, GL_FALSE, stride,
                          reinterpret_cast<const void*>(offset));
  };
  attrib(0, 3, 0);
  attrib(1, 3, pos_bytes);
  if (has_uvs_) attrib(2, 2, 2 * pos_bytes);
  if (has_tangents_) attrib(3, 4, 2 * pos_bytes + uv_bytes);
  if (has_occlusion_) attrib(4, 4, 2 * pos_bytes + uv_bytes + tan_bytes);
  if (has_transfer_)
    for (GLuint k = 0; k < 3; ++k)
      attrib(5 + k, 3, transfer_at + k * 3 * sizeof(float),
             GLsizei(kTransferCoefficients * sizeof(float)));
  glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, ibo_);
  glBufferData(GL_ELEMENT_ARRAY_BUFFER, GLsizeiptr(index_count_ * sizeof(std::uint32_t)),
               mesh.indices.data(), GL_STATIC_DRAW);
  glBindVertexArray(0);
  if (!mesh.ground.empty() && mesh.ground.occluded.size() ==
                                  std::size_t(mesh.ground.size) * std::size_t(mesh.ground.size)) {
    std::vector<std::uint8_t> texels(mesh.ground.occluded.size());
    for (std::size_t i = 0; i < texels.size(); ++i)
      texels[i] =
          std::uint8_t(std::lround(255.0f * std::clamp(mesh.ground.occluded[i], 0.0f, 1.0f)));
    glGenTextures(1, &ground_tex_);
    glBindTexture(GL_TEXTURE_2D, ground_tex_);
    glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
    glTexImage2D(GL_TEXTURE_2D, 0, GL_R8, mesh.ground.size, mesh.ground.size, 0, GL_RED,
                 GL_UNSIGNED_BYTE, texels.data());
    glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
    gl::set_sampling(GL_TEXTURE_2D, GL_LINEAR, GL_CLAMP_TO_EDGE, GL_CLAMP_TO_EDGE);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAX_LEVEL, 0);
    ground_rect_ = {mesh.ground.min, mesh.ground.max, mesh.ground.size, {}, {}};
    const std::size_t n_texels = texels.size();
    if (mesh.ground.hidden_transfer.size() == n_texels * kTransferCoefficients) {
      std::vector<float> layers(3 * n_texels * 4, 0.0f);
      for (std::size_t i = 0; i < n_texels; ++i)
        for (std::size_t k = 0; k < std::size_t(kTransferCoefficients); ++k)
          layers[((k / 3) * n_texels + i) * 4 + k % 3] =
              mesh.ground.hidden_transfer[i * kTransferCoefficients + k];
      glGenTextures(1, &ground_transfer_tex_);
      glBindTexture(GL_TEXTURE_2D_ARRAY, ground_transfer_tex_);
      glTexImage3D(GL_TEXTURE_2D_ARRAY, 0, GL_RGBA16F, mesh.ground.size, mesh.ground.size, 3, 0,
                   GL_RGBA, GL_FLOAT, layers.data());
      gl::set_sampling(GL_TEXTURE_2D_ARRAY, GL_LINEAR, GL_CLAMP_TO_EDGE, GL_CLAMP_TO_EDGE);
      glTexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_MAX_LEVEL, 0);
    }
  }
  gl::check("uploading a mesh");
}

GpuMesh::GpuMesh(GpuMesh&& o) noexcept { *this = std::move(o); }

GpuMesh& GpuMesh::operator=(GpuMesh&& o) noexcept {
  if (this != &o) {
    release();
    vao_ = std::exchange(o.vao_, 0), vbo_ = std::exchange(o.vbo_, 0), ibo_ = std::exchange(o.ibo_, 0);
    ground_tex_ = std::exchange(o.ground_tex_, 0), ground_rect_ = o.ground_rect_;
    ground_transfer_tex_ = std::exchange(o.ground_transfer_tex_, 0);
    index_count_ = o.index_count_, parts_ = std::move(o.parts_), has_uvs_ = o.has_uvs_, has_tangents_ = o.has_tangents_;
    has_occlusion_ = o.has_occlusion_, has_transfer_ = o.has_transfer_;
    bounds_ = o.bounds_;
  }
  return *this;
}

GpuMesh::~GpuMesh() { release(); }

void GpuMesh::release() {
  if (vao_) glDeleteVertexArrays(1, &vao_);
  if (vbo_) glDeleteBuffers(1, &vbo_);
  if (ibo_) glDeleteBuffers(1, &ibo_);
  if (ground_tex_) glDeleteTextures(1, &ground_tex_);
  if (ground_transfer_tex_) glDeleteTextures(1, &ground_transfer_tex_);
  vao_ = vbo_ = ibo_ = ground_tex_ = ground_transfer_tex_ = 0;
}

}  // namespace arlight::render
