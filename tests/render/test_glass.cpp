// Glass (dissertation §5.5): a solid glass sphere standing over the real floor, seen from above
// like an AR object on a table, against a ray tracer written here: Snell's law at the near and
// the far surface, the Fresnel terms of both, and what the ray sees when it leaves. Through the
// maps (§5.5.1) that is the environment in the ray's direction; with live refraction (§5.5.3) it
// is the camera frame's pixel where the ray meets the floor, or far away.
#include <algorithm>

#include "arlight/common/response.hpp"
#include "render_fixtures.hpp"

namespace arlight::render {
namespace {

using namespace testing;

constexpr int W = 320, H = 240;
constexpr double kRadius = 0.5, kIor = 1.5;
const glm::dvec3 kCentre(0.0, 0.0, 0.6);  // scene frame, +Z up from the floor (z = 0)

double fresnel(double cos_i, double eta) {
  const double sin2_t = eta * eta * (1.0 - cos_i * cos_i);
  if (sin2_t >= 1.0) return 1.0;
  const double cos_t = std::sqrt(1.0 - sin2_t);
  const double rs = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
  const double rp = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
  return 0.5 * (rs * rs + rp * rp);
}

// Snell's law in vector form (GLSL's refract, in double).
glm::dvec3 refract(glm::dvec3 i, glm::dvec3 n, double eta) {
  const double k = 1.0 - eta * eta * (1.0 - glm::dot(n, i) * glm::dot(n, i));
  if (k < 0.0) return glm::dvec3(0.0);
  return eta * i - (eta * glm::dot(n, i) + std::sqrt(k)) * n;
}

// A ray through the sphere: the share reflected at the near surface, the directions reflected
// there and leaving the far surface (scene frame), where it leaves and the share that does.
struct GlassRay {
  double impact;  // the view ray's distance from the centre, in radii
  double reflected;
  glm::dvec3 reflect_dir, inside_dir, exit_point, exit_dir;
  double through;
};

struct GlassScene {
  GlContext& ctx = context();
  Renderer r{W, H};
  CameraIntrinsics k = CameraIntrinsics::from_fov(W, H, 50.0);
  PinholeCamera cam{k};
  glm::dmat4 camera_from_scene, scene_from_camera;
  GpuMesh sphere{make_sphere(float(kRadius), 96, 192)};
  glm::mat4 model = glm::translate(glm::mat4(1.0f), glm::vec3(kCentre));

  // A camera at `eye` looking at `target` (scene frame).
  void look(glm::dvec3 eye, glm::dvec3 target) {
    camera_from_scene = glm::lookAt(eye, target, glm::dvec3(0, 0, 1));
    scene_from_camera = glm::inverse(camera_from_scene);
    r.set_camera(k, camera_from_scene);
  }

  std::optional<GlassRay> trace(int x, int y) const {
    const glm::dvec3 eye(scene_from_camera * glm::dvec4(0, 0, 0, 1));
    const glm::dvec3 d =
        glm::normalize(glm::dmat3(scene_from_camera) * cam.unproject({double(x), double(y)}));
    const double along = glm::dot(kCentre - eye, d);
    const double miss = glm::length(kCentre - eye - along * d);
    if (miss >= kRadius) return std::nullopt;
    const double half_chord = std::sqrt(kRadius * kRadius - miss * miss);
    const glm::dvec3 p = eye + (along - half_chord) * d;
    const glm::dvec3 n = (p - kCentre) / kRadius;
    GlassRay g;
    g.impact = miss / kRadius;
    g.reflected = fresnel(glm::dot(n, -d), 1.0 / kIor);
    g.reflect_dir = glm::reflect(d, n);
    const glm::dvec3 t_in = refract(d, n, 1.0 / kIor);
    g.inside_dir = t_in;
    // The far root of |p + s t_in - c| = R from p on the sphere: s = -2 (p - c).t_in.
    g.exit_point = p - 2.0 * glm::dot(p - kCentre, t_in) * t_in;
    const glm::dvec3 n_out = (g.exit_point - kCentre) / kRadius;
    g.exit_dir = refract(t_in, -n_out, kIor);
    g.through = (1.0 - g.reflected) * (1.0 - fresnel(glm::dot(t_in, n_out), kIor));
    return g;
  }

  // Where a ray leaving the object shows in the frame (OpenCV pixel), as the renderer takes it:
  // on the floor if it goes down to it, else at infinity.
  std::optional<glm::dvec2> frame_pixel(glm::dvec3 x, glm::dvec3 d) const {
    const glm::dvec4 p =
        d.z < 0 && x.z > 0 ? glm::dvec4(x - d * (x.z / d.z), 1.0) : glm::dvec4(d, 0.0);
    return cam.project(glm::dvec3(camera_from_scene * p));
  }
};

// A frame of smooth waves, a different one per channel: a pixel off by a fraction of the
// waves' period reads a clearly different code.
cv::Mat wave_frame() {
  cv::Mat m(H, W, CV_8UC3);
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const double r = 128 + 90 * std::sin(2 * M_PI * x / 23.0);
      const double g = 128 + 90 * std::sin(2 * M_PI * y / 19.0);
      const double b = 128 + 90 * std::sin(2 * M_PI * (x + y) / 31.0);
      m.at<cv::Vec3b>(y, x) =
          cv::Vec3b(cv::saturate_cast<std::uint8_t>(b), cv::saturate_cast<std::uint8_t>(g),
                    cv::saturate_cast<std::uint8_t>(r));
    }
  return m;
}

// The frame's codes (RGB, 0..255) bilinear at an OpenCV pixel, as GL samples it (clamped).
glm::dvec3 sample(const cv::Mat& frame, glm::dvec2 q) {
  const double fx = std::clamp(q.x, 0.0, W - 1.0), fy = std::clamp(q.y, 0.0, H - 1.0);
  const int x0 = std::min(int(fx), W - 2), y0 = std::min(int(fy), H - 2);
  const double ax = fx - x0, ay = fy - y0;
  const auto at = [&](int x, int y) { return glm::dvec3(bgr_at(frame, x, y)); };
  return glm::mix(glm::mix(at(x0, y0), at(x0 + 1, y0), ax),
                  glm::mix(at(x0, y0 + 1), at(x0 + 1, y0 + 1), ax), ay);
}

glm::dvec3 decode(const CameraResponse& resp, glm::dvec3 code) {
  glm::dvec3 out;
  for (int c = 0; c < 3; ++c) {
    const int i = std::min(int(code[c]), 254);
    out[c] = glm::mix(double(resp.linear(i, c)), double(resp.linear(i + 1, c)), code[c] - i);
  }
  return out;
}

struct CodeErrors {
  double mean = 0, p95 = 0;
  std::size_t pixels = 0;
};

// The composite's codes against a prediction over the sphere's pixels well inside its rim.
template <class Predict>
CodeErrors compare(const GlassScene& s, const cv::Mat& out, Predict predict) {
  std::vector<double> errors;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const auto g = s.trace(x, y);
      if (!g || g->impact > 0.95) continue;
      const std::optional<glm::dvec3> expected = predict(*g, x, y);
      if (!expected) continue;
      const glm::dvec3 got(bgr_at(out, x, y));
      for (int c = 0; c < 3; ++c) errors.push_back(std::abs(got[c] - (*expected)[c]));
    }
  CodeErrors e;
  e.pixels = errors.size() / 3;
  if (errors.empty()) return e;
  for (double v : errors) e.mean += v / double(errors.size());
  std::sort(errors.begin(), errors.end());
  e.p95 = errors[std::size_t(0.95 * double(errors.size() - 1))];
  return e;
}

// Live refraction: every pixel of the sphere is the frame's pixel where Snell's law at both
// surfaces sends the view ray, decoded by the camera's response, times both Fresnel
// transmissions, and encoded again; black maps, so nothing is reflected. A sphere that ignored
// the far surface, or showed the frame straight through, reads codes far off.
TEST(Glass, LiveRefractionShowsTheFramesPixelsWhereSnellsLawSendsTheRay) {
  GlassScene s;
  s.r.set_refraction(Refraction::LiveFrame);
  set_constant_maps(s.r, Projection::LatLong, glm::vec3(0.0f));
  const cv::Mat frame = wave_frame();
  const CameraResponse srgb = CameraResponse::srgb();
  const auto encode = [&](glm::dvec3 linear) {
    glm::dvec3 code;
    for (int c = 0; c < 3; ++c) code[c] = std::round(255.0 * srgb.encode(float(linear[c]), c));
    return code;
  };
  // The codes the frame shows along a ray leaving the object, through the glass.
  const auto through_glass = [&](const GlassScene& s, const GlassRay& g, glm::dvec3 from,
                                 glm::dvec3 dir) -> std::optional<glm::dvec3> {
    const auto q = s.frame_pixel(from, dir);
    if (!q || q->x < 1 || q->y < 1 || q->x > W - 2 || q->y > H - 2) return std::nullopt;
    return encode(g.through * decode(srgb, sample(frame, *q)));
  };
  // From above, as on a table (the rays end on the floor), and level with the sphere (those
  // leaving upwards go far away).
  std::size_t on_floor = 0, far_away = 0;
  for (const auto& [eye, target] :
       {std::pair{glm::dvec3(0.3, -2.6, 1.7), glm::dvec3(0, 0, 0.45)},
        std::pair{glm::dvec3(0.2, -2.2, 0.62), glm::dvec3(0, 0, 0.6)}}) {
    s.look(eye, target);
    cv::Mat out;
    s.r.begin_frame();
    s.r.draw(s.sphere, glass(float(kIor)), s.model);
    composite(s.r, frame, {ToneMode::CameraMatched, 1.0, 1.0}, out);
    EXPECT_GT(s.r.timings().refraction_ms, 0.0);

    const CodeErrors snell = compare(s, out, [&](const GlassRay& g, int, int) {
      const auto code = through_glass(s, g, g.exit_point, g.exit_dir);
      if (code) ++(g.exit_dir.z < 0 && g.exit_point.z > 0 ? on_floor : far_away);
      return code;
    });
    // Wrong models: the far surface ignored (the ray goes on as it went in), no refraction.
    const CodeErrors one_surface = compare(s, out, [&](const GlassRay& g, int, int) {
      return through_glass(s, g, g.exit_point, g.inside_dir);
    });
    const CodeErrors straight = compare(s, out, [&](const GlassRay& g, int x, int y) {
      return std::optional(encode(g.through * decode(srgb, sample(frame, glm::dvec2(x, y)))));
    });
    std::printf(
        "glass from (%.1f, %.1f, %.2f): %zu pixels; mean %.2f p95 %.1f codes; "
        "one surface %.1f, straight %.1f\n",
        eye.x, eye.y, eye.z, snell.pixels, snell.mean, snell.p95, one_surface.mean, straight.mean);
    ASSERT_GT(snell.pixels, 3000u);
    EXPECT_LT(snell.mean, 1.0);
    EXPECT_LT(snell.p95, 3.0);
    EXPECT_GT(one_surface.mean, 20.0 * snell.mean);
    EXPECT_GT(straight.mean, 20.0 * snell.mean);
  }
  EXPECT_GT(on_floor, 1000u);  // both kinds of background were checked
  EXPECT_GT(far_away, 1000u);
}

// Through the maps: the radiance is the Fresnel reflection of the map in the reflected
// direction plus both surfaces' transmission times the map where the ray leaves. A gradient
// room, L(d) = c0 + c1.d, tells directions apart everywhere.
TEST(Glass, ThroughTheMapsShowsTheRoomWhereTheRayLeavesWithBothFresnelTerms) {
  GlassScene s;
  s.look(glm::dvec3(0.3, -2.6, 1.7), glm::dvec3(0, 0, 0.45));
  const glm::dvec3 c0(1.0, 0.8, 0.6);
  const glm::dmat3 c1(glm::dvec3(0.5, 0.1, 0.2), glm::dvec3(-0.3, 0.4, 0.1),
                      glm::dvec3(0.2, -0.2, 0.45));  // columns: d.x, d.y, d.z
  const auto room = [&](glm::dvec3 d) { return c0 + c1 * glm::normalize(d); };
  const EnvLayout layout = EnvLayout::for_size(Projection::LatLong, 256);
  EnvMap env(layout);
  for (int y = 0; y < layout.height(); ++y)
    for (int x = 0; x < layout.width(); ++x)
      env.image.set(x, y, glm::vec3(room(layout.texel_dir(x, y))));
  s.r.set_maps({1.0, 1280.0}, {env, env});  // glass(): shininess 1280, the second map
  s.r.begin_frame();
  s.r.draw(s.sphere, glass(float(kIor)), s.model);
  const HdrReadback hdr = s.r.read_hdr();

  double err = 0, err_no_fresnel = 0, err_one_surface = 0;
  int n = 0;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const auto g = s.trace(x, y);
      if (!g || g->impact > 0.95 || !hdr.mask[std::size_t(y) * W + x]) continue;
      const glm::dvec3 got(hdr.radiance.at(x, y));
      const glm::dvec3 want = g->reflected * room(g->reflect_dir) + g->through * room(g->exit_dir);
      const auto rel = [&](glm::dvec3 v) { return glm::length(got - v) / glm::length(v); };
      err += rel(want);
      err_no_fresnel += rel(room(g->exit_dir));
      err_one_surface +=
          rel(g->reflected * room(g->reflect_dir) + g->through * room(g->inside_dir));
      ++n;
    }
  ASSERT_GT(n, 3000);
  err /= n, err_no_fresnel /= n, err_one_surface /= n;
  std::printf(
      "glass through the maps: %d pixels, mean error %.2f %% (no Fresnel %.1f %%, one "
      "surface %.1f %%)\n",
      n, 100 * err, 100 * err_no_fresnel, 100 * err_one_surface);
  EXPECT_LT(err, 0.003);
  EXPECT_GT(err_no_fresnel, 5 * err);
  EXPECT_GT(err_one_surface, 5 * err);
}

// Live glass is drawn after the opaque objects (it needs the frame): an opaque object in front
// of it still hides it, pixel for pixel, and the frame shows through the rest of it.
TEST(Glass, LiveGlassBehindAnOpaqueObjectStaysHidden) {
  GlassScene s;
  s.look(glm::dvec3(0.3, -2.6, 1.7), glm::dvec3(0, 0, 0.45));
  s.r.set_refraction(Refraction::LiveFrame);
  set_constant_maps(s.r, Projection::LatLong, glm::vec3(0.4f, 0.3f, 0.2f));
  const cv::Mat frame = wave_frame();
  const GpuMesh ball(make_sphere(0.2f, 32, 64));
  const glm::mat4 in_front = glm::translate(glm::mat4(1.0f), glm::vec3(0.1f, -0.9f, 0.6f));
  Material plastic;
  plastic.kd = glm::vec3(0.6f, 0.2f, 0.1f), plastic.ks = glm::vec3(0.2f), plastic.shininess = 16;

  cv::Mat alone, both;
  s.r.begin_frame();
  s.r.draw(ball, plastic, in_front);
  composite(s.r, frame, {ToneMode::CameraMatched, 1.0, 1.0}, alone);
  const std::vector<std::uint8_t> ball_mask = s.r.read_hdr().mask;
  s.r.begin_frame();
  s.r.draw(s.sphere, glass(float(kIor)), s.model);  // first in draw order, drawn last
  s.r.draw(ball, plastic, in_front);
  composite(s.r, frame, {ToneMode::CameraMatched, 1.0, 1.0}, both);
  const std::vector<std::uint8_t> both_mask = s.r.read_hdr().mask;

  int ball_pixels = 0, over_glass = 0, glass_pixels = 0, glass_changed = 0;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const std::size_t i = std::size_t(y) * W + x;
      if (ball_mask[i]) {
        ++ball_pixels;
        over_glass += s.trace(x, y).has_value();
        ASSERT_EQ(bgr_at(both, x, y), bgr_at(alone, x, y)) << "at " << x << ", " << y;
      } else if (both_mask[i]) {
        ++glass_pixels;
        glass_changed += bgr_at(both, x, y) != bgr_at(frame, x, y);
      }
    }
  EXPECT_GT(over_glass, 500);  // the ball covers part of the glass
  EXPECT_GT(glass_pixels, 3000);
  EXPECT_GT(glass_changed, glass_pixels * 9 / 10);
}

}  // namespace
}  // namespace arlight::render
