// The session checkpoint format (server/daemon/src/checkpoint.*) without a daemon: round trips,
// version 1 checkpoints as arlightd wrote them before xxHash still read, damage refused.
#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>

#include "arlight/common/atomic_file.hpp"
#include "arlight/common/error.hpp"
#include "checkpoint.hpp"

namespace arlight::daemon {
namespace {

namespace fs = std::filesystem;

fs::path fresh_dir(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("arlight_checkpoint_" + name);
  fs::remove_all(dir);
  return dir;
}

SessionCheckpoint sample() {
  SessionCheckpoint c;
  c.id = "0123456789abcdef0123456789abcdef";
  c.device_id = "phone-1";
  c.camera = CameraIntrinsics::from_fov(640, 480, 60);
  c.camera.distortion = {0.1, -0.02, 0.0, 0.001, 0.0};
  c.response = "filmic";
  c.map_size = 64;
  c.frames_received = 90, c.frames_processed = 80, c.frames_dropped = 7, c.frames_skipped = 3;
  c.last_sequence = 90;
  c.request = MapRequest{{1, 10, 1280}, 128, Projection::LatLong, "sh:12"};
  const std::size_t texels = 64 * 64;
  for (std::size_t i = 0; i < texels; ++i) {
    c.accumulators.weight.push_back(float(i % 7) * 0.5f);
    for (int k = 0; k < 3; ++k) c.accumulators.weighted_radiance.push_back(float(i) * 0.25f + k);
  }
  return c;
}

void expect_same(const SessionCheckpoint& a, const SessionCheckpoint& b) {
  EXPECT_EQ(a.id, b.id);
  EXPECT_EQ(a.device_id, b.device_id);
  EXPECT_EQ(a.camera.width, b.camera.width);
  EXPECT_EQ(a.camera.fx, b.camera.fx);
  EXPECT_EQ(a.camera.distortion, b.camera.distortion);
  EXPECT_EQ(a.response, b.response);
  EXPECT_EQ(a.map_size, b.map_size);
  EXPECT_EQ(a.frames_received, b.frames_received);
  EXPECT_EQ(a.frames_processed, b.frames_processed);
  EXPECT_EQ(a.frames_dropped, b.frames_dropped);
  EXPECT_EQ(a.frames_skipped, b.frames_skipped);
  EXPECT_EQ(a.last_sequence, b.last_sequence);
  ASSERT_EQ(a.request.has_value(), b.request.has_value());
  if (a.request) {
    EXPECT_EQ(a.request->shininess, b.request->shininess);
    EXPECT_EQ(a.request->size, b.request->size);
    EXPECT_EQ(a.request->projection, b.request->projection);
    EXPECT_EQ(a.request->method, b.request->method);
    EXPECT_EQ(a.request->kind, b.request->kind);
    EXPECT_EQ(a.request->levels, b.request->levels);
  }
  EXPECT_EQ(a.accumulators.weight, b.accumulators.weight);
  EXPECT_EQ(a.accumulators.weighted_radiance, b.accumulators.weighted_radiance);
}

std::string read_bytes(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

TEST(Checkpoint, RoundTripsEverythingAndKeepsOnlyTheNewestGeneration) {
  const fs::path dir = fresh_dir("roundtrip");
  EXPECT_FALSE(read_checkpoint(dir).has_value());  // nothing there yet
  SessionCheckpoint c = sample();
  write_checkpoint(dir, c, 1);
  c.frames_processed = 81;
  c.request.reset();
  write_checkpoint(dir, c, 2);
  EXPECT_FALSE(fs::exists(dir / "accum-1.bin"));
  EXPECT_TRUE(fs::exists(dir / "accum-2.bin"));
  const auto back = read_checkpoint(dir);
  ASSERT_TRUE(back);
  expect_same(c, *back);
  const auto meta = nlohmann::json::parse(read_bytes(dir / "session.json"));
  EXPECT_EQ(meta.at("version"), kCheckpointVersion);
  EXPECT_EQ(meta.at("checksum_xxh3").get<std::uint64_t>(),
            checkpoint_xxh3(read_bytes(dir / "accum-2.bin")));
}

// Frames that changed nothing move only the manifest's counts and sequence (issue 36 §5): the
// accumulator file is not written again, and the manifest still names it with its checksum.
TEST(Checkpoint, NewFrameCountsAloneRewriteOnlyTheManifest) {
  const fs::path dir = fresh_dir("manifest_only");
  SessionCheckpoint c = sample();
  const AccumulatorFile file = write_checkpoint(dir, c, 3);
  EXPECT_EQ(file.name, "accum-3.bin");
  const auto written = fs::last_write_time(dir / file.name);
  const SessionCheckpoint full = c;
  c.frames_received += 40, c.frames_processed += 40, c.last_sequence += 40;
  c.accumulators = {};  // not read
  EXPECT_EQ(write_checkpoint(dir, c, 3, file).name, file.name);
  EXPECT_EQ(fs::last_write_time(dir / file.name), written);
  const auto back = read_checkpoint(dir);
  ASSERT_TRUE(back);
  EXPECT_EQ(back->last_sequence, full.last_sequence + 40);
  EXPECT_EQ(back->frames_received, full.frames_received + 40);
  EXPECT_EQ(back->accumulators.weight, full.accumulators.weight);  // the map as it was
  ASSERT_TRUE(back->accumulator_file);
  EXPECT_EQ(back->accumulator_file->name, file.name);
  EXPECT_EQ(back->accumulator_file->checksum_xxh3, file.checksum_xxh3);
}

// A session that asked for a GGX chain resumes asking for it (issue 34 §2).
TEST(Checkpoint, KeepsAGgxChainRequest) {
  const fs::path dir = fresh_dir("ggx");
  SessionCheckpoint c = sample();
  c.request = MapRequest{.shininess = {}, .size = 256, .kind = wire::MapKind::Ggx, .levels = 5,
                         .specular_lights = 6};
  write_checkpoint(dir, c, 1);
  const auto back = read_checkpoint(dir);
  ASSERT_TRUE(back);
  expect_same(c, *back);
  EXPECT_EQ(back->request->ggx_min_face(), 16);
  EXPECT_EQ(back->request->specular_lights, 6);  // the lights still taken out of the chain
}

// Two phones, one room (issue 49 §1): where each contributor's frames sit on the map is kept; a
// registration that is not a rotation, or a scale that is not positive, is damage.
TEST(Checkpoint, KeepsTheContributorsRegistrations) {
  const fs::path dir = fresh_dir("contributors");
  SessionCheckpoint c = sample();
  c.contributors = {{"phone-b", glm::normalize(glm::dquat(0.5, 0.0, 0.8660254, 0.0)), 0.625},
                    {"phone-c", glm::dquat(1, 0, 0, 0), 1.5}};
  write_checkpoint(dir, c, 1);
  const auto back = read_checkpoint(dir);
  ASSERT_TRUE(back);
  EXPECT_EQ(back->contributors, c.contributors);
  c.contributors[1].radiance_scale = 0.0;
  write_checkpoint(dir, c, 2);
  EXPECT_THROW(
      {
        try {
          read_checkpoint(dir);
        } catch (const InputError& e) {
          EXPECT_NE(std::string(e.what()).find("phone-c"), std::string::npos) << e.what();
          throw;
        }
      },
      InputError);
  c.contributors = {};  // a checkpoint before issue 49 names none
  write_checkpoint(dir, c, 3);
  EXPECT_TRUE(read_checkpoint(dir)->contributors.empty());
}

// A version 1 checkpoint exactly as arlightd wrote it before this format (FNV-1a checksum).
TEST(Checkpoint, ReadsVersion1AsEarlierDaemonsWroteIt) {
  const fs::path dir = fresh_dir("v1");
  fs::create_directories(dir);
  const SessionCheckpoint c = sample();
  std::string bytes = "ARLACC01";
  const std::uint64_t texels = c.accumulators.weight.size();
  bytes.append(reinterpret_cast<const char*>(&texels), sizeof texels);
  bytes.append(reinterpret_cast<const char*>(c.accumulators.weighted_radiance.data()),
               c.accumulators.weighted_radiance.size() * sizeof(float));
  bytes.append(reinterpret_cast<const char*>(c.accumulators.weight.data()),
               c.accumulators.weight.size() * sizeof(float));
  write_file_atomically(dir / "accum-3.bin", bytes);
  const CameraIntrinsics& k = c.camera;
  nlohmann::json meta = {{"format", "arlight-session"},
                         {"version", 1},
                         {"id", c.id},
                         {"device_id", c.device_id},
                         {"camera",
                          {{"width", k.width},
                           {"height", k.height},
                           {"fx", k.fx},
                           {"fy", k.fy},
                           {"cx", k.cx},
                           {"cy", k.cy},
                           {"distortion", k.distortion}}},
                         {"response", c.response},
                         {"map_size", c.map_size},
                         {"frames_received", c.frames_received},
                         {"frames_processed", c.frames_processed},
                         {"frames_dropped", c.frames_dropped},
                         {"frames_skipped", c.frames_skipped},
                         {"last_sequence", c.last_sequence},
                         {"request",
                          {{"shininess", c.request->shininess},
                           {"size", c.request->size},
                           {"projection", "latlong"},
                           {"method", c.request->method}}},
                         {"accumulators", "accum-3.bin"},
                         {"checksum", checkpoint_fnv1a(bytes)}};
  write_file_atomically(dir / "session.json", meta.dump(1) + "\n");
  const auto back = read_checkpoint(dir);
  ASSERT_TRUE(back);
  expect_same(c, *back);
  // Version 1's checksum is FNV-1a with the offset basis one digit short (1469598103934665603,
  // not 14695981039346656037): pinned by value, since that is what version 1 files carry.
  EXPECT_EQ(checkpoint_fnv1a("a"), 0x44bd8ad473cd9906ull);
}

TEST(Checkpoint, DamageIsAnErrorNamingWhatIsWrong) {
  const auto expect_error = [](const fs::path& dir, const std::string& words) {
    try {
      read_checkpoint(dir);
      ADD_FAILURE() << "accepted; expected an error about " << words;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
    }
  };
  const fs::path dir = fresh_dir("damage");
  write_checkpoint(dir, sample(), 1);
  std::string accum = read_bytes(dir / "accum-1.bin");
  const std::string manifest = read_bytes(dir / "session.json");

  accum[100] ^= 1;  // one bit of one texel
  write_file_atomically(dir / "accum-1.bin", accum);
  expect_error(dir, "checksum");
  fs::remove(dir / "accum-1.bin");
  expect_error(dir, "checksum");

  write_checkpoint(dir, sample(), 2);
  write_file_atomically(dir / "session.json", manifest.substr(0, manifest.size() / 2));
  expect_error(dir, "session.json");

  auto meta = nlohmann::json::parse(manifest);
  meta["accumulators"] = "accum-2.bin";
  meta["version"] = 3;
  write_file_atomically(dir / "session.json", meta.dump());
  expect_error(dir, "version");
  meta["version"] = 2;
  meta["accumulators"] = "../../etc/passwd";
  write_file_atomically(dir / "session.json", meta.dump());
  expect_error(dir, "leaves the folder");
  meta["accumulators"] = "accum-2.bin";
  meta.erase("map_size");
  write_file_atomically(dir / "session.json", meta.dump());
  expect_error(dir, "map_size");
  // A map size no layout has (an old checkpoint's angle map), or a layout of another shape.
  meta["map_size"] = -3;
  write_file_atomically(dir / "session.json", meta.dump());
  expect_error(dir, "map_size");
  meta["map_size"] = 64;
  meta["layout"] = {{"projection", "cube"}, {"width", 64}, {"height", 65}};
  write_file_atomically(dir / "session.json", meta.dump());
  expect_error(dir, "layout");
}

}  // namespace
}  // namespace arlight::daemon
