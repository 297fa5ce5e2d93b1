// Runs the real arlight-maps binary.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "arlight/hdr_io.hpp"
#include "arlight/resample.hpp"
#include "arlight/sh.hpp"

namespace fs = std::filesystem;

namespace {

struct RunResult {
  int status;
  std::string output;  // stdout and stderr
};

RunResult run(const std::string& args) {
  const std::string cmd = std::string(ARLIGHT_MAPS_EXE) + " " + args + " 2>&1";
  FILE* p = popen(cmd.c_str(), "r");
  RunResult r{-1, {}};
  if (!p) return r;
  char buf[4096];
  while (std::size_t n = std::fread(buf, 1, sizeof buf, p)) r.output.append(buf, n);
  const int st = pclose(p);
  r.status = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
  return r;
}

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

  // The coefficients are those of the library on the same resampled map, in l(l+1)+m order.
  using namespace arlight;
  const EnvLayout layout = EnvLayout::for_size(Projection::AngleMap, 64);
  const ShCoeffs want = sh_project(resample(load_envmap(kProbe).env, layout), 6);
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
