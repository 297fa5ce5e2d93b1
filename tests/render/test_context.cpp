// The headless context, shader loading errors and the projection from intrinsics.
#include <filesystem>
#include <fstream>

#include "render_fixtures.hpp"

namespace arlight::render {
namespace {

using testing::context;

TEST(GlContext, HeadlessGivesEs3WithFloatTargets) {
  GlContext& ctx = context();
  EXPECT_NE(ctx.version().find("OpenGL ES 3"), std::string::npos) << ctx.version();
  EXPECT_TRUE(ctx.has_extension("GL_EXT_color_buffer_float"));
  EXPECT_FALSE(ctx.has_window());
}

TEST(GlContext, WindowWithoutDisplayIsAClearError) {
  if (GlContext::window_available()) GTEST_SKIP() << "a display is available";
  try {
    GlContext::window(64, 64, "test");
    FAIL() << "expected GlError";
  } catch (const GlError& e) {
    EXPECT_NE(std::string(e.what()).find("no display"), std::string::npos) << e.what();
  }
}

TEST(Shader, CompileErrorNamesTheFileAndTheLog) {
  context();
  const auto dir = std::filesystem::temp_directory_path() / ("arlight_shader_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  std::ofstream(dir / "ok.vert") << "#version 300 es\nvoid main() { gl_Position = vec4(0.0); }\n";
  std::ofstream(dir / "bad.frag") << "#version 300 es\nprecision mediump float;\nout vec4 o;\n"
                                     "void main() { o = undefined_thing; }\n";
  try {
    Program p(dir, "ok.vert", "bad.frag");
    FAIL() << "expected GlError";
  } catch (const GlError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("bad.frag"), std::string::npos) << m;
    EXPECT_NE(m.find("undefined_thing"), std::string::npos) << m;  // GL's info log
  }
  EXPECT_THROW(Program(dir, "ok.vert", "missing.frag"), GlError);
  std::filesystem::remove_all(dir);
}

TEST(Projection, IntrinsicsMapCameraPointsToTheirOpenCvPixels) {
  CameraIntrinsics k;
  k.width = 640, k.height = 480, k.fx = 500, k.fy = 520, k.cx = 300.25, k.cy = 250.75;
  const glm::mat4 p = projection_from_intrinsics(k, 640, 480, 0.1f, 50.0f);
  const PinholeCamera cam(k);
  for (glm::dvec3 x : {glm::dvec3(0.3, -0.2, -2.0), glm::dvec3(-1.0, 0.7, -3.5), glm::dvec3(0, 0, -1)}) {
    const glm::vec4 clip = p * glm::vec4(glm::vec3(x), 1.0f);
    // Window coordinates (row 0 = image top) minus 0.5 are OpenCV pixels.
    const double u = (clip.x / clip.w + 1.0) * 0.5 * 640 - 0.5;
    const double v = (clip.y / clip.w + 1.0) * 0.5 * 480 - 0.5;
    const glm::dvec2 want = *cam.project(x);
    EXPECT_NEAR(u, want.x, 1e-3);
    EXPECT_NEAR(v, want.y, 1e-3);
  }
  // Half the size: the same point lands at half the pixel edge coordinate.
  const glm::mat4 half = projection_from_intrinsics(k, 320, 240, 0.1f, 50.0f);
  const glm::vec4 clip = half * glm::vec4(0.3f, -0.2f, -2.0f, 1.0f);
  const double u = (clip.x / clip.w + 1.0) * 0.5 * 320;
  EXPECT_NEAR(u, (cam.project({0.3, -0.2, -2.0})->x + 0.5) / 2.0, 1e-3);
}

TEST(Renderer, RefusesAWrongSizedFrame) {
  context();
  Renderer r(32, 24);
  cv::Mat out;
  EXPECT_THROW(composite(r, cv::Mat(10, 10, CV_8UC3), {}, out), std::invalid_argument);
}

}  // namespace
}  // namespace arlight::render
