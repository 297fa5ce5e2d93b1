// The guided capture against the fixed path, and the stated uncertainty against the real error,
// on simulated captures of real probes (issue 48; arlight-bench-guided has every probe).
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <string>

#include "arlight/capture/capture.hpp"
#include "arlight/common/hdr_io.hpp"
#include "arlight/common/resample.hpp"
#include "arlight/guided/guided_capture.hpp"
#include "arlight/lighting/lighting.hpp"

using namespace arlight;

namespace {

// arlight-bench-guided's irradiance map.
const EnvLayout kIrradianceLayout = EnvLayout::for_size(Projection::AngleMap, 128);

EnvMap irradiance(const EnvMap& env) {
  const double shininess[] = {1.0};
  return lighting::compute_maps(resample(env, kIrradianceLayout), shininess, kIrradianceLayout,
                                lighting::parse_method("auto"))
      .maps[0];
}

std::string probe_path(const char* name) {
  return std::string(ARLIGHT_SOURCE_DIR) + "/data/probes/" + name;
}

// A capture of `probe` at 320x240 and 20 fps for 12 s, fixed (top-down, the page's old order)
// or guided; the irradiance error (thesis eq. 6.1, mean) every half second.
struct Scored {
  std::vector<double> time, error;
  std::vector<double> bracketed;  // per score: the share of normals whose error the bound holds
  double peak_rate = 0;
};

Scored scored_capture(const char* probe, std::optional<double> guided_rate) {
  const EnvMap truth = load_envmap(probe_path(probe)).env;
  const EnvMap truth_irradiance = irradiance(truth);
  guided::GuidedCaptureOptions o;
  o.camera.width = 320, o.camera.height = 240, o.camera.fps = 20, o.camera.frames = 240;
  o.camera.trajectory = sim::TrajectoryKind::TopDownSweep;
  o.camera.seed = 1;
  if (guided_rate) o.camera.guided = sim::GuidedMotionParams{.max_rate_deg_s = *guided_rate};
  o.capture.layout = capture::capture_layout_for(256);
  guided::GuidedCapture c(probe_path(probe), o);
  Scored s;
  double next = 0.5;
  glm::dvec3 last(0.0);
  while (auto step = c.step()) {
    const double t = step->frame.time;
    const glm::dvec3 view = guided::view_direction(step->frame.orientation);
    if (t > 0)
      s.peak_rate = std::max(s.peak_rate, glm::degrees(std::acos(std::clamp(
                                              glm::dot(view, last), -1.0, 1.0))) * o.camera.fps);
    last = view;
    if (t + 1e-9 < next) continue;
    next += 0.5;
    const EnvMap estimate = irradiance(c.session().environment());
    s.time.push_back(t);
    s.error.push_back(lighting::map_error(truth_irradiance, estimate).mean);
    // The bound per normal of the irradiance map against the real relative error there.
    const capture::LightUncertainty& u = c.session().uncertainty();
    int held = 0, n = 0;
    for (int y = 0; y < kIrradianceLayout.height(); ++y)
      for (int x = 0; x < kIrradianceLayout.width(); ++x) {
        if (!kIrradianceLayout.texel_valid(x, y)) continue;
        const double lt = luminance(truth_irradiance.image.at(x, y));
        const double le = luminance(estimate.image.at(x, y));
        held += std::abs(le - lt) / lt <= u.at(kIrradianceLayout.texel_dir(x, y)), ++n;
      }
    s.bracketed.push_back(double(held) / n);
  }
  return s;
}

double seconds_to(const Scored& s, double target) {
  double since = -1.0;
  for (std::size_t i = 0; i < s.error.size(); ++i) {
    if (s.error[i] > target) since = -1.0;
    else if (since < 0.0) since = s.time[i];
  }
  return since < 0.0 ? 1e9 : since;
}

}  // namespace

// On a Venice square under the sun, a user who turns to the views arlightd asks for, no faster
// than the fixed path turns, has the irradiance within 5 % sooner than the fixed path (measured
// 6.5 s against 8.5 s); the stated bound holds for >= 90 % of the normals throughout both
// captures.
TEST(GuidedCapture, ReachesFivePercentSoonerThanTheFixedPathAndTheBoundHolds) {
  const Scored fixed = scored_capture("venice.exr", std::nullopt);
  const Scored guided = scored_capture("venice.exr", fixed.peak_rate);
  const double f5 = seconds_to(fixed, 0.05), g5 = seconds_to(guided, 0.05);
  std::printf("to 5 %%: guided %.1f s, fixed %.1f s\n", g5, f5);
  EXPECT_LT(g5, f5) << "guided " << g5 << " s, fixed " << f5 << " s";
  EXPECT_LT(g5, 1e9) << "the guided capture never got within 5 %";
  for (const Scored* s : {&fixed, &guided})
    for (std::size_t i = 0; i < s->bracketed.size(); ++i)
      EXPECT_GE(s->bracketed[i], 0.9) << "at " << s->time[i] << " s, error " << s->error[i];
}
