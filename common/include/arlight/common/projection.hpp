// Environment-map projections (angle map, lat-long, cube) with exact round trips
// direction <-> uv <-> texel and the exact solid angle of every texel.
// The rules (axes, orientation, texel centres) are written down in common/CONVENTIONS.md.
#pragma once

#include <cstdint>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "arlight/common/image.hpp"

namespace arlight {

enum class Projection { AngleMap, LatLong, Cube };

std::string_view projection_name(Projection p);  // "anglemap", "latlong", "cube"
std::optional<Projection> parse_projection(std::string_view name);

// The shape of one environment map: its projection and the size of the stored image.
// A cube map is stored as one image, `face` wide and 6*`face` tall, faces in the order
// +X, -X, +Y, -Y, +Z, -Z from the top (the GL_TEXTURE_CUBE_MAP_POSITIVE_X + i order).
class EnvLayout {
 public:
  // Throws std::invalid_argument naming the expected shape when width x height does not fit
  // the projection (angle map: square; lat-long: 2:1; cube: 1:6).
  EnvLayout(Projection projection, int width, int height);

  // The sizes the tools' --size N means: angle map N x N, lat-long 2N x N, cube N x N a face.
  static EnvLayout for_size(Projection projection, int n);

  // Guesses the projection of a width x height image from its shape (2:1 lat-long,
  // 1:1 angle map, 1:6 cube); std::nullopt for any other shape.
  static std::optional<Projection> guess_projection(int width, int height);

  Projection projection() const { return projection_; }
  int width() const { return width_; }
  int height() const { return height_; }
  int face_size() const { return width_; }  // cube maps only
  std::size_t texel_count() const { return std::size_t(width_) * std::size_t(height_); }
  bool operator==(const EnvLayout&) const = default;

  // uv spans the whole stored image: u in [0,1] left to right, v in [0,1] top to bottom.
  glm::dvec3 uv_to_dir(glm::dvec2 uv) const;
  glm::dvec2 dir_to_uv(glm::dvec3 dir) const;  // dir need not be normalized; must be non-zero

  // Whether uv lies on the sphere's image (always, except outside an angle map's disk).
  bool uv_on_sphere(glm::dvec2 uv) const;

  // Continuous pixel coordinates: texel (i, j) covers [i, i+1) x [j, j+1), centre (i+.5, j+.5).
  glm::dvec2 uv_to_pixel(glm::dvec2 uv) const { return {uv.x * width_, uv.y * height_}; }
  glm::dvec2 pixel_to_uv(glm::dvec2 p) const { return {p.x / width_, p.y / height_}; }
  glm::ivec2 dir_to_texel(glm::dvec3 dir) const;

  // Direction of texel (x, y)'s centre. Angle-map texels whose centre lies outside the disk
  // but that still overlap it (the rim) get the direction at the disk's edge (the back pole).
  glm::dvec3 texel_dir(int x, int y) const;
  // Exact solid angle (steradians) of the part of the sphere texel (x, y) covers; the sum over
  // all texels is 4*pi. Zero for angle-map texels wholly outside the disk.
  double texel_solid_angle(int x, int y) const;
  bool texel_valid(int x, int y) const { return texel_solid_angle(x, y) > 0.0; }

  // The cube face (0..5 = +X, -X, +Y, -Y, +Z, -Z) a direction falls on; ties go to X, then Y.
  static int cube_face_of_direction(glm::dvec3 dir);

 private:
  Projection projection_;
  int width_;
  int height_;
};

// The per-texel geometry of a layout, computed once and shared (it only depends on the
// layout): the valid texels' indices, unit directions and solid angles, as separate arrays so
// that SIMD loops can stream them.
struct TexelTable {
  EnvLayout layout;
  std::vector<std::uint32_t> index;  // y * width + x of each valid texel
  std::vector<double> x, y, z;       // unit direction of each valid texel
  std::vector<double> solid_angle;   // steradians, sums to 4*pi
  std::size_t size() const { return index.size(); }
};

// Cached: repeated calls with the same layout return the same table (thread-safe).
std::shared_ptr<const TexelTable> texel_table(const EnvLayout& layout);

// An environment map: radiance (linear RGB) over the sphere in a given projection.
struct EnvMap {
  EnvLayout layout;
  Image image;

  EnvMap(EnvLayout layout_, Image image_);  // throws std::invalid_argument on a size mismatch
  explicit EnvMap(EnvLayout layout_) : EnvMap(layout_, Image(layout_.width(), layout_.height())) {}
};

}  // namespace arlight
