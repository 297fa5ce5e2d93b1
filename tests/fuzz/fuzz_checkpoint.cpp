// Fuzz target: a session checkpoint as arlightd reads it on a resume (possibly written by another
// daemon, or damaged by a crash or a full disk). The input is two parts (fuzz_support.hpp):
// session.json and accum-1.bin. read_checkpoint must say what is wrong with an InputError; what
// it accepts must have accumulators of the size its map needs.
#include "arlight/common/error.hpp"
#include "checkpoint.hpp"
#include "fuzz_support.hpp"

using namespace arlight;
namespace fs = std::filesystem;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto parts = fuzz::split_parts(data, size, 2);
  const fs::path dir = fuzz::scratch() / "checkpoint";
  fs::create_directories(dir);
  fuzz::write_file(dir / "session.json", parts[0]);
  fuzz::write_file(dir / "accum-1.bin", parts[1]);
  try {
    const auto c = daemon::read_checkpoint(dir);
    if (c && c->accumulators.weight.size() * 3 != c->accumulators.weighted_radiance.size())
      fuzz::finding("a checkpoint was accepted with accumulators of different sizes");
  } catch (const InputError& e) {
    fuzz::refused(e);
  }
  return 0;
}

FuzzSeeds arlight_fuzz_seeds() {
  const fs::path dir = fuzz::scratch() / "seed-checkpoint";
  fs::remove_all(dir);
  daemon::SessionCheckpoint c;
  c.id = "0123456789abcdef0123456789abcdef";
  c.device_id = "phone-1";
  c.camera = CameraIntrinsics::from_fov(64, 48, 60);
  c.map_size = 4;
  c.frames_received = c.frames_processed = c.last_sequence = 10;
  c.accumulators.weight.assign(16, 0.5f);
  c.accumulators.weighted_radiance.assign(48, 0.25f);
  FuzzSeeds seeds;
  daemon::write_checkpoint(dir, c, 1);
  seeds.push_back(fuzz::join_parts(
      {fuzz::read_file(dir / "session.json"), fuzz::read_file(dir / "accum-1.bin")}));
  c.request = daemon::MapRequest{{1, 10, 80}, 64, Projection::AngleMap, "auto"};
  fs::remove_all(dir);
  daemon::write_checkpoint(dir, c, 1);
  seeds.push_back(fuzz::join_parts(
      {fuzz::read_file(dir / "session.json"), fuzz::read_file(dir / "accum-1.bin")}));
  return seeds;
}
