// Runs the real arlight-model binary: the radiance-transfer bake, and the page's baked copy.
#include <gtest/gtest.h>

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>

#include "support/run_tool.hpp"

namespace fs = std::filesystem;
using json = nlohmann::json;
using namespace arlight;

namespace {

test::RunResult run(const std::string& args) { return test::run_tool(ARLIGHT_MODEL_EXE, args); }

const std::string kBunny = std::string(ARLIGHT_SOURCE_DIR) + "/data/models/bunny.glb";

}  // namespace

// The bake reports its time and what it found: the bunny (2,826 vertices) is mostly open, its
// creases hidden from half the room or more; fewer rays give the same occlusion to a few percent.
TEST(ArlightModel, BakeReportsTheBunnysOcclusionAndItsTime) {
  const test::RunResult r = run("bake " + kBunny);
  ASSERT_EQ(r.status, 0) << r.output;
  const json j = json::parse(r.output);
  EXPECT_EQ(j.at("vertices"), 2826);
  const json& bake = j.at("bake");
  EXPECT_EQ(bake.at("directions"), 1024);
  EXPECT_GT(bake.at("bake_seconds").get<double>(), 0.0);
  EXPECT_GT(bake.at("ao").at("mean").get<double>(), 0.85);
  EXPECT_LT(bake.at("ao").at("mean").get<double>(), 0.95);
  EXPECT_LT(bake.at("ao").at("min").get<double>(), 0.5);
  const test::RunResult coarse = run("bake " + kBunny + " --directions 512");
  ASSERT_EQ(coarse.status, 0) << coarse.output;
  EXPECT_NEAR(json::parse(coarse.output).at("bake").at("ao").at("mean").get<double>(),
              bake.at("ao").at("mean").get<double>(), 0.01);

  const test::RunResult few = run("bake " + kBunny + " --directions 4");
  EXPECT_NE(few.status, 0);
  EXPECT_NE(few.output.find("--directions"), std::string::npos) << few.output;
  const test::RunResult missing = run("bake /nonexistent/model.glb");
  EXPECT_EQ(missing.status, 1);
  EXPECT_NE(missing.output.find("/nonexistent/model.glb"), std::string::npos) << missing.output;
}

// convert --bake writes the occlusion and the transfer into the copy (what arlightd serves the
// page); a plain convert does not.
TEST(ArlightModel, ConvertBakeCarriesTheOcclusionInTheCopy) {
  const fs::path dir = fs::temp_directory_path() / "arlight_model_test_convert";
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string plain = (dir / "plain.glb").string(), baked = (dir / "baked.glb").string();
  ASSERT_EQ(run("convert " + kBunny + " " + plain).status, 0);
  ASSERT_EQ(run("convert --bake " + kBunny + " " + baked).status, 0);
  const test::RunResult p = run("info " + plain), b = run("info " + baked);
  ASSERT_EQ(p.status, 0) << p.output;
  ASSERT_EQ(b.status, 0) << b.output;
  EXPECT_FALSE(json::parse(p.output).at("occlusion").get<bool>());
  EXPECT_TRUE(json::parse(b.output).at("occlusion").get<bool>());
  EXPECT_FALSE(json::parse(p.output).at("ground").get<bool>());
  EXPECT_TRUE(json::parse(b.output).at("ground").get<bool>());
  EXPECT_FALSE(json::parse(p.output).at("transfer").get<bool>());
  EXPECT_TRUE(json::parse(b.output).at("transfer").get<bool>());
  // 2,826 bent normals and occlusions of 4 floats each and SH-9 transfers of 9 floats each, the
  // floor's 64 x 64 occlusions and transfers (1 + 9 floats), and their accessors' few hundred
  // bytes.
  const auto extra = fs::file_size(baked) - fs::file_size(plain);
  EXPECT_GE(extra, 2826u * (16u + 36u) + 4096u * 40u);
  EXPECT_LT(extra, 2826u * (16u + 36u) + 4096u * 40u + 1024u);
}

// lightmap needs UVs: the bunny has none, and says so without writing anything.
TEST(ArlightModel, LightMapOfAModelWithoutUvsIsRefusedByName) {
  const fs::path out = fs::temp_directory_path() / "arlight_model_test_light.png";
  fs::remove(out);
  const test::RunResult r = run("lightmap " + kBunny + " " + out.string() + " --size 64");
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_NE(r.output.find("no UVs"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("bunny.glb"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(out));
}
