// Map sets as their tiles arrive (protocol/PROTOCOL.md, item 7): level-0 tiles fill the maps,
// MapSetComplete finishes a set and makes older unfinished ones stale. No networking: the
// native protocol client and the browser client (WebAssembly) both use it.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <vector>

#include "arlight/common/projection.hpp"
#include "arlight/protocol/wire.hpp"

namespace arlight::client {

// A map set as it arrives: level-0 tiles fill `maps`; complete once MapSetComplete came.
// Phong: a map per shininess. Ggx: the GGX chain, maps[k] level k (cube maps, each half the
// face of the one before) at perceptual roughness[k].
struct ReceivedMapSet {
  std::uint32_t id = 0;
  wire::MapKind kind = wire::MapKind::Phong;
  std::vector<double> shininess;  // Phong
  std::vector<double> roughness;  // Ggx
  std::vector<EnvMap> maps;
  std::vector<std::size_t> texels_received;  // per map, level 0
  bool preview_received = false;             // the coarse tiles of every map
  bool complete = false;
  double server_seconds = 0;
  double coverage = 0;       // of the environment map the set was computed from
  std::uint64_t frames = 0;  // frames merged into that map
};

class MapSetAssembler {
 public:
  // What this connection asked for (RequestMaps). Only a set of exactly these maps is used
  // (Phong: the shininess list; Ggx: a chain of as many levels, each level's face half the one
  // before, roughness rising), and none before a request: a resumed session's set still in
  // flight for an earlier connection's request reaches the new connection too (a client that
  // asked for no maps was then drawn with them).
  void expect(const wire::RequestMaps& request);
  // A watcher (Hello's watch_session) asks for nothing: it takes whatever whole sets the
  // session streams, Phong or GGX, as long as each is consistent in itself.
  void expect_any();
  // A tile whose size disagrees with its set's first tiles, or whose data does not decode, is
  // dropped (the set then never completes its texel count).
  void add_tile(const wire::MapTile& tile);
  // The completed set, or nullopt unless every one of its `done.maps` maps arrived whole (a set
  // begun on an earlier connection of a resumed session, or with a dropped tile, is not used).
  std::optional<ReceivedMapSet> complete(const wire::MapSetComplete& done);

 private:
  std::map<std::uint32_t, ReceivedMapSet> building_;
  bool requested_ = false;
  bool any_ = false;  // expect_any()
  wire::MapKind kind_ = wire::MapKind::Phong;
  std::vector<float> expected_;  // Phong: as the wire carries them
  std::size_t levels_ = 0;       // Ggx
};

}  // namespace arlight::client
