// The shadow catcher (ShadowSettings): shadows of virtual objects on the real floor, the plane
// z = 0 of the scene (marker) frame, by differential rendering (tutorial §6.3).
#include <GLES3/gl3.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <glm/gtc/matrix_transform.hpp>
#include <map>
#include <numbers>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "arlight/common/sh.hpp"
#include "arlight/render/transfer.hpp"
#include "render_fixtures.hpp"

namespace arlight::render {
namespace {

using namespace testing;

constexpr int W = 320, H = 240;

// Scene z up -> world y up (the lighting frame): a rotation of -90 degrees about x.
glm::dmat3 world_from_scene() {
  return glm::dmat3(glm::rotate(glm::dmat4(1.0), -std::numbers::pi / 2, glm::dvec3(1, 0, 0)));
}

// A camera at `eye` (scene frame) looking at `target`, scene z up.
glm::dmat4 look(glm::dvec3 eye, glm::dvec3 target) {
  return glm::lookAt(eye, target, glm::dvec3(0, 0, 1));
}

struct View {
  CameraIntrinsics k = CameraIntrinsics::from_fov(W, H, 60.0);
  glm::dmat4 camera_from_scene;
  glm::dmat4 view_proj() const {
    return glm::dmat4(projection_from_intrinsics(k, W, H, 0.01f, 100.0f)) * camera_from_scene;
  }
  // OpenCV pixel (row 0 at the top) of a scene point.
  glm::dvec2 project(glm::dvec3 p) const {
    const glm::dvec4 c = view_proj() * glm::dvec4(p, 1.0);
    const glm::dvec2 ndc = glm::dvec2(c) / c.w;
    return {(ndc.x + 1) * 0.5 * W - 0.5, (ndc.y + 1) * 0.5 * H - 0.5};
  }
  // The floor point (z = 0) seen through pixel (x, y), if the ray goes down.
  std::optional<glm::dvec3> floor_point(int x, int y) const {
    const glm::dmat4 inv = glm::inverse(view_proj());
    const glm::dvec2 ndc((x + 0.5) / W * 2 - 1, (y + 0.5) / H * 2 - 1);
    glm::dvec4 a = inv * glm::dvec4(ndc, -1, 1), b = inv * glm::dvec4(ndc, 1, 1);
    const glm::dvec3 p0 = glm::dvec3(a) / a.w, p1 = glm::dvec3(b) / b.w;
    if (!(p1.z < p0.z) || p0.z <= 0) return std::nullopt;
    return p0 + (p1 - p0) * (p0.z / (p0.z - p1.z));
  }
};

// Live SH (order 3) of a dim uniform sky plus a delta light of irradiance `e` (at normal
// incidence) from world direction `l`: coefficients a 4 pi Y_00 + e Y_lm(l).
ShCoeffs sky_and_sun(double sky, glm::dvec3 l, double e) {
  ShCoeffs sh(3);
  std::vector<double> y(std::size_t(sh_count(3)));
  sh_basis_all(3, l, y);
  for (std::size_t i = 0; i < y.size(); ++i) sh.c[i] = glm::dvec3(e * y[i]);
  sh.c[0] += glm::dvec3(sky * 4 * std::numbers::pi * 0.5 / std::sqrt(std::numbers::pi));
  return sh;
}

double srgb_decode(double v) {
  v /= 255.0;
  return v <= 0.04045 ? v / 12.92 : std::pow((v + 0.055) / 1.055, 2.4);
}

// Linear darkening 1 - L_out / L_frame of a pixel (sRGB codes, green channel).
double darkening(const cv::Mat& out, const cv::Mat& frame, int x, int y) {
  return 1.0 - srgb_decode(out.at<cv::Vec3b>(y, x)[1]) / srgb_decode(frame.at<cv::Vec3b>(y, x)[1]);
}

void maybe_write(const char* name, const cv::Mat& img) {
  if (const char* dir = std::getenv("ARLIGHT_SHADOW_PNG"))
    cv::imwrite(std::string(dir) + "/" + name, img);
}

// (a) A sphere above the floor, one strong light: the darkest floor pixels are around where
// the ray from the sphere's centre along -l meets z = 0; far pixels keep the frame's bytes; the
// darkening is about f (the light's share) and never much more.
TEST(Shadow, DirectionalShadowFallsAlongTheLight) {
  context();
  Renderer r(W, H);
  const glm::dvec3 l_scene = glm::normalize(glm::dvec3(0.5, 0.3, 1.0));
  const glm::dvec3 l_world = world_from_scene() * l_scene;
  r.set_sh(sky_and_sun(0.05, l_world, 3.0));
  View v;
  v.camera_from_scene = look({0.0, -4.0, 3.0}, {0, 0, 0.3});
  r.set_camera(v.k, v.camera_from_scene);
  r.set_world_from_scene(world_from_scene());
  ShadowSettings s;
  s.enabled = true;
  s.light_direction = glm::vec3(l_world);
  s.light_colour = glm::vec3(3.0f);
  r.set_shadow(s);
  const float f = r.shadow_fraction();
  EXPECT_NEAR(f, 0.85f, 1e-4f);  // 3 cos vs pi 0.05 of sky: clamped

  const GpuMesh sphere(make_sphere(0.5f, 32, 64));
  const glm::dvec3 centre(0, 0, 1.2);
  Material m;
  r.begin_frame();
  r.draw(sphere, m, glm::translate(glm::mat4(1.0f), glm::vec3(centre)));
  const cv::Mat frame(H, W, CV_8UC3, cv::Scalar(150, 160, 170));
  cv::Mat out;
  composite(r, frame, {}, out);
  maybe_write("shadow_directional.png", out);
  const HdrReadback hdr = r.read_hdr();

  const glm::dvec3 hit = centre - l_scene * (centre.z / l_scene.z);
  const glm::dvec2 expected = v.project(hit);
  double max_d = 0;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x)
      if (!hdr.mask[std::size_t(y) * W + x]) max_d = std::max(max_d, darkening(out, frame, x, y));
  glm::dvec2 sum(0);
  double n = 0, far_checked = 0;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      if (hdr.mask[std::size_t(y) * W + x]) continue;
      const double d = darkening(out, frame, x, y);
      if (d >= 0.97 * max_d) sum += glm::dvec2(x, y), n += 1;
      EXPECT_LE(d, f + 0.03) << "at " << x << "," << y;
      const auto p = v.floor_point(x, y);
      if (!p || (glm::length(glm::dvec2(*p)) > 2.0 && glm::length(glm::dvec2(*p - hit)) > 2.0)) {
        ASSERT_EQ(out.at<cv::Vec3b>(y, x), frame.at<cv::Vec3b>(y, x))
            << "far pixel " << x << "," << y;
        far_checked += 1;
      }
    }
  ASSERT_GT(n, 0);
  const glm::dvec2 darkest = sum / n;
  std::printf(
      "[shadow] f = %.3f, max darkening %.3f over %.0f px, centroid (%.1f, %.1f), "
      "expected (%.1f, %.1f); %.0f far pixels unchanged\n",
      f, max_d, n, darkest.x, darkest.y, expected.x, expected.y, far_checked);
  EXPECT_LT(glm::length(darkest - expected), 3.0);
  EXPECT_GT(max_d, f - 0.1);  // the umbra takes the light's share away
  EXPECT_GT(far_checked, W * H / 3);
  // Directly under the sphere, off the shadow, the floor is much lighter than in the umbra.
  const glm::dvec2 under = v.project({0, 0, 0});
  EXPECT_LT(darkening(out, frame, int(std::lround(under.x)), int(std::lround(under.y))),
            0.5 * max_d);
}

// (b) A constant environment: no dominant light (its bands 0-1 vanish), no directional shadow,
// but a contact shadow that is darkest right under the object and fades with distance.
TEST(Shadow, ContactShadowUnderConstantLight) {
  context();
  Renderer r(W, H);
  set_constant_maps(r, Projection::LatLong, glm::vec3(0.5f));
  ShadowSettings s;
  s.enabled = true;
  const ShCoeffs sh = sh_project(constant_env(Projection::LatLong, 32, glm::vec3(0.5f)), 3);
  const DominantLight light = sh_dominant_light(sh);  // as arlightd sends it
  s.light_direction = light.direction;
  s.light_colour = light.colour;
  r.set_shadow(s);
  View v;
  v.camera_from_scene = look({0.0, -4.0, 3.0}, {0, 0, 0.3});
  r.set_camera(v.k, v.camera_from_scene);
  r.set_world_from_scene(world_from_scene());
  EXPECT_LT(r.shadow_fraction(), 0.01f);

  const GpuMesh sphere(make_sphere(0.5f, 32, 64));
  Material m;
  r.begin_frame();
  r.draw(sphere, m, glm::translate(glm::mat4(1.0f), glm::vec3(0, 0, 1.0f)));
  const cv::Mat frame(H, W, CV_8UC3, cv::Scalar(150, 160, 170));
  cv::Mat out;
  composite(r, frame, {}, out);
  maybe_write("shadow_contact.png", out);
  const HdrReadback hdr = r.read_hdr();

  for (glm::dvec2 dir : {glm::dvec2(1, 0), glm::dvec2(-1, 0), glm::dvec2(0, -1)}) {
    double prev = 1.0;
    std::vector<double> ds;
    for (double rho = 0.0; rho <= 1.8; rho += 0.1) {
      const glm::dvec2 px = v.project(glm::dvec3(dir * rho, 0.0));
      const int x = int(std::lround(px.x)), y = int(std::lround(px.y));
      ASSERT_FALSE(hdr.mask[std::size_t(y) * W + x]) << "the sphere hides the floor at rho " << rho;
      const double d = darkening(out, frame, x, y);
      EXPECT_LE(d, prev + 0.01) << "not monotonic at rho " << rho;
      prev = d;
      ds.push_back(d);
    }
    std::printf(
        "[shadow] contact darkening along (%.0f, %.0f): %.3f at 0, %.3f at 0.5, %.3f at 1, %.3f at "
        "1.8\n",
        dir.x, dir.y, ds[0], ds[5], ds[10], ds.back());
    // Cosine-weighted occlusion right under a sphere of radius 0.5 at height 1: (r/h)^2 = 0.25.
    EXPECT_NEAR(ds[0], 0.25, 0.04);
    EXPECT_GT(ds[0], ds[10] + 0.1);
    EXPECT_LT(ds.back(), 0.01);
  }
}

// A flat disc (radius a) held at height h over the floor, with its bounds reaching the floor (a
// degenerate triangle there, as a table's legs would): the ellipsoid in its bounds is all wrong
// (it would sit on the floor and black out the point under the disc), the baked floor is right.
// A floor point at distance rho from under the disc's centre sees it with the form factor
// F = (1 - (h^2 + rho^2 - a^2) / sqrt((h^2 + rho^2 + a^2)^2 - 4 a^2 rho^2)) / 2 (a parallel
// disc), so under a uniform sky the catcher darkens it by F.
TEST(Shadow, BakedFloorOcclusionFollowsTheShapeNotItsBounds) {
  context();
  const double a = 0.5, h = 0.5;
  Mesh disc;
  disc.positions.push_back({0.0f, float(h), 0.0f});
  disc.normals.push_back({0.0f, -1.0f, 0.0f});
  constexpr int kRim = 96;
  for (int i = 0; i < kRim; ++i) {
    const double t = 2.0 * std::numbers::pi * i / kRim;
    disc.positions.push_back({float(a * std::cos(t)), float(h), float(a * std::sin(t))});
    disc.normals.push_back({0.0f, -1.0f, 0.0f});
    disc.indices.insert(disc.indices.end(),
                        {0u, std::uint32_t(1 + i), std::uint32_t(1 + (i + 1) % kRim)});
  }
  const auto foot = std::uint32_t(disc.positions.size());
  disc.positions.push_back({0.0f, 0.0f, 0.0f});  // the bounds reach the floor
  disc.normals.push_back({0.0f, 1.0f, 0.0f});
  disc.indices.insert(disc.indices.end(), {foot, foot, foot});
  compute_bounds(disc);
  bake_occlusion(disc, 4096);
  ASSERT_FALSE(disc.ground.empty());

  Renderer r(W, H);
  set_constant_maps(r, Projection::LatLong, glm::vec3(0.5f));
  ShadowSettings s;
  s.enabled = true;
  s.light_direction = glm::vec3(0, 1, 0);
  s.light_colour = glm::vec3(0.0f);  // no directional share: the sky alone
  r.set_shadow(s);
  View v;
  v.camera_from_scene = look({0.0, -4.0, 1.0}, {0, 0, 0});  // low: it sees under the disc
  r.set_camera(v.k, v.camera_from_scene);
  r.set_world_from_scene(world_from_scene());
  // Object +Y onto scene +Z: the disc's floor is the scene's z = 0.
  const glm::mat4 stand =
      glm::rotate(glm::mat4(1.0f), std::numbers::pi_v<float> / 2, glm::vec3(1, 0, 0));
  const GpuMesh baked(disc);
  Mesh unbaked_mesh = disc;
  unbaked_mesh.ground = {};
  const GpuMesh unbaked(unbaked_mesh);
  const cv::Mat frame(H, W, CV_8UC3, cv::Scalar(150, 160, 170));
  const auto shade = [&](const GpuMesh& mesh) {
    r.begin_frame();
    r.draw(mesh, Material{}, stand);
    cv::Mat out;
    composite(r, frame, {}, out);
    return out;
  };
  const cv::Mat with_bake = shade(baked), with_ellipsoid = shade(unbaked);
  maybe_write("shadow_baked_floor.png", with_bake);
  int checked = 0;
  for (const double rho : {0.0, 0.3, 0.6, 0.9, 1.2}) {
    for (const glm::dvec2 dir : {glm::dvec2(1, 0), glm::dvec2(-1, 0), glm::dvec2(0, -1)}) {
      const glm::dvec3 floor(dir * rho, 0.0);
      const glm::dvec2 px = v.project(floor);
      const int x = int(std::lround(px.x)), y = int(std::lround(px.y));
      const double q = h * h + rho * rho + a * a;
      const double form =
          0.5 * (1.0 - (h * h + rho * rho - a * a) / std::sqrt(q * q - 4 * a * a * rho * rho));
      EXPECT_NEAR(darkening(with_bake, frame, x, y), form, 0.04) << "rho " << rho;
      ++checked;
    }
  }
  EXPECT_EQ(checked, 15);
  // Under the centre the disc hides half the sky (a = h); the ellipsoid would hide nearly all.
  const glm::dvec2 c = v.project({0, 0, 0});
  EXPECT_GT(darkening(with_ellipsoid, frame, int(std::lround(c.x)), int(std::lround(c.y))), 0.8);
}

// (c) Shadows off: the output is byte-identical to a renderer that never had them; on, they
// change neither the object's pixels nor Reinhard's log-average (the mask is the object's).
TEST(Shadow, DisabledIsByteIdenticalAndMaskUnchanged) {
  context();
  const glm::dvec3 l_world = world_from_scene() * glm::normalize(glm::dvec3(-0.4, 0.2, 1.0));
  const GpuMesh sphere(make_sphere(0.5f, 32, 64));
  const cv::Mat frame = noise_frame(W, H);
  View v;
  v.camera_from_scene = look({1.0, -3.5, 2.5}, {0, 0, 0.4});
  auto render = [&](int shadow_mode, ToneMode mode, cv::Mat& out, float& log_avg,
                    HdrReadback& hdr) {
    Renderer r(W, H);
    r.set_sh(sky_and_sun(0.1, l_world, 2.0));
    r.set_camera(v.k, v.camera_from_scene);
    r.set_world_from_scene(world_from_scene());
    ShadowSettings s;
    s.enabled = true;
    s.light_direction = glm::vec3(l_world);
    s.light_colour = glm::vec3(2.0f);
    if (shadow_mode >= 1) r.set_shadow(s);
    if (shadow_mode == 1) r.set_shadow(ShadowSettings{});  // on, then off again
    Material m;
    m.ks = glm::vec3(0.2f);
    r.begin_frame();
    r.draw(sphere, m, glm::translate(glm::mat4(1.0f), glm::vec3(0, 0, 0.5f)));
    ToneMapping tone;
    tone.mode = mode;
    composite(r, frame, tone, out);
    log_avg = r.last_log_average();
    hdr = r.read_hdr();
  };
  for (ToneMode mode : {ToneMode::CameraMatched, ToneMode::Reinhard}) {
    cv::Mat never, off, on;
    float la_never = 0, la_off = 0, la_on = 0;
    HdrReadback h_never, h_off, h_on;
    render(0, mode, never, la_never, h_never);
    render(1, mode, off, la_off, h_off);
    render(2, mode, on, la_on, h_on);
    EXPECT_EQ(cv::norm(never, off, cv::NORM_INF), 0.0);
    EXPECT_EQ(h_on.mask, h_never.mask);
    if (mode == ToneMode::Reinhard) {
      EXPECT_EQ(la_on, la_never);
    }
    std::size_t darker = 0;
    for (int y = 0; y < H; ++y)
      for (int x = 0; x < W; ++x) {
        const bool masked = h_never.mask[std::size_t(y) * W + x];
        const cv::Vec3b a = never.at<cv::Vec3b>(y, x), b = on.at<cv::Vec3b>(y, x);
        if (masked) {
          ASSERT_EQ(a, b) << "object pixel " << x << "," << y;
        } else {
          for (int c = 0; c < 3; ++c) ASSERT_LE(b[c], a[c]) << "brighter at " << x << "," << y;
          darker += a != b;
        }
      }
    EXPECT_GT(darker, std::size_t(500));
  }
}

// The shadow's cost at 1280x720 with the bunny on the marker (printed; no timed assertion).
TEST(Shadow, CostAt1280x720) {
  GlContext& ctx = context();
  constexpr int BW = 1280, BH = 720;
  Renderer r(BW, BH);
  const Mesh mesh = load_gltf(std::filesystem::path(ARLIGHT_ASSETS_DIR) / "models/bunny.glb");
  const GpuMesh bunny(mesh);
  const glm::dvec3 l_world = world_from_scene() * glm::normalize(glm::dvec3(0.5, 0.3, 1.0));
  r.set_sh(sky_and_sun(0.1, l_world, 2.0));
  const CameraIntrinsics k = CameraIntrinsics::from_fov(BW, BH, 60.0);
  r.set_camera(k, look({0.0, -0.35, 0.25}, {0, 0, 0.05}));
  r.set_world_from_scene(world_from_scene());
  // The bunny 0.15 m tall standing on the marker (glTF +Y up -> scene +Z up).
  const float s = 0.15f / std::max(mesh.bounds.size().y, 1e-6f);
  glm::mat4 model = glm::rotate(glm::mat4(1.0f), glm::radians(90.0f), glm::vec3(1, 0, 0));
  model = glm::scale(model, glm::vec3(s));
  model = glm::translate(
      model, -glm::vec3(mesh.bounds.centre().x, mesh.bounds.min.y, mesh.bounds.centre().z));
  Material m;
  m.kd = glm::vec3(0.6f, 0.5f, 0.4f);
  const cv::Mat frame = noise_frame(BW, BH);
  cv::Mat out;
  double with = 0, without = 0, shadow = 0;
  const int frames = 10;
  for (int on = 0; on < 2; ++on) {
    ShadowSettings st;
    st.enabled = on == 1;
    st.light_direction = glm::vec3(l_world);
    st.light_colour = glm::vec3(2.0f);
    r.set_shadow(st);
    for (int f = -2; f < frames; ++f) {
      r.begin_frame();
      r.draw(bunny, m, model);
      composite(r, frame, {}, out);
      if (f < 0) continue;
      (on ? with : without) += r.timings().total() / frames;
      if (on) shadow += r.timings().shadow_ms / frames;
    }
  }
  maybe_write("shadow_bunny.png", out);
  std::printf(
      "[timing] %s, bunny, %dx%d: frame %.2f ms without shadow, %.2f ms with; shadow pass "
      "%.2f ms\n",
      ctx.renderer().c_str(), BW, BH, without, with, shadow);
  RecordProperty("shadow_ms", std::to_string(shadow));
  EXPECT_GT(shadow, 0.0);
}

// ---- Soft shadows from the room's light clusters against the ray-traced ratio ----

// Three rooms (world frame, lat-long): a sun and its sky, two lamps in a dim room, an overcast
// sky. `compact` lights are discs of that angular radius.
EnvMap soft_shadow_room(const std::string& name) {
  const EnvLayout layout = EnvLayout::for_size(Projection::LatLong, 64);
  EnvMap map(layout);
  const auto disc = [](glm::dvec3 d, glm::dvec3 centre, double radius_deg) {
    return glm::dot(d, glm::normalize(centre)) > std::cos(radius_deg * std::numbers::pi / 180.0);
  };
  for (int y = 0; y < layout.height(); ++y)
    for (int x = 0; x < layout.width(); ++x) {
      const glm::dvec3 d = layout.texel_dir(x, y);
      double l = 0;
      if (name == "sun") {
        l = d.y > 0 ? 0.6 + 0.4 * d.y : 0.25;
        if (disc(d, {0.5, 0.8, 0.3}, 3.0)) l += 300.0;
      } else if (name == "lamps") {
        l = 0.2;
        if (disc(d, {0.5, 1.0, 0.3}, 5.0)) l += 120.0;
        if (disc(d, {-0.6, 0.8, -0.2}, 5.0)) l += 80.0;
      } else if (name == "constant") {
        l = 1.0;
      } else if (name == "horizon") {  // bright around the horizon, dark overhead (a street)
        l = d.y > 0 ? 0.1 + 2.0 * std::pow(1.0 - d.y, 3.0) : 0.1;
      } else {  // overcast: bright towards the zenith (the CIE overcast sky's 1 + 2 sin)
        l = d.y > 0 ? (1.0 + 2.0 * d.y) / 3.0 : 0.1;
      }
      map.image.set(x, y, glm::vec3(float(l)));
    }
  return map;
}

// Mean |ratio - reference| over the floor pixels in or near the shadow (either below 0.99),
// for a ball above the floor lit by `room` through its light clusters (`lights` of them).
struct SoftShadowScore {
  double mean_error = 0;
  int pixels = 0;
  int lights_drawn = 0;
};
// `standing`: the ball (radius 0.4) stands on the floor with its floor transfer baked
// (bake_occlusion), else it floats 0.3 above it with none (the ellipsoid's contact shadow).
SoftShadowScore soft_shadow_score(const EnvMap& room, int lights, cv::Mat* image = nullptr,
                                  const Mesh* standing = nullptr) {
  Renderer r(W, H);
  r.set_maps({1.0, 1280.0}, {room, room});  // the sharpest map is the room's radiance
  View v;
  v.camera_from_scene = look({0.0, -3.0, 3.5}, {0, 0, 0.3});
  r.set_camera(v.k, v.camera_from_scene);
  r.set_world_from_scene(world_from_scene());
  ShadowSettings s;
  s.enabled = true;
  s.lights = lights;
  s.min_ratio = 0.0f, s.max_fraction = 1.0f;
  r.set_shadow(s);
  const Mesh ball = standing ? *standing : make_sphere(0.4f, 32, 64);
  // Standing: object +Y (its bake's up) is scene +Z, its lowest point on z = 0.
  const glm::mat4 model =
      standing ? glm::rotate(glm::translate(glm::mat4(1.0f), glm::vec3(0.0f, 0.0f, 0.4f)),
                             std::numbers::pi_v<float> / 2, glm::vec3(1, 0, 0))
               : glm::translate(glm::mat4(1.0f), glm::vec3(0.0f, 0.0f, 0.7f));
  const GpuMesh gpu_ball(ball);
  r.begin_frame();
  r.draw(gpu_ball, Material{}, model);
  const cv::Mat frame(H, W, CV_8UC3, cv::Scalar(118, 118, 118));  // ~18 % grey in sRGB
  cv::Mat out;
  composite(r, frame, {}, out);
  if (image) *image = out;
  const HdrReadback hdr = r.read_hdr();

  std::vector<glm::vec3> scene_positions;
  for (const glm::vec3& p : ball.positions)
    scene_positions.push_back(glm::vec3(model * glm::vec4(p, 1.0f)));
  const Occluder occluder(scene_positions, ball.indices);
  const ShadowReference reference(room, glm::transpose(world_from_scene()), {0, 0, 1});
  std::vector<glm::ivec2> pixels;
  std::vector<glm::dvec3> points;
  for (int y = 0; y < H; y += 3)
    for (int x = 0; x < W; x += 3) {
      const auto p = v.floor_point(x, y);
      if (!p || hdr.mask[std::size_t(y) * W + x] || glm::length(glm::dvec2(*p)) > 3.0) continue;
      pixels.push_back({x, y}), points.push_back(*p);
    }
  const std::vector<double> truth = reference.ratios(occluder, points);
  SoftShadowScore score;
  score.lights_drawn = r.timings().shadow_lights;
  double sum = 0;
  for (std::size_t i = 0; i < pixels.size(); ++i) {
    const double ratio = 1.0 - darkening(out, frame, pixels[i].x, pixels[i].y);
    if (ratio > 0.99 && truth[i] > 0.99) continue;
    sum += std::abs(ratio - truth[i]);
    ++score.pixels;
  }
  score.mean_error = score.pixels ? sum / score.pixels : 0.0;
  return score;
}

// The browser's path (composite_in_place: the frame uploaded to camera_texture() as R, G, B,
// the factors blended into it on the GPU) darkens the same pixels by the same amount as
// composite() (factors read back, applied to the BGR frame on the CPU): the page and the native
// client draw one soft shadow.
TEST(SoftShadow, TheBrowsersPathDarkensTheFloorAsTheNativeOneDoes) {
  context();
  const EnvMap room = soft_shadow_room("lamps");
  Renderer r(W, H);
  r.set_maps({1.0, 1280.0}, {room, room});
  View v;
  v.camera_from_scene = look({0.0, -3.0, 3.5}, {0, 0, 0.3});
  r.set_camera(v.k, v.camera_from_scene);
  r.set_world_from_scene(world_from_scene());
  ShadowSettings s;
  s.enabled = true;
  s.lights = 8;
  r.set_shadow(s);
  const GpuMesh ball(make_sphere(0.4f, 32, 64));
  const glm::mat4 model = glm::translate(glm::mat4(1.0f), glm::vec3(0.0f, 0.0f, 0.7f));
  // A frame whose channels differ (B, G, R order mistakes show) and vary across it.
  cv::Mat frame(H, W, CV_8UC3);
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x)
      frame.at<cv::Vec3b>(y, x) = cv::Vec3b(uchar(90 + x / 8), uchar(130 + y / 8), uchar(180));

  r.begin_frame();
  r.draw(ball, Material{}, model);
  cv::Mat native;
  composite(r, frame, {}, native);
  ASSERT_GE(r.timings().shadow_lights, 2);

  r.begin_frame();
  r.draw(ball, Material{}, model);
  cv::Mat rgb;
  cv::cvtColor(frame, rgb, cv::COLOR_BGR2RGB);
  glBindTexture(GL_TEXTURE_2D, r.camera_texture());
  glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
  glTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, W, H, GL_RGB, GL_UNSIGNED_BYTE, rgb.data);
  glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
  r.composite_in_place({});
  EXPECT_EQ(r.timings().shadow_lights, 8);
  GLuint fbo = 0;
  glGenFramebuffers(1, &fbo);
  glBindFramebuffer(GL_FRAMEBUFFER, fbo);
  glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, r.camera_texture(),
                         0);
  cv::Mat rgba(H, W, CV_8UC4);
  glReadPixels(0, 0, W, H, GL_RGBA, GL_UNSIGNED_BYTE, rgba.data);
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  glDeleteFramebuffers(1, &fbo);
  ASSERT_EQ(glGetError(), GLenum(GL_NO_ERROR));
  cv::Mat in_place;
  cv::cvtColor(rgba, in_place, cv::COLOR_RGBA2BGR);
  maybe_write("shadow_in_place.png", in_place);

  int shadowed = 0, max_diff = 0;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const cv::Vec3b a = native.at<cv::Vec3b>(y, x), b = in_place.at<cv::Vec3b>(y, x);
      const cv::Vec3b f = frame.at<cv::Vec3b>(y, x);
      for (int c = 0; c < 3; ++c) max_diff = std::max(max_diff, std::abs(int(a[c]) - int(b[c])));
      if (int(f[1]) - int(b[1]) >= 10 && int(f[2]) - int(b[2]) >= 10) ++shadowed;
    }
  std::printf("[shadow] browser's path: %d pixels darkened by >= 10 codes, max difference %d\n",
              shadowed, max_diff);
  EXPECT_GT(shadowed, 500);
  EXPECT_LE(max_diff, 2);
}

// The floor's ambient shadow follows where the light comes from (tutorial §6.1's receiver plane
// with its SH-9 transfer): a ball standing on the floor, its floor baked, under a sky bright
// overhead (the ball hides much of its light from the floor beside it) and one bright around
// the horizon (it hides little). With no compact light in these rooms (N = 1 draws no hard
// shadow) the whole ratio is the floor's transfer dotted with the room's light: nearer the
// ray-traced ratio than the cosine-weighted share of a uniform sky (the same bake without its
// transfer), and the same as that share in a uniform room. N = 8 (broad patches of the sky as
// hard shadows) is printed for bench/RESULTS.md.
TEST(SoftShadow, TheFloorsAmbientShadowFollowsWhereTheLightComesFrom) {
  context();
  Mesh baked = make_sphere(0.4f, 32, 64);
  bake_occlusion(baked, 1024);
  ASSERT_FALSE(baked.ground.hidden_transfer.empty());
  Mesh uniform = baked;
  uniform.ground.hidden_transfer.clear();
  for (const std::string room_name : {"constant", "overcast", "horizon"}) {
    const EnvMap room = soft_shadow_room(room_name);
    std::map<int, std::pair<SoftShadowScore, SoftShadowScore>> scores;
    for (const int n : {1, 8}) {
      scores[n] = {soft_shadow_score(room, n, nullptr, &baked),
                   soft_shadow_score(room, n, nullptr, &uniform)};
      std::printf(
          "[soft-shadow] %s, a standing ball, N = %d (%d drawn): mean |ratio - ray traced| %.4f "
          "with the floor's transfer, %.4f with its uniform occlusion (%d px)\n",
          room_name.c_str(), n, scores[n].first.lights_drawn, scores[n].first.mean_error,
          scores[n].second.mean_error, scores[n].first.pixels);
    }
    const auto& [transfer, cosine] = scores[1];
    EXPECT_EQ(transfer.lights_drawn, 0) << room_name;
    EXPECT_GT(transfer.pixels, 1000) << room_name;
    if (room_name == "constant") {
      EXPECT_NEAR(transfer.mean_error, cosine.mean_error, 0.001);
    } else {
      EXPECT_LT(transfer.mean_error, 0.025) << room_name;
      EXPECT_LT(transfer.mean_error, 0.9 * cosine.mean_error) << room_name;
    }
  }
}

// Tutorial §6's claim: as the hard shadows grow in number the blend converges to the ray-traced
// soft shadow (here the Embree ratio over every texel of the room). Printed per room and N for
// bench/RESULTS.md; the error is in units of the unshadowed floor's light.
TEST(SoftShadow, ConvergesToTheRayTracedRatioAsTheLightsGrow) {
  context();
  for (const std::string room_name : {"sun", "lamps", "overcast"}) {
    const EnvMap room = soft_shadow_room(room_name);
    std::map<int, SoftShadowScore> scores;
    for (const int n : {1, 2, 4, 8, 16, 32}) {
      cv::Mat image;
      scores[n] = soft_shadow_score(room, n, &image);
      maybe_write(("soft_shadow_" + room_name + "_" + std::to_string(n) + ".png").c_str(), image);
      std::printf(
          "[soft-shadow] %s: N = %d (%d drawn): mean |ratio - ray traced| %.4f over %d px\n",
          room_name.c_str(), n, scores[n].lights_drawn, scores[n].mean_error, scores[n].pixels);
    }
    EXPECT_GT(scores[32].pixels, 200) << room_name;
    // Within the 5 % from 8 lights on (measured 0.011-0.029).
    for (const int n : {8, 16, 32})
      EXPECT_LT(scores[n].mean_error, 0.04) << room_name << " N " << n;
    EXPECT_LE(scores[32].mean_error, scores[1].mean_error + 0.002) << room_name;
    if (room_name != "overcast") {  // compact lights: the AO alone is far off, clusters converge
      EXPECT_GT(scores[1].mean_error, 1.5 * scores[32].mean_error) << room_name;
    }
    if (room_name == "lamps") {  // two lamps: one cluster, then each lamp, then their parts
      EXPECT_GT(scores[2].mean_error, scores[4].mean_error) << room_name;
      EXPECT_GT(scores[4].mean_error, scores[8].mean_error) << room_name;
    }
  }
}

}  // namespace
}  // namespace arlight::render
