// A session's checkpoint on disk (DATA/sessions/<id>/): what a resume needs to continue where
// the session was. Two files: the accumulators (accum-<generation>.bin: "ARLACC01", the texel
// count as a little-endian u64, then sum(w L) as 3 floats per texel and sum(w) as 1 float per
// texel) and the manifest session.json naming them with their checksum. The accumulators are
// written to a new file and the manifest renamed in last, so a crash at any point leaves the
// previous checkpoint whole.
//
// Format versions: 2 (written) checks the accumulators with XXH3-64 (xxHash); 1 (arlightd
// before 2026-12) with FNV-1a 64. Both are read.
#pragma once

#include <cstdint>
#include <filesystem>
#include <glm/gtc/quaternion.hpp>
#include <optional>
#include <string>
#include <vector>

#include "arlight/capture/capture.hpp"
#include "arlight/common/camera.hpp"
#include "arlight/common/projection.hpp"
#include "map_request.hpp"

namespace arlight::daemon {

inline constexpr int kCheckpointVersion = 2;
inline constexpr std::size_t kMaxContributorCheckpoints = 64;  // devices a checkpoint may name

// The accumulator file a manifest names, with its checksum.
struct AccumulatorFile {
  std::string name;
  std::uint64_t checksum_xxh3 = 0;
};

// Another device that captured into the session (issue 49 §1): where its frames sit on the map.
// A contributor joining again with that device id continues from it without registering anew.
struct ContributorCheckpoint {
  std::string device_id;
  glm::dquat offset{1, 0, 0, 0};  // world = offset * its sensor's orientation
  double radiance_scale = 1.0;    // its radiance in the map's units
  bool operator==(const ContributorCheckpoint&) const = default;
};

struct SessionCheckpoint {
  std::string id, device_id;
  CameraIntrinsics camera;
  std::string response = "srgb";  // the curve's name the frames were linearised with
  int map_size = 0;
  // The layout of the accumulators; checkpoints before 2026-12-02 have none: theirs is an angle
  // map of map_size (capture_layout() says which).
  std::optional<EnvLayout> layout;
  EnvLayout capture_layout() const {
    return layout ? *layout : EnvLayout::for_size(Projection::AngleMap, map_size);
  }
  // last_sequence: every frame up to it is in the checkpoint (processed, dropped or skipped);
  // a client sends the frames after it again after a resume (issue 36 §5).
  std::uint64_t frames_received = 0, frames_processed = 0, frames_dropped = 0, frames_skipped = 0,
                last_sequence = 0;
  // The fraction of the sphere the map had seen (for people and fail-over checks; a resume
  // recomputes it from the accumulators).
  double coverage = 0;
  // The generation it was written as (accum-<generation>.bin): a daemon that resumes the
  // session continues the count, so its first checkpoint never overwrites the file the
  // manifest still names.
  int generation = 0;
  std::optional<MapRequest> request;
  std::vector<ContributorCheckpoint> contributors;  // the registered ones (checkpoints before
                                                    // issue 49 have none)
  capture::Accumulators accumulators;
  // Read: the file they came from (a version 2 checkpoint's), so that a checkpoint of new
  // frame counts alone can name it again.
  std::optional<AccumulatorFile> accumulator_file;
};

// Writes `c` into `dir` (created if needed) as generation `generation` (increasing per session)
// and removes the accumulator files of older generations; returns the accumulators' file.
// With `same_accumulators` (a file an earlier call of this generation returned: the map has not
// changed since, only the frame counts and sequence have) only the manifest is rewritten, naming
// that file, and c.accumulators is not read. Throws on I/O failure; the previous checkpoint
// stays whole then.
AccumulatorFile write_checkpoint(const std::filesystem::path& dir, const SessionCheckpoint& c,
                                 int generation,
                                 const std::optional<AccumulatorFile>& same_accumulators = {});

// The checkpoint in `dir`; std::nullopt when it has none (no manifest). InputError naming the
// file and what is wrong when it is damaged: a manifest that does not parse or lacks a field,
// an unknown version, an accumulator file missing, of the wrong size or failing its checksum.
std::optional<SessionCheckpoint> read_checkpoint(const std::filesystem::path& dir);

// The checksums of both versions, for tests that write a version 1 checkpoint.
std::uint64_t checkpoint_fnv1a(const std::string& bytes);
std::uint64_t checkpoint_xxh3(const std::string& bytes);

}  // namespace arlight::daemon
