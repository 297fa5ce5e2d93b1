#include "checkpoint.hpp"

#include <xxhash.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <limits>
#include <type_traits>
#include <nlohmann/json.hpp>

#include "arlight/common/atomic_file.hpp"
#include "arlight/common/error.hpp"

namespace arlight::daemon {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

// A whole number field of a manifest in T's range, or InputError naming it: nlohmann's get<T>()
// of a number that does not fit (5e19 for a uint64, a fraction) is undefined behaviour.
template <class T>
T whole(const json& parent, const char* key, const std::string& where) {
  const json& v = parent.at(key);
  if (v.is_number_unsigned()) {
    const auto u = v.get<std::uint64_t>();
    if (u <= std::uint64_t(std::numeric_limits<T>::max())) return T(u);
  } else if (v.is_number_integer()) {
    const auto i = v.get<std::int64_t>();
    if (std::is_signed_v<T> && i >= std::int64_t(std::numeric_limits<T>::min()) &&
        i <= std::int64_t(std::numeric_limits<T>::max()))
      return T(i);
  }
  throw InputError(where + ": '" + key + "' is not a whole number in range");
}

template <class T>
T whole_or(const json& parent, const char* key, T fallback, const std::string& where) {
  return parent.contains(key) ? whole<T>(parent, key, where) : fallback;
}

constexpr char kAccumMagic[8] = {'A', 'R', 'L', 'A', 'C', 'C', '0', '1'};
constexpr char kManifest[] = "session.json";

json camera_json(const CameraIntrinsics& k) {
  return {{"width", k.width}, {"height", k.height},        {"fx", k.fx}, {"fy", k.fy}, {"cx", k.cx},
          {"cy", k.cy},       {"distortion", k.distortion}};
}

CameraIntrinsics camera_from_json(const json& j, const std::string& where) {
  CameraIntrinsics k;
  k.width = whole<int>(j, "width", where), k.height = whole<int>(j, "height", where);
  k.fx = j.at("fx"), k.fy = j.at("fy"), k.cx = j.at("cx"), k.cy = j.at("cy");
  k.distortion = j.at("distortion").get<std::array<double, 5>>();
  return k;
}

std::string accumulator_bytes(const capture::Accumulators& acc) {
  std::string bytes(kAccumMagic, sizeof kAccumMagic);
  const std::uint64_t texels = acc.weight.size();
  bytes.append(reinterpret_cast<const char*>(&texels), sizeof texels);
  bytes.append(reinterpret_cast<const char*>(acc.weighted_radiance.data()),
               acc.weighted_radiance.size() * sizeof(float));
  bytes.append(reinterpret_cast<const char*>(acc.weight.data()), acc.weight.size() * sizeof(float));
  return bytes;
}

capture::Accumulators parse_accumulators(const std::string& bytes, const std::string& where) {
  std::uint64_t texels = 0;
  if (bytes.size() < sizeof kAccumMagic + sizeof texels ||
      std::memcmp(bytes.data(), kAccumMagic, sizeof kAccumMagic) != 0)
    throw InputError(where + ": the accumulator file has no ARLACC01 header");
  std::memcpy(&texels, bytes.data() + sizeof kAccumMagic, sizeof texels);
  const std::size_t offset = sizeof kAccumMagic + sizeof texels;
  if (texels > (bytes.size() - offset) / (4 * sizeof(float)) ||
      bytes.size() != offset + texels * 4 * sizeof(float))
    throw InputError(where + ": the accumulator file has the wrong size");
  capture::Accumulators acc;
  acc.weighted_radiance.resize(texels * 3);
  acc.weight.resize(texels);
  std::memcpy(acc.weighted_radiance.data(), bytes.data() + offset, texels * 3 * sizeof(float));
  std::memcpy(acc.weight.data(), bytes.data() + offset + texels * 3 * sizeof(float),
              texels * sizeof(float));
  return acc;
}

}  // namespace

// Version 1's checksum as arlightd computed it: FNV-1a 64, but with the offset basis one digit
// short (the standard one is 14695981039346656037). Kept as it was: version 1 files carry it.
std::uint64_t checkpoint_fnv1a(const std::string& bytes) {
  std::uint64_t h = 1469598103934665603ull;
  for (unsigned char c : bytes) h = (h ^ c) * 1099511628211ull;
  return h;
}

std::uint64_t checkpoint_xxh3(const std::string& bytes) {
  return XXH3_64bits(bytes.data(), bytes.size());
}

AccumulatorFile write_checkpoint(const fs::path& dir, const SessionCheckpoint& c, int generation,
                                 const std::optional<AccumulatorFile>& same_accumulators) {
  json meta = {{"format", "arlight-session"},
               {"version", kCheckpointVersion},
               {"id", c.id},
               {"device_id", c.device_id},
               {"camera", camera_json(c.camera)},
               {"response", c.response},
               {"map_size", c.map_size},
               {"frames_received", c.frames_received},
               {"frames_processed", c.frames_processed},
               {"frames_dropped", c.frames_dropped},
               {"frames_skipped", c.frames_skipped},
               {"last_sequence", c.last_sequence},
               {"coverage", c.coverage},
               {"generation", generation}};
  if (c.layout)
    meta["layout"] = {{"projection", std::string(projection_name(c.layout->projection()))},
                      {"width", c.layout->width()},
                      {"height", c.layout->height()}};
  if (c.request)
    meta["request"] = {{"shininess", c.request->shininess},
                       {"size", c.request->size},
                       {"projection", std::string(projection_name(c.request->projection))},
                       {"method", c.request->method},
                       {"kind", c.request->kind == wire::MapKind::Ggx ? "ggx" : "phong"},
                       {"levels", c.request->levels},
                       {"specular_lights", c.request->specular_lights}};
  for (const ContributorCheckpoint& k : c.contributors)
    meta["contributors"].push_back(
        {{"device_id", k.device_id},
         {"offset", {k.offset.w, k.offset.x, k.offset.y, k.offset.z}},
         {"radiance_scale", k.radiance_scale}});
  fs::create_directories(dir);
  AccumulatorFile file;
  if (same_accumulators) {
    file = *same_accumulators;
  } else {
    const std::string bytes = accumulator_bytes(c.accumulators);
    file = {"accum-" + std::to_string(generation) + ".bin", checkpoint_xxh3(bytes)};
    write_file_atomically(dir / file.name, bytes);
  }
  meta["accumulators"] = file.name;
  meta["checksum_xxh3"] = file.checksum_xxh3;
  write_file_atomically(dir / kManifest, meta.dump(1) + "\n");
  if (!same_accumulators)
    for (const auto& entry : fs::directory_iterator(dir)) {
      const std::string f = entry.path().filename().string();
      if (f.starts_with("accum-") && f != file.name) fs::remove(entry.path());
    }
  return file;
}

std::optional<SessionCheckpoint> read_checkpoint(const fs::path& dir) {
  const fs::path manifest = dir / kManifest;
  if (!fs::exists(manifest)) return std::nullopt;
  const std::string where = "session checkpoint '" + manifest.string() + "'";
  try {
    const json meta = json::parse(std::ifstream(manifest));
    const int version = whole<int>(meta, "version", where);
    if (meta.at("format") != "arlight-session" || version < 1 || version > kCheckpointVersion)
      throw InputError(where + ": not a version 1 or 2 session checkpoint");
    SessionCheckpoint c;
    c.id = meta.at("id").get<std::string>();
    c.device_id = meta.at("device_id").get<std::string>();
    c.camera = camera_from_json(meta.at("camera"), where);
    c.response = meta.value("response", std::string("srgb"));
    c.map_size = whole<int>(meta, "map_size", where);
    c.frames_received = whole<std::uint64_t>(meta, "frames_received", where);
    c.frames_processed = whole<std::uint64_t>(meta, "frames_processed", where);
    c.frames_dropped = whole<std::uint64_t>(meta, "frames_dropped", where);
    c.frames_skipped = whole<std::uint64_t>(meta, "frames_skipped", where);
    c.last_sequence = whole<std::uint64_t>(meta, "last_sequence", where);
    c.coverage = meta.value("coverage", 0.0);
    if (meta.contains("layout")) {
      const json& l = meta["layout"];
      const auto projection = parse_projection(l.at("projection").get<std::string>());
      if (!projection) throw InputError(where + ": unknown layout projection");
      try {
        c.layout = EnvLayout(*projection, whole<int>(l, "width", where), whole<int>(l, "height", where));
      } catch (const std::invalid_argument& e) {
        throw InputError(where + ": layout: " + e.what());
      }
    }
    if (meta.contains("request")) {
      const json& r = meta["request"];
      MapRequest req;
      req.shininess = r.at("shininess").get<std::vector<double>>();
      req.size = whole<int>(r, "size", where);
      const auto projection = parse_projection(r.at("projection").get<std::string>());
      if (!projection) throw InputError(where + ": unknown projection");
      req.projection = *projection;
      req.method = r.at("method");
      // Checkpoints from before the GGX chain (issue 34 §2) hold Phong requests only.
      const std::string kind = r.value("kind", std::string("phong"));
      if (kind != "phong" && kind != "ggx")
        throw InputError(where + ": unknown map kind '" + kind + "'");
      req.kind = kind == "ggx" ? wire::MapKind::Ggx : wire::MapKind::Phong;
      req.levels = whole_or<int>(r, "levels", 0, where);
      // Checkpoints from before issue 51 take no lights out of the chain.
      req.specular_lights = whole_or<int>(r, "specular_lights", 0, where);
      if (req.specular_lights < 0 || req.specular_lights > kMaxSpecularLights ||
          (req.specular_lights != 0 && req.kind != wire::MapKind::Ggx))
        throw InputError(where + ": specular_lights " + std::to_string(req.specular_lights) +
                         " is not a GGX request's 0 to " + std::to_string(kMaxSpecularLights));
      c.request = req;
    }
    if (meta.contains("contributors")) {
      if (!meta["contributors"].is_array() || meta["contributors"].size() > kMaxContributorCheckpoints)
        throw InputError(where + ": contributors must be a list of at most " +
                         std::to_string(kMaxContributorCheckpoints));
      for (const json& k : meta["contributors"]) {
        ContributorCheckpoint cc;
        cc.device_id = k.at("device_id").get<std::string>();
        const auto q = k.at("offset").get<std::array<double, 4>>();
        cc.offset = glm::dquat(q[0], q[1], q[2], q[3]);
        cc.radiance_scale = k.at("radiance_scale").get<double>();
        if (!(std::abs(glm::length(cc.offset) - 1.0) < 1e-3) ||
            !std::isfinite(cc.radiance_scale) || !(cc.radiance_scale > 0.0))
          throw InputError(where + ": contributor " + cc.device_id +
                           ": offset must be a unit quaternion and radiance_scale > 0");
        c.contributors.push_back(cc);
      }
    }
    const std::string file = meta.at("accumulators").get<std::string>();
    if (file.find('/') != std::string::npos || file.find("..") != std::string::npos)
      throw InputError(where + ": the accumulator file name '" + file + "' leaves the folder");
    // Checkpoints before 2026-12 name their generation only in the file name.
    int named_generation = 0;
    if (std::sscanf(file.c_str(), "accum-%d.bin", &named_generation) != 1) named_generation = 0;
    c.generation = std::max(whole_or<int>(meta, "generation", 0, where), named_generation);
    std::ifstream in(dir / file, std::ios::binary);
    const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const bool intact =
        version == 1 ? checkpoint_fnv1a(bytes) == whole<std::uint64_t>(meta, "checksum", where)
                     : checkpoint_xxh3(bytes) == whole<std::uint64_t>(meta, "checksum_xxh3", where);
    if (!intact)
      throw InputError(where + ": the accumulator file is missing or damaged (checksum)");
    c.accumulators = parse_accumulators(bytes, where);
    if (version >= 2)
      c.accumulator_file = AccumulatorFile{file, whole<std::uint64_t>(meta, "checksum_xxh3", where)};
    std::optional<EnvLayout> layout;
    try {
      layout = c.capture_layout();
    } catch (const std::invalid_argument& e) {
      throw InputError(where + ": map_size " + std::to_string(c.map_size) + ": " + e.what());
    }
    if (c.accumulators.weight.size() != layout->texel_count())
      throw InputError(where + ": " + std::to_string(c.accumulators.weight.size()) +
                       " accumulated texels do not fit its " + std::to_string(layout->width()) +
                       "x" + std::to_string(layout->height()) + " map");
    return c;
  } catch (const json::exception& e) {
    throw InputError(where + ": " + e.what());
  }
}

}  // namespace arlight::daemon
