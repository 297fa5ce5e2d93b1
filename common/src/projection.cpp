#include "arlight/common/projection.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <glm/geometric.hpp>
#include <list>
#include <mutex>
#include <numbers>
#include <stdexcept>
#include <string>

#include "parallel.hpp"

namespace arlight {

namespace {

constexpr double kPi = std::numbers::pi;

std::string shape(int w, int h) { return std::to_string(w) + "x" + std::to_string(h); }

// ---- angle map (Debevec's angular map, thesis eq. 2.12 / Alg. 2.2 and 2.4) ------------------
// Disk coordinates: s to the right, t up, both in [-1, 1]; r = |(s, t)| is the angle from the
// forward direction (-Z) divided by pi.

glm::dvec3 anglemap_dir(double s, double t) {
  const double r = std::hypot(s, t);
  if (r == 0.0) return {0.0, 0.0, -1.0};
  const double rc = std::min(r, 1.0);  // outside the disk: the back pole (see CONVENTIONS.md)
  const double alpha = kPi * rc;
  const double k = std::sin(alpha) / r;
  return {s * k, t * k, -std::cos(alpha)};
}

glm::dvec2 anglemap_st(glm::dvec3 d) {
  const double rho = std::hypot(d.x, d.y);
  // Thesis Alg. 2.2 tests `acos(dz) > 0 && b > 0` and returns the border (0.5, 1.0) for the
  // centre direction too; here only the back pole (rho == 0 and looking backwards) is singular,
  // and the forward direction maps to the centre.
  if (rho == 0.0) return d.z <= 0.0 ? glm::dvec2(0.0, 0.0) : glm::dvec2(0.0, 1.0);
  const double alpha = std::atan2(rho, -d.z);  // angle from -Z, accurate at both ends
  const double r = alpha / kPi;
  return {d.x / rho * r, d.y / rho * r};
}

// Solid angle of the square [s0,s1] x [t0,t1] of the disk, clipped to the disk. The angle map's
// area element is dw = pi^2 sinc(r) ds dt (the thesis's sinc weight, Alg. 4.2/4.4). By Green's
// theorem its integral over a region equals the flux of F = g(r) r_hat with
// g(r) = (1 - cos(pi r)) / r through the region's boundary: along a straight edge at signed
// distance h from the origin that is h * integral (1 - cos(pi r)) / r^2 dl (smooth, integrated
// by Gauss-Legendre), and along the disk's rim (r = 1, g = 2) it is 2 * arc angle.
constexpr std::array<double, 8> kGl8x = {
    -0.9602898564975363, -0.7966664774136267, -0.5255324099163290, -0.1834346424956498,
    0.1834346424956498,  0.5255324099163290,  0.7966664774136267,  0.9602898564975363};
constexpr std::array<double, 8> kGl8w = {0.1012285362903763, 0.2223810344533745, 0.3137066458778873,
                                         0.3626837833783620, 0.3626837833783620, 0.3137066458778873,
                                         0.2223810344533745, 0.1012285362903763};

double edge_flux(glm::dvec2 p, glm::dvec2 q) {
  const glm::dvec2 e = q - p;
  const double len = glm::length(e);
  if (len <= 0.0) return 0.0;
  const glm::dvec2 n = glm::dvec2(e.y, -e.x) / len;  // outward normal for CCW traversal
  const double h = glm::dot(p, n);
  if (h == 0.0) return 0.0;
  // Split long edges so the 8-point rule stays exact to rounding even on tiny maps.
  const int pieces = std::max(1, int(std::ceil(len / 0.0625)));
  double sum = 0.0;
  for (int k = 0; k < pieces; ++k) {
    const glm::dvec2 a = p + e * (double(k) / pieces), b = p + e * (double(k + 1) / pieces);
    const glm::dvec2 mid = 0.5 * (a + b), half = 0.5 * (b - a);
    double piece = 0.0;
    for (int i = 0; i < 8; ++i) {
      const glm::dvec2 x = mid + kGl8x[i] * half;
      const double r2 = glm::dot(x, x);
      // (1 - cos(pi r)) / r^2 = 2 sin^2(pi r / 2) / r^2, finite (pi^2/2) at r = 0.
      const double sn = std::sin(0.5 * kPi * std::sqrt(r2));
      piece += kGl8w[i] * (r2 > 1e-300 ? 2.0 * sn * sn / r2 : 0.5 * kPi * kPi);
    }
    sum += piece * 0.5 * glm::length(b - a);
  }
  return h * sum;
}

// Angle (radians) of the unit circle that lies inside the square.
double rim_arc_inside(double s0, double s1, double t0, double t1) {
  std::vector<double> cuts = {0.0, 2.0 * kPi};
  auto add = [&](double a) {
    a = std::fmod(a, 2.0 * kPi);
    if (a < 0) a += 2.0 * kPi;
    cuts.push_back(a);
  };
  for (double c : {s0, s1})
    if (std::abs(c) <= 1.0) add(std::acos(c)), add(-std::acos(c));
  for (double c : {t0, t1})
    if (std::abs(c) <= 1.0) add(std::asin(c)), add(kPi - std::asin(c));
  std::sort(cuts.begin(), cuts.end());
  double inside = 0.0;
  for (std::size_t i = 0; i + 1 < cuts.size(); ++i) {
    const double a = cuts[i], b = cuts[i + 1];
    if (b - a <= 0.0) continue;
    const double m = 0.5 * (a + b), cs = std::cos(m), sn = std::sin(m);
    if (cs >= s0 && cs <= s1 && sn >= t0 && sn <= t1) inside += b - a;
  }
  return inside;
}

double anglemap_square_solid_angle(double s0, double s1, double t0, double t1) {
  const std::array<glm::dvec2, 4> v = {glm::dvec2(s0, t0), glm::dvec2(s1, t0), glm::dvec2(s1, t1),
                                       glm::dvec2(s0, t1)};
  double flux = 0.0;
  bool all_inside = true;
  for (const auto& c : v) all_inside = all_inside && glm::dot(c, c) <= 1.0;
  for (int i = 0; i < 4; ++i) {
    const glm::dvec2 p = v[i], q = v[(i + 1) % 4];
    if (all_inside) {
      flux += edge_flux(p, q);
      continue;
    }
    // Clip the edge to the disk: |p + l (q - p)|^2 <= 1.
    const glm::dvec2 e = q - p;
    const double a = glm::dot(e, e), b = 2.0 * glm::dot(p, e), c = glm::dot(p, p) - 1.0;
    const double disc = b * b - 4.0 * a * c;
    if (disc <= 0.0) continue;
    const double sq = std::sqrt(disc);
    const double l0 = std::max(0.0, (-b - sq) / (2.0 * a));
    const double l1 = std::min(1.0, (-b + sq) / (2.0 * a));
    if (l1 > l0) flux += edge_flux(p + l0 * e, p + l1 * e);
  }
  if (!all_inside) flux += 2.0 * rim_arc_inside(s0, s1, t0, t1);
  return std::max(0.0, flux);
}

// ---- lat-long -----------------------------------------------------------------------------
// u = 0.5 looks at -Z; u grows towards +X (turning right); v = 0 is straight up (+Y).

glm::dvec3 latlong_dir(glm::dvec2 uv) {
  const double phi = 2.0 * kPi * (uv.x - 0.5);
  const double el = kPi * (0.5 - uv.y);
  const double c = std::cos(el);
  return {std::sin(phi) * c, std::sin(el), -std::cos(phi) * c};
}

glm::dvec2 latlong_uv(glm::dvec3 d) {
  const double phi = std::atan2(d.x, -d.z);
  const double el = std::atan2(d.y, std::hypot(d.x, d.z));
  return {phi / (2.0 * kPi) + 0.5, 0.5 - el / kPi};
}

// ---- cube map (OpenGL's face table, GL 4.6 spec table 8.19) -----------------------------------

glm::dvec3 cube_dir(int face, double sc, double tc) {
  glm::dvec3 d;
  switch (face) {
    case 0:
      d = {1.0, -tc, -sc};
      break;
    case 1:
      d = {-1.0, -tc, sc};
      break;
    case 2:
      d = {sc, 1.0, tc};
      break;
    case 3:
      d = {sc, -1.0, -tc};
      break;
    case 4:
      d = {sc, -tc, 1.0};
      break;
    default:
      d = {-sc, -tc, -1.0};
      break;
  }
  return glm::normalize(d);
}

// (sc, tc) in [-1, 1] on the given face.
glm::dvec2 cube_sc_tc(int face, glm::dvec3 d) {
  switch (face) {
    case 0:
      return {-d.z / d.x, -d.y / d.x};
    case 1:
      return {-d.z / d.x, d.y / d.x};  // ma = -x: sc = +z/|x|, tc = -y/|x|
    case 2:
      return {d.x / d.y, d.z / d.y};
    case 3:
      return {-d.x / d.y, d.z / d.y};  // ma = -y: sc = x/|y|, tc = -z/|y|
    case 4:
      return {d.x / d.z, -d.y / d.z};
    default:
      return {d.x / d.z, d.y / d.z};  // ma = -z: sc = -x/|z|, tc = -y/|z|
  }
}

// Solid angle of the face rectangle [a0,a1] x [b0,b1] (face coordinates in [-1,1]) on a cube
// face at distance 1: the standard closed form A(a,b) = atan(ab / sqrt(a^2 + b^2 + 1)).
double cube_rect_solid_angle(double a0, double a1, double b0, double b1) {
  auto A = [](double a, double b) { return std::atan2(a * b, std::sqrt(a * a + b * b + 1.0)); };
  return A(a1, b1) - A(a0, b1) - A(a1, b0) + A(a0, b0);
}

}  // namespace

std::string_view projection_name(Projection p) {
  switch (p) {
    case Projection::AngleMap:
      return "anglemap";
    case Projection::LatLong:
      return "latlong";
    case Projection::Cube:
      return "cube";
  }
  return "unknown";
}

std::optional<Projection> parse_projection(std::string_view name) {
  if (name == "anglemap") return Projection::AngleMap;
  if (name == "latlong") return Projection::LatLong;
  if (name == "cube") return Projection::Cube;
  return std::nullopt;
}

EnvLayout::EnvLayout(Projection projection, int width, int height)
    : projection_(projection), width_(width), height_(height) {
  if (width < 1 || height < 1)
    throw std::invalid_argument("environment map size must be positive, got " +
                                shape(width, height));
  const bool ok = (projection == Projection::AngleMap && width == height) ||
                  (projection == Projection::LatLong && width == 2 * height) ||
                  (projection == Projection::Cube && height == 6 * width);
  if (!ok) {
    const char* want = projection == Projection::AngleMap  ? "square (N x N)"
                       : projection == Projection::LatLong ? "2:1 (2N x N)"
                                                           : "1:6 (N x 6N, faces stacked)";
    throw std::invalid_argument(std::string(projection_name(projection)) + " must be " + want +
                                ", got " + shape(width, height));
  }
}

EnvLayout EnvLayout::for_size(Projection projection, int n) {
  switch (projection) {
    case Projection::AngleMap:
      return EnvLayout(projection, n, n);
    case Projection::LatLong:
      return EnvLayout(projection, 2 * n, n);
    case Projection::Cube:
      return EnvLayout(projection, n, 6 * n);
  }
  throw std::invalid_argument("unknown projection");
}

std::optional<Projection> EnvLayout::guess_projection(int width, int height) {
  if (width <= 0 || height <= 0) return std::nullopt;
  if (width == 2 * height) return Projection::LatLong;
  if (width == height) return Projection::AngleMap;
  if (height == 6 * width) return Projection::Cube;
  return std::nullopt;
}

int EnvLayout::cube_face_of_direction(glm::dvec3 d) {
  const double ax = std::abs(d.x), ay = std::abs(d.y), az = std::abs(d.z);
  if (ax >= ay && ax >= az) return d.x >= 0 ? 0 : 1;
  if (ay >= az) return d.y >= 0 ? 2 : 3;
  return d.z >= 0 ? 4 : 5;
}

glm::dvec3 EnvLayout::uv_to_dir(glm::dvec2 uv) const {
  switch (projection_) {
    case Projection::AngleMap:
      return anglemap_dir(2.0 * uv.x - 1.0, 1.0 - 2.0 * uv.y);
    case Projection::LatLong:
      return latlong_dir(uv);
    case Projection::Cube: {
      const double fv = uv.y * 6.0;
      const int face = std::clamp(int(std::floor(fv)), 0, 5);
      return cube_dir(face, 2.0 * uv.x - 1.0, 2.0 * (fv - face) - 1.0);
    }
  }
  return {0, 0, -1};
}

glm::dvec2 EnvLayout::dir_to_uv(glm::dvec3 d) const {
  switch (projection_) {
    case Projection::AngleMap: {
      const glm::dvec2 st = anglemap_st(d);
      return {0.5 * (st.x + 1.0), 0.5 * (1.0 - st.y)};
    }
    case Projection::LatLong:
      return latlong_uv(d);
    case Projection::Cube: {
      const int face = cube_face_of_direction(d);
      const glm::dvec2 st = cube_sc_tc(face, d);
      // Clamp rounding just outside [-1,1] so a face edge never spills into the next face.
      const double s = std::clamp(0.5 * (st.x + 1.0), 0.0, 1.0);
      const double t = std::clamp(0.5 * (st.y + 1.0), 0.0, std::nextafter(1.0, 0.0));
      return {s, (face + t) / 6.0};
    }
  }
  return {0.5, 0.5};
}

bool EnvLayout::uv_on_sphere(glm::dvec2 uv) const {
  if (projection_ != Projection::AngleMap) return true;
  const double s = 2.0 * uv.x - 1.0, t = 1.0 - 2.0 * uv.y;
  return s * s + t * t <= 1.0;
}

glm::ivec2 EnvLayout::dir_to_texel(glm::dvec3 dir) const {
  if (projection_ == Projection::Cube) {
    // Per face in pixels: going through uv, (face + t) / 6 * height can round a direction on
    // a face's bottom edge into the next face.
    const int face = cube_face_of_direction(dir);
    const glm::dvec2 st = cube_sc_tc(face, dir);
    const int n = width_;
    return {std::clamp(int(std::floor(0.5 * (st.x + 1.0) * n)), 0, n - 1),
            face * n + std::clamp(int(std::floor(0.5 * (st.y + 1.0) * n)), 0, n - 1)};
  }
  const glm::dvec2 p = uv_to_pixel(dir_to_uv(dir));
  return {std::clamp(int(std::floor(p.x)), 0, width_ - 1),
          std::clamp(int(std::floor(p.y)), 0, height_ - 1)};
}

glm::dvec3 EnvLayout::texel_dir(int x, int y) const {
  return uv_to_dir(pixel_to_uv({x + 0.5, y + 0.5}));
}

double EnvLayout::texel_solid_angle(int x, int y) const {
  switch (projection_) {
    case Projection::AngleMap: {
      const double n = width_;
      return anglemap_square_solid_angle(2.0 * x / n - 1.0, 2.0 * (x + 1) / n - 1.0,
                                         1.0 - 2.0 * (y + 1) / n, 1.0 - 2.0 * y / n);
    }
    case Projection::LatLong: {
      const double el_top = kPi * (0.5 - double(y) / height_);
      const double el_bottom = kPi * (0.5 - double(y + 1) / height_);
      return 2.0 * kPi / width_ * (std::sin(el_top) - std::sin(el_bottom));
    }
    case Projection::Cube: {
      const double n = width_;
      const int row = y % width_;
      return cube_rect_solid_angle(2.0 * x / n - 1.0, 2.0 * (x + 1) / n - 1.0, 2.0 * row / n - 1.0,
                                   2.0 * (row + 1) / n - 1.0);
    }
  }
  return 0.0;
}

EnvMap::EnvMap(EnvLayout layout_, Image image_) : layout(layout_), image(std::move(image_)) {
  if (image.width() != layout.width() || image.height() != layout.height())
    throw std::invalid_argument("environment map image is " + shape(image.width(), image.height()) +
                                " but its " + std::string(projection_name(layout.projection())) +
                                " layout needs " + shape(layout.width(), layout.height()));
}

std::shared_ptr<const TexelTable> texel_table(const EnvLayout& layout) {
  static std::mutex mutex;
  static std::list<std::shared_ptr<const TexelTable>> cache;  // most recent first
  constexpr std::size_t kCacheEntries = 8;
  {
    std::lock_guard lock(mutex);
    for (auto it = cache.begin(); it != cache.end(); ++it) {
      if ((*it)->layout == layout) {
        auto hit = *it;
        cache.erase(it);
        cache.push_front(hit);
        return hit;
      }
    }
  }
  const int w = layout.width(), h = layout.height();
  std::vector<double> omega(layout.texel_count());
  detail::parallel_for(0, h, [&](int y) {
    for (int x = 0; x < w; ++x) omega[std::size_t(y) * w + x] = layout.texel_solid_angle(x, y);
  });
  auto table = std::make_shared<TexelTable>(TexelTable{layout, {}, {}, {}, {}, {}});
  for (std::size_t i = 0; i < omega.size(); ++i) {
    if (omega[i] <= 0.0) continue;
    const int x = int(i % w), y = int(i / w);
    const glm::dvec3 d = layout.texel_dir(x, y);
    table->index.push_back(std::uint32_t(i));
    table->x.push_back(d.x), table->y.push_back(d.y), table->z.push_back(d.z);
    table->solid_angle.push_back(omega[i]);
  }
  std::lock_guard lock(mutex);
  cache.push_front(table);
  if (cache.size() > kCacheEntries) cache.pop_back();
  return table;
}

}  // namespace arlight
