// Runs the real arlight-maps binary.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <numbers>
#include <string>
#include <tuple>

#include "arlight/common/hdr_io.hpp"
#include "arlight/common/resample.hpp"
#include "arlight/common/sh.hpp"
#include "support/run_tool.hpp"

namespace fs = std::filesystem;
using namespace arlight;

namespace {

using test::RunResult;

RunResult run(const std::string& args) { return test::run_tool(ARLIGHT_MAPS_EXE, args); }

fs::path temp_dir(const char* name) {
  fs::path d = fs::temp_directory_path() / ("arlight_maps_test_" + std::string(name));
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

const std::string kProbe = std::string(ARLIGHT_SOURCE_DIR) + "/data/probes/venice.exr";

}  // namespace

TEST(ArlightMapsSh, WritesReconstructionPreviewAndJson) {
  const fs::path out = temp_dir("sh");
  const RunResult r = run("sh --input " + kProbe + " --order 6 --size 64 --out " + out.string() +
                          " --json " + (out / "r.json").string());
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("clamped"), std::string::npos)
      << "the probe's negative values are reported";
  ASSERT_TRUE(fs::exists(out / "reconstruction.exr"));
  ASSERT_TRUE(fs::exists(out / "reconstruction.png"));
  const auto j = nlohmann::json::parse(std::ifstream(out / "r.json"));
  EXPECT_EQ(j["order"], 6);
  EXPECT_EQ(j["size"], 64);
  EXPECT_GE(j["seconds_project"].get<double>(), 0.0);
  EXPECT_GE(j["seconds_reconstruct"].get<double>(), 0.0);
  ASSERT_EQ(j["coefficients"].size(), 36u);
  ASSERT_EQ(j["coefficients"][0].size(), 3u);

  // The coefficients are those of the library on the probe's own texels, in l(l+1)+m order.
  using namespace arlight;
  const EnvLayout layout = EnvLayout::for_size(Projection::AngleMap, 64);
  const ShCoeffs want = sh_project(load_envmap(kProbe).env, 6);
  for (int k : {0, 2, 7, 35})
    for (int c = 0; c < 3; ++c)
      EXPECT_NEAR(j["coefficients"][k][c].get<double>(), want.c[std::size_t(k)][c],
                  1e-9 * (1 + std::abs(want.c[std::size_t(k)][c])));

  // The EXR carries the coefficients and the projection; its pixels are the reconstruction.
  const LoadedImage exr = load_image(out / "reconstruction.exr");
  EXPECT_EQ(exr.metadata.projection, Projection::AngleMap);
  ASSERT_EQ(exr.metadata.sh_coefficients.size(), 36u);
  EXPECT_NEAR(exr.metadata.sh_coefficients[0][1], want.c[0].y, 1e-5 * std::abs(want.c[0].y));
  const glm::dvec3 centre = sh_evaluate(want, layout.texel_dir(32, 32));
  EXPECT_NEAR(exr.image.at(32, 32).x, centre.x, 2e-3 * std::abs(centre.x));
}

// Issue 16 §2: the projection integrates over the input's own texels with their exact solid
// angles, so L00 is the exact sum whatever --size (which only sets the reconstruction's size).
// Before, the probe was resampled to a --size angle map first: 1.05 % off at 512, 0.1 % at 1024.
TEST(ArlightMapsSh, L00IsTheExactSolidAngleSumAtEverySize) {
  const fs::path out = temp_dir("sh_exact");
  // The exact sum over the 512x256 lat-long probe: row j spans polar angles [pi j/H,
  // pi (j+1)/H], each of its texels 2 pi / W of azimuth, so its solid angle is
  // (2 pi / W) (cos theta_j - cos theta_j+1).
  const LoadedEnvMap probe = load_envmap(kProbe);
  const int w = probe.env.layout.width(), h = probe.env.layout.height();
  ASSERT_EQ(probe.env.layout.projection(), Projection::LatLong);
  glm::dvec3 sum(0.0);
  for (int y = 0; y < h; ++y) {
    const double omega =
        2 * std::numbers::pi / w *
        (std::cos(std::numbers::pi * y / h) - std::cos(std::numbers::pi * (y + 1) / h));
    for (int x = 0; x < w; ++x) sum += omega * glm::dvec3(probe.env.image.at(x, y));
  }
  const glm::dvec3 l00 = sum * (0.5 / std::sqrt(std::numbers::pi));
  for (int size : {64, 256, 512, 1024}) {
    const RunResult r = run("sh --input " + kProbe + " --order 2 --size " + std::to_string(size) +
                            " --out " + out.string() + " --json " + (out / "r.json").string());
    ASSERT_EQ(r.status, 0) << r.output;
    const auto j = nlohmann::json::parse(std::ifstream(out / "r.json"));
    for (int c = 0; c < 3; ++c)
      EXPECT_NEAR(j["coefficients"][0][c].get<double>(), l00[c], 1e-3 * l00[c])
          << "size " << size << " channel " << c;
  }
}

TEST(ArlightMapsSh, HigherOrdersFitBetter) {
  const fs::path out = temp_dir("orders");
  double last = 1e30;
  for (int order : {1, 4, 16}) {
    const RunResult r = run("sh --input " + kProbe + " --order " + std::to_string(order) +
                            " --size 64 --out " + out.string());
    ASSERT_EQ(r.status, 0) << r.output;
    const auto j = nlohmann::json::parse(std::ifstream(out / "sh.json"));
    const double e = j["rms_error"].get<double>();
    EXPECT_LT(e, last) << "order " << order;
    last = e;
  }
}

TEST(ArlightMapsSh, BadInputGivesAClearErrorAndStatus2) {
  const fs::path out = temp_dir("bad");
  RunResult r =
      run("sh --input " + (out / "missing.exr").string() + " --order 3 --out " + out.string());
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.output.find("missing.exr': no such file"), std::string::npos) << r.output;
  std::ofstream(out / "junk.exr") << "junk";
  r = run("sh --input " + (out / "junk.exr").string() + " --order 3 --out " + out.string());
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.output.find("junk.exr"), std::string::npos) << r.output;
  r = run("sh --input " + kProbe + " --order 0");
  EXPECT_NE(r.status, 0);
  EXPECT_NE(r.output.find("--order"), std::string::npos) << r.output;
}

TEST(ArlightMaps, HelpListsTheSubcommandAndItsOptions) {
  RunResult r = run("--help");
  EXPECT_EQ(r.status, 0);
  EXPECT_NE(r.output.find("sh"), std::string::npos);
  r = run("sh --help");
  EXPECT_EQ(r.status, 0);
  for (const char* opt : {"--input", "--order", "--size", "--json", "--out"})
    EXPECT_NE(r.output.find(opt), std::string::npos) << opt;
}

// ---- compute / compare / diff ----------------------------------------------------------------

TEST(ArlightMapsCompute, WritesEveryMapPreviewContactSheetAndJson) {
  const fs::path out = temp_dir("compute");
  const RunResult r = run("compute --input " + kProbe +
                          " --method sh:12 --shininess 1,10,80 --size 32 --projection cube --out " +
                          out.string() + " --json " + (out / "c.json").string());
  ASSERT_EQ(r.status, 0) << r.output;
  const auto j = nlohmann::json::parse(std::ifstream(out / "c.json"));
  EXPECT_EQ(j["method"], "sh:12");
  EXPECT_GT(j["seconds"].get<double>(), 0.0);
  ASSERT_EQ(j["maps"].size(), 3u);
  const double s[] = {1, 10, 80};
  for (std::size_t k = 0; k < 3; ++k) {
    EXPECT_EQ(j["maps"][k]["shininess"].get<double>(), s[k]);
    EXPECT_GE(j["maps"][k]["seconds"].get<double>(), 0.0);
    const fs::path exr = j["maps"][k]["file"].get<std::string>();
    ASSERT_TRUE(fs::exists(exr)) << exr;
    EXPECT_TRUE(fs::exists(fs::path(exr).replace_extension(".png")));
    const LoadedEnvMap m = load_envmap(exr);
    EXPECT_EQ(m.env.layout.projection(), Projection::Cube);
    EXPECT_EQ(m.env.layout.width(), 32);
    EXPECT_EQ(m.info.metadata.shininess.value_or(0.0), s[k]);
  }
  EXPECT_TRUE(fs::exists(out / "contact_sheet.png"));
}

TEST(ArlightMapsCompute, SizeMeansNxNAngleMap2NxNLatLongNxNCubeFace) {
  const fs::path out = temp_dir("sizes");
  for (const auto& [proj, w, h] : {std::tuple{"anglemap", 16, 16}, std::tuple{"latlong", 32, 16},
                                   std::tuple{"cube", 16, 96}}) {
    const RunResult r = run(std::string("compute --input ") + kProbe +
                            " --method mipmap --shininess 10 --size 16 --projection " + proj +
                            " --out " + out.string());
    ASSERT_EQ(r.status, 0) << r.output;
    const LoadedEnvMap m = load_envmap(out / "mipmap_s10.exr");
    EXPECT_EQ(m.env.layout.width(), w) << proj;
    EXPECT_EQ(m.env.layout.height(), h) << proj;
  }
}

TEST(ArlightMapsCompare, ReportsEveryMethodByTheGivenNameAgainstAccurate) {
  const fs::path out = temp_dir("compare");
  const std::string args = "compare --input " + kProbe +
                           " --size 32 --methods accurate,sh:20,mipmap,auto --shininess 1,40 "
                           "--cache-dir " +
                           (out / "cache").string() + " --out " + out.string();
  RunResult r = run(args + " --json " + (out / "a.json").string());
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("mean error"), std::string::npos) << r.output;
  auto j = nlohmann::json::parse(std::ifstream(out / "a.json"));
  EXPECT_EQ(j["size"], 32);
  ASSERT_EQ(j["methods"].size(), 4u);
  const char* names[] = {"accurate", "sh:20", "mipmap", "auto"};
  for (std::size_t m = 0; m < 4; ++m) {
    EXPECT_EQ(j["methods"][m]["name"], names[m]);
    EXPECT_GE(j["methods"][m]["seconds"].get<double>(), 0.0);
    ASSERT_EQ(j["methods"][m]["maps"].size(), 2u);
    for (const auto& map : j["methods"][m]["maps"]) {
      EXPECT_GE(map["mean_error"].get<double>(), 0.0);
      EXPECT_GE(map["max_error"].get<double>(), map["mean_error"].get<double>());
    }
  }
  EXPECT_EQ(j["methods"][0]["maps"][0]["max_error"].get<double>(), 0.0);
  EXPECT_GT(j["methods"][2]["maps"][0]["mean_error"].get<double>(),
            j["methods"][1]["maps"][0]["mean_error"].get<double>());
  EXPECT_FALSE(j["methods"][0].contains("cached"));
  // Second run: the reference comes from the cache; --no-cache recomputes it.
  r = run(args + " --json " + (out / "b.json").string());
  ASSERT_EQ(r.status, 0) << r.output;
  j = nlohmann::json::parse(std::ifstream(out / "b.json"));
  EXPECT_TRUE(j["methods"][0].value("cached", false));
  r = run(args + " --no-cache --json " + (out / "c.json").string());
  ASSERT_EQ(r.status, 0) << r.output;
  j = nlohmann::json::parse(std::ifstream(out / "c.json"));
  EXPECT_FALSE(j["methods"][0].contains("cached"));
  EXPECT_TRUE(fs::exists(out / "contact_sheet.png"));
  // A damaged cache entry is recomputed, not trusted.
  for (const auto& e : fs::recursive_directory_iterator(out / "cache"))
    if (e.path().extension() == ".exr") std::ofstream(e.path()) << "junk";
  r = run(args + " --json " + (out / "d.json").string());
  ASSERT_EQ(r.status, 0) << r.output;
  j = nlohmann::json::parse(std::ifstream(out / "d.json"));
  EXPECT_FALSE(j["methods"][0].contains("cached"));
}

TEST(ArlightMapsDiff, SameEnvironmentIsZeroAndADarkerOneIsMeasured) {
  const fs::path out = temp_dir("diff");
  // A copy of the probe at half the radiance: every map is exactly half, a 50 % error.
  LoadedEnvMap probe = load_envmap(kProbe);
  for (float& v : probe.env.image.storage()) v *= 0.5f;
  write_exr(out / "half.exr", probe.env.image.view(), {}, ExrPixel::Float);
  RunResult r = run("diff --reference " + kProbe + " --test " + kProbe +
                    " --shininess 1,20 --size 32 --json " + (out / "same.json").string());
  ASSERT_EQ(r.status, 0) << r.output;
  auto j = nlohmann::json::parse(std::ifstream(out / "same.json"));
  ASSERT_EQ(j["maps"].size(), 2u);
  for (const auto& m : j["maps"]) EXPECT_EQ(m["max_error"].get<double>(), 0.0);
  r = run("diff --reference " + kProbe + " --test " + (out / "half.exr").string() +
          " --shininess 1,20 --size 32 --json " + (out / "half.json").string());
  ASSERT_EQ(r.status, 0) << r.output;
  j = nlohmann::json::parse(std::ifstream(out / "half.json"));
  for (const auto& m : j["maps"]) EXPECT_NEAR(m["mean_error"].get<double>(), 0.5, 0.01);
}

TEST(ArlightMapsCompute, BadInputGivesOneClearLineAndNonZeroStatus) {
  const fs::path out = temp_dir("compute_bad");
  struct Case {
    std::string args, says;
  };
  const Case cases[] = {
      {"compute --input " + kProbe + " --method fastest", "method 'fastest'"},
      {"compute --input " + kProbe + " --shininess 1,0.5", "0.5 is below 1"},
      {"compute --input " + kProbe + " --shininess 1,x", "'x' is not a number"},
      {"compute --input " + kProbe + " --method mipmap --size 48", "power of two"},
      {"compute --input " + (out / "none.exr").string(), "none.exr': no such file"},
      {"compare --input " + kProbe + " --methods auto,bogus --size 16", "method 'bogus'"},
      {"diff --reference " + kProbe + " --test " + (out / "none.exr").string(), "none.exr"},
      {"compute --input " + kProbe + " --projection sphere", "--projection 'sphere'"},
  };
  for (const Case& c : cases) {
    const bool has_out = c.args.rfind("diff", 0) != 0;
    const RunResult r = run(c.args + (has_out ? " --out " + out.string() : ""));
    EXPECT_NE(r.status, 0) << c.args;
    EXPECT_NE(r.output.find(c.says), std::string::npos) << c.args << "\n" << r.output;
    EXPECT_LE(std::count(r.output.begin(), r.output.end(), '\n'), 2) << r.output;
  }
}

// Tutorial §9: previews with a global or a local operator, the input's size, any other name
// refused naming it.
TEST(ArlightMapsPreview, WritesEachToneAndRefusesAnUnknownOne) {
  const fs::path out = temp_dir("preview");
  for (const char* tone : {"global", "drago", "reinhard", "mantiuk"}) {
    const fs::path png = out / (std::string(tone) + ".png");
    const RunResult r = run("preview " + kProbe + " --tone " + tone + " --out " + png.string());
    ASSERT_EQ(r.status, 0) << r.output;
    EXPECT_EQ(r.output.find("WARN"), std::string::npos) << r.output;
    const LoadedImage img = load_image(png);
    EXPECT_EQ(img.image.width(), 512) << tone;
    EXPECT_EQ(img.image.height(), 256) << tone;
  }
  const RunResult bad = run("preview " + kProbe + " --tone aces --out " + (out / "x.png").string());
  EXPECT_EQ(bad.status, 2);
  EXPECT_NE(bad.output.find("'aces'"), std::string::npos) << bad.output;
  const RunResult missing =
      run("preview " + (out / "none.exr").string() + " --out " + (out / "y.png").string());
  EXPECT_EQ(missing.status, 2) << missing.output;
  EXPECT_FALSE(fs::exists(out / "y.png"));
}
